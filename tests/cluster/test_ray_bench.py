"""`tmpc bench --backend ray` on a local Ray cluster of 2 CPUs (opt-in: `pip install -e
'.[test,cluster]' && pytest -m cluster -n 0`): the same plans as the local pool for the same
seeds, a worker killed in the middle of a task (the task runs again and is counted once), and a
resumed sweep running only what an interrupted one left."""

from __future__ import annotations

import os
import signal
import threading
import time

import pytest

from tests.support import CLUTTER
from tmpc.runtime.bench.results import read_results, run_key
from tmpc.runtime.cli.main import main

pytestmark = pytest.mark.cluster
SEEDS = 3


@pytest.fixture(scope="module")
def cluster():
    # imported here, not at collection: the default suite deselects these tests without Ray
    ray = pytest.importorskip("ray")
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False,
             runtime_env={"env_vars": {k: os.environ[k] for k in ("TMPC_CACHE_DIR",)
                                       if k in os.environ}})
    yield
    ray.shutdown()


def _bench(out, *extra, seeds=SEEDS, limit="20"):
    return main(["bench", str(CLUTTER), "--seeds", str(seeds), "--time-limit", limit,
                 "-o", str(out), "--validate", *extra])


def _plans(path) -> dict:
    return {run_key(r): r["actions"] for r in read_results(path)}


def test_ray_plans_equal_the_local_pool(cluster, tmp_path):
    local, remote = tmp_path / "local.jsonl", tmp_path / "ray.jsonl"
    assert _bench(local, "--backend", "local", "--workers", "2") == 0
    assert _bench(remote, "--backend", "ray", "--workers", "2") == 0
    assert _plans(local) == _plans(remote) and len(_plans(remote)) == SEEDS
    recs = read_results(remote)
    assert all(r["valid"] is True for r in recs)
    assert {r["worker"] for r in recs} != {r["worker"] for r in read_results(local)}


def _ray_task_pids() -> list[int]:
    """Processes running a run_task (Ray names a worker by its task while it runs one)."""
    import psutil
    out = []
    for p in psutil.process_iter(["cmdline"]):
        cmd = " ".join(p.info["cmdline"] or [])
        if cmd.startswith("ray::run_task"):
            out.append(p.pid)
    return out


def test_a_killed_worker_is_retried_and_counted_once(cluster, tmp_path):
    """SIGKILL one worker in the middle of its task: Ray runs the task again (max_retries), and
    the results file has each run once."""
    out = tmp_path / "r.jsonl"
    killed = []

    def killer():
        deadline = time.time() + 120
        while time.time() < deadline and not killed:
            pids = _ray_task_pids()
            if pids:
                time.sleep(0.5)               # mid-task
                os.kill(pids[0], signal.SIGKILL)
                killed.append(pids[0])
            time.sleep(0.05)

    t = threading.Thread(target=killer, daemon=True)
    t.start()
    assert _bench(out, "--backend", "ray", "--workers", "2", seeds=4) == 0
    t.join(5)
    assert killed, "no worker was seen running a task"
    recs = read_results(out)
    keys = [run_key(r) for r in recs]
    assert len(keys) == len(set(keys)) == 4
    assert all(r["status"] == "solved" for r in recs)
    assert killed[0] not in {int(r["worker"].rsplit(":", 1)[1]) for r in recs}


def test_resume_after_an_interrupted_sweep_runs_only_the_missing_cells(cluster, tmp_path,
                                                                       monkeypatch):
    """Ctrl-C after the second finished run cancels the rest; --resume runs only those."""
    from tmpc.runtime.bench import dispatch
    out = tmp_path / "r.jsonl"
    real = dispatch.Dispatch.finished
    seen = []

    def finished(self, task, rec, progress):
        real(self, task, rec, progress)
        seen.append(run_key(task))
        if len(seen) == 2:
            raise KeyboardInterrupt

    monkeypatch.setattr(dispatch.Dispatch, "finished", finished)
    assert _bench(out, "--backend", "ray", "--workers", "2", seeds=5) == 130
    first = read_results(out)
    assert len(first) == 2
    monkeypatch.setattr(dispatch.Dispatch, "finished", real)
    submitted = []
    real_tasks = dispatch.Dispatch.tasks

    def tasks(self, prec):
        got = real_tasks(self, prec)
        submitted.extend(run_key(t) for t in got)
        return got

    monkeypatch.setattr(dispatch.Dispatch, "tasks", tasks)
    assert _bench(out, "--backend", "ray", "--workers", "2", "--resume", seeds=5) == 0
    done_first = {run_key(r) for r in first}
    assert set(submitted) == {k for k in _plans(out)} - done_first and len(submitted) == 3
    assert len(read_results(out)) == 5
