"""Write clutter problems: `python examples/clutter/generate.py N [--red] [-o DIR]`.

Writes DIR/scene-N[-red].json, DIR/problem-N[-red].pddl and the run manifest DIR/clutter-N[-red].toml
naming them and the domain in this folder (the bundled scene.json/problem.pddl are N=1), so
`tmpc run DIR/clutter-N.toml` plans it. Deterministic: the same N gives the same files.
"""

from __future__ import annotations

import argparse
import json
import os
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
    domain = (Path(__file__).resolve().parent / "domain.pddl")
    rel = os.path.relpath(domain, out.resolve())
    (out / f"clutter-{tag}.toml").write_text(
        f"# tmpc run manifest: clutter with {args.n} stick(s){' and 14 red' if args.red else ''}"
        f" (examples/clutter/generate.py)\n[problem]\ndomain = {json.dumps(rel)}\n"
        f"problem = \"problem-{tag}.pddl\"\nscene = \"scene-{tag}.json\"\n")
    print(f"wrote {out}/scene-{tag}.json, {out}/problem-{tag}.pddl and {out}/clutter-{tag}.toml "
          f"(`tmpc run {out}/clutter-{tag}.toml`)")


if __name__ == "__main__":
    main()
