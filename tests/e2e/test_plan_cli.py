"""`tmpc plan`: IPC plan output that replays, exit codes, messages, atomic output; every engine
of the registry, the portfolio, engine errors."""

from __future__ import annotations

import os
import stat
import subprocess
import sys

import pytest

from tests.bench.gen import GRIPPER_DOMAIN, gripper_problem
from tests.support import EXAMPLES, FIXTURES
from tmpc.compiler.ground import ground
from tmpc.lang.program import load_checked
from tmpc.runtime.cli.main import main
from tmpc.runtime.planners import ENGINES

BLOCKS = [str(EXAMPLES / "blocksworld" / "domain.pddl"), str(EXAMPLES / "blocksworld" / "p01.pddl")]
ONCE = """(define (domain once) (:requirements :strips)
  (:predicates (token) (x) (y) (z))
  (:action ax :precondition (token) :effect (and (x) (not (token))))
  (:action ay :precondition (token) :effect (and (y) (not (token)))))
"""


def _files(tmp_path, domain: str, problem: str) -> list[str]:
    d, p = tmp_path / "domain.pddl", tmp_path / "problem.pddl"
    d.write_text(domain)
    p.write_text(problem)
    return [str(d), str(p)]


def replay(files: list[str], text: str) -> int:
    """Replay an IPC plan on the ground problem; returns its length."""
    gp = ground(load_checked(files))
    state = gp.init
    steps = [ln for ln in text.splitlines() if ln.strip() and not ln.startswith(";")]
    for line in steps:
        name, *args = line.strip("()").split()
        a = gp.find_action(name, *args)
        assert a is not None and gp.applicable(state, a), line
        state = gp.apply(state, a)
    assert gp.goal_satisfied(state)
    return len(steps)


def test_plan_to_stdout_replays(capsys):
    assert main(["plan", *BLOCKS]) == 0
    out, err = capsys.readouterr()
    assert replay(BLOCKS, out) == 6
    assert out.endswith("; cost = 6 (unit cost)\n; length 6\n")
    assert "plan of length 6 (shortest possible)" in err


def test_min_steps_past_the_optimum_is_not_called_shortest(capsys):
    assert main(["plan", *BLOCKS, "--min-steps", "8"]) == 0
    out, err = capsys.readouterr()
    assert replay(BLOCKS, out) == 8 and "shortest with at least 8 steps" in err


def test_output_file_is_written_atomically_with_normal_permissions(tmp_path, capsys):
    target = tmp_path / "out.plan"
    target.write_text("old")
    assert main(["plan", *BLOCKS, "-o", str(target)]) == 0
    assert capsys.readouterr().out == ""
    assert replay(BLOCKS, target.read_text()) == 6
    mask = os.umask(0)
    os.umask(mask)
    assert stat.S_IMODE(target.stat().st_mode) == 0o666 & ~mask
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.plan"]      # no temp left
    assert main(["plan", *BLOCKS, "-o", str(tmp_path / "no" / "dir.plan")]) == 1
    assert "E828" in capsys.readouterr().err


def test_verbose_prints_statistics_per_horizon(capsys):
    assert main(["plan", *BLOCKS, "-v"]) == 0
    err = capsys.readouterr().err
    assert "horizon   clauses" in err and "lower bound: 5" in err
    assert "      5 " in err and "unsat" in err and "sat" in err


def test_unsolvable_reports_the_horizon_proven(tmp_path, capsys):
    files = _files(tmp_path, ONCE, "(define (problem p) (:domain once) (:init (token)) "
                                   "(:goal (and (x) (y))))")
    assert main(["plan", *files, "--max-steps", "7"]) == 3
    err = capsys.readouterr().err
    assert "error[E612]: no plan of length <= 7" in err
    assert main(["plan", *files, "--min-steps", "4", "--max-steps", "5"]) == 3
    assert "no plan of length 4 to 5 (lengths below 2 are impossible)" in capsys.readouterr().err


def test_unreachable_goal_names_the_atom_and_points_at_the_goal(tmp_path, capsys):
    files = _files(tmp_path, ONCE, "(define (problem p) (:domain once) (:init (token))\n"
                                   "  (:goal (and (x) (z))))")
    assert main(["plan", *files]) == 3
    err = capsys.readouterr().err
    assert "problem.pddl:2:10: error[E611]: no plan: no sequence of actions can make (z) true" \
        in err
    assert "(:goal (and (x) (z))))" in err


def test_goal_true_at_start_prints_an_empty_plan(tmp_path, capsys):
    files = _files(tmp_path, ONCE, "(define (problem p) (:domain once) (:init (x)) (:goal (x)))")
    assert main(["plan", *files]) == 0
    assert capsys.readouterr().out == "; cost = 0 (unit cost)\n; length 0\n"


def test_no_actions(tmp_path, capsys):
    dom = "(define (domain none) (:requirements :strips) (:predicates (p) (q)))"
    files = _files(tmp_path, dom, "(define (problem p) (:domain none) (:init (p)) (:goal (q)))")
    assert main(["plan", *files]) == 3
    assert "E611" in capsys.readouterr().err


def test_action_costs_are_reported_and_not_minimized(capsys):
    d = FIXTURES / "classical" / "rover-costs"
    files = [str(d / "domain.pddl"), str(d / "p01.pddl")]
    assert main(["plan", *files]) == 0
    out = capsys.readouterr().out
    assert replay(files, out) == 9
    assert "(general cost)" in out and "action costs are not minimized" in out


@pytest.mark.parametrize("args,code", [(["--min-steps", "5", "--max-steps", "4"], 2),
                                       (["--max-steps", "-1"], 2), (["--time-limit", "0"], 2)])
