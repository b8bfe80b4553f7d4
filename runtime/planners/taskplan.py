"""Incremental SAT task planning on Z3 (thesis Alg. 3): the planner behind `tmpc plan` and the
candidate task plans of the TMP planners.

:class:`TaskPlanner` keeps one Z3 solver (``SolverFor("QF_FD")``) for its whole life and deepens
the horizon one step at a time, encoding each new layer and step by instantiating the templates of
:mod:`tmpc.compiler.smt.encode`. Before the first query it computes two kinds of redundant knowledge that
make Z3's job much easier:

* **disjoint action landmarks** (LM-cut, :mod:`tmpc.compiler.smt.bound`): their number is an
  admissible lower bound, so horizons below it are skipped without a proof, and per horizon they
  give counting constraints (each landmark used, at most ``slack + 1`` times);
* **mutex pairs** (h^2, :mod:`tmpc.compiler.smt.mutex`) as binary clauses in every layer.

The goal of horizon ``T`` and its counting constraints are asserted in a push/pop scope
(``goal_mode="scope"``). Passing the goal as assumptions instead (``"assumptions"``) needs the
horizon-specific counting constraints guarded by an assumed literal, and Z3's cardinality
constraints lose their strength when guarded: clutter with 10 sticks takes 6 s to >60 s that way
against 0.2-0.8 s in a scope (bench: ``tests/bench/test_bench_taskplan.py``). Constraints are only
ever added outside the scope, so a horizon proven unsatisfiable stays so: later calls start past it.

For the TMP planners (docs/math.md §B):

* :meth:`TaskPlanner.next_plan` — the shortest plan that satisfies everything added so far;
* :meth:`TaskPlanner.exclude_prefix` — ``not (a^1 and ... and a^n)``: no later plan starts with
  that prefix (its first failed transition);
* :meth:`TaskPlanner.add_evidence` — a geometric literal's value after a prefix, pinning its
  blocker (``geometric=True``; see the module docstring of :mod:`tmpc.compiler.smt.encode`);
* :meth:`TaskPlanner.add_blocker_rule`, :meth:`TaskPlanner.add_atom_rule`,
  :meth:`TaskPlanner.add_action_rule` — the greedy planner's rules
  (:mod:`tmpc.runtime.planners.greedy`), which hold whatever came before: clauses in every
  layer over ``moved`` variables of the objects they name (``mv<i>@k``: a step up to ``k``
  moved object ``i``);
* :meth:`TaskPlanner.plans` — distinct candidate plans, shortest first.

Constraints naming steps beyond the encoded horizon wait until the horizon gets there.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from functools import cached_property
from typing import Iterable, Iterator

from tmpc.compiler.ground import GeoLiteral, GroundAction, GroundProblem
from tmpc.compiler.smt import Changers, Encoding, encode, lmcut, mutex_pairs, relevant_atoms

GOAL_MODES = ("assumptions", "scope")

#: PlanResult.status values
SOLVED, EXHAUSTED, TIMEOUT, UNREACHABLE = "solved", "exhausted", "timeout", "unreachable"


@dataclass(frozen=True)
class HorizonStats:
    """One horizon: what was added to the solver for it and how its goal query went."""

    horizon: int
    clauses: int            # assertions added for this horizon (its layer and step)
    variables: int          # variables declared for it
    encode_s: float         # building and parsing the text
    solve_s: float          # the goal query
    result: str             # sat | unsat | unknown


@dataclass
class PlanResult:
    """``actions`` (None unless ``status == "solved"``) and the horizon: the plan length when
    solved, else where the search stopped (``exhausted``: every horizon up to ``max_steps`` has
    no plan; ``timeout``: the time ran out while at ``horizon``; ``unreachable``: the goal is not
    even reachable in the delete relaxation, so no length works)."""

    status: str
    actions: list[GroundAction] | None
    horizon: int
    stats: list[HorizonStats] = field(default_factory=list)
    seconds: float = 0.0
    #: every plan length below this one is proven impossible
    impossible_below: int = 0

    @property
    def solved(self) -> bool:
        return self.status == SOLVED


class TaskPlanner:
    """Shortest sequential plans of a ground problem by incremental SAT.

    ``geometric``: geometric literals of preconditions and the goal get blocker variables (TMP);
    else they count as satisfied (classical PDDL). ``goal_mode``: ``"scope"`` (push/pop, the
    default) or ``"assumptions"``. ``amo``: the at-most-one-action encoding (``"pb"``,
    ``"ladder"``). ``changers``: which actions may change a geometric literal (default: those with
    kinematic effects). ``lower_bound`` / ``mutexes``: use landmarks / h^2 mutexes (on by
    default; off only to measure what they buy); ``analysis_budget``: seconds each of the two
    analyses may take (landmarks stop early with what they found, mutexes are dropped).
    """

    def __init__(self, problem: GroundProblem, geometric: bool = False, *,
                 goal_mode: str = "scope", amo: str = "pb",
                 changers: Changers | None = None, lower_bound: bool = True,
                 mutexes: bool = True, analysis_budget: float = 1.0):
        import z3
        if goal_mode not in GOAL_MODES:
            raise ValueError(f"goal_mode must be one of {GOAL_MODES}")
        self.z3 = z3
        self.problem = problem
        self.analysis_budget = analysis_budget
        self.goal_mode = goal_mode
        t0 = time.perf_counter()
        self.landmarks = self._landmarks() if lower_bound else None
        self.bound_seconds = time.perf_counter() - t0
        t0 = time.perf_counter()
        self.mutexes = self._mutexes() if mutexes else None
        self.encoding: Encoding = encode(problem, geometric, amo, changers,
                                         self.landmarks.sets if self.landmarks else (),
                                         self.mutexes or ())
        self.template_seconds = time.perf_counter() - t0
        # a context of its own: Z3's models depend on the history of the context they are made
        # in (fresh names, term ids), so in the shared global one the second planner of a
        # process finds other plans than the first; this way a plan depends only on
        # the problem and what was added
        self.ctx = z3.Context()
        self.solver = z3.SolverFor("QF_FD", ctx=self.ctx)
        #: the last encoded layer (steps 1..layers are encoded too)
        self.layers = -1
        self._unsat: set[int] = set()                       # horizons proven impossible
        self._timeout_set = False
        self.lower_bound = self._lower_bound() if lower_bound else \
            (None if self.encoding.goal_level is None else 0)
        self.stats: list[HorizonStats] = []
        self._pending: list[tuple[int, str]] = []           # (layer needed, assertions)
        self._goals: set[int] = set()                       # horizons whose goal is declared
        self._assumed: set[int] = set()                     # ... and asserted (assumptions)
        self._selectors: set[int] = set()                   # declared h@n
        self._sizes: dict[int, tuple[int, int, float]] = {}
        #: per step, the term whose value names its action (:meth:`_extract`)
        self._step_terms: dict[int, object] = {}
        #: the rules' templates (:meth:`add_blocker_rule` and the like), instantiated in every
        #: layer (``@K``) and every step (``@P``, ``@K``), those encoded and those to come
        self._every_layer: list[str] = []
        self._every_step: list[str] = []
        #: per movable object (lower-case), the name of its ``moved`` variable (``mv<i>@k``:
        #: a step up to ``k`` moved it)
        self._moved_vars: dict[str, str] = {}
        #: the rules encoded (each known once)
        self._rules: set[tuple] = set()
        self._extend_to(0)

    def _mutexes(self):
        return mutex_pairs(self.problem, relevant_atoms(self.problem),
                           budget_s=self.analysis_budget)

    def _landmarks(self):
        return lmcut(self.problem, budget_s=self.analysis_budget)

    def _lower_bound(self) -> int | None:
        """The first horizon that may have a plan: the goal's relaxed level and the number of
        disjoint landmarks (both admissible); None if the goal is not relaxed-reachable."""
        level = self.encoding.goal_level
        if level is None:
            return None
        return max(level, self.landmarks.bound if self.landmarks else 0)

    # ---- encoding ---------------------------------------------------------------------------
    def _extend_to(self, k: int, deadline: float | None = None) -> bool:
        """Encode layers and steps up to ``k``; False if the deadline passed first."""
        enc = self.encoding
        while self.layers < k:
            if deadline is not None and time.perf_counter() >= deadline:
                return False
            t0 = time.perf_counter()
            n = self.layers + 1
            text = enc.layer_text(n)
            clauses, variables = enc.sizes["layer"]
            if n == 0:
                text += enc.init
                clauses += enc.sizes["init"][0]
            else:
                text += enc.step_text(n)
                clauses += enc.sizes["step"][0]
                variables += enc.sizes["step"][1]
            text += "".join(t.replace("@K", f"@{n}") for t in self._every_layer)
            if n:
                text += "".join(t.replace("@P", f"@{n - 1}").replace("@K", f"@{n}")
                                for t in self._every_step)
            ready = [c for need, c in self._pending if need <= n]
            self._pending = [(need, c) for need, c in self._pending if need > n]
            text += "".join(ready)
            self.solver.from_string(text)
            self.layers = n
            self._sizes[n] = (clauses + len(ready), variables, time.perf_counter() - t0)
        return True

    def _add(self, layer: int, clause: list[str], declare: str = "") -> None:
        """Assert ``clause`` now, or once ``layer`` is encoded. ``declare``: declarations of the
        variables the clause introduces."""
        text = declare + _assert(clause)
        if layer <= self.layers:
            self.solver.from_string(text)
        else:
            self._pending.append((layer, text))

    # ---- constraints from the TMP planners ----------------------------------------------------
    def exclude_prefix(self, prefix: Iterable[GroundAction]) -> None:
        """No later plan starts with ``prefix`` (docs/math.md §B plan exclusion). The empty prefix
        excludes every plan."""
        prefix = list(prefix)
        self._add(len(prefix), self.encoding.prefix_clause(prefix))

    def exclude_plan(self, plan: Iterable[GroundAction]) -> None:
        """No later plan is exactly ``plan``; longer plans that start with it stay possible
        (the clause holds only at horizon ``len(plan)``, through its selector ``h@n``)."""
        plan = list(plan)
        n = len(plan)
        self._add(n, self.encoding.prefix_clause(plan) + [f"(not h@{n})"],
                  self._declare_selector(n))

    def add_evidence(self, prefix: Iterable[GroundAction], literal: GeoLiteral | tuple,
                     value: bool) -> bool:
        """After ``prefix``, the geometric ``literal`` ``(predicate, args, positive)`` is known
        to hold (``value``) or not: ``(a^1 and ... and a^n) -> (not b@n and g@n = value)``.
        Returns False (and adds nothing) if no precondition or goal uses the literal."""
        if not self.encoding.geometric:
            raise ValueError("evidence needs a planner built with geometric=True")
        m = self.encoding.geo_index(literal)
        if m is None:
            return False
        prefix = list(prefix)
        for clause in self.encoding.evidence_clauses(prefix, m, value):
            self._add(len(prefix), clause)
        return True

    # ---- rules: the greedy planner's, as clauses in every layer ---------------------------
    # (:mod:`tmpc.runtime.planners.greedy`) Without them the portfolio's SAT planner gave plans
    # that broke one, to be excluded and asked again: on Blocks World F, 514 of 738 SAT calls.
    # A rule holds whatever came before, so its clauses go in every layer, those encoded and
    # those to come, over ``moved`` variables of the objects it names.

    def add_blocker_rule(self, literal: GeoLiteral | tuple, objects: Iterable[str]) -> bool:
        """The geometric ``literal`` is false wherever none of ``objects`` has moved yet; False
        (nothing added) if no precondition or goal uses it, none of ``objects`` is ever moved
        or the rule is known."""
        m = self._geo(literal)
        movers = self._moved_lits(objects) if m is not None else []
        if not movers or not self._new_rule(("blocker", m, frozenset(movers))):
            return False
        self._false_where(m, movers)
        return True

    def add_atom_rule(self, literal: GeoLiteral | tuple, atoms: Iterable[int]) -> bool:
        """The geometric ``literal`` is false wherever all of ``atoms`` (ids, at least one)
        hold; False (nothing added) if no precondition or goal uses it, an atom has no
        variable (nothing reads it) or the rule is known."""
        m, atoms = self._geo(literal), sorted(set(atoms))
        if m is None or not atoms or any(a not in self.encoding.relevant for a in atoms) or \
                not self._new_rule(("atom", m, tuple(atoms))):
            return False
        self._false_where(m, [f"(not p{a}@K)" for a in atoms])
        return True

    def add_action_rule(self, prefix: Iterable[GroundAction], action: GroundAction,
                        objects: Iterable[str] = (), atoms: Iterable[int] = ()) -> bool:
        """``action`` is ruled out wherever all of ``atoms`` hold and none of ``objects`` has
        moved (objects never moved count as not moved); False (nothing added) if one of
        ``objects`` moved in ``prefix`` (where the failure was seen), an atom has no variable
        or the rule is known. (The greedy planner's signature and meaning.)"""
        atoms, objects = sorted(set(atoms)), {o.lower() for o in objects}
        if any(a not in self.encoding.relevant for a in atoms):
            return False
        if any(a.id in self._movers.get(o, ()) for o in objects for a in prefix):
            return False
        movers = self._moved_lits(objects)
        if not self._new_rule(("action", action.id, frozenset(movers), tuple(atoms))):
            return False
        lits = [f"(not a{action.id}@K)"] + [f"(not p{a}@P)" for a in atoms] + \
            [v.replace("@K", "@P") for v in movers]
        self._template(step=_assert(lits))
        return True

    @property
    def rules(self) -> int:
        """The number of rules encoded."""
        return len(self._rules)

    def _geo(self, literal) -> int | None:
        if not self.encoding.geometric:
            raise ValueError("rules need a planner built with geometric=True")
        return self.encoding.geo_index(literal)

    def _new_rule(self, key: tuple) -> bool:
        if key in self._rules:
            return False
        self._rules.add(key)
        return True

    def _false_where(self, m: int, lits: list[str]) -> None:
        """In every layer: ``(or lits)`` or the literal ``m`` is known false there."""
        self._template(layer=_assert(lits + [f"(not b{m}@K)"]) +
                       _assert(lits + [f"(not g{m}@K)"]))

    @cached_property
    def _movers(self) -> dict[str, set[int]]:
        """Per object (lower-case) some action moves, the ids of the actions whose kinematic
        effects (conditional ones too) move it."""
        out: dict[str, set[int]] = {}
        for a in self.problem.actions:
            for ke in [*a.kinematic, *(k for ce in a.conditional for k in ce.kinematic)]:
                out.setdefault(ke.child.lower(), set()).add(a.id)
        return out

    def _moved_lits(self, objects: Iterable[str]) -> list[str]:
        """The ``moved`` variables (over layer ``@K``) of those of ``objects`` some action
        moves, declared on first use."""
        out = []
        for name in sorted({o.lower() for o in objects}):
            ids = self._movers.get(name)
            if not ids:
                continue
            var = self._moved_vars.get(name)
            if var is None:
                var = self._moved_vars[name] = f"mv{len(self._moved_vars)}"
                acts = " ".join(f"a{j}@K" for j in sorted(ids))
                self._template(layer=f"(declare-const {var}@K Bool)",
                               step=f"(assert (= {var}@K (or {var}@P {acts})))", init=var)
            out.append(f"{var}@K")
        return out

    def _template(self, layer: str = "", step: str = "", init: str = "") -> None:
        """Add ``layer`` to every layer and ``step`` to every step, encoded or to come;
        ``init``: a variable false in layer 0."""
        now = []
        if layer:
            self._every_layer.append(layer)
            now += [layer.replace("@K", f"@{n}") for n in range(self.layers + 1)]
        if init:
            # layer 0 is encoded at construction: its unit clause is asserted at once
            now.append(f"(assert (not {init}@0))")
        if step:
            self._every_step.append(step)
            now += [step.replace("@P", f"@{n - 1}").replace("@K", f"@{n}")
                    for n in range(1, self.layers + 1)]
        if now:
            self.solver.from_string("".join(now))

    # ---- solving ----------------------------------------------------------------------------
    def next_plan(self, max_steps: int = 200, time_limit: float | None = None,
                  min_steps: int = 0, horizon_cap: float | None = None) -> PlanResult:
        """The shortest plan of length ``min_steps..max_steps`` satisfying everything added so
        far; horizons already proven impossible are skipped. ``horizon_cap``: seconds one
        horizon's check may take before the next horizon is tried (the plan found may then be
        longer than the shortest: a first solution needs a plan, not a proof that no shorter one
        exists); a horizon so skipped is tried again, with the same cap, at the next call."""
        t0 = time.perf_counter()
        deadline = None if time_limit is None else t0 + time_limit
        stats: list[HorizonStats] = []

        def result(status: str, k: int, plan=None) -> PlanResult:
            return PlanResult(status, plan, k, stats, time.perf_counter() - t0,
                              self.impossible_below())

        if self.lower_bound is None:
            return result(UNREACHABLE, 0)
        k = max(self.lower_bound, min_steps)
        while k <= max_steps:
            if k in self._unsat:
                k += 1
                continue
            if deadline is not None and time.perf_counter() >= deadline:
                return result(TIMEOUT, k)
            had = self.layers
            if not self._extend_to(k, deadline):
                return result(TIMEOUT, k)
            new = [self._sizes[n] for n in range(had + 1, k + 1)]
            check_by = deadline
            if horizon_cap is not None:
                capped = time.perf_counter() + horizon_cap
                check_by = capped if deadline is None else min(deadline, capped)
            answer, solve_s = self._check(k, check_by)
            st = HorizonStats(k, sum(x[0] for x in new), sum(x[1] for x in new),
                              sum(x[2] for x in new), solve_s, answer)
            stats.append(st)
            self.stats.append(st)
            if answer == "sat":
                return result(SOLVED, k, self._extract(k))
            if answer == "unknown":
                if horizon_cap is None or (deadline is not None and
                                           time.perf_counter() >= deadline):
                    return result(TIMEOUT, k)
                k += 1                            # not proven: tried again at the next call
                continue
            self._unsat.add(k)
            k += 1
        return result(EXHAUSTED, max_steps)

    def impossible_below(self) -> int:
        """Every plan length below this one is proven impossible (the lower bound, then the
        horizons proven unsatisfiable)."""
        if self.lower_bound is None:
            return 1 << 30
        k = self.lower_bound
        while k in self._unsat:
            k += 1
        return k

    plan = next_plan

    def plans(self, max_steps: int = 200, time_limit: float | None = None,
              min_steps: int = 0) -> Iterator[list[GroundAction]]:
        """Distinct plans, shortest first. Each plan is excluded once the consumer asks for the
        next one (add stronger exclusions or evidence in between)."""
        t0 = time.perf_counter()
        while True:
            left = None if time_limit is None else time_limit - (time.perf_counter() - t0)
            if left is not None and left <= 0:
                return
            result = self.next_plan(max_steps, left, min_steps)
            if not result.solved:
                return
            yield result.actions
            self.exclude_plan(result.actions)

    def _check(self, k: int, deadline: float | None) -> tuple[str, float]:
        """Is there a plan of horizon ``k``? The goal literals of layer ``k``, the horizon
        selector ``h@k`` and the counting constraints of ``k`` are asserted in a scope (or
        assumed, the constraints guarded by ``h@k``)."""
        z3 = self.z3
        decls, text, lits = self.encoding.goal_text(k)
        lits = lits + [f"h@{k}"]
        if k not in self._goals:                # Z3 keeps declarations across push/pop
            self._goals.add(k)
            self.solver.from_string(self._declare_selector(k) + decls)
        if deadline is not None:
            self.solver.set("timeout", max(1, int((deadline - time.perf_counter()) * 1000)))
            self._timeout_set = True
        elif self._timeout_set:
            self.solver.set("timeout", 4294967295)
            self._timeout_set = False
        t0 = time.perf_counter()
        guard = None
        if deadline is not None:
            # Z3's timeout is not always honoured (preprocessing large formulas): interrupt the
            # context from a timer thread too (ctypes releases the GIL during the check)
            guard = threading.Timer(max(0.0, deadline - t0) + 0.05, self.solver.ctx.interrupt)
            guard.daemon = True
            guard.start()
        pushed = False
        try:
            if self.goal_mode == "scope":
                self.solver.push()
                pushed = True
                self.solver.from_string(text + "".join(f"(assert {lit})" for lit in lits) +
                                        self.encoding.landmark_text(k))
                r = self.solver.check()
                model = self.solver.model() if r == z3.sat else None
                self.solver.pop()
                pushed = False
            else:
                if k not in self._assumed:
                    self._assumed.add(k)
                    self.solver.from_string(text + self.encoding.landmark_text(k, f"h@{k}"))
                r = self.solver.check(*[_lit_expr(z3, lit, self.ctx) for lit in lits])
                model = self.solver.model() if r == z3.sat else None
        except z3.Z3Exception as e:
            # the timer's interrupt came outside `check` (in push or while parsing): Z3 raises
            # "canceled" there instead of answering unknown. Taken as unknown whenever it says
            # so (a Hanoi 6 run crashed on one before its deadline; not reproduced).
            if "cancel" not in str(e).lower() and \
                    (deadline is None or time.perf_counter() < deadline):
                raise
            if pushed:
                self.solver.pop()
            self._assumed.discard(k)   # parsed again next time (twice: the same constraints)
            r, model = "unknown", None
        finally:
            if guard is not None:
                guard.cancel()
        self._model = model
        return str(r), time.perf_counter() - t0

    def _declare_selector(self, n: int) -> str:
        """The declaration of ``h@n`` the first time it is needed, else nothing."""
        if n in self._selectors:
            return ""
        self._selectors.add(n)
        return f"(declare-const h@{n} Bool)"

    def _extract(self, k: int) -> list[GroundAction]:
        """The plan of the last model, one action per step: each step's action is read as the
        value of one term (the sum of ``id + 1`` over its true action variables; the encoding
        makes exactly one true). Printing the model and scanning it (as before 2026-12-06)
        took 33 ms a plan on Blocks World E, 28% of its SAT planner's time."""
        z3, actions = self.z3, self.problem.actions
        plan = []
        for s in range(1, k + 1):
            term = self._step_terms.get(s)
            if term is None:
                zero = z3.IntVal(0, self.ctx)
                term = self._step_terms[s] = z3.Sum(
                    [z3.If(z3.Bool(f"a{a.id}@{s}", self.ctx), z3.IntVal(a.id + 1, self.ctx),
                           zero) for a in actions])
            j = self._model.eval(term, model_completion=True).as_long() - 1
            if not 0 <= j < len(actions) or not z3.is_true(self._model.eval(
                    z3.Bool(f"a{j}@{s}", self.ctx), model_completion=True)):
                raise RuntimeError(f"the model of horizon {k} does not give one action per "
                                   f"step (step {s})")
            plan.append(actions[j])
        return plan


def _assert(clause: list[str]) -> str:
    if not clause:
        return "(assert false)"
    return f"(assert {clause[0]})" if len(clause) == 1 else f"(assert (or {' '.join(clause)}))"


def _lit_expr(z3, lit: str, ctx=None):
    if lit.startswith("(not "):
        return z3.Not(z3.Bool(lit[5:-1], ctx))
    return z3.Bool(lit, ctx)


def simulate(problem: GroundProblem, plan: list[GroundAction]) -> tuple[bool, str]:
    """Replay ``plan`` from the initial state (geometry satisfied): (ok, what failed)."""
    state = problem.init
    for k, a in enumerate(plan, start=1):
        if not problem.applicable(state, a):
            return False, f"step {k}: {a.name} is not applicable"
        state = problem.apply(state, a)
    if not problem.goal_satisfied(state):
        return False, "the goal does not hold at the end"
    return True, ""


__all__ = ["TaskPlanner", "PlanResult", "HorizonStats", "simulate", "SOLVED", "EXHAUSTED",
           "TIMEOUT", "UNREACHABLE"]
