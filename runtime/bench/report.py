"""`tmpc bench report R.jsonl -o DIR`: plots of a results file (PNG) and an HTML page that embeds
them (self-contained: the images are data URIs), regenerated from the file alone.

* ``success.png``: the fraction of runs solved within t seconds of planning, per planner (and
  parameter point), over every problem of the file;
* ``time_vs_size.png``: the median planning time with its interquartile range against problem
  size (ground actions), log scale; an unsolved run counts as infinitely long, as in the table;
* ``cost.png``: the median best cost over planning time of anytime runs (those with a
  ``cost_trace``), per problem and planner; only when the file has such runs;
* ``error_over_edits.png``: a repair experiment's error over the formulas evaluated within each
  repair and its parameter error over repairs (the thesis's Fig. 3.3), when an input is a
  ``report.json`` of `tmpc repair --experiment` (a colour per experiment);
* ``table.md``: the Markdown tables of docs/performance.md's sweeps: a row per problem and
  planner (solved, median time and IQR, actions, cost, setup, memory), and a row per repair
  experiment.

matplotlib is imported when a report is drawn (not by ``tmpc --help``).
"""

from __future__ import annotations

import base64
import html
import io
import json
import math
import re
from collections import defaultdict
from pathlib import Path

from tmpc.lang.fileio import atomic_write_bytes, atomic_write_text
from tmpc.runtime.bench.physics import physics_table
from tmpc.runtime.bench.results import read_results
from tmpc.runtime.bench.sweep import cost_at, quantile
from tmpc.runtime.repair import edits_figure, repair_table


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


def read_inputs(files) -> tuple[list[dict], list[dict]]:
    """The runs of the results files (JSON lines) and the repair reports (``report.json`` of
    `tmpc repair --experiment`: one JSON object with ``trials``) among ``files``."""
    recs, reports = [], []
    for f in files:
        doc = _repair_report(f)
        if doc is not None:
            reports.append(doc)
        else:
            recs += [r for r in read_results(f) if r.get("status") in ("solved", "partial",
                                                                       "crash")]
    return recs, reports


def _repair_report(path) -> dict | None:
    """``path``'s repair report, or None when it is a results file (a JSON object a line)."""
    with open(path, "rb") as f:
        try:
            json.loads(f.readline())
            return None                     # its first line is a whole record: JSON lines
        except ValueError:
            pass
        f.seek(0)
        try:
            doc = json.loads(f.read())
        except ValueError:
            return None                     # a torn results file
    return doc if isinstance(doc, dict) and isinstance(doc.get("trials"), list) else None


def write_report(files, out_dir) -> list[Path]:
    """Draw the report of the results ``files`` (and repair reports) into ``out_dir``; returns
    the files written."""
    import matplotlib
    matplotlib.use("Agg")
    recs, reports = read_inputs(files)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    figures = [("success.png", "Success rate over time", success_plot),
               ("time_vs_size.png", "Median planning time against problem size", size_plot),
               ("cost.png", "Cost over time (anytime planners)", cost_plot)]
    written = []
    for name, title, draw in figures:
        if not recs:
            break
        _save(draw(recs), out / name, title, written)
    if reports:
        _save(edits_figure(reports), out / "error_over_edits.png",
              "Error over edits (repair experiments)", written)
    suite = suite_table(recs) if recs else ""
    tables = ((suite + "\n" if suite else "") + (summary_table(recs) if recs else "")
              + ("\n" if recs and reports else "") + (repair_table(reports) if reports else ""))
    atomic_write_text(out / "table.md", tables)
    page = out / "report.html"
    atomic_write_text(page, html_page(files, recs, reports, written, tables))
    return [p for p, _ in written] + [out / "table.md", page]


def _save(fig, path: Path, title: str, written: list) -> None:
    import matplotlib.pyplot as plt
    if fig is None:
        return
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    atomic_write_bytes(path, buf.getvalue())
    written.append((path, title))


def _natural(name: str) -> tuple:
    """clutter-2 before clutter-10."""
    return tuple(int(t) if t.isdigit() else t for t in re.split(r"(\d+)", name))


#: a variation of an instance is named ``<instance>~v<seed>`` (examples/lagriffoul/bench.py)
_VARIATION = re.compile(r"~v\d+$")


