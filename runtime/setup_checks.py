"""The errors `tmpc run` raises before planning, as diagnostics `tmpc check` reports too.

One source for both: :class:`~tmpc.runtime.problem.PlanningProblem` raises the first of them,
and `tmpc check` on a run configuration lists them all, at the span that causes each, without
compiling a kernel (grounding, the robot's kinematics, fcl). The codes, in the order a run
meets them (:data:`SETUP_CODES`):

* E821: the scene has no robot;
* E822: an object a geometric atom names is neither a scene object nor a robot frame (at the
  object's declaration);
* E581: a geometric atom reads the support region of an object that has none (at the atom's
  predicate, naming the object);
* E566: an action the problem can apply holds an object the scene marks static (at the action);
* E824: the goal is unreachable even ignoring deletes and geometry (at the goal);
* E834: a geometric goal atom that can never change (it names no movable object and no robot
  frame) is false in the scene (at the atom): evaluated once, by the numpy interpreter;
* E829: a start joint outside its limits; E823: the start state in collision.
"""

from __future__ import annotations

import difflib
from functools import cached_property

import numpy as np

from tmpc.compiler import ir
from tmpc.compiler.ground import ground
from tmpc.compiler.lower import Lowerer
from tmpc.compiler.robot import RobotModel, robot_model
from tmpc.compiler.state import initial_state
from tmpc.lang import ast as A
from tmpc.lang.diagnostics import Diagnostic, InputError, TmpcError, error, warning
from tmpc.lang.world import collision_tolerance
from tmpc.runtime.collision import CollisionWorld
from tmpc.runtime.evaluate import Evaluator, Obj
from tmpc.runtime.start_atoms import disagreements

#: the setup errors, in the order a run meets them
SETUP_CODES = ("E821", "E822", "E581", "E566", "E824", "E834", "E829", "E823")