def test_bad_limits_are_usage_errors(args, code, capsys):
    assert main(["plan", *BLOCKS, *args]) == code
    assert "E610" in capsys.readouterr().err


def test_time_limit(capsys):
    d = FIXTURES / "classical" / "tower-derived"
    assert main(["plan", str(d / "domain.pddl"), str(d / "p02.pddl"),
                 "--time-limit", "0.000001"]) == 3
    assert "E613" in capsys.readouterr().err


def test_bad_inputs_give_diagnostics_without_traceback(tmp_path):
    bad = _files(tmp_path, "(define (domain d) (:predicates (p))", "(define (problem q))")
    r = subprocess.run([sys.executable, "-m", "tmpc.runtime.cli", "plan", *bad],
                       capture_output=True, text=True)
    assert r.returncode == 1 and "error[E" in r.stderr and "Traceback" not in r.stderr
    two = _files(tmp_path, ONCE, ONCE.replace("once", "twice"))
    assert main(["plan", *two]) == 1
    numeric = _files(tmp_path, """(define (domain n) (:requirements :fluents)
      (:predicates (p)) (:functions (fuel))
      (:action a :precondition (p) :effect (decrease (fuel) 1)))""",
                     "(define (problem q) (:domain n) (:init (p) (= (fuel) 3)) (:goal (p)))")
    assert main(["plan", *numeric]) == 1


# ---- engines ---------------------------------------------------------------------------------
@pytest.mark.parametrize("engine", sorted(ENGINES))
def test_every_engine_plans_and_the_plan_replays(engine, capsys):
    assert main(["plan", *BLOCKS, "--engine", engine]) == 0
    out, err = capsys.readouterr()
    assert replay(BLOCKS, out) == 6 and out.endswith("; cost = 6 (unit cost)\n; length 6\n")
    assert "plan of length 6 (shortest possible) from the " in err


def test_engines_agree_on_lengths_of_the_classical_fixtures(capsys):
    for d in sorted((FIXTURES / "classical").iterdir()):
        files = [str(d / "domain.pddl"), str(next(d.glob("p*.pddl")))]
        lengths = []
        for engine in ("sat", "astar"):
            assert main(["plan", *files, "--engine", engine]) == 0
            lengths.append(replay(files, capsys.readouterr().out))
        if "costs" not in d.name and "power" not in d.name:
            assert lengths[0] == lengths[1], d.name


def test_astar_minimizes_action_costs(capsys):
    d = FIXTURES / "classical" / "rover-costs"
    files = [str(d / "domain.pddl"), str(d / "p01.pddl")]
    for engine in ("astar", "auto"):
        assert main(["plan", *files, "--engine", engine]) == 0
        out, err = capsys.readouterr()
        assert replay(files, out) == 11
        assert "; cost = 18 (general cost)\n; length 11 (cheapest possible)\n" in out
        assert "and cost 18 (cheapest possible) from the astar engine" in err


def test_verbose_names_the_engine_and_its_statistics(capsys):
    assert main(["plan", *BLOCKS, "--engine", "astar", "-v"]) == 0
    err = capsys.readouterr().err
    assert "astar: solved" in err and "expanded (" in err and "/s)" in err and "LM-cut" in err
    assert main(["plan", *BLOCKS, "--engine", "auto", "-v"]) == 0
    err = capsys.readouterr().err
    assert "engine auto: " in err and "answered first" in err


def test_astar_proves_there_is_no_plan(tmp_path, capsys):
    files = _files(tmp_path, ONCE, "(define (problem p) (:domain once) (:init (token)) "
                                   "(:goal (and (x) (y))))")
    for engine in ("astar", "auto"):
        assert main(["plan", *files, "--engine", engine]) == 3
        assert "error[E616]: no plan: A* explored all 3 reachable states" in \
            capsys.readouterr().err


def test_engine_usage_errors(capsys):
    assert main(["plan", *BLOCKS, "--engine", "astar", "--min-steps", "2"]) == 2
    assert "E610" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:
        main(["plan", *BLOCKS, "--engine", "fd"])
    assert exc.value.code == 2
    assert "invalid choice: 'fd'" in capsys.readouterr().err


def test_auto_with_min_steps_is_sat(capsys):
    assert main(["plan", *BLOCKS, "--engine", "auto", "--min-steps", "8"]) == 0
    out, err = capsys.readouterr()
    assert replay(BLOCKS, out) == 8 and "from the sat engine" in err


def test_time_limit_of_every_engine(tmp_path, capsys):
    files = _files(tmp_path, GRIPPER_DOMAIN, gripper_problem(14))
    for engine in ("astar", "auto"):
        assert main(["plan", *files, "--engine", engine, "--time-limit", "0.5"]) == 3
        err = capsys.readouterr().err
        assert "error[E613]: time limit of 0.5 s reached: " in err and "A* expanded " in err
        assert "no plan costs less than " in err


@pytest.mark.parametrize("args,loaded", [(["--help"], False), (["plan", *BLOCKS], False),
                                         (["plan", *BLOCKS, "--engine", "astar"], True)],
                         ids=["help", "sat", "astar"])
def test_numba_loads_with_astar_only(args, loaded):
    """The compiled LM-cut's numba (~0.6 s to load) is imported by A* alone."""
    code = ("import sys\nfrom tmpc.runtime.cli.main import main\n"
            f"try:\n    main({args!r})\nexcept SystemExit:\n    pass\n"
            "print('numba' in sys.modules, file=sys.stderr)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.stderr.strip().splitlines()[-1] == str(loaded), r.stderr
