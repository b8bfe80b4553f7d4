"""The step encoding of a :class:`~tmpc.compiler.ground.GroundProblem` for incremental SAT planning.

Thesis Alg. 3 (docs/math.md §B): a plan of length ``T`` is a model of layers ``0..T`` of Boolean
state variables and steps ``1..T`` of Boolean action variables, one action per step. The encoding
is a set of **templates**, SMT-LIB2 text with placeholders, instantiated once per layer or step by
string replacement (``@K`` = this layer/step, ``@P`` = the previous layer). Building clauses as
text and letting Z3 parse them is ~10x faster than z3's Python operators (docs/design.md §6.3); the
same text is what :func:`smtlib_templates` serializes for the artifact.

Variables (``k`` a layer or step number):

* ``p<i>@k`` atom ``i`` (discrete, kinematic or derived) in layer ``k``; only *relevant* atoms get
  one: those some precondition, effect condition, the goal or a relevant axiom reads.
* ``a<j>@k`` ground action ``j`` is step ``k`` (it moves layer ``k-1`` to layer ``k``).
* geometric mode only, per geometric literal ``m`` of a precondition or the goal: ``g<m>@k`` (the
  literal holds in layer ``k``) and ``b<m>@k``, its **blocker** (its value in layer ``k`` is
  unknown). See "Geometric literals" below.
* ``t<n>@k``, ``d<n>@k``, ``q<n>@k``: auxiliaries of the step, layer and goal templates.

Templates (:class:`Encoding`):

* ``layer`` (``@K``): declarations of layer ``K`` and the axioms of derived atoms there.
* ``init``: layer 0 is the initial state (unit clauses, relevant non-derived atoms).
* ``step`` (``@P``, ``@K``): action variables of step ``K``; exactly one action per step (at
  least one, plus an at-most-one: Z3's native cardinality constraint ``((_ at-most 1) ...)`` or a
  sequential-counter ladder, :data:`AMO`); preconditions (``a -> pre`` over layer ``P``: literals
  as binary clauses, remaining disjunctions by a one-directional Tseitin encoding); effects with
  PDDL's add-after-delete semantics (an atom both added and deleted ends true), conditional
  effects through a *fire* variable ``f <-> a and condition@P``; explanatory frame axioms (an atom
  that changes was changed by one of the actions or effects that can change it).
* ``goal`` (``@K``): definitions for a goal with disjunctions; the goal itself is a list of
  literals (:attr:`Encoding.goal_literals`) the planner passes as assumptions or asserts in a
  scope.

**Derived predicates.** A derived atom is defined in every layer by ``h <-> body_1 or ... or
body_n`` (bodies in the same layer). Strata make this well-defined across negation. Positive
recursion *within* a stratum is different: Clark completion alone admits self-supporting loops
(``reach(x) <-> reach(y)``), so it is unsound. We compute the ground positive dependency graph
of the relevant derived atoms; an atom outside every cycle gets its completion; each strongly
connected component ``S`` with a cycle is **unrolled by levels**: ``h#0`` evaluates the bodies
with the atoms of ``S`` false, ``h#l`` with those of ``S`` at level ``l-1``, and ``h = h#(|S|-1)``:
the least fixpoint of a monotone operator on ``|S|`` atoms is reached in ``|S|`` applications.
Size: ``|S|`` copies of the component's bodies per layer (transitive closure over ``n`` blocks:
``n`` components of ``n`` atoms, ``O(n^4)`` clauses per layer). Chosen over rank variables for
being obviously correct and propagation-friendly; rank encodings would be ``O(log |S|)`` per body
literal if large components ever matter. Geometric literals inside axiom bodies and inside the
conditions of conditional effects count as satisfied (the discrete view of
:meth:`~tmpc.compiler.ground.GroundProblem.apply` without an oracle).

**Geometric literals** (thesis §4.3.5). In the discrete view (``geometric=False``) every
geometric literal is satisfied. In geometric mode each geometric literal ``m`` that a precondition
or the goal uses (positive and negated uses are different literals) has, per layer, ``g<m>``
("holds in that layer's mode") and ``b<m>`` ("its value there is unknown"). A use requires
``b<m> or g<m>``: unknown literals are optimistically possible. Evidence from sampling pins both
(:meth:`Encoding.evidence_clauses`: after plan prefix ``a^1..a^n``, ``not b<m>@n`` and
``g<m>@n = value``). Knowledge persists across a step unless that step's action *may change* the
literal (``b`` and ``g`` are equal in both layers otherwise); after such a step both are free
again. By default every action with a kinematic effect (its own or conditional) may change every
geometric literal: objects move only through kinematic effects, and a literal's value can depend on
objects it does not name (an obstacle in the way); a caller who knows better passes ``changers``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Iterable

from tmpc.compiler.ground import (
    GAnd,
    GAtom,
    GeoLiteral,
    GFalse,
    GFormula,
    GGeo,
    GNot,
    GOr,
    GroundAction,
    GroundProblem,
    GTrue,
    atom_ids,
    conjuncts,
)
from tmpc.compiler.smt.analysis import components, relaxed_fixpoint, relaxed_levels, relevant_atoms
from tmpc.compiler.smt.mutex import mutex_groups

#: at-most-one encodings: Z3's native cardinality constraint, or a sequential counter (ladder)
AMO = ("pb", "ladder")

#: a function naming the actions (by id) that may change a geometric literal's value
Changers = Callable[[GeoLiteral], Iterable[int]]


def neg(lit: str) -> str:
    """The complement of an SMT-LIB literal ``x`` / ``(not x)``."""
    return lit[5:-1] if lit.startswith("(not ") else f"(not {lit})"


class _Text:
    """Declarations and assertions of one template, rendered as SMT-LIB2."""

    def __init__(self, aux: str, layer: str):
        self.aux_prefix, self.layer = aux, layer
        self.decls: list[str] = []
        self.asserts: list[str] = []
        self.n_aux = 0
        self.n_clauses = 0

    def declare(self, name: str) -> str:
        self.decls.append(name)
        return name

    def aux(self) -> str:
        self.n_aux += 1
        return self.declare(f"{self.aux_prefix}{self.n_aux - 1}{self.layer}")

    def clause(self, lits: list[str]) -> None:
        self.n_clauses += 1
        if not lits:
            self.asserts.append("(assert false)")
        elif len(lits) == 1:
            self.asserts.append(f"(assert {lits[0]})")
        else:
            self.asserts.append(f"(assert (or {' '.join(lits)}))")

    def raw(self, assertion: str) -> None:
        self.n_clauses += 1
        self.asserts.append(assertion)

    def render(self) -> str:
        return self.render_decls() + "".join(self.asserts)

    def render_decls(self) -> str:
        return "".join(f"(declare-const {d} Bool)" for d in self.decls)

    @property
    def size(self) -> tuple[int, int]:
        """(assertions, variables)."""
        return self.n_clauses, len(self.decls)


class _Formulas:
    """Clauses for ground formulas in one template, over atoms of one or two layers."""

    def __init__(self, out: _Text, geo_index: dict[GeoLiteral, int] | None):
        self.out = out
        self.geo = geo_index          # None: discrete view (geometric literals satisfied)
        self._defined: dict[tuple, str | bool] = {}

    def leaf(self, f: GFormula, layer: str) -> list[str] | None:
        """The literals whose disjunction is the leaf ``f``; None for a satisfied leaf."""
        t = type(f)
        if t is GAtom:
            return [f"p{f.id}{layer}"]
        if t is GNot and type(f.part) is GAtom:
            return [f"(not p{f.part.id}{layer})"]
        if self.geo is None:
            return None
        lit = geo_literal(f)
        m = self.geo[lit]
        return [f"b{m}{layer}", f"g{m}{layer}"]

    def require(self, head: list[str], f: GFormula, layer: str) -> None:
        """Clauses for ``(or head) or f`` (one-directional Tseitin for ``f``)."""
        t = type(f)
        if t is GTrue:
            return
        if t is GFalse:
            self.out.clause(head)
        elif t is GAnd:
            for p in f.parts:
                self.require(head, p, layer)
        elif t is GOr:
            lits = list(head)
            for p in f.parts:
                if type(p) in (GAnd, GOr):
                    x = self.out.aux()
                    self.require([neg(x)], p, layer)
                    lits.append(x)
                else:
                    leaf = self.leaf(p, layer)
                    if leaf is None:
                        return
                    lits += leaf
            self.out.clause(lits)
        else:
            leaf = self.leaf(f, layer)
            if leaf is not None:
                self.out.clause(head + leaf)

    def define(self, f: GFormula, layer: str, subst: dict[int, str | bool] | None = None,
               tag: object = None) -> str | bool:
        """A literal equivalent to ``f`` (or a constant). Geometric leaves are satisfied.
        ``subst`` replaces atoms (level copies of recursive derived atoms); ``tag`` keys the
        cache for a given ``subst``."""
        t = type(f)
        if t is GTrue:
            return True
        if t is GFalse:
            return False
        if t is GAtom:
            if subst is not None and f.id in subst:
                return subst[f.id]
            return f"p{f.id}{layer}"
        if t is GNot:
            return True if type(f.part) is GGeo else f"(not p{f.part.id}{layer})"
        if t is GGeo:
            return True
        key = (f, layer, tag)
        got = self._defined.get(key)
        if got is None:
            got = self._defined[key] = self._define_junction(f, layer, subst, tag)
        return got

    def _define_junction(self, f, layer, subst, tag) -> str | bool:
        is_and = type(f) is GAnd
        lits = []
        for p in f.parts:
            x = self.define(p, layer, subst, tag)
            if x is (not is_and):        # a false conjunct / a true disjunct decides
                return x
            if x is not is_and:
                lits.append(x)
        if not lits:
            return is_and
        if len(lits) == 1:
            return lits[0]
        return self.equal_junction(lits, is_and)

    def equal_junction(self, lits: list[str], is_and: bool, name: str | None = None) -> str:
        """``name`` (a fresh auxiliary by default) <-> and/or of ``lits``."""
        x = name or self.out.aux()
        if is_and:
            for lit in lits:
                self.out.clause([neg(x), lit])
            self.out.clause([x] + [neg(lit) for lit in lits])
        else:
            self.out.clause([neg(x)] + lits)
            for lit in lits:
                self.out.clause([x, neg(lit)])
        return x


def geo_literal(f: GFormula) -> GeoLiteral:
    if type(f) is GNot:
        return GeoLiteral(f.part.predicate, f.part.args, False)
    return GeoLiteral(f.predicate, f.args, True)


def _geo_literals(f: GFormula) -> Iterable[GeoLiteral]:
    t = type(f)
    if t is GGeo or (t is GNot and type(f.part) is GGeo):
        yield geo_literal(f)
    elif t in (GAnd, GOr):
        for p in f.parts:
            yield from _geo_literals(p)


@dataclass(frozen=True)
class Encoding:
    """The templates of one ground problem (see the module docstring for the variables)."""

    problem: GroundProblem
    geometric: bool
    amo: str
    #: atom ids that have variables
    relevant: frozenset[int]
    #: geometric literals with ``g``/``b`` variables (geometric mode), index = ``m``
    geo_literals: tuple[GeoLiteral, ...]
    layer: str
    init: str
    step: str
    goal: str
    #: declarations of ``goal``'s auxiliaries (Z3 keeps declarations across push/pop: declare
    #: them once per horizon, assert ``goal`` each time)
    goal_decls: str
    #: the goal as literals over layer ``@K`` (assumptions or asserted in a scope)
    goal_literals: tuple[str, ...]
    #: per action id, the first step it can be (relaxed planning graph level + 1)
    first_step: tuple[int, ...]
    #: the first horizon at which the goal is relaxed-reachable (an admissible lower bound);
    #: None if never
    goal_level: int | None
    #: disjoint action landmarks (ground action ids; :mod:`tmpc.compiler.smt.bound`), with step
    #: indicators ``l<i>@k`` in the step template; empty if none were given
    landmarks: tuple[frozenset[int], ...] = ()
    #: (assertions, variables) per template
    sizes: dict[str, tuple[int, int]] = field(default_factory=dict)

    def layer_text(self, k: int) -> str:
        return self.layer.replace("@K", f"@{k}")

    def step_text(self, k: int) -> str:
        """Step ``k`` (from layer ``k-1`` to ``k``), with the actions that cannot be step ``k``
        yet (relaxed planning graph) fixed false."""
        text = self.step.replace("@P", f"@{k - 1}").replace("@K", f"@{k}")
        late = [j for j, s in enumerate(self.first_step) if s > k]
        return text + "".join(f"(assert (not a{j}@{k}))" for j in late)

    def goal_text(self, k: int) -> tuple[str, str, list[str]]:
        """The goal in layer ``k``: declarations, definitions and its literals."""
        return (self.goal_decls.replace("@K", f"@{k}"), self.goal.replace("@K", f"@{k}"),
                [lit.replace("@K", f"@{k}") for lit in self.goal_literals])

    def landmark_text(self, horizon: int, guard: str | None = None) -> str:
        """Counting constraints a plan of exactly ``horizon`` steps satisfies, given ``h``
        disjoint landmarks and slack ``s = horizon - h``: each landmark is used at least once and
        at most ``s + 1`` times, and at most ``s`` steps use an action in no landmark. Guarded
        by ``guard`` (a horizon selector) if given. Empty without landmarks."""
        n = len(self.landmarks)
        if not n or horizon < n:
            return ""
        slack = horizon - n
        head = f"(or (not {guard}) " if guard else "(and "
        parts = []
        steps = range(1, horizon + 1)
        for i in range(n):
            lits = " ".join(f"l{i}@{k}" for k in steps)
            parts.append(f"(or {lits})")
            if slack + 1 < horizon:
                parts.append(f"((_ at-most {slack + 1}) {lits})")
        if slack < horizon:
            parts.append(f"((_ at-most {slack}) {' '.join(f'o@{k}' for k in steps)})"
                         if slack else " ".join(f"(not o@{k})" for k in steps))
        return "".join(f"(assert {head}{p}))" for p in parts)

    def action_var(self, action: GroundAction | int, step: int) -> str:
        j = action if isinstance(action, int) else action.id
        return f"a{j}@{step}"

    def prefix_clause(self, prefix: Iterable[GroundAction | int]) -> list[str]:
        """The literals of ``not (a^1 and ... and a^n)`` for a plan prefix."""
        return [f"(not {self.action_var(a, k)})" for k, a in enumerate(prefix, start=1)]

    def geo_index(self, literal: GeoLiteral | tuple) -> int | None:
        """``m`` of a geometric literal ``(predicate, args, positive)`` (names compare without
        case); None if no precondition or goal uses it."""
        pred, args, positive = literal
        want = (pred.lower(), tuple(a.lower() for a in args), bool(positive))
        for m, g in enumerate(self.geo_literals):
            if (g.predicate.lower(), tuple(a.lower() for a in g.args), g.positive) == want:
                return m
        return None

    def evidence_clauses(self, prefix: list[GroundAction | int], m: int,
                         value: bool) -> list[list[str]]:
        """``(a^1 and ... and a^n) -> (not b<m>@n and g<m>@n = value)`` as two clauses."""
        n = len(prefix)
        head = self.prefix_clause(prefix)
        g = f"g{m}@{n}"
        return [head + [f"(not b{m}@{n})"], head + [g if value else neg(g)]]


def encode(problem: GroundProblem, geometric: bool = False, amo: str = "pb",
           changers: Changers | None = None,
           landmarks: Iterable[frozenset[int]] = (),
           mutexes: Iterable[tuple[int, int]] = ()) -> Encoding:
    """The templates of ``problem``. ``geometric``: blocker variables for geometric literals
    (else they count as satisfied); ``amo``: the at-most-one encoding (:data:`AMO`);
    ``changers``: which actions may change a geometric literal (default: every action with a
    kinematic effect); ``landmarks``: disjoint action landmarks for counting constraints
    (:meth:`Encoding.landmark_text`); ``mutexes``: atom pairs no reachable state holds, added to
    every layer (:mod:`tmpc.compiler.smt.mutex`)."""
    landmarks = tuple(landmarks)
    if amo not in AMO:
        raise ValueError(f"amo must be one of {AMO}")
    relevant = relevant_atoms(problem)
    geo = _used_geo_literals(problem) if geometric else ()
    geo_index = {g: m for m, g in enumerate(geo)} if geometric else None
    layer = _layer_template(problem, relevant, geo, geo_index)
    for group in mutex_groups([(p, q) for p, q in mutexes if p in relevant and q in relevant]):
        if len(group) == 2:
            layer.clause([f"(not p{group[0]}@K)", f"(not p{group[1]}@K)"])
        else:
            layer.raw(f"(assert ((_ at-most 1) {' '.join(f'p{i}@K' for i in group)}))")
    init = _Text("i", "@0")
    for i in sorted(relevant):
        if problem.atoms[i].kind != "derived":
            init.clause([f"p{i}@0" if (problem.init >> i) & 1 else f"(not p{i}@0)"])
    step = _step_template(problem, relevant, geo, geo_index, amo, changers)
    _landmark_indicators(step, problem, landmarks)
    goal, goal_lits = _goal_template(problem, geo_index)
    first, goal_level = relaxed_levels(problem)
    return Encoding(problem, geometric, amo, frozenset(relevant), tuple(geo), layer.render(),
                    init.render(), step.render(), "".join(goal.asserts), goal.render_decls(),
                    tuple(goal_lits),
                    tuple(first), goal_level, landmarks,
                    {"layer": layer.size, "init": init.size, "step": step.size,
                     "goal": goal.size})


def smtlib_templates(problem: GroundProblem, geometric: bool = False,
                     amo: str = "pb") -> dict[str, str]:
    """The templates as SMT-LIB2 text, for the artifact: ``layer`` (placeholder ``@K``),
    ``init``, ``step`` (``@P`` = ``@K`` minus one), ``goal`` (``@K``; the goal is the conjunction
    of ``goal-literals``, one per line), and ``readme`` saying how to instantiate them."""
    enc = encode(problem, geometric, amo)
    return {
        "readme": _README,
        "layer": enc.layer,
        "init": enc.init,
        "step": enc.step,
        "goal": enc.goal_decls + enc.goal,
        "goal-literals": "\n".join(enc.goal_literals),
    }


_README = """\
; tmpc step encoding (compiler/smt/encode.py). A plan of length T is a model of:
;   layer[K:=0..T] + init + step[P:=K-1, K:=K for K=1..T] + goal[K:=T] + goal-literals[K:=T]
; where X[K:=k] replaces every "@K" by "@k" (and "@P" by "@(k-1)").
; p<i>@k: atom i in layer k; a<j>@k: ground action j is step k (one per step);
; g<m>@k / b<m>@k: geometric literal m holds / is unknown in layer k (geometric mode).
"""


# ---------------------------------------------------------------------------------------------
# Geometric literals


def _used_geo_literals(problem: GroundProblem) -> list[GeoLiteral]:
    seen: dict[GeoLiteral, None] = {}
    for a in problem.actions:
        seen.update(dict.fromkeys(_geo_literals(a.pre.formula)))
    seen.update(dict.fromkeys(_geo_literals(problem.goal.formula)))
    return list(seen)


# ---------------------------------------------------------------------------------------------
# Templates


def _layer_template(problem, relevant, geo, geo_index) -> _Text:
    out = _Text("d", "@K")
    for i in sorted(relevant):
        out.declare(f"p{i}@K")
    for m in range(len(geo)):
        out.declare(f"g{m}@K")
        out.declare(f"b{m}@K")
    bodies: dict[int, list[GFormula]] = {}
    for ax in problem.axioms:
        if ax.head in relevant:
            bodies.setdefault(ax.head, []).append(ax.body)
    derived = sorted(i for i in relevant if problem.atoms[i].kind == "derived")
    edges = {h: {i for b in bodies.get(h, ()) for i in atom_ids(b, positive_only=True)
                 if i in bodies} for h in derived}
    fm = _Formulas(out, geo_index)
    for comp in components(derived, edges):
        if len(comp) == 1 and comp[0] not in edges[comp[0]]:
            h = comp[0]
            _define_head(fm, f"p{h}@K", bodies.get(h, []), None, None)
        else:
            _unroll(fm, sorted(comp), bodies)
    return out


def _define_head(fm: _Formulas, name: str, bodies: list[GFormula], subst, tag) -> None:
    """``name <-> body_1 or ... or body_n``."""
    lits = []
    for b in bodies:
        x = fm.define(b, "@K", subst, tag)
        if x is True:
            fm.out.clause([name])
            return
        if x is not False:
            lits.append(x)
    if not lits:
        fm.out.clause([neg(name)])
    else:
        fm.equal_junction(lits, False, name)


def _unroll(fm: _Formulas, comp: list[int], bodies: dict[int, list[GFormula]]) -> None:
    """A recursive component: its least fixpoint by ``len(comp)`` level copies."""
    n = len(comp)
    subst: dict[int, str | bool] = {h: False for h in comp}
    for level in range(n):
        names = {h: f"p{h}@K" if level == n - 1 else fm.out.aux() for h in comp}
        for h in comp:
            _define_head(fm, names[h], bodies.get(h, []), subst, (id(comp), level))
        if level:                       # monotone levels: a redundant clause that propagates
            for h in comp:
                if isinstance(subst[h], str):
                    fm.out.clause([neg(subst[h]), names[h]])
        subst = dict(names)


def _step_template(problem, relevant, geo, geo_index, amo, changers) -> _Text:
    out = _Text("t", "@K")
    names = [out.declare(f"a{a.id}@K") for a in problem.actions]
    _exactly_one(out, names, amo)
    fm = _Formulas(out, geo_index)
    adders: dict[int, list[str]] = {}
    deleters: dict[int, list[str]] = {}
    for a, act in zip(problem.actions, names):
        _precondition(out, fm, a, act, geo_index)
        _effects(out, fm, a, act, relevant, adders, deleters)
    for i in sorted(relevant):
        if problem.atoms[i].kind == "derived":
            continue
        out.clause([f"(not p{i}@K)", f"p{i}@P"] + adders.get(i, []))
        out.clause([f"p{i}@K", f"(not p{i}@P)"] + deleters.get(i, []))
    if geo:
        _persistence(out, problem, geo, changers)
    return out


def _landmark_indicators(out: _Text, problem: GroundProblem,
                         landmarks: tuple[frozenset[int], ...]) -> None:
    """``l<i>@K`` <-> step ``K`` is an action of landmark ``i``; ``o@K`` <-> of none."""
    if not landmarks:
        return
    covered: set[int] = set()
    fm = _Formulas(out, None)
    for i, lm in enumerate(landmarks):
        fm.equal_junction([f"a{j}@K" for j in sorted(lm)], False, out.declare(f"l{i}@K"))
        covered |= lm
    other = [f"a{a.id}@K" for a in problem.actions if a.id not in covered]
    o = out.declare("o@K")
    if other:
        fm.equal_junction(other, False, o)
    else:
        out.clause([neg(o)])


def _exactly_one(out: _Text, names: list[str], amo: str) -> None:
    out.clause(list(names))
    if len(names) < 2:
        return
    if amo == "pb":
        out.raw(f"(assert ((_ at-most 1) {' '.join(names)}))")
        return
    # sequential counter: s_i = "one of x_1..x_i is true"
    prev = None
    for k, x in enumerate(names):
        last = k == len(names) - 1
        s = None if last else out.aux()
        if s is not None:
            out.clause([neg(x), s])
        if prev is not None:
            out.clause([neg(x), neg(prev)])
            if s is not None:
                out.clause([neg(prev), s])
        prev = s


def _precondition(out: _Text, fm: _Formulas, a: GroundAction, act: str, geo_index) -> None:
    na = neg(act)
    for i in sorted(a.pre.pos):
        out.clause([na, f"p{i}@P"])
    for i in sorted(a.pre.neg):
        out.clause([na, f"(not p{i}@P)"])
    if geo_index is not None:
        for lit in a.pre.geometric:
            m = geo_index[lit]
            out.clause([na, f"b{m}@P", f"g{m}@P"])
    if a.pre.extra is not None:
        fm.require([na], a.pre.extra, "@P")


def _effects(out: _Text, fm: _Formulas, a: GroundAction, act: str, relevant,
             adders: dict, deleters: dict) -> None:
    na = neg(act)
    fires = []                                       # (fire literal, conditional effect)
    for ce in a.conditional:
        if not (ce.adds | ce.dels) & relevant:
            continue
        cond = fm.define(ce.condition, "@P")
        if cond is False:
            continue
        fires.append((act if cond is True else fm.equal_junction([act, cond], True), ce))
    for i in sorted(a.adds & relevant):
        out.clause([na, f"p{i}@K"])
        adders.setdefault(i, []).append(act)
    for i in sorted(a.dels & relevant):
        out.clause([na, f"(not p{i}@K)"] + [f for f, ce in fires if i in ce.adds])
        deleters.setdefault(i, []).append(act)
    for f, ce in fires:
        nf = neg(f)
        for i in sorted(ce.adds & relevant):
            if i not in a.adds:
                out.clause([nf, f"p{i}@K"])
                adders.setdefault(i, []).append(f)
        for i in sorted((ce.dels - ce.adds - a.adds) & relevant):
            others = [g for g, c in fires if c is not ce and i in c.adds]
            out.clause([nf, f"(not p{i}@K)"] + others)
            deleters.setdefault(i, []).append(f)


def _persistence(out: _Text, problem: GroundProblem, geo, changers: Changers | None) -> None:
    """Knowledge of a geometric literal (``b``, ``g``) carries over a step whose action cannot
    change it."""
    if changers is None:
        kin = frozenset(a.id for a in problem.actions
                        if a.kinematic or any(ce.kinematic for ce in a.conditional))
        groups = {kin: list(range(len(geo)))}
    else:
        groups = {}
        for m, lit in enumerate(geo):
            groups.setdefault(frozenset(changers(lit)), []).append(m)
    n_actions = len(problem.actions)
    for acts, lits in groups.items():
        if len(acts) == n_actions:
            continue                            # every step may change them
        if acts:
            c = out.aux()                       # c -> one of the changers is this step
            out.clause([neg(c)] + [f"a{j}@K" for j in sorted(acts)])
            head = [c]
        else:
            head = []
        for m in lits:
            for v in (f"b{m}", f"g{m}"):
                out.clause(head + [f"(not {v}@K)", f"{v}@P"])
                out.clause(head + [f"{v}@K", f"(not {v}@P)"])


def _goal_template(problem: GroundProblem, geo_index) -> tuple[_Text, list[str]]:
    out = _Text("q", "@K")
    goal = problem.goal
    lits = [f"p{i}@K" for i in sorted(goal.pos)] + [f"(not p{i}@K)" for i in sorted(goal.neg)]
    rest = [c for c in conjuncts(goal.formula)
            if not (type(c) is GAtom or (type(c) is GNot and type(c.part) is GAtom))]
    if geo_index is None:
        rest = [c for c in rest if type(c) not in (GGeo, GNot)]
    if rest:
        x = out.aux()
        fm = _Formulas(out, geo_index)
        for c in rest:
            fm.require([neg(x)], c, "@K")
        lits.append(x)
    return out, lits


__all__ = ["Encoding", "encode", "smtlib_templates", "relevant_atoms", "relaxed_levels",
           "relaxed_fixpoint", "AMO",
           "neg", "geo_literal"]
