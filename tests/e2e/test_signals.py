"""SIGINT and SIGTERM at several instants (tmpc.runtime.interrupts): during setup (a cold
compile) the process stops at once with exit 130, no plan and no temporary file left; during
planning it stops with its best progress (exit 3, a complete plan file, status `interrupted`).
They were lost, ended in SIGSEGV, or left nothing on SIGTERM."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time

import pytest

from tests.support import EXAMPLES


def _start(cfg, tmp_path, aot_folder, *extra):
    """``tmpc run CFG`` with a cache of its own (its artifact compiles cold), but for the
    kernels built ahead of time (the collision pass's numba build comes before the compile;
    a signal there is not what these tests send)."""
    cache = tmp_path / "cache"
    cache.mkdir(exist_ok=True)
    if not (cache / "aot").exists():
        (cache / "aot").symlink_to(aot_folder)
    env = {**os.environ, "TMPC_CACHE_DIR": str(cache)}
    return subprocess.Popen([sys.executable, "-m", "tmpc.runtime.cli", "run", str(cfg), "-o",
                             str(tmp_path / "plan.json"), *extra],
                            stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True, env=env)


def _leftovers(root) -> list[str]:
    return [str(p) for p in root.rglob("*") if p.name.endswith(".tmp")]


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_during_setup_stops_at_once(tmp_path, sig, aot_folder):
    src = tmp_path / "tabletop"
    shutil.copytree(EXAMPLES / "tabletop", src)
    p = _start(src / "tabletop.toml", tmp_path, aot_folder)
    line = p.stderr.readline()            # "compiling the problem into the artifact cache..."
    assert "compiling" in line, line
    time.sleep(0.5)
    p.send_signal(sig)
    t = time.monotonic()
    err = p.stderr.read()
    assert p.wait(timeout=60) == 130, err
    waited = time.monotonic() - t
    assert "interrupted" in err and "Traceback" not in err and "Exception" not in err, err
    assert not (tmp_path / "plan.json").exists() and not _leftovers(tmp_path)
    assert waited < 30, waited            # not after the compile (that takes ~10 s cold)


@pytest.mark.slow
def test_a_signal_during_planning_gives_the_best_progress(tmp_path, aot_folder):
    src = tmp_path / "tabletop"
    shutil.copytree(EXAMPLES / "tabletop", src)
    scene = json.loads((src / "scene.json").read_text())
    tray = next(o for o in scene["objects"] if o["name"] == "tray")
    tray["pose"]["translation"] = [9.0, 0.0, 0.4]        # out of reach: planning never ends
    (src / "scene.json").write_text(json.dumps(scene))
    first = _start(src / "tabletop.toml", tmp_path, aot_folder, "--time-limit", "2")
    first.communicate(timeout=600)                        # compiled, then partial after 2 s
    assert first.returncode == 3
    p = _start(src / "tabletop.toml", tmp_path, aot_folder, "--time-limit", "120")
    time.sleep(8)                                         # warm setup is ~2 s
    p.send_signal(signal.SIGINT)
    err = p.communicate(timeout=60)[1]
    assert p.returncode == 3, err
    doc = json.loads((tmp_path / "plan.json").read_text())
    assert doc["status"] == "interrupted" and not _leftovers(tmp_path)


def test_ctrl_c_stops_a_runaway_lua_file(tmp_path):
    """Lua work inside C functions (string.rep) ignored Ctrl-C: `check` ran for hours."""
    lua = tmp_path / "bomb.lua"
    lua.write_text('for i = 1, 3e6 do local s = ("x"):rep(1e7) end\n')
    p = subprocess.Popen([sys.executable, "-m", "tmpc.runtime.cli", "check", str(lua)],
                         stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
    time.sleep(2)
    if p.poll() is not None:               # the sandbox's own limits stopped it: also fine
        assert p.returncode == 1 and "Traceback" not in p.stderr.read()
        return
    t = time.monotonic()
    p.send_signal(signal.SIGINT)
    assert p.wait(timeout=30) == 130
    assert time.monotonic() - t < 5
