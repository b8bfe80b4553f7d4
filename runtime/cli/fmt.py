"""`tmpc fmt FILE... [--check]`: format in place (atomic), or report files that would change."""

from __future__ import annotations

import sys
from pathlib import Path

from tmpc.lang.diagnostics import InputError, error
from tmpc.lang.fileio import atomic_write_text
from tmpc.lang.formatter import format_doc
from tmpc.lang.reader import parse_source
from tmpc.lang.source import SourceFile


def format_source(src: SourceFile):
    """(formatted text or None, diagnostics). None when the file has syntax errors.

    The result is re-parsed and compared with the original AST before anyone sees it, so `fmt`
    can never change what a file means.
    """
    parsed = parse_source(src)
    errors = [d for d in parsed.diagnostics if d.is_error]
    if errors:
        return None, errors
    text = format_doc(parsed.sexpr)
    again = parse_source(SourceFile(src.path, text))
    kept = [c.text.rstrip() for c in again.sexpr.comments]
    if again.definitions != parsed.definitions or \
            kept != [c.text.rstrip() for c in parsed.sexpr.comments]:
        return None, [error("E900", "internal error: formatting would change the meaning or the comments "
                            "of this file; it was left as it is (please report this)", None)]
    return text, []


def run_fmt(paths: list[str], check: bool, fmt: str, print_diags) -> int:
    status = 0
    files: dict[str, SourceFile] = {}
    diags = []
    for path in paths:
        try:
            src = SourceFile("<stdin>", sys.stdin.read()) if path == "-" else SourceFile.read(path)
        except (OSError, UnicodeDecodeError) as exc:
            raise InputError(error("E010", f"cannot read {path}: {exc}", None)) from None
        files[src.path] = src
        text, errs = format_source(src)
        if text is None:
            diags += errs
            status = 1
            continue
        if path == "-":
            if not check:
                sys.stdout.write(text)
            elif text != src.text:
                status = 1
            continue
        if text == src.text:
            continue
        if check:
            sys.stderr.write(f"would reformat {path}\n")
            status = 1
        else:
            # through a symlink to its target: the link stays a link
            atomic_write_text(Path(path).resolve(), text)
            sys.stderr.write(f"reformatted {path}\n")
    if diags:
        print_diags(diags, files, fmt)
    return status
