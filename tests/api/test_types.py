"""The public API type-checks: mypy over tmpc.runtime.api (the top ``tmpc`` included), every
function annotated, no errors."""

from __future__ import annotations

import subprocess
import sys

from tests.support import ROOT


def test_the_api_type_checks():
    out = subprocess.run([sys.executable, "-m", "mypy", "--follow-imports=silent",
                          "--ignore-missing-imports", "--disallow-untyped-defs",
                          "--disallow-incomplete-defs", "--no-incremental", "runtime/api"],
                         cwd=ROOT, capture_output=True, text=True)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "Success" in out.stdout
