"""Repair reports: ``report.json``, a Markdown table, and the thesis's Fig. 3.3 panels as PNG
(error over edits within each repair, parameter error over repairs)."""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np

from tmpc.lang.fileio import atomic_write_bytes, atomic_write_text
from tmpc.runtime.repair.loop import comparable


def write_report(out_dir: str | Path, report: dict, results: list, truth, parse) -> list[Path]:
    """Write the report files into ``out_dir``; ``parse(text)`` reads a stored formula."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
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
    return [out / "report.json", out / "table.md", *_plots(out, report, results, truth, parse)]


def _plots(out: Path, report: dict, results: list, truth, parse) -> list[Path]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.8))
    for res in results:
        for step in res.repairs:
            trace = np.maximum(np.asarray(step.trace, float), 1e-12)
            a.plot(np.arange(len(trace)), trace, color="tab:blue", alpha=0.25, lw=1)
        errs = [comparable(parse(s.formula), truth) for s in res.repairs]
        ys = [np.nan if e is None else max(e, 1e-6) for e in errs]
        b.plot(np.arange(1, len(ys) + 1), ys, marker=".", alpha=0.6)
    a.set(yscale="log", xlabel="formulas evaluated in one repair (edits)",
          ylabel="best error (squared distance)", title="error over edits")
    b.set(yscale="log", xlabel="repair", ylabel="parameter error (m / rad)",
          title="parameter error over repairs (gaps: other structure)")
    fig.suptitle(f"experiment {report['experiment']}: {len(results)} trials")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    path = out / f"experiment{report['experiment']}.png"
    atomic_write_bytes(path, buf.getvalue())
    return [path]
