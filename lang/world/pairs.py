"""Allowed-collision lists: planet's CSV (one pair of link or object names a line)."""

from __future__ import annotations

import re
from pathlib import Path

from tmpc.lang.source import Span
from tmpc.lang.world.reader import LoadReport, Reader, read_source


def load_allowed_pairs(path: str | Path, report: LoadReport | None = None
                       ) -> tuple[tuple[str, str], ...]:
    """``nameA,nameB`` per line (spaces trimmed; blank lines and ``#`` comments skipped).
    Returns the pairs in file order without repeats. A malformed line is SceneError E517."""
    source = read_source(path, "allowed-collision")
    report = report or LoadReport()
    r = Reader(source, report, legacy=False)
    out: list[tuple[str, str]] = []
    seen: set[tuple[str, str]] = set()
    offset = 0
    for lineno, line in enumerate(source.text.split("\n"), 1):
        start, offset = offset, offset + len(line) + 1
        body = line.strip()
        if not body or body.startswith("#"):
            continue
        fields = [f.strip() for f in body.split(",")]
        if len(fields) != 2 or not all(fields) or any(re.search(r"\s", f) for f in fields):
            lead = len(line) - len(line.lstrip())
            r.record("E516", Span(source.path, start + lead, start + len(line.rstrip())),
                     f"line {lineno}: expected two names separated by a comma, found "
                     f"\"{body}\"", "each line is nameA,nameB (link, joint or object names)")
            continue
        a, b = fields
        if (a, b) not in seen and (b, a) not in seen:
            seen.add((a, b))
            out.append((a, b))
    r.finish()
    return tuple(out)
