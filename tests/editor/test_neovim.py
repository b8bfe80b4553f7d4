"""A real editor end to end (opt-in: ``pytest -m editor``): headless Neovim opens an example
domain with `tmpc lsp` attached, receives the diagnostic of an error injected by an edit, and
gets a hover. Needs ``nvim`` on PATH (Debian's ``neovim`` package; 0.7 or later)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.support import EXAMPLES

pytestmark = pytest.mark.editor
DRIVE = Path(__file__).with_name("drive.lua")


@pytest.mark.skipif(shutil.which("nvim") is None, reason="needs Neovim (apt install neovim)")
def test_neovim_gets_diagnostics_of_an_edit_and_a_hover(tmp_path):
    shutil.copytree(EXAMPLES / "tabletop", tmp_path / "tabletop")
    out = tmp_path / "seen.json"
    env = {**os.environ, "TMPC_NVIM_OUT": str(out),
           "TMPC_NVIM_FILE": str(tmp_path / "tabletop" / "domain.pddl"),
           "TMPC_NVIM_ROOT": str(tmp_path),
           "TMPC_NVIM_CMD": json.dumps([sys.executable, "-m", "tmpc.runtime.cli", "lsp",
                                        "--no-worker"])}
    r = subprocess.run(["nvim", "--headless", "-u", "NONE", "-i", "NONE", "-n",
                        "-c", f"luafile {DRIVE}"], env=env, capture_output=True, text=True,
                       timeout=120, stdin=subprocess.DEVNULL)
    assert out.exists(), (r.returncode, r.stdout, r.stderr)
    seen = json.loads(out.read_text())
    assert seen["ok"], seen["error"]
    assert seen["initialized"] and seen["before"] == 0
    assert seen["steps"] == ["attached", "edited", "hovered"]
    errors = [d for d in seen["diagnostics"] if "reachh" in d["message"]]
    assert errors, seen["diagnostics"]
    assert errors[0]["lnum"] == seen["edited_line"] - 1
    hover = seen["hover"]
    text = hover["value"] if isinstance(hover, dict) else json.dumps(hover)
    # the compiled meaning, with the stdlib's `near` inlined, although the domain has an error
    assert "(reach ?g - gripper ?c - cube)" in text, text
    assert "unsatisfaction distance" in text and "distance(position(?g), position(?c))" in text
