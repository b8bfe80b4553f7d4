"""The suite's metrics (docs/benchmarks.md): N random variations of each instance (vary.py,
seeds 0..N-1), planned by `tmpc bench` (the optimal planner to its first solution, validated), then the
suite's table and plots by `tmpc bench report`.

    python examples/lagriffoul/bench.py hanoi-3 blocks-D --variations 10 --time-limit 300 \\
        -o docs/results/lagriffoul.jsonl --report docs/benchmarks

The variations go to --work (default: a folder beside the results); the results file is a
`tmpc bench` JSONL results file, so an interrupted sweep continues with the same command
(`--resume`). With --report, the suite's table also replaces the lines between the markers
`<!-- suite table -->` and `<!-- end suite table -->` of docs/benchmarks.md.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
DOCS = HERE.parent.parent / "docs" / "benchmarks.md"
BEGIN, END = "<!-- suite table -->", "<!-- end suite table -->"


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("instances", nargs="+")
    ap.add_argument("--variations", type=int, default=10)
    ap.add_argument("--time-limit", type=float, default=300.0)
    ap.add_argument("--planners", default="optimal")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("-o", "--output", required=True, help="results file (.jsonl)")
    ap.add_argument("--work", help="where the variations go")
    ap.add_argument("--report", help="report folder (tmpc bench report)")
    args = ap.parse_args(argv)
    out = Path(args.output)
    work = Path(args.work) if args.work else out.with_suffix("").parent / (out.stem + "-variations")
    inputs = []
    for inst in args.instances:
        if not (HERE / inst / "run.toml").is_file():
            print(f"bench.py: no instance {inst!r} (examples/lagriffoul/<instance>/run.toml)",
                  file=sys.stderr)
            return 2
        for seed in range(args.variations):
            dest = work / f"{inst}~v{seed}"
            if not (dest / "run.toml").is_file():
                subprocess.run([sys.executable, str(HERE / "vary.py"), str(HERE / inst),
                                "--seed", str(seed), "-o", str(dest)], check=True)
            inputs.append(str(dest / "run.toml"))
    cmd = [sys.executable, "-m", "tmpc.runtime.cli", "bench", *inputs,
           "--planners", args.planners, "--seeds", "1", "--time-limit", str(args.time_limit),
           "--validate", "--workers", str(args.workers), "-o", str(out)]
    if args.planners == "optimal":
        cmd += ["--param", "first_solution=true"]     # the suite measures the first solution
    if out.is_file() and out.stat().st_size:
        cmd.append("--resume")
    code = subprocess.run(cmd).returncode
    if args.report:
        subprocess.run([sys.executable, "-m", "tmpc.runtime.cli", "bench", "report", str(out), "-o",
                        args.report], check=True)
        table = (Path(args.report) / "table.md").read_text().split("\n\n")[0]
        text = DOCS.read_text()
        if BEGIN in text and END in text:
            text = re.sub(re.escape(BEGIN) + ".*?" + re.escape(END),
                          BEGIN + "\n" + table.strip() + "\n" + END, text, flags=re.S)
            DOCS.write_text(text)
    return code


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
