"""Writes examples/lagriffoul/<instance>/run.toml for every instance of the suite (the instance
names are a contract: scripts outside the repo use them). Run it after changing a line here;
tests/runtime/test_lagriffoul.py checks the files are what it writes.

    python examples/lagriffoul/make_runs.py
"""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
BLOCKS = "CDEFGHIJ"

#: instance -> (problem folder, domain, problem, scene, meshes, semantics module, names,
#: [robot] mobile_base or None, time limit, title)
#: [planner] lines beyond the time limit, per instance
PLANNER = {
    # 2^n - 1 moves of two steps each (grasp, move): past the default 100 steps
    "hanoi-5": ['max_steps = 200'],
    "hanoi-6": ['max_steps = 200'],
    # 28 steps and more: the decoupled planner follows a plan step by step, where the optimal
    # one samples every mode it reached (docs/benchmarks.md); a failed motion costs its
    # budget, and the step's next configuration mostly holds at once (docs/planning.md)
    "clutter": ['name = "decoupled"', 'motion_checks = 2500'],
    # the kitchens' 26-34 steps too, side by side with the optimal planner (10/10 each;
    # docs/benchmarks-log.md, nineteenth session): the full kitchen median 44.6 s against
    # 78.3 s; without radishes 14.7 s against 14.2 s, every one within 30 s against 8 of 10
    "kitchen": ['name = "decoupled"'],
    "kitchen-noradish": ['name = "decoupled"'],
    # most of Blocks E's task plans fail at a transition: the decoupled planner tries a plan's
    # transitions before its motions (lazy_motions), the optimal one samples every mode it
    # reached (docs/benchmarks.md: 10/10 against 8/10); a failed step sends the search back
    # to the step that moved what it needs (backjump: 10/10 against 9/10, side by side); the
    # arm a step does not use starts where the run started it (park_idle: median 69.0 s
    # against 83.3 s, side by side; Blocks G 9/10 against 7/10)
    "blocks-E": ['name = "decoupled"', 'lazy_motions = true', 'backjump = true',
                 'park_idle = true'],
}
# Blocks F-J hand more blocks from one arm to the other through the table: a block is put down
# first where the plan's next grasp of it holds (lookahead: Blocks F 2/10 with it, 0 before;
# Blocks E 9/10 with it, median 162.5 s, against 10/10 and 126.0 s without, a session before)
PLANNER.update({f"blocks-{x}": PLANNER["blocks-E"] + ['lookahead = true'] for x in "FGHIJ"})
# a step's rounds after its first start partly from the arm's earlier valid configurations
# (seed_starts, side by side: Blocks F median 42.1 s against 71.7 s, 10/10 both; Blocks H
# 9/10, median 186.7 s, against 3/7; Blocks E median 19.5 s against 27.4 s and G 104.1 s
# against 123.2 s, but single variations 2-4x as long: G leaves it off; Blocks I 5/10,
# 4 within 300 s, against 2/10, 1 within 300 s)
for x in "FHI":
    PLANNER[f"blocks-{x}"] = PLANNER[f"blocks-{x}"] + ['seed_starts = 8']
# Blocks E seeds too, with its motions' retreats by the hand that acts (sideways too) and the
# idle arm moved alone first (retreat_sideways, park_first: v7's failed motions, 13 against
# 38, each moved both arms out of and into narrow places under the ceiling; ten variations
# side by side with seeds alone: median 19.2 s against 19.1 s, mean 22.3 s against 30.3 s,
# max 45.9 s against 124.9 s). Blocks G with the three: v3 not in 300 s (90 failed motions);
# Blocks F alike with them or without; Blocks H 10/10 with them, median 162.0 s, max 237.1 s,
# against 166.0 s and 273.2 s with seeds alone, side by side (33 failed motions against 55)
PLANNER["blocks-E"] = PLANNER["blocks-E"] + ['seed_starts = 8']
for x in "EH":
    PLANNER[f"blocks-{x}"] = PLANNER[f"blocks-{x}"] + ['retreat_sideways = true',
                                                       'park_first = true']
