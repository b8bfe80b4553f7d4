"""`tmpc cache info|clear [PART...]`: what the user cache holds (docs/architecture.md), and
emptying it."""

from __future__ import annotations

import sys

from tmpc.compiler.cache import PARTS, cache_info, cache_root, clear_cache
from tmpc.runtime.cli.exits import EXIT_OK, EXIT_USAGE


def run_cache(args) -> int:
    unknown = [p for p in args.parts if p not in PARTS]
    if unknown:
        sys.stderr.write(f"tmpc cache: unknown part {', '.join(unknown)}; parts: "
                         f"{', '.join(PARTS)}\n")
        return EXIT_USAGE
    if args.action == "info":
        sys.stdout.write(f"{cache_root()}\n")
        for info in cache_info():
            if args.parts and info.name not in args.parts:
                continue
            sys.stdout.write(f"  {info.name + '/':11} {info.files:6d} files "
                             f"{info.bytes / 1e6:9.1f} MB  {info.what}\n")
        return EXIT_OK
    removed = clear_cache(args.parts or None)
    freed = sum(i.bytes for i in removed)
    sys.stderr.write(f"removed {', '.join(i.name for i in removed) or 'nothing'} "
                     f"({freed / 1e6:.1f} MB) from {cache_root()}\n")
    return EXIT_OK