def suite_table(recs: list[dict]) -> str:
    """The benchmark suite's metrics (docs/benchmarks.md): a row per instance and planner over
    its variations (problems named ``<instance>~v<seed>``): runs, success rate, success within
    60 and 300 s, median, mean and max planning time of the solved runs, median plan length
    (actions) and median motion length (configuration-space path length). Empty without
    variations."""
    rows = defaultdict(list)
    for r in recs:
        if _VARIATION.search(r["problem"]):
            rows[(_VARIATION.sub("", r["problem"]), cell(r))].append(r)
    if not rows:
        return ""

    def f(x: float) -> str:
        return "—" if math.isnan(x) else f"{x:.1f}"

    lines = ["| instance | planner | runs | solved | ≤ 60 s | ≤ 300 s | median s | mean s | "
             "max s | median actions | median motion length |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for (inst, name), rs in sorted(rows.items(), key=lambda kv: (_natural(kv[0][0]), kv[0][1])):
        solved = [r for r in rs if r.get("solved")]
        times = [solve_time(r) for r in solved]
        n = len(rs)
        acts = [float(r.get("n_actions", len(r.get("actions") or []))) for r in solved]
        length = [float(r["path_length"]) for r in solved if r.get("path_length") is not None]
        med = (lambda xs: quantile(xs, 0.5) if xs else math.nan)
        lines.append(
            f"| {inst} | {name} | {n} | {len(solved) / n:.0%} | "
            f"{sum(t <= 60 for t in times)}/{n} | {sum(t <= 300 for t in times)}/{n} | "
            f"{f(med(times))} | {f(sum(times) / len(times) if times else math.nan)} | "
            f"{f(max(times) if times else math.nan)} | {f(med(acts))} | {f(med(length))} |")
    return "\n".join(lines) + "\n"


def summary_table(recs: list[dict]) -> str:
    """A Markdown row per problem and planner cell: solved, median time to the (first) solution
    and IQR (an unsolved run counts as infinitely long), median actions and cost of the solved
    runs, median setup, peak RSS, invalid plans and the median load before the runs."""
    rows = defaultdict(list)
    for r in recs:
        rows[(r["problem"], cell(r))].append(r)

    def t(x: float) -> str:
        return "—" if math.isnan(x) else ("unsolved" if math.isinf(x) else f"{x:.2f}")

    def med(xs: list) -> float:
        xs = [float(x) for x in xs if x is not None]
        return quantile(xs, 0.5) if xs else math.nan

    lines = ["| problem | planner | solved | median s (IQR) | median actions | median cost | "
             "setup s | peak RSS MiB | invalid | load |", "|---|---|---|---|---|---|---|---|---|---|"]
    for (problem, name), rs in sorted(rows.items(), key=lambda kv: (_natural(kv[0][0]),
                                                                   kv[0][1])):
        times = [solve_time(r) for r in rs]
        solved = [r for r in rs if r.get("solved")]
        rss = [r["peak_rss_mib"] for r in rs if r.get("peak_rss_mib") is not None]
        checked = [r for r in rs if r.get("valid") is not None]
        acts = med([r.get("n_actions", len(r.get("actions") or [])) for r in solved])
        lines.append(
            f"| {problem} | {name} | {len(solved)}/{len(rs)} | {t(quantile(times, 0.5))} "
            f"({t(quantile(times, 0.25))}–{t(quantile(times, 0.75))}) | "
            f"{'—' if math.isnan(acts) else f'{acts:g}'} | "
            f"{t(med([r.get('cost') for r in solved]))} | "
            f"{t(med([r.get('setup_seconds') for r in rs]))} | "
            f"{f'{max(rss):.0f}' if rss else '—'} | "
            + (f"{sum(r['valid'] is False for r in checked)}/{len(checked)}" if checked
               else "not checked") + " | "
            f"{t(med([(r.get('load_before') or [None])[0] for r in rs]))} |")
    physics = physics_table(recs)
    return "\n".join(lines) + "\n" + ("\n" + physics if physics else "")


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


def html_page(files, recs: list[dict], reports: list[dict],
              figures: list[tuple[Path, str]], tables: str) -> str:
    """A self-contained page: the tables of ``table.md`` and the figures as data URIs."""
    imgs = "".join(
        f"<figure><img alt=\"{html.escape(title)}\" src=\"data:image/png;base64,"
        f"{base64.b64encode(path.read_bytes()).decode()}\"><figcaption>{html.escape(title)}"
        "</figcaption></figure>" for path, title in figures)
    sources = ", ".join(html.escape(str(f)) for f in files)
    what = [f"{len(recs)} runs"] if recs else []
    what += [f"{len(reports)} repair report{'s' * (len(reports) != 1)}"] if reports else []
    return ("<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            "<title>tmpc bench report</title><style>body{font-family:sans-serif;margin:2em}"
            "table{border-collapse:collapse;margin-bottom:1em}td,th{border:1px solid #ccc;"
            "padding:.3em .6em}img{max-width:100%}figure{display:inline-block;margin:1em}"
            "</style></head><body>"
            f"<h1>tmpc bench report</h1><p>{' and '.join(what) or 'nothing'} from {sources}</p>"
            + _html_tables(tables) + imgs + "<script type=\"application/json\" id=\"data\">"
            f"{html.escape(json.dumps({'runs': len(recs), 'repair_reports': len(reports)}))}"
            "</script></body></html>\n")


def _html_tables(md: str) -> str:
    """The Markdown tables of ``md`` (a header, a rule, rows; blank lines between) as HTML."""
    out = []
    for block in md.strip().split("\n\n"):
        lines = [ln.strip().strip("|").split("|") for ln in block.splitlines() if ln.strip()]
        if len(lines) < 2:
            continue
        head, body = lines[0], lines[2:]
        out.append("<table><tr>" + "".join(f"<th>{html.escape(c.strip())}</th>" for c in head)
                   + "</tr>" + "".join("<tr>" + "".join(f"<td>{html.escape(c.strip())}</td>"
                                                        for c in row) + "</tr>" for row in body)
                   + "</table>")
    return "".join(out)