class SetupChecks:
    """The setup checks of one loaded world with a program and a problem. ``ground``: its
    :class:`~tmpc.compiler.ground.GroundProblem`; ``model``: the robot's (None: none)."""

    def __init__(self, world, ground, model: RobotModel | None):
        self.world, self.ground, self.model = world, ground, model
        self.program = world.program
        self.scope = world.program.scope

    # ---- symbolic and scene consistency --------------------------------------------------------
    def robot(self) -> list[Diagnostic]:
        if self.model is None:
            return [error("E821", "the scene has no robot to plan for", None,
                          f"give the scene ({self.world.scene.path}) a `robot`")]
        return []

    @cached_property
    def _known_names(self) -> frozenset[str]:
        """Scene objects and robot frames (links, and joints naming their child links), lower
        case: names compare without case, as the kernels' entity table does."""
        return frozenset(n.lower() for n in self._names())

    def objects(self) -> list[Diagnostic]:
        """E822, one per object, at its declaration (the problem's, or the domain's constant)."""
        missing = sorted({a.lower() for g in self.ground.geometric for a in g.args
                          if a.lower() not in self._known_names})
        out = []
        for key in missing:
            info = self.scope.objects.get(key)
            name = info.name if info is not None else None
            out.append(error(
                "E822", f"object `{name.text if name else key}` appears in geometric atoms but "
                "is neither a scene object nor a robot frame",
                name.span if name is not None else self.program.problem.span,
                f"add it to the scene ({self.world.scene.path}), or check its spelling: "
                + _nearest(key, self._names())))
        return out

    def _names(self) -> list[str]:
        names = [o.name for o in self.world.scene.objects]
        if self.model is not None:
            names += list(self.model.frames) + list(self.model.frame_index)
        return names

    def support_regions(self) -> list[Diagnostic]:
        """E581: a ground geometric atom whose predicate reads ``(support-region ?s)`` with an
        object in ``?s`` that has no support region."""
        slots = self._support_slots()
        out, seen = [], set()
        for g in self.ground.geometric:
            for i in slots.get(g.predicate.lower(), ()):
                obj = self.world.scene.object(g.args[i])
                if obj is None or obj.support is not None or (g.predicate, obj.name) in seen:
                    continue
                seen.add((g.predicate, obj.name))
                decl = self.scope.predicates[g.predicate.lower()]
                out.append(error(
                    "E581", f"`{g.predicate}` reads the support region of `{obj.name}`, which "
                    "has none: the predicate can never hold there", decl.name.span,
                    f"give `{obj.name}` a `support` box in {self.world.scene.path} (what can "
                    "rest on it, in its own frame), or keep it out of this predicate's "
                    "arguments"))
        return out

    def _support_slots(self) -> dict[str, tuple[int, ...]]:
        out = {}
        lower = Lowerer(self.scope)
        for key, decl in self.scope.predicates.items():
            if decl.kind is not A.Kind.GEOMETRIC or decl.semantics is None:
                continue
            try:
                body = lower.predicate(decl).body
            except (TmpcError, ValueError):
                continue            # the compiler reports what does not lower
            slots = {n.args[0].index for n in ir.walk(body) if isinstance(n, ir.Op)
                     and n.op == "support" and isinstance(n.args[0], ir.Arg)}
            if slots:
                out[key] = tuple(sorted(slots))
        return out

    def static_holds(self) -> list[Diagnostic]:
        """E566: an applicable action (relaxed-reachable) links an object marked static."""
        out, seen = [], set()
        for a in self.ground.actions:
            for k in a.kinematic:
                obj = self.world.scene.object(k.child) if k.op == "link" else None
                if obj is None or obj.movable or (a.schema, obj.name) in seen:
                    continue
                seen.add((a.schema, obj.name))
                decl = self.scope.actions.get(a.schema.lower())
                out.append(error(
                    "E566", f"`{a.name}` holds `{obj.name}`, which the scene marks static",
                    decl.name.span if decl is not None else None,
                    f"mark `{obj.name}` movable in {self.world.scene.path}, or narrow the "
                    "action's parameter types so it cannot take static objects"))
        return out

    def goal(self) -> list[Diagnostic]:
        """E824, at the goal atoms nothing adds (or at the goal, when each has an adder but
        they cannot all be reached)."""
        if self.ground.goal_relaxed_reachable:
            return []
        goal = self.program.problem.goal
        culprits = [lit for lit in A.conjuncts(goal) if isinstance(lit, A.Atom)
                    and not self._ever_true(lit)]
        return [error("E824", "the goal is unreachable: even ignoring delete effects and "
                      "geometry, no sequence of actions makes it true"
                      + (f"; nothing makes `{_atom_text(culprits[0])}` true" if culprits else ""),
                      culprits[0].span if culprits else getattr(goal, "span", None),
                      "check the goal atoms and the actions that add them (`tmpc plan` on the "
                      "domain and problem shows the symbolic side alone)")]

    def _ever_true(self, atom: A.Atom) -> bool:
        """Is a discrete goal atom true at the start or added by some action? (Geometric and
        derived atoms count as possible.)"""
        decl = self.scope.predicates.get(atom.pred.key)
        if decl is None or decl.kind is A.Kind.GEOMETRIC or atom.pred.key in self.scope.derived:
            return True
        i = self.ground.atom_id(atom.pred.text, *(t.name.text for t in atom.args))
        if i is None:
            return False
        if self.ground.init >> i & 1:
            return True
        return any(a.add_mask >> i & 1 or any(ce.add_mask >> i & 1 for ce in a.conditional)
                   for a in self.ground.actions)

    # ---- the start state ---------------------------------------------------------------------
    def start_limits(self, q0: np.ndarray) -> list[Diagnostic]:
        """E829: the scene's start joint values (as written) within the model's limits."""
        m = self.model
        raw = dict(self.world.scene.robot.joint_values) if self.world.scene.robot else {}
        raw.update(zip(m.q_names[:3], q0[:3]) if m.mobile_base else ())
        out = [(name, float(raw[name]), float(lo), float(hi)) for name, lo, hi, w in
               zip(m.q_names, m.lower, m.upper, m.wraps)
               if name in raw and not w and not (lo - 1e-9 <= raw[name] <= hi + 1e-9)]
        if not out:
            return []
        name, v, lo, hi = out[0]
        more = f" (and {len(out) - 1} more)" if len(out) > 1 else ""
        return [error("E829", f"the start has `{name}` = {v:g}, outside its limits "
                      f"[{lo:g}, {hi:g}]{more}", None,
                      f"set it within the limits in {self.world.scene.path} (the scene's start "
                      "joint values; a mobile base's x and y stay within the scene bounds)")]

    def start_collisions(self, collision, q0, poses, held, tolerance: float) -> list[Diagnostic]:
        """E823: the start state in collision, naming the pairs and depths."""
        rep = collision.check(q0, poses=poses, attached=held)
        if rep.valid:
            return []
        pairs = ", ".join(f"{a} with {b} ({d * 1000:.1f} mm)" for a, b, d in rep.pairs[:5])
        return [error("E823", f"the start state is in collision: {pairs}", None,
                      "move the robot or the objects in the scene, or allow deeper contact: a "
                      f"native manifest's [planner] collision_tolerance (now {tolerance} m)")]

    def fixed_goal_atoms(self) -> list[Diagnostic]:
        """E834: goal atoms over objects that never move, false in the scene's start."""
        scene, scope = self.world.scene, self.scope
        if self.model is None:
            return []
        s0 = initial_state(scene, self.model)
        ev = Evaluator(scene, self.model, None, None, s0.poses, scope)
        out = []
        for lit in A.conjuncts(self.program.problem.goal):
            atom, positive = (lit.part, False) if isinstance(lit, A.Not) else (lit, True)
            decl = scope.predicates.get(atom.pred.key) if isinstance(atom, A.Atom) else None
            if decl is None or decl.kind is not A.Kind.GEOMETRIC or decl.semantics is None:
                continue
            names = [t.name.text for t in atom.args]
            objs = [scene.object(n) for n in names]
            if any(o is None or o.movable or o.parent is not None for o in objs):
                continue          # a robot frame, a movable object, or one riding on something
            env = {p.name.key: Obj(o.name) for p, o in zip(decl.params, objs)}
            try:
                holds = bool(ev.value(decl.semantics, env))
            except TmpcError:
                continue          # needs the robot's frames: the goal's projection decides it
            if holds != positive:
                text = _atom_text(atom)
                out.append(error(
                    "E834", f"the goal {'needs' if positive else 'excludes'} {text}, which is "
                    f"{'false' if positive else 'true'} in the scene and names nothing that "
                    "moves: no plan can change it", atom.span,
                    "make one of its objects movable, or move them in the scene "
                    f"({scene.path})"))
        return out

    def symbolic(self) -> list[Diagnostic]:
        """The checks that need no collision world, in a run's order."""
        return (self.robot() or self.objects() + self.support_regions() + self.static_holds()
                + self.goal() + self.fixed_goal_atoms())


