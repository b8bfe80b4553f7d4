"""Shared test helpers: the fixture corpus and a parse/check shortcut."""

from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
FIXTURES = Path(__file__).resolve().parent / "fixtures"
EXAMPLES = ROOT / "examples"
STDLIB = ROOT / "stdlib"


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


@pytest.fixture
def tmp_cwd(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    return tmp_path
