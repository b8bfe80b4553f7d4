"""Plain helpers shared by the tests (imported as ``from tests.support import ...``): the
checkout's folders, the fixture corpus and a parse/check shortcut. Fixtures live in conftest.py."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TESTS = ROOT / "tests"
FIXTURES = TESTS / "fixtures"
EXAMPLES = ROOT / "examples"
STDLIB = ROOT / "stdlib"
DOCS = ROOT / "docs"
#: legacy-format inputs written for the tests (planet and tmit-star layouts, no third-party file)
LEGACY = FIXTURES / "legacy"

TABLETOP = EXAMPLES / "tabletop" / "tabletop.toml"
CLUTTER = EXAMPLES / "clutter" / "clutter.toml"


def program_dirs(*groups: str) -> list[Path]:
    """Fixture folders holding one domain and its problems (corpus tests glob these)."""
    out = []
    for g in groups:
        base = FIXTURES / g
        out += sorted(p.parent for p in base.rglob("domain.pddl"))
    return out


def pddl_files(*groups: str) -> list[Path]:
    out = []
    for g in groups:
        out += sorted((FIXTURES / g).rglob("*.pddl"))
    return out


def example_programs() -> list[list[Path]]:
    """Each example folder: its domain first, then its problems."""
    progs = []
    for d in sorted(p.parent for p in EXAMPLES.rglob("domain.pddl")):
        probs = sorted(p for p in d.glob("*.pddl") if p.name != "domain.pddl")
        progs.append([d / "domain.pddl", *probs])
    return progs


def check(text: str, path: str = "test.pddl"):
    """Check one in-memory file (domain and/or problem). Returns the CheckReport."""
    from tmpc.lang.program import Workspace, check_parsed
    from tmpc.lang.source import SourceFile
    ws = Workspace()
    parsed = ws.add_source(SourceFile(path, text))
    return check_parsed(ws, [parsed])


def codes(report) -> list[str]:
    return [d.code for d in report.diagnostics]


def errors(report) -> list[str]:
    return [d.code for d in report.diagnostics if d.is_error]


# ---- diagnostics of the world loaders (scenes and run configurations) ----------------------------

def raises(code: str, fn, *args, **kwargs):
    """Call ``fn``; it must raise SceneError with a ``code`` diagnostic. Returns (diag, files)."""
    import pytest

    from tmpc.lang.diagnostics import SceneError
    with pytest.raises(SceneError) as info:
        fn(*args, **kwargs)
    diags = [d for d in info.value.diagnostics if d.code == code]
    assert diags, f"expected {code}, got {[(d.code, d.message) for d in info.value.diagnostics]}"
    return diags[0], info.value.files


def where(diag, files) -> tuple[int, int]:
    """1-based (line, column) of a diagnostic's span."""
    assert diag.span is not None, diag
    return files[diag.span.path].line_col(diag.span.start)


def pos_of(text: str, needle: str, nth: int = 0) -> tuple[int, int]:
    """1-based (line, column) of the ``nth`` occurrence of ``needle`` in ``text``."""
    from tmpc.lang.source import SourceFile
    i = -1
    for _ in range(nth + 1):
        i = text.index(needle, i + 1)
    return SourceFile("x", text).line_col(i)


def run_tmpc(*args, cwd=None):
    """``tmpc ARGS`` in a fresh interpreter (text output captured)."""
    import subprocess
    import sys
    return subprocess.run([sys.executable, "-m", "tmpc.runtime.cli", *map(str, args)],
                          capture_output=True, text=True, cwd=cwd, timeout=600)


def tmpc_here(*args, cwd=None, env=None, stdin: str | None = None):
    """``tmpc ARGS`` in this process (:func:`tmpc.runtime.cli.main.main`), answered as
    :func:`run_tmpc` answers: a CompletedProcess with the exit code (argparse's usage exit
    included), stdout and stderr (pipes: not terminals). The command's JAX import, artifact
    loads and kernel compiles are this process's, shared with the tests run in it; what needs
    a process of its own (signals, what a fresh interpreter imports, the interpreter's exit)
    uses :func:`run_tmpc`. ``env`` replaces the environment for the call, ``cwd`` the working
    directory, ``stdin`` is the text on standard input."""
    import contextlib
    import io
    import os
    import subprocess
    import sys

    from tmpc.runtime.cli.main import main

    def pipe(text: str = "") -> io.TextIOWrapper:
        return io.TextIOWrapper(io.BytesIO(text.encode()), encoding="utf-8", newline=None)

    argv = [str(a) for a in args]
    out, err = pipe(), pipe()
    here, environ, stdin_was = os.getcwd(), dict(os.environ), sys.stdin
    try:
        if cwd is not None:
            os.chdir(cwd)
        if env is not None:
            os.environ.clear()
            os.environ.update(env)
        sys.stdin = pipe(stdin or "")
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = main(argv)
            except SystemExit as exc:          # argparse's usage errors and --help
                code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    finally:
        sys.stdin = stdin_was
        os.chdir(here)
        if env is not None:
            os.environ.clear()
            os.environ.update(environ)
    texts = []
    for stream in (out, err):
        stream.flush()
        texts.append(stream.buffer.getvalue().decode("utf-8", errors="replace"))
    return subprocess.CompletedProcess(["tmpc", *argv], code, *texts)


def validate_result(problem, result, path, planner: str, seed: int = 0):
    """(plan document, validator report) of a planner's result written to ``path``."""
    from tmpc.runtime.plans import plan_document, write_json_atomic
    from tmpc.runtime.validate import validate_plan
    doc = plan_document(problem, result, planner=planner, seed=seed, input_path=str(CLUTTER),
                        setup_seconds=0.0)
    write_json_atomic(path, doc)
    return doc, validate_plan(problem.world, str(path))
