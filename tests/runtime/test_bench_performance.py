"""`tmpc bench report --docs`: the performance document from results documents and `tmpc bench`
results files, deterministic, through the CLI."""

from __future__ import annotations

import json

import pytest

from tmpc.runtime.bench import ResultsError, render_performance

DOC = {"format": "tmpc-results/1", "title": "A family", "issue": "Z",
       "command": "tmpc bench x.toml -o R.jsonl", "date": "2026-12-05", "machine": "a laptop",
       "about": "What it measures.",
       "tables": [{"caption": "Numbers:",
                   "columns": [{"key": "p", "label": "problem"},
                               {"key": "t", "label": "median s", "format": ".2f"},
                               {"key": "n", "label": "states", "format": ","}],
                   "rows": [{"p": "a", "t": 0.5, "n": 1234}, {"p": "b", "t": None, "n": 7}]}],
       "notes": ["Goal met."]}


def run(problem: str, seed: int, t: float) -> dict:
    return {"problem": problem, "planner": "unified", "seed": seed, "params": {},
            "status": "solved", "solved": True, "valid": True, "actions": ["a", "b"],
            "planning_seconds": t, "setup_seconds": 1.0, "cost": 2.0, "worker": 0}


def test_renders_a_document(tmp_path):
    (tmp_path / "10-a.json").write_text(json.dumps(DOC))
    text = render_performance(tmp_path)
    assert text.startswith("# Performance\n")
    assert "- [A family (issue Z)](#a-family-issue-z)" in text
    assert "## A family (issue Z)\n\nWhat it measures.\n" in text
    assert "Measured 2026-12-05 on a laptop. Regenerate with:\n\n```bash\ntmpc bench x.toml" in text
    assert "| problem | median s | states |\n|---|---|---|\n| a | 0.50 | 1,234 |\n| b | — | 7 |" \
        in text
    assert "- Goal met.\n" in text
    assert render_performance(tmp_path) == text                    # deterministic


def test_bench_results_files_render_as_tables(tmp_path):
    results = tmp_path / "R.jsonl"
    results.write_text("".join(json.dumps(run("clutter-2", s, 0.1 * (s + 1))) + "\n"
                               for s in range(3)))
    (tmp_path / "20-sweep.json").write_text(json.dumps(
        {**DOC, "title": "A sweep", "tables": [{"caption": "From the file:", "source": "R.jsonl"}]}))
    (tmp_path / "loose.jsonl").write_text(json.dumps(run("clutter-1", 0, 0.3)) + "\n")
    text = render_performance(tmp_path)
    assert "| clutter-2 | unified | 3/3 | 0.20 (0.15–0.25) | 2 | 2.00 | 1.00 |" in text
    assert text.count("| clutter-2 |") == 1                         # named: not rendered again
    assert "## Results file loose.jsonl\n" in text and "| clutter-1 | unified | 1/1 |" in text


def test_a_malformed_document_is_refused(tmp_path):
    (tmp_path / "bad.json").write_text(json.dumps({**DOC, "machine": ""}))
    with pytest.raises(ResultsError, match="machine"):
        render_performance(tmp_path)


def test_the_command_writes_the_document(tmp_path, capsys):
    from tmpc.runtime.cli.main import main
    (tmp_path / "10-a.json").write_text(json.dumps(DOC))
    out = tmp_path / "performance.md"
    assert main(["bench", "report", "--docs", str(tmp_path), "-o", str(out)]) == 0
    assert out.read_text() == render_performance(tmp_path)
    assert main(["bench", "report", "--docs", str(tmp_path), "-o", "-"]) == 0
    assert capsys.readouterr().out == out.read_text()
    assert main(["bench", "report", "--docs", str(tmp_path)]) == 2            # no -o
    assert main(["bench", "report", "--docs", str(tmp_path / "nope"), "-o", str(out)]) == 1
