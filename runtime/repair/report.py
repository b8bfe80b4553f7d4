"""Repair reports: ``report.json``, a Markdown table, and the thesis's Fig. 3.3 panels as PNG
(error over edits within each repair, parameter error over repairs).

The panels are drawn from ``report.json`` alone (each trial's ``repairs``: the best error over
the formulas one repair evaluated, and the repaired formula's parameter error), so `tmpc bench
report` draws them again from the file (:func:`edits_figure`, :func:`repair_table`).
"""

from __future__ import annotations

import io
import json
import math
from pathlib import Path

import numpy as np

from tmpc.lang.fileio import atomic_write_bytes, atomic_write_text
from tmpc.runtime.repair.loop import comparable


def write_report(out_dir: str | Path, report: dict, results: list, truth, parse) -> list[Path]:
    """Write the report files into ``out_dir``; ``parse(text)`` reads a stored formula. Each
    trial of ``report`` gains ``repairs`` (from ``results``, the trials' loop results)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    for row, res in zip(report["trials"], results):
        row["repairs"] = repair_records(res, truth, parse)
    if not report["trials"]:                 # a single repair (`tmpc repair ... --report`)
        report["repairs"] = [repair_records(res, truth, parse) for res in results]
    atomic_write_text(out / "report.json", json.dumps(report, indent=1) + "\n")
    rows = report["trials"]
    lines = ["| seed | final formula | structurally correct | parameter error | edits | "
             "unexpected | mean loop s |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        pe = "—" if r["param_error"] is None else f"{r['param_error']:.4f}"
        loop = f"{np.mean(r['loop_seconds']):.2f}" if r["loop_seconds"] else "—"
        lines.append(f"| {r['seed']} | `{r['final_formula']}` | {r['structurally_correct']} | "
                     f"{pe} | {r['edits']} | {r['unexpected']} | {loop} |")
    atomic_write_text(out / "table.md", "\n".join(lines) + "\n")
    return [out / "report.json", out / "table.md", *_plots(out, report)]


def repair_records(res, truth, parse) -> list[dict]:
    """A trial's repairs as report.json keeps them: the observation that caused each, its error,
    edits, ``trace`` (the best error after each formula evaluated) and ``param_error`` (the
    repaired formula's largest parameter difference from the truth; null: other structure)."""
    return [{"observation": s.observation, "error": _g(s.error), "edits": s.edits,
             "trace": [_g(e) for e in s.trace],
             "param_error": comparable(parse(s.formula), truth)} for s in res.repairs]


def _g(x: float) -> float | None:
    """Six significant digits (a plot's precision); JSON has no inf/nan: None."""
    x = float(x)
    return float(f"{x:.6g}") if math.isfinite(x) else None


def trial_repairs(report: dict) -> list[list[dict]]:
    """Each trial's repair records (a report of a single repair keeps them at the top)."""
    got = [t.get("repairs") or [] for t in report.get("trials") or []]
    return got or [r for r in report.get("repairs") or [] if isinstance(r, list)]


def edits_figure(reports: list[dict]):
    """The Fig. 3.3 panels of one or more reports (a colour per report): error over the
    formulas evaluated within each repair, and parameter error over repairs."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.8))
    for k, report in enumerate(reports):
        colour = f"C{k}"
        trials = trial_repairs(report)
        label = (f"experiment {report['experiment']}" if report.get("experiment") is not None
                 else "repair") + f" ({len(trials)} trials)"
        for t, repairs in enumerate(trials):
            for r in repairs:
                trace = np.maximum(np.array([np.inf if e is None else e for e in r["trace"]],
                                            float), 1e-12)
                a.plot(np.arange(len(trace)), trace, color=colour, alpha=0.25, lw=1)
            ys = [np.nan if r["param_error"] is None else max(r["param_error"], 1e-6)
                  for r in repairs]
            b.plot(np.arange(1, len(ys) + 1), ys, marker=".", alpha=0.6, color=colour,
                   label=label if t == 0 else None)
    a.set(yscale="log", xlabel="formulas evaluated in one repair (edits)",
          ylabel="best error (squared distance)", title="error over edits")
    b.set(yscale="log", xlabel="repair", ylabel="parameter error (m / rad)",
          title="parameter error over repairs (gaps: other structure)")
    if len(reports) > 1 and b.get_legend_handles_labels()[0]:
        b.legend(fontsize="small")
    if len(reports) == 1:
        fig.suptitle(label)
    fig.tight_layout()
    return fig


def repair_table(reports: list[dict]) -> str:
    """A Markdown row per report: the README's table of repair experiments."""
    lines = ["| experiment | trials | structurally correct | parameter error: max / median "
             "(matching structure) | unexpected (median) | observations (median) | edits per "
             "trial (median) | repair loop s: max / median | repair loop CPU s: max / median |",
             "|---|---|---|---|---|---|---|---|---|"]
    for rep in reports:
        rows = rep.get("trials") or []
        if not rows:
            continue
        pe = [r["param_error"] for r in rows if r.get("param_error") is not None]
        loops = [s for r in rows for s in r.get("loop_seconds") or []]
        cpu = [s for r in rows for s in r.get("loop_cpu_seconds") or []]
        med = (lambda xs, f="{:g}": "—" if not xs else f.format(float(np.median(xs))))
        obs = [r["observations"] for r in rows if r.get("observations") is not None]
        lines.append(
            f"| {rep.get('experiment', '—')} | {len(rows)} | "
            f"{sum(bool(r.get('structurally_correct')) for r in rows)}/{len(rows)} | "
            + (f"{max(pe):.4f} / {float(np.median(pe)):.4f}" if pe else "—") + " | "
            f"{med([r['unexpected'] for r in rows])} | {med(obs)} | "
            f"{med([r['edits'] for r in rows])} | "
            + (f"{max(loops):.2f} / {float(np.median(loops)):.3f}" if loops else "—") + " | "
            + (f"{max(cpu):.2f} / {float(np.median(cpu)):.3f}" if cpu else "—") + " |")
    return "\n".join(lines) + "\n"


def _plots(out: Path, report: dict) -> list[Path]:
    import matplotlib.pyplot as plt

    fig = edits_figure([report])
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    name = f"experiment{report['experiment']}.png" if report.get("experiment") is not None \
        else "repair.png"
    path = out / name
    atomic_write_bytes(path, buf.getvalue())
    return [path]
