"""`tmpc bench report`'s HTML page opens in headless Chromium without console errors and shows
its figures (opt-in: `apt-get install chromium` and `pytest -m browser -n 0`)."""

from __future__ import annotations

import json
import shutil
import subprocess

import pytest

pytestmark = pytest.mark.browser
CHROMIUM = next((shutil.which(n) for n in ("chromium", "chromium-browser", "google-chrome")
                 if shutil.which(n)), None)


@pytest.mark.skipif(CHROMIUM is None, reason="no chromium on PATH (apt-get install chromium)")
def test_report_page_opens_without_console_errors(tmp_path):
    from tmpc.runtime.bench import write_report
    results = tmp_path / "r.jsonl"
    results.write_text("".join(json.dumps(
        {"problem": "clutter", "planner": "unified", "seed": s, "params": {}, "status": "solved",
         "solved": True, "planning_seconds": 1.0 + s, "ground_actions": 12, "time_limit": 10,
         "valid": True, "actions": ["(pick s1)"], "cost": 2.0}) + "\n" for s in range(5)))
    page = [p for p in write_report([results], tmp_path / "rep") if p.suffix == ".html"][0]
    # the page counts its loaded images into the title, so the dumped DOM shows they decoded
    probe = tmp_path / "probe.html"
    probe.write_text(page.read_text().replace(
        "</body>", "<script>window.addEventListener('load', () => { document.title = "
        "'loaded ' + [...document.images].filter(i => i.naturalWidth > 0).length; });"
        "</script></body>"))
    proc = subprocess.run(
        [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--enable-logging=stderr",
         "--v=0", "--virtual-time-budget=3000", "--dump-dom", probe.as_uri()],
        capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "<title>loaded 2</title>" in proc.stdout
    console = [ln for ln in proc.stderr.splitlines() if "CONSOLE" in ln or "Uncaught" in ln]
    assert console == [], console