# a release's configurations the roomiest first, and more aimed that way (spread_placements;
# ten variations each, twenty-fifth session): Blocks E median 19.6 s against 17.5 s side by
# side, mean 22.3 s against 33.6 s, max 35.2 s against 89.0 s (v0's and v7's failed motions
# 7 and 0 against 21 and 28); Sort Clutter median 8.6 s, mean 11.6 s, max 24.0 s against its
# row's 9.7 s, 13.0 s and 30.1 s; the full kitchen 21.5 s, 29.9 s, 60.8 s against 26.4 s,
# 43.1 s, 110.5 s; without radishes 5.1 s, 6.7 s, 13.3 s against 7.0 s, 7.2 s, 9.7 s
for x in ("blocks-E", "clutter", "kitchen", "kitchen-noradish"):
    PLANNER[x] = PLANNER[x] + ['spread_placements = true']
# Blocks F (with lookahead) with the order alone: median 38.9 s, mean 46.6 s, max 89.8 s against
# its row's 46.8 s, 55.2 s, 135.0 s; with the aimed configurations too, seven variations: median
# 70.2 s (v2 129.1 s against 55.2 s). Blocks G with both: v4 196.4 s against 65.2 s; stopped,
# G-J leave it off
PLANNER["blocks-F"] = PLANNER["blocks-F"] + ['spread_placements = true', 'aim_placements = false']
# Hanoi 3 with the decoupled planner, Blocks E's first options and the roomiest release (ten
# variations, twenty-sixth session): 10/10, median 3.1 s, mean 16.5 s, max 57.0 s, against the
# optimal planner's 9/10 and 64.5 s; six of ten plan from their first task plan in 2-4 s. The
# back peg's grasp needs the discs at the edges of their slack (docs/benchmarks-log.md,
# "Hanoi's geometry"), which the roomiest release gives. Hanoi 4: v0, v1 not planned in 300 s
PLANNER["hanoi-3"] = PLANNER["blocks-E"][:4] + ['spread_placements = true']
# a plan ends at a step out of the arm's reach once its rule is learnt, the same grasp of the
# blocks not moved yet is probed at once, and a failed motion of a whole chain is planned once
# more on 4 times the budget (give_up_missed, probe_reach, chain_retry; ten variations,
# twenty-sixth session): Blocks E median 16.8 s, mean 17.7 s, max 25.4 s against its row's
# 19.6 s, 22.3 s, 35.2 s; Blocks G 68.0 s, 67.9 s, 102.6 s against 91.6 s, 101.0 s, 193.6 s;
# Blocks H 80.4 s, 98.7 s, 248.0 s against 162.0 s, 173.0 s, 237.1 s; Blocks I 10/10, 103.2 s,
# 115.6 s, 201.3 s against 5/10 (252.0 s median). Blocks J is not planned either way (two
# variations with them). Blocks F: 42.8 s, 52.1 s, 149.5 s against 38.9 s, 46.7 s, 89.8 s
# (without chain_retry 37.7 s, 69.7 s, 171.6 s): F leaves them off
REACH = ['give_up_missed = true', 'probe_reach = true', 'chain_retry = 4']
for x in "EGHIJ":
    PLANNER[f"blocks-{x}"] = PLANNER[f"blocks-{x}"] + REACH
# Blocks D with Blocks E's planner and options (ten variations, twenty-sixth session): 10/10,
# median 3.7 s, mean 5.6 s, max 15.8 s, motions 35 long, against the optimal planner's 9.7 s,
# 16.4 s, 42.5 s and 49
PLANNER["blocks-D"] = list(PLANNER["blocks-E"])

