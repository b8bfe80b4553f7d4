"""The durable store of a repair: every observation and every repair step, in SQLite (WAL).

An observation is committed before repair uses it, so ``kill -9`` at any point loses nothing that
was used, and ``tmpc repair --resume`` continues from the store. A process holds an exclusive
``flock`` on the database file while it writes; a second writer gets a clear error instead of
interleaving its observations. The ``meta`` table names the domain, the action and its
parameters; opening a store made for another one is an error.
"""

from __future__ import annotations

import fcntl
import json
import sqlite3
from dataclasses import dataclass
from pathlib import Path

from tmpc.lang.diagnostics import InputError, error

FORMAT = "tmpc-repair-store/1"

_SCHEMA = """
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS observations (
    id INTEGER PRIMARY KEY, trial INTEGER NOT NULL, seq INTEGER NOT NULL,
    action TEXT NOT NULL, arguments TEXT NOT NULL, state TEXT NOT NULL,
    success INTEGER NOT NULL, result TEXT NOT NULL, features TEXT NOT NULL,
    expected INTEGER NOT NULL, how TEXT NOT NULL, UNIQUE (trial, seq));
CREATE TABLE IF NOT EXISTS repairs (
    id INTEGER PRIMARY KEY, trial INTEGER NOT NULL, observation INTEGER NOT NULL,
    formula TEXT NOT NULL, previous TEXT NOT NULL, error REAL NOT NULL, hypothesis TEXT NOT NULL,
    edits INTEGER NOT NULL, evaluated INTEGER NOT NULL, seconds REAL NOT NULL,
    trace TEXT NOT NULL, ties TEXT NOT NULL, cpu_seconds REAL NOT NULL DEFAULT 0);
"""


@dataclass
class Observation:
    """One execution: the state, the ground action, whether it succeeded, the state after it."""

    action: str
    arguments: tuple[str, ...]
    state: dict
    success: bool
    result: dict
    #: constraint-space values: instance text -> coordinates (continuous) or truth (discrete)
    features: dict
    #: whether the model of the time predicted the outcome; how the state was drawn
    expected: bool = True
    how: str = "naive"
    seq: int = 0


@dataclass
class RepairStep:
    observation: int
    formula: str
    previous: str
    error: float
    hypothesis: str
    edits: int
    evaluated: int
    seconds: float
    trace: list
    ties: list
    #: the process's CPU time during the repair (every thread: JAX's and XLA's included)
    cpu_seconds: float = 0.0


class Store:
    """An open store; use as a context manager (closes and unlocks)."""

    def __init__(self, path: str | Path, meta: dict[str, str]):
        self.path = Path(path)
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._lock = open(self.path, "ab")
        except OSError as exc:
            raise InputError(error("E840", f"{path}: cannot open the repair store: "
                                   f"{exc.strerror}", None)) from None
        try:
            fcntl.flock(self._lock.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            self._lock.close()
            raise InputError(error("E841", f"{path}: the repair store is in use by another "
                                   "process", None, "wait for it to finish, or give this run "
                                   "its own --db")) from None
        try:
            self.db = sqlite3.connect(self.path, isolation_level=None)
            self.db.execute("PRAGMA journal_mode=WAL")
            self.db.execute("PRAGMA synchronous=FULL")
            self.db.executescript(_SCHEMA)
            if "cpu_seconds" not in {r[1] for r in self.db.execute("PRAGMA table_info(repairs)")}:
                # a store from before repairs recorded their CPU time
                self.db.execute("ALTER TABLE repairs ADD COLUMN cpu_seconds REAL NOT NULL "
                                "DEFAULT 0")
            self._check_meta({"format": FORMAT, **meta})
        except sqlite3.DatabaseError as exc:
            self.close()
            raise InputError(error("E840", f"{path}: not a repair store ({exc})", None,
                                   "give --db a new file name")) from None

    def _check_meta(self, meta: dict[str, str]) -> None:
        have = dict(self.db.execute("SELECT key, value FROM meta"))
        if not have:
            with self.db:
                self.db.execute("BEGIN")
                self.db.executemany("INSERT INTO meta VALUES (?, ?)", sorted(meta.items()))
            return
        for key, value in meta.items():
            if have.get(key) != value:
                raise InputError(error(
                    "E842", f"{self.path}: the store was made for {key} `{have.get(key)}`, "
                    f"not `{value}`", None, "use a new --db for another domain or action"))

    def close(self) -> None:
        if getattr(self, "db", None) is not None:
            self.db.close()
            self.db = None
        if not self._lock.closed:
            fcntl.flock(self._lock.fileno(), fcntl.LOCK_UN)
            self._lock.close()

    def __enter__(self) -> "Store":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # ---- writes: one transaction each, committed before the caller goes on ---------------------
    def add_observation(self, trial: int, obs: Observation) -> None:
        with self.db:
            self.db.execute("BEGIN IMMEDIATE")
            self.db.execute(
                "INSERT INTO observations (trial, seq, action, arguments, state, success, result,"
                " features, expected, how) VALUES (?,?,?,?,?,?,?,?,?,?)",
                (trial, obs.seq, obs.action, json.dumps(list(obs.arguments)),
                 json.dumps(obs.state, sort_keys=True), int(obs.success),
                 json.dumps(obs.result, sort_keys=True), json.dumps(obs.features, sort_keys=True),
                 int(obs.expected), obs.how))

    def add_repair(self, trial: int, step: RepairStep) -> None:
        with self.db:
            self.db.execute("BEGIN IMMEDIATE")
            self.db.execute(
                "INSERT INTO repairs (trial, observation, formula, previous, error, hypothesis, "
                "edits, evaluated, seconds, trace, ties, cpu_seconds) "
                "VALUES (?,?,?,?,?,?,?,?,?,?,?,?)",
                (trial, step.observation, step.formula, step.previous, step.error, step.hypothesis,
                 step.edits, step.evaluated, step.seconds, json.dumps(step.trace),
                 json.dumps(step.ties), step.cpu_seconds))

    # ---- reads ---------------------------------------------------------------------------------
    def observations(self, trial: int) -> list[Observation]:
        rows = self.db.execute(
            "SELECT action, arguments, state, success, result, features, expected, how, seq "
            "FROM observations WHERE trial = ? ORDER BY seq", (trial,))
        return [Observation(a, tuple(json.loads(args)), json.loads(s), bool(ok), json.loads(r),
                            json.loads(f), bool(e), how, seq)
                for a, args, s, ok, r, f, e, how, seq in rows]

    def repairs(self, trial: int) -> list[RepairStep]:
        rows = self.db.execute(
            "SELECT observation, formula, previous, error, hypothesis, edits, evaluated, seconds, "
            "trace, ties, cpu_seconds FROM repairs WHERE trial = ? ORDER BY id", (trial,))
        return [RepairStep(o, f, b, e, h, ed, ev, s, json.loads(t), json.loads(ti), cpu)
                for o, f, b, e, h, ed, ev, s, t, ti, cpu in rows]

    def trials(self) -> list[int]:
        return [t for (t,) in self.db.execute(
            "SELECT DISTINCT trial FROM observations ORDER BY trial")]
