"""`tmpc bench report R.jsonl -o DIR`: plots of a results file (PNG) and an HTML page that embeds
them (self-contained: the images are data URIs), regenerated from the file alone.

* ``success.png``: the fraction of runs solved within t seconds of planning, per planner (and
  parameter point), over every problem of the file;
* ``time_vs_size.png``: the median planning time with its interquartile range against problem
  size (ground actions), log scale; an unsolved run counts as infinitely long, as in the table;
* ``cost.png``: the median best cost over planning time of anytime runs (those with a
  ``cost_trace``), per problem and planner; only when the file has such runs.

matplotlib is imported when a report is drawn (not by ``tmpc --help``).
"""

from __future__ import annotations

import base64
import html
import json
import math
from collections import defaultdict
from pathlib import Path

from tmpc.runtime.bench.results import read_results
from tmpc.runtime.bench.sweep import cost_at, quantile


def cell(rec: dict) -> str:
    """A planner at its parameter point (the plots' legend)."""
    params = rec.get("params") or {}
    return rec["planner"] + ("[" + ",".join(f"{k}={v}" for k, v in sorted(params.items()))
                             + "]" if params else "")


def solve_time(rec: dict) -> float:
    """Seconds to the (first) solution; inf when unsolved."""
    if not rec.get("solved"):
        return math.inf
    t = rec.get("first_solution_seconds") or rec.get("planning_seconds") or \
        rec.get("solve_seconds")
    return math.inf if t is None else float(t)


def write_report(files, out_dir) -> list[Path]:
    """Draw the report of the results ``files`` into ``out_dir``; returns the files written."""
    import matplotlib
    matplotlib.use("Agg")
    recs = [r for f in files for r in read_results(f)
            if r.get("status") in ("solved", "partial", "crash")]
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    figures = [("success.png", "Success rate over time", success_plot),
               ("time_vs_size.png", "Median planning time against problem size", size_plot),
               ("cost.png", "Cost over time (anytime planners)", cost_plot)]
    written = []
    for name, title, draw in figures:
        fig = draw(recs)
        if fig is None:
            continue
        fig.savefig(out / name, dpi=110, bbox_inches="tight")
        matplotlib.pyplot.close(fig)
        written.append((out / name, title))
    page = out / "report.html"
    page.write_text(html_page(files, recs, written), encoding="utf-8")
    return [p for p, _ in written] + [page]


def _axes(title: str, xlabel: str, ylabel: str):
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    ax.set_title(title)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(True, alpha=0.3)
    return fig, ax


def success_plot(recs: list[dict]):
    """Fraction solved by time t, per planner cell (a step function over the runs' times)."""
    fig, ax = _axes("Success rate over time", "planning time t (s)", "fraction solved by t")
    by = defaultdict(list)
    for r in recs:
        by[cell(r)].append(solve_time(r))
    limit = max((float(r.get("time_limit") or 0) for r in recs), default=0.0) or max(
        (t for ts in by.values() for t in ts if math.isfinite(t)), default=1.0)
    for name, times in sorted(by.items()):
        xs = sorted(t for t in times if math.isfinite(t))
        steps_x = [0.0] + xs + [limit]
        steps_y = [0.0] + [(i + 1) / len(times) for i in range(len(xs))] + [len(xs) / len(times)]
        ax.step(steps_x, steps_y, where="post", label=f"{name} ({len(times)} runs)")
    ax.set_ylim(-0.02, 1.02)
    if by:
        ax.legend(fontsize="small")
    return fig


def size_plot(recs: list[dict]):
    """Median time with IQR against problem size (ground actions), per planner cell."""
    fig, ax = _axes("Median planning time against problem size", "problem size (ground actions)",
                    "planning time (s), median and IQR")
    by = defaultdict(lambda: defaultdict(list))
    for r in recs:
        by[cell(r)][r.get("ground_actions") or 0].append(solve_time(r))
    for name, sizes in sorted(by.items()):
        xs, med, lo, hi = [], [], [], []
        for size in sorted(sizes):
            m = quantile(sizes[size], 0.5)
            if not math.isfinite(m):
                continue                     # fewer than half solved: no median to draw
            q1, q3 = quantile(sizes[size], 0.25), quantile(sizes[size], 0.75)
            xs.append(size)
            med.append(m)
            lo.append(m - q1)
            hi.append((q3 if math.isfinite(q3) else m) - m)
        if xs:
            ax.errorbar(xs, med, yerr=[lo, hi], marker="o", capsize=4, label=name)
    ax.set_yscale("log")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize="small")
    return fig


def cost_plot(recs: list[dict]):
    """Median best cost over time of anytime runs, per problem and planner cell (None: no
    anytime runs in the file)."""
    anytime = [r for r in recs if r.get("cost_trace")]
    if not anytime:
        return None
    fig, ax = _axes("Cost over time (anytime planners)", "planning time t (s)",
                    "median best cost by t")
    by = defaultdict(list)
    for r in anytime:
        by[(r["problem"], cell(r))].append(r["cost_trace"])
    limit = max(float(r.get("time_limit") or 0) or max(s for s, _ in r["cost_trace"])
                for r in anytime)
    grid = [limit * i / 200 for i in range(1, 201)]
    for (problem, name), traces in sorted(by.items()):
        ys = []
        for t in grid:
            costs = [cost_at(tr, t) for tr in traces]
            ys.append(quantile([math.inf if c is None else c for c in costs], 0.5))
        pts = [(t, y) for t, y in zip(grid, ys) if math.isfinite(y)]
        if pts:
            ax.step(*zip(*pts), where="post", label=f"{problem} {name} ({len(traces)} runs)")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize="small")
    return fig


def html_page(files, recs: list[dict], figures: list[tuple[Path, str]]) -> str:
    """A self-contained page: a summary table per cell and the figures as data URIs."""
    rows = defaultdict(list)
    for r in recs:
        rows[(r["problem"], cell(r))].append(r)
    trs = []
    for (problem, name), rs in sorted(rows.items()):
        times = [solve_time(r) for r in rs]
        med = quantile(times, 0.5)
        trs.append("<tr>" + "".join(f"<td>{html.escape(str(v))}</td>" for v in (
            problem, name, f"{sum(r.get('solved', False) for r in rs)}/{len(rs)}",
            "unsolved" if not math.isfinite(med) else f"{med:.2f}",
            sum(r.get("valid") is False for r in rs))) + "</tr>")
    imgs = "".join(
        f"<figure><img alt=\"{html.escape(title)}\" src=\"data:image/png;base64,"
        f"{base64.b64encode(path.read_bytes()).decode()}\"><figcaption>{html.escape(title)}"
        "</figcaption></figure>" for path, title in figures)
    sources = ", ".join(html.escape(str(f)) for f in files)
    return ("<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            "<title>tmpc bench report</title><style>body{font-family:sans-serif;margin:2em}"
            "table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:.3em .6em}"
            "img{max-width:100%}figure{display:inline-block;margin:1em}</style></head><body>"
            f"<h1>tmpc bench report</h1><p>{len(recs)} runs from {sources}</p>"
            "<table><tr><th>problem</th><th>planner</th><th>solved</th>"
            "<th>median time (s)</th><th>invalid plans</th></tr>" + "".join(trs) + "</table>"
            + imgs + f"<script type=\"application/json\" id=\"data\">"
            f"{html.escape(json.dumps({'runs': len(recs)}))}</script></body></html>\n")