def instances() -> dict[str, tuple]:
    out: dict[str, tuple] = {}
    for n in range(3, 7):
        names = {f"d{i}": f"disc{i}" for i in range(1, n + 1)}
        out[f"hanoi-{n}"] = ("problem1", "hanoi.pddl", f"hanoi_pb_{n}.pddl",
                             f"hanoi_xml/hanoi{n}.xml", "hanoi_meshes", "hanoi", names, None,
                             300, f"Towers of Hanoi, {n} discs ({2 ** n - 1} moves)")
    for k, letter in enumerate(BLOCKS):
        blocks = "abcdefghij"[:k + 3]
        names = {b: f"block_{b}" for b in blocks}
        names.update({"red-tray": "red_tray", "blue-tray": "blue_tray"})
        out[f"blocks-{letter}"] = ("problem2", "blocksworld.pddl",
                                   f"blocksworld_pb_{letter}.pddl",
                                   f"blocksworld_xml/blocksworld{letter}.xml",
                                   "blocksworld_meshes", "blocksworld", names, None, 300,
                                   f"Blocks World {letter}, {k + 3} blocks")
    sticks = {}
    for i in range(1, 8):
        sticks[f"bs{i}"] = f"stick_blue{i}"
        sticks[f"gs{i}"] = f"stick_green{i}"
    for i in range(1, 15):
        sticks[f"rs{i}"] = f"stick_red{i}"
    out["clutter"] = ("problem3", "clutter.pddl", "clutter_pb7.pddl", "clutter.xml",
                      "clutter_meshes", "clutter", sticks, True, 300,
                      "Sort Clutter pb7: 7 blue and 7 green sticks to their tables, 14 red")
    mono = {}
    for i in range(1, 5):
        mono[f"rs{i}"], mono[f"rt{i}"] = f"stick_red{i}", f"target_red{i}"
        mono[f"bs{i}"], mono[f"bt{i}"] = f"stick_blue{i}", f"target_blue{i}"
    for i in range(1, 4):
        mono[f"gs{i}"], mono[f"gt{i}"] = f"stick_green{i}", f"target_green{i}"
    out["nonmono"] = ("problem4", "nonmono.pddl", "nonmono_pb.pddl", "nonmono.xml",
                      "nonmono_meshes", "clutter", mono, True, 300,
                      "Non-Monotonic: 3 green sticks across; the blockers go back")
    for name, problem, scene, what in (
            ("kitchen", "kitchen_pb.pddl", "kitchen.xml", "the full kitchen, with radishes"),
            ("kitchen-noradish", "kitchen_noradish_pb.pddl", "kitchen_noradish.xml",
             "the thesis's kitchen without radishes")):
        out[name] = ("problem5", "kitchen.pddl", problem, scene, "kitchen_meshes", "kitchen", {},
                     None, 300, f"Kitchen (problem 5, reconstructed): {what}")
    return out


def render(name: str, spec: tuple) -> str:
    folder, domain, problem, scene, meshes, module, names, mobile, limit, title = spec
    data = f"../data/{folder}"
    lines = [f"# Lagriffoul et al. 2018, {title}.",
             f"# tmpc run examples/lagriffoul/{name}/run.toml   (written by ../make_runs.py)",
             "[problem]",
             f'domain = "{data}/{domain}"',
             f'problem = "{data}/{problem}"',
             f'scene = "{data}/{scene}"',
             f'mesh_dir = "{data}/{meshes}"',
             f'semantics = "../semantics/{module}.tmpc"',
             ""]
    if mobile is not None:
        lines += ["[robot]",
                  "# the file says <movebase>false</movebase>, but its tables stand 2 m from the",
                  "# robot: the base moves (docs/benchmarks.md)",
                  f"mobile_base = {'true' if mobile else 'false'}", ""]
    if names:
        lines += ["[names]   # PDDL name = the scene's object name"]
        lines += [f'{k} = "{v}"' for k, v in names.items()]
    lines += ["", "[planner]", f"time_limit = {limit}", *PLANNER.get(name, []), ""]
    text = "\n".join(lines)
    while "\n\n\n" in text:
        text = text.replace("\n\n\n", "\n\n")
    return text


def main(argv: list[str]) -> int:
    for name, spec in instances().items():
        path = HERE / name / "run.toml"
        path.parent.mkdir(exist_ok=True)
        path.write_text(render(name, spec))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
