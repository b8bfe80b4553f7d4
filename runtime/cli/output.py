"""Printing diagnostics for the commands: rendered (rustc-style, to stderr) or as JSON (stdout)."""

from __future__ import annotations

import sys

from tmpc.lang.diagnostics import render, render_json, sort_key, use_color

#: diagnostics rendered as text before the rest are only counted (JSON lists them all)
SHOWN = 50


def print_diagnostics(diags, files, fmt: str, stream=None) -> None:
    """Diagnostics as JSON on stdout (every one), or rendered on ``stream`` (stderr): the first
    :data:`SHOWN` in order, then a count of the rest, so the output stays bounded whatever the
    input (as compilers do)."""
    stream = stream or sys.stderr
    if fmt == "json":
        sys.stdout.write(render_json(diags, files) + "\n")
        return
    color = use_color(stream)
    ordered = sorted(diags, key=sort_key)
    for d in ordered[:SHOWN]:
        stream.write(render(d, files, color) + "\n\n")
    if len(ordered) > SHOWN:
        stream.write(f"... and {len(ordered) - SHOWN} more ({summary(ordered[SHOWN:])}); "
                     "`--format json` lists every one\n\n")


def summary(diags) -> str:
    errors = sum(1 for d in diags if d.is_error)
    warnings = len(diags) - errors
    parts = []
    if errors:
        parts.append(f"{errors} error{'s' if errors != 1 else ''}")
    if warnings:
        parts.append(f"{warnings} warning{'s' if warnings != 1 else ''}")
    return ", ".join(parts)
