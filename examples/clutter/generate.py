"""Write clutter problems: `python examples/clutter/generate.py N [--red] [-o DIR]`.

Writes DIR/scene-N[-red].json and DIR/problem-N[-red].pddl for the domain in this folder (the
bundled scene.json/problem.pddl are N=1). Deterministic: the same N gives the same files.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from tmpc.lang.world.generate import clutter_problem, clutter_scene


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("n", type=int, help="number of sticks to move (1-14)")
    ap.add_argument("--red", action="store_true", help="add the 14 red distractor sticks")
    ap.add_argument("-o", "--out", default=".", help="output directory")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    tag = f"{args.n}{'-red' if args.red else ''}"
    (out / f"scene-{tag}.json").write_text(json.dumps(clutter_scene(args.n, args.red), indent=1))
    (out / f"problem-{tag}.pddl").write_text(clutter_problem(args.n, args.red))
    print(f"wrote {out}/scene-{tag}.json and {out}/problem-{tag}.pddl")


if __name__ == "__main__":
    main()