def setup_diagnostics(world) -> list[Diagnostic]:
    """Every error a run of ``world`` (a run configuration, loaded with its program) would raise
    before planning; none compiles a kernel. For `tmpc check`."""
    program = world.program
    if program is None or program.problem is None:
        return []
    try:
        model = robot_model(world.scene)
        checks = SetupChecks(world, ground(program), model)
        out = checks.symbolic()
        if model is None or out:
            return out
        s0 = initial_state(world.scene, model)
        q0 = np.asarray(s0.q, float)
        out = checks.start_limits(q0)
        if out:
            return out
        tolerance = collision_tolerance(world.config)
        collision = CollisionWorld(world.scene, robot_model(world.scene, strict_meshes=True),
                                   tolerance=tolerance, allowed=world.allowed_pairs())
        return checks.start_collisions(collision, q0, s0.poses, s0.held, tolerance)
    except TmpcError as exc:
        return list(exc.diagnostics)


def init_meanings(world) -> list[Diagnostic]:
    """W840: an `:init` atom whose predicate a semantics module gives a meaning
    (docs/language.md, "Semantics modules") while the meaning is false in the scene: the PDDL
    file and the scene disagree (the task planner believes the file, the geometry is the
    scene's; for a placement on a fixed support the scene holds another, plans start from that
    one: :mod:`tmpc.runtime.start_atoms`). Evaluated once per atom, by the numpy interpreter;
    for `tmpc check`."""
    out = []
    path = world.scene.path
    for item, settled in disagreements(world):
        hint = (f"plans start from the scene's {settled.text} instead (docs/language.md, "
                f"\"Semantics modules\"; the scene: {path})" if settled is not None else
                f"the task planner starts from the file's atoms; the geometry is the scene's "
                f"({path})")
        out.append(warning("W840", f"{_atom_text(item)} is in `:init`, but its meaning is "
                           "false in the scene: the file and the scene disagree", item.span,
                           hint))
    return out


def raise_setup_errors(world) -> None:
    """Raise :func:`setup_diagnostics`' errors (an :class:`InputError`), if any."""
    diagnostics = setup_diagnostics(world)
    if diagnostics:
        raise InputError(diagnostics, world.files)


def _atom_text(a: A.Atom) -> str:
    return "(" + " ".join([a.pred.text] + [t.name.text for t in a.args]) + ")"


def _nearest(key: str, names: list[str]) -> str:
    close = difflib.get_close_matches(key, [n.lower() for n in names], n=1, cutoff=0.6)
    if not close:
        return "no scene object or robot frame has a similar name"
    spelled = {n.lower(): n for n in names}
    return f"did you mean `{spelled[close[0]]}`?"
