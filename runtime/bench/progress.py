"""A distributed sweep's progress on stderr: a live bar (rich) with done / failed / running, the
ETA and the current median planning time of the cell that last finished a run; a line per run
when stderr is not a terminal (CI logs, ``2> log``)."""

from __future__ import annotations

import sys
from collections import defaultdict

from tmpc.runtime.bench.sweep import quantile


class Progress:
    """``update(rec)`` after each finished run, ``running(n)`` as the in-flight count changes."""

    def __init__(self, total: int, skipped: int = 0, live: bool | None = None):
        self.total, self.skipped = total, skipped
        self.done = self.failed = self.now_running = 0
        self.cells: dict[str, list[float]] = defaultdict(list)
        self.last = ""
        self.live = sys.stderr.isatty() if live is None else live
        self._bar = None
        if self.live:
            self._start_bar()
        elif skipped:
            sys.stderr.write(f"resuming: {skipped} runs already in the results file\n")

    def _start_bar(self) -> None:
        from rich.console import Console
        from rich.progress import (BarColumn, MofNCompleteColumn, Progress as Bar, TextColumn,
                                   TimeElapsedColumn, TimeRemainingColumn)
        self._bar = Bar(TextColumn("[bold]bench"), BarColumn(bar_width=24), MofNCompleteColumn(),
                        TimeElapsedColumn(), TextColumn("ETA"), TimeRemainingColumn(),
                        TextColumn("{task.description}"), console=Console(file=sys.stderr),
                        transient=False)
        self._bar.start()
        self._task = self._bar.add_task("", total=self.total)

    def running(self, n: int) -> None:
        self.now_running = n
        self._refresh()

    def update(self, rec: dict, failed: bool) -> None:
        self.done += 1
        self.failed += failed
        cell = f"{rec['problem']} {rec['planner']}" + "".join(
            f" {k}={v}" for k, v in sorted((rec.get("params") or {}).items()))
        t = rec.get("planning_seconds")
        self.cells[cell].append(t if rec.get("solved") and t is not None else float("inf"))
        med = quantile(self.cells[cell], 0.5)
        self.last = f"{cell}: median {'unsolved' if med == float('inf') else f'{med:.2f} s'}"
        self.now_running = max(0, self.now_running - 1)
        if self._bar is None:
            sys.stderr.write(f"[{self.done}/{self.total}] {cell} seed {rec['seed']}: "
                             f"{rec.get('status')}"
                             + (f" in {t:.2f} s" if t is not None else "")
                             + f" on {rec.get('worker')} ({self.failed} failed; {self.last})\n")
        self._refresh()

    def _refresh(self) -> None:
        if self._bar is not None:
            self._bar.update(self._task, completed=self.done, description=(
                f"done {self.done} failed {self.failed} running {self.now_running} | "
                f"{self.last}"))

    def close(self) -> None:
        if self._bar is not None:
            self._bar.stop()
