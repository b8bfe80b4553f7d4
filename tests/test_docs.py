"""Documentation stays true: every diagnostic code the code can emit is documented."""

from __future__ import annotations

import re

from tests.support import ROOT


def test_every_diagnostic_code_is_documented():
    used = set()
    for folder in ("lang", "compiler", "runtime"):
        for path in (ROOT / folder).rglob("*.py"):
            used |= set(re.findall(r'"([EW]\d{3})"', path.read_text()))
    documented = set(re.findall(r"^\| ([EW]\d{3}) \|", (ROOT / "docs" / "diagnostics.md")
                                .read_text(), re.M))
    assert used - documented == set(), "undocumented codes"
    assert documented - used == set(), "documented codes no longer used"


def test_readme_quick_start_has_two_commands():
    text = (ROOT / "README.md").read_text()
    block = text.split("## Quick start", 1)[1].split("\n## ", 1)[0]
    code = re.findall(r"```[a-z]*\n(.*?)```", block, re.S)
    cmds = [ln for c in code for ln in c.splitlines() if ln.strip() and not ln.startswith("#")]
    assert len(cmds) == 2


def test_readme_is_a_map():
    """The README stays a map: measurements belong in docs/performance.md, history in
    CHANGELOG.md."""
    lines = (ROOT / "README.md").read_text().splitlines()
    assert len(lines) <= 250
    cells = [c for ln in lines if ln.startswith("|") for c in ln.strip("|").split("|")]
    assert max(len(c.strip()) for c in cells) <= 200


def test_performance_doc_is_rendered_from_its_results():
    """docs/performance.md is exactly `tmpc bench report --docs docs/results`'s rendering, so it
    cannot go stale: change a results file and render again."""
    from tmpc.runtime.bench import render_performance
    assert (ROOT / "docs" / "performance.md").read_text() == \
        render_performance(ROOT / "docs" / "results"), (
        "regenerate: tmpc bench report --docs docs/results -o docs/performance.md")


def test_results_files_record_their_provenance():
    import json
    docs = sorted((ROOT / "docs" / "results").glob("*.json"))
    assert docs
    for path in docs:
        doc = json.loads(path.read_text())
        assert doc["format"] == "tmpc-results/1"
        assert doc["command"] and doc["date"] and doc["machine"], path.name
        assert doc["tables"], path.name


def test_license_is_mit():
    assert (ROOT / "LICENSE").read_text().startswith("MIT License")
