"""A results file (``-o R.jsonl``): one JSON object per finished run, appended and flushed as
runs finish, so a killed sweep loses only the runs in flight.

Each line holds at least ``problem``, ``planner``, ``seed``, ``params``, ``status``, ``valid``
(bool, or null when not validated), ``actions``, ``planning_seconds``, ``setup_seconds``,
``cost`` and ``worker`` (docs/bench.md lists the rest). ``--resume`` skips the runs the file
already has; a torn last line (the process was killed in the middle of a write) is ignored and
cut off before anything is appended.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

from tmpc.runtime.bench.params import params_key

#: statuses of a finished run: ``--resume`` does not run these again (an ``interrupted`` run was
#: cut short by Ctrl-C and an ``error`` one could not set up: both run again)
FINISHED = ("solved", "partial", "crash")


def run_key(rec: dict) -> tuple:
    """What identifies a run across backends and resumes: (problem, planner, seed, params)."""
    return rec["problem"], rec["planner"], int(rec["seed"]), params_key(rec.get("params"))


def read_results(path) -> list[dict]:
    """The records of a results file; a line that is not a JSON object is skipped (a torn last
    line), so a file of a killed sweep reads."""
    out = []
    with open(path, "rb") as f:
        for line in f:
            try:
                rec = json.loads(line)
            except ValueError:
                continue
            if isinstance(rec, dict) and "problem" in rec:
                out.append(rec)
    return out


def _clean(v):
    """JSON has no inf or nan: inf -> "inf", nan -> None (as the tmpc-bench/1 summary)."""
    if isinstance(v, float) and not math.isfinite(v):
        return None if math.isnan(v) else ("inf" if v > 0 else "-inf")
    if isinstance(v, dict):
        return {k: _clean(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_clean(x) for x in v]
    return v


class ResultsFile:
    """Appends records to ``path``; ``done`` holds the keys of its finished runs."""

    def __init__(self, path, resume: bool):
        self.path = Path(path)
        self.done: set[tuple] = set()
        self.records: list[dict] = []
        if resume and self.path.exists():
            self._cut_torn_tail()
            self.records = read_results(self.path)
            self.done = {run_key(r) for r in self.records if r.get("status") in FINISHED}
        self._f = open(self.path, "a" if resume else "w", encoding="utf-8")

    def _cut_torn_tail(self) -> None:
        """Drop an unterminated last line (kill -9 in the middle of a write)."""
        data = self.path.read_bytes()
        if data and not data.endswith(b"\n"):
            with open(self.path, "r+b") as f:
                f.truncate(data.rfind(b"\n") + 1)

    def append(self, rec: dict) -> None:
        self._f.write(json.dumps(_clean(rec), separators=(",", ":")) + "\n")
        self._f.flush()
        os.fsync(self._f.fileno())
        self.records.append(rec)

    def close(self) -> None:
        self._f.close()
