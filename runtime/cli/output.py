"""Printing diagnostics for the commands: rendered (rustc-style, to stderr) or as JSON (stdout)."""

from __future__ import annotations

import sys

from tmpc.lang.diagnostics import render, render_json, sort_key, use_color


def print_diagnostics(diags, files, fmt: str, stream=None) -> None:
    stream = stream or sys.stderr
    if fmt == "json":
        sys.stdout.write(render_json(diags, files) + "\n")
        return
    color = use_color(stream)
    for d in sorted(diags, key=sort_key):
        stream.write(render(d, files, color) + "\n\n")


def summary(diags) -> str:
    errors = sum(1 for d in diags if d.is_error)
    warnings = len(diags) - errors
    parts = []
    if errors:
        parts.append(f"{errors} error{'s' if errors != 1 else ''}")
    if warnings:
        parts.append(f"{warnings} warning{'s' if warnings != 1 else ''}")
    return ", ".join(parts)
