"""`tmpc compile INPUT -o ART.tmpa` (or ``--domain --problem --scene [--semantics]``): a
self-contained artifact, written atomically; no file on failure."""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

from tmpc.compiler.artifact import open_world
from tmpc.compiler.export import build_artifact
from tmpc.lang.diagnostics import InputError, error
from tmpc.lang.fileio import unwritable
from tmpc.lang.inputs import load_world
from tmpc.runtime.cli.exits import EXIT_OK
from tmpc.runtime.problem import register_run_kernels


def run_compile(args) -> int:
    why = unwritable(args.output)
    if why:
        raise InputError(error("E592", f"cannot write {args.output}: {why}", None,
                               "give -o a path in an existing, writable folder"))
    if args.input is None:
        if not (args.domain and args.problem and args.scene):
            raise InputError(error("E585", "give a run configuration, or --domain, --problem "
                                   "and --scene", None))
        world = _world_from_parts(args)
    else:
        world = open_world(args.input)
    if world.program is None:
        raise InputError(error("E585", f"{args.input}: a scene alone cannot be compiled; give a "
                               "run configuration that names the domain and problem", None))
    manifest = build_artifact(world, args.output, register_run_kernels)
    kernels = manifest["bank"]["kernels"]
    skipped = sorted(k for k, member in kernels.items() if member is None)
    sys.stderr.write(f"wrote {args.output}: {len(kernels)} kernels"
                     + (f" ({len(skipped)} traced from the sources when used: "
                        f"{', '.join(skipped)} call untraceable Lua)" if skipped else "")
                     + f", {len(manifest['members'])} members\n")
    return EXIT_OK


def _world_from_parts(args):
    """A run manifest beside the output, pointing at the given files (absolute paths)."""
    lines = ["[problem]"] + [f'{k} = "{Path(v).resolve()}"' for k, v in
                             (("domain", args.domain), ("problem", args.problem),
                              ("scene", args.scene), ("semantics", args.semantics)) if v]
    with tempfile.TemporaryDirectory() as d:
        manifest = Path(d) / "run.toml"
        manifest.write_text("\n".join(lines) + "\n")
        return load_world(manifest)
