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
