"""`tmpc validate INPUT PLAN.json`: an independent check of a plan (docs/plan-format.md).

Independent of the planner's acceptance code for every fact it checks:

* link poses: pinocchio (else a walk down the validator's own joint tree),
  :mod:`tmpc.runtime.validate.kinematics` — not the JAX forward kinematics of ``compiler/robot.py``;
* collisions: raw python-fcl objects built here from the URDF and the scene,
  :mod:`tmpc.runtime.validate.collision` — not ``CollisionWorld`` and its sphere pass;
* geometric predicates: the numpy AST interpreter :mod:`tmpc.runtime.evaluate` (Lua-defined ones:
  the Lua function evaluated directly) — not the compiled JAX kernels;
* discrete preconditions, effects and the goal: a lifted STRIPS/ADL simulator,
  :mod:`tmpc.runtime.validate.logic` — not ``compiler/ground/problem.py``'s ground problem.

Shared with the planner: the loaded scene, the checked domain/problem, and
:class:`~tmpc.compiler.robot.RobotModel` only as a table of frame names and the configuration layout
the interpreter's ``joint`` operator reads.

Checks, state by state (a violation names the state index): the first state is the initial state;
joints within limits and the base within the scene's bounds (planar, at the scene's height);
joints that are not controllable at their scene value; no collision (at the penetration
tolerance); static objects where the scene puts them; held objects where their frame carries them;
the mode follows from the previous state (unchanged after a motion, the action's effects after an
action; ``mode.held`` = the kinematic atoms); an action's precondition — discrete and geometric —
holds at its state; the configuration and every object pose stay the same across an action;
objects that are not held stay put during a motion, and the straight joint-space motion to the
next state is collision-free at ``resolution`` (no coordinate moves more than it between two
checked configurations; base yaw and continuous joints the short way); the goal holds at the last
state. A bare planet/tmit-star array has no modes: they are reconstructed by simulation.
"""

from __future__ import annotations

import math
import time

import numpy as np

from tmpc.lang.diagnostics import InputError, error
from tmpc.lang.world import collision_tolerance
from tmpc.runtime.plans import Plan, PlanState, parse_ground, pose_matrix, read_plan
from tmpc.runtime.start_atoms import settled_placements
from tmpc.runtime.validate.checks import StateChecks
from tmpc.runtime.validate.collision import Checker
from tmpc.runtime.validate.kinematics import (
    Kinematics,
    full_joint_values,
    read_urdf,
    scene_defaults,
    urdf_path,
)
from tmpc.runtime.validate.logic import Facts, Logic
from tmpc.runtime.validate.predicates import Predicates
from tmpc.runtime.validate.report import Report, Violation
from tmpc.runtime.validate.state import (
    ResolvedState,
    action_text,
    dict_text,
    norm_action,
    report_order,
)

#: how a plan is read (docs/validate.md "Conventions"): auto = tmpc for tmpc-plan/1 files, else
#: the planner a bare array's action spelling names
CONVENTIONS = ("auto", "tmpc", "tmit-star", "planet")
LEGACY_CONVENTIONS = ("tmpc", "tmit-star", "planet")
class Validator(StateChecks):
    """Validate plans for one world (a run configuration with a domain and a problem)."""

    def __init__(self, world, tolerance: float | None = None, resolution: float = 0.05,
                 convention: str = "auto", strict: bool = False, start: str = "scene"):
        if convention not in CONVENTIONS:
            raise ValueError(f"convention must be one of {CONVENTIONS}")
        self.convention_option = convention
        self.strict = strict
        #: "scene": the first state must be the scene's start; "plan": it is the start
        self.start = start
        self.convention = "tmpc"
        self.world, self.scene = world, world.scene
        self.tolerance = default_tolerance(world) if tolerance is None else float(tolerance)
        self.resolution = float(resolution)
        # the file's placement atoms the scene replaces, as the planners start from them
        self.logic = Logic(world.program, settled_placements(world))
        spec = self.scene.robot
        self.desc = read_urdf(urdf_path(world.scene)) if spec is not None else None
        self.kin = Kinematics(self.desc) if self.desc is not None else None
        self.checker = Checker(self.desc, self.scene, self.tolerance, list(world.allowed_pairs()))
        self.mobile = bool(spec is not None and spec.mobile_base)
        self.T_base0 = pose_matrix(spec.base_pose) if spec is not None else np.eye(4)
        self.link_index = {n: i for i, n in enumerate(self.desc.links)} if self.desc else {}
        self.defaults, self.controllable = self._defaults()
        self.predicates = Predicates(world, self.link_index, self.frame_T)
        self.mounted = self._mounted()
        self._linked: set[str] = set()

    # ---- the robot ------------------------------------------------------------------------------
    def _defaults(self) -> tuple[dict[str, float], set[str]]:
        if self.desc is None:
            return {}, set()
        return scene_defaults(self.desc, self.scene.robot)

    def link_poses(self, T_root: np.ndarray, values: dict[str, float]) -> np.ndarray:
        if self.kin is None:
            return np.zeros((0, 4, 4))
        return self.kin.poses(T_root, full_joint_values(self.desc, values))

    def frame_T(self, st: ResolvedState, name: str) -> np.ndarray | None:
        """World pose of a robot frame (link, or joint = its child link) or an object."""
        if self.desc is not None:
            link = name if name in self.link_index else (
                self.desc.joint(name).child if self.desc.joint(name) is not None else None)
            if link is not None:
                return st.link_T[self.link_index[link]]
        o = self.scene.object(name)
        return st.objects.get(o.name) if o is not None else None

    # ---- the run --------------------------------------------------------------------------------
    def validate(self, plan: Plan) -> Report:
        t0 = time.perf_counter()
        rep = Report(len(plan.states), plan.action_count, tolerance=self.tolerance,
                     resolution=self.resolution, kinematics=self.kin.backend if self.kin else "",
                     status=plan.status)
        if plan.status not in (None, "solved"):
            rep.notes.append(f"the plan's status is `{plan.status}`")
        if plan.form == "array":
            rep.notes.append("a bare state array: modes reconstructed by simulation")
        self.convention = self.convention_option if self.convention_option != "auto" else \
            plan.meta.get("convention", "tmpc") if plan.form == "array" else "tmpc"
        if self.convention not in LEGACY_CONVENTIONS:
            self.convention = "tmpc"
        self._legacy = {"motions": 0, "snaps": []}
        self.v, self.w = rep.violations, rep.warnings
        self._linked = set()
        self._check_action_list(plan)
        prev: ResolvedState | None = None
        for ps in plan.states:
            st = self._resolve(ps, prev)
            self._check_state(ps, st, prev, rep)
            prev = st
        if prev.action is not None:
            self.add(prev.index, "action", f"the plan ends with action {action_text(prev.action)}"
                     ": its effects need a following state (same configuration, the new mode)")
        self._check_goal(prev)
        if self.convention != "tmpc":
            rep.notes.append(self._convention_note())
        rep.violations.sort(key=report_order)
        if self.predicates.lua_used:
            rep.notes.append("Lua predicates evaluated directly: " +
                             ", ".join(sorted(self.predicates.lua_used)))
        rep.seconds = time.perf_counter() - t0
        return rep

    def add(self, state, kind, message, to=None, **details) -> None:
        self.v.append(Violation(state, kind, message, to, details))

    def warn(self, state, kind, message, **details) -> None:
        """A warning (W830): an error too with ``strict``."""
        (self.v if self.strict else self.w).append(Violation(state, kind, message, None, details))

    def _check_action_list(self, plan: Plan) -> None:
        if plan.actions is None:
            return
        listed = [parse_ground(a) for a in plan.actions]
        steps = [s.action for s in plan.states if s.action is not None]
        if [norm_action(a) for a in listed] != [norm_action(a) for a in steps]:
            self.add(None, "actions", f"the plan's `actions` ({len(listed)}) differ from the "
                     f"actions of its states ({len(steps)})")

    # ---- resolving a state ----------------------------------------------------------------------
    def _resolve(self, ps: PlanState, prev: ResolvedState | None) -> ResolvedState:
        i = ps.index
        facts, held = self._mode(ps, prev)
        values = dict(self.defaults if prev is None else prev.values)
        for name, v in ps.joints.items():
            j = self.desc.joint(name) if self.desc is not None else None
            if j is None or not j.movable:
                self.add(i, "joint", f"unknown joint `{name}`" + (
                    f" (the robot `{self.desc.name}` has no movable joint of that name)"
                    if self.desc is not None else " (the scene has no robot)"))
            elif j.mimic is not None:
                pass   # checked against its source in _check_joints
            else:
                values[name] = v
        T_root = ps.base if ps.base is not None else (self.T_base0 if prev is None else
                                                      prev.T_root)
        link_T = self.link_poses(T_root, values)
        st = ResolvedState(i, values, T_root, link_T, {}, facts, held, ps.action)
        st.objects = self._objects(ps, st, prev)
        return st

    def _mode(self, ps: PlanState, prev: ResolvedState | None) -> tuple[Facts, dict[str, str]]:
        """The state's facts and held objects: the plan's mode when given (checked against what
        the previous state implies), else the simulated one."""
        L = self.logic
        i = ps.index
        if prev is None:
            expected = L.initial()
            why = "the problem's initial state" if self.start == "scene" else None
        elif prev.action is not None and self._bound(prev) is None:
            # an action that is not one of the domain's (reported at its state): the plan's mode
            # is taken as it is
            expected, why = prev.facts, None
        elif prev.action is not None:
            act, env = self._bound(prev)
            expected = L.apply(act, env, prev.facts, self._geo_fn(prev))
            why = f"action {action_text(prev.action)}"
        else:
            expected = prev.facts
            why = "a motion (the mode is unchanged)"
        facts = expected
        if ps.mode_atoms is not None:
            given = self._given_facts(ps, expected)
            want = {a for a in expected.atoms if L.is_state_atom(a[0])}
            have = {a for a in given.atoms if L.is_state_atom(a[0])}
            if want != have and why is not None:
                miss = ", ".join(L.atom_text(a) for a in sorted(want - have))
                extra = ", ".join(L.atom_text(a) for a in sorted(have - want))
                parts = ([f"missing {miss}"] if miss else []) + ([f"extra {extra}"] if extra
                                                                 else [])
                self.add(i, "mode", f"mode does not follow from {why}: " + "; ".join(parts))
            facts = given
        held = self._held(facts)
        if ps.mode_held is not None:
            given_held = {self._object_name(o): f for o, f in ps.mode_held.items()}
            if {k.lower(): v.lower() for k, v in given_held.items()} != \
                    {k.lower(): v.lower() for k, v in held.items()}:
                self.add(i, "mode", f"mode.held {dict_text(given_held)} does not match the "
                         f"kinematic atoms of the mode {dict_text(held)}")
        return facts, held

    def _given_facts(self, ps: PlanState, expected: Facts) -> Facts:
        L = self.logic
        atoms = {a for a in expected.atoms if not L.is_state_atom(a[0])}   # statics stay
        for pred, args in ps.mode_atoms:
            key, keys = pred.lower(), tuple(a.lower() for a in args)
            decl = L.scope.predicates.get(key)
            bad = decl is None or len(decl.params) != len(keys) or \
                any(k not in L.objects for k in keys)
            if bad:
                self.add(ps.index, "mode", f"mode atom ({' '.join((pred,) + args)}) names an "
                         "unknown predicate or object, or has the wrong number of arguments")
            elif L.is_state_atom(key):
                atoms.add((key, keys))
        return Facts(frozenset(atoms), expected.numbers)

    def _held(self, facts: Facts) -> dict[str, str]:
        """Held objects: the kinematic atoms' children; an object the scene mounts on the robot
        (its parent chain ends at a robot frame) counts as held by it while no kinematic atom of
        the plan so far names it."""
        out = {}
        for a in facts.atoms:
            pc = self.logic.kinematic(a)
            if pc is not None:
                out[self._object_name(pc[1])] = self._frame_name(pc[0])
                self._linked.add(self._object_name(pc[1]))
        for obj, frame in self.mounted.items():
            if obj not in out and obj not in self._linked:
                out[obj] = frame
        return out

    def _mounted(self) -> dict[str, str]:
        """Objects whose scene parent chain ends at a robot frame (or the robot: its root)."""
        out = {}
        robot = self.scene.robot
        for o in self.scene.objects:
            anchor, seen = o.parent, {o.name.lower()}
            while anchor is not None and self.scene.object(anchor) is not None \
                    and anchor.lower() not in seen:
                seen.add(anchor.lower())
                anchor = self.scene.object(anchor).parent
            if anchor is None or robot is None:
                continue
            if anchor.lower() == robot.name.lower() and self.desc is not None:
                out[o.name] = self.desc.root
            elif self.desc is not None and (anchor in self.link_index or
                                            self.desc.joint(anchor) is not None):
                out[o.name] = anchor
        return out

    def _object_name(self, key: str) -> str:
        o = self.scene.object(key)
        return o.name if o is not None else self.logic.name(key.lower())

    def _frame_name(self, key: str) -> str:
        name = self.logic.name(key.lower())
        if self.desc is not None:
            for n in list(self.link_index) + [j.name for j in self.desc.joints]:
                if n.lower() == name.lower():
                    return n
        return self._object_name(name)

    def _objects(self, ps: PlanState, st: ResolvedState,
                 prev: ResolvedState | None) -> dict[str, np.ndarray]:
        """World poses of every scene object: the plan's where given; otherwise the previous
        state's (held objects: carried by their frame)."""
        out: dict[str, np.ndarray] = {}
        for name, T in ps.objects.items():
            o = self.scene.object(name)
            if o is None:
                self.add(ps.index, "object", f"unknown object `{name}` in object_poses")
            else:
                out[o.name] = T
        base = self._initial_objects(st) if prev is None else prev.objects
        for o in self.scene.objects:
            if o.name in out:
                continue
            if o.name in st.held and prev is not None and o.name in prev.held:
                T = self._carried(st, prev, o.name)
                out[o.name] = T if T is not None else base[o.name]
            else:
                out[o.name] = base[o.name]
        return out

    def _initial_objects(self, st: ResolvedState) -> dict[str, np.ndarray]:
        """Object poses of the scene's start: parent chains composed; a chain ending at a robot
        frame (or the robot's name: its root) is carried by it in the state's configuration."""
        out = {}
        robot = self.scene.robot
        for o in self.scene.objects:
            T, anchor, seen = pose_matrix(o.pose), o.parent, {o.name.lower()}
            while anchor is not None and self.scene.object(anchor) is not None \
                    and anchor.lower() not in seen:
                p = self.scene.object(anchor)
                seen.add(anchor.lower())
                T, anchor = pose_matrix(p.pose) @ T, p.parent
            if anchor is not None and robot is not None and anchor.lower() == robot.name.lower():
                T = st.T_root @ T
            elif anchor is not None:
                F = self.frame_T(st, anchor)
                T = F @ T if F is not None else T
            out[o.name] = T
        return out

    def _carried(self, st: ResolvedState, prev: ResolvedState, obj: str) -> np.ndarray | None:
        """Where ``obj`` is in ``st`` if it keeps its pose relative to its parent since ``prev``."""
        parent = st.held[obj]
        Pp, Pn = self.frame_T(prev, parent), self.frame_T(st, parent)
        if Pp is None or Pn is None or prev.held.get(obj) != parent:
            return None
        return Pn @ np.linalg.inv(Pp) @ prev.objects[obj]


# ---------------------------------------------------------------------------------------------
# helpers


def default_tolerance(world) -> float:
    """The run configuration's default penetration tolerance (the planner's too):
    :func:`tmpc.lang.world.collision_tolerance`."""
    return collision_tolerance(world.config)


# ---------------------------------------------------------------------------------------------
# the command


def validate_plan(world, plan: Plan | str, tolerance: float | None = None,
                  resolution: float = 0.05, convention: str = "auto",
                  strict: bool = False, start: str = "scene") -> Report:
    """Validate ``plan`` (a :class:`Plan` or a path) in ``world``; see the module docstring.
    ``strict``: warnings (a released object that does not rest, W830) are violations.
    ``start``: ``"scene"``, the plan must start at the scene's start; ``"plan"``, its first
    state is the start (a plan made from an observed state: its configuration, object poses
    and mode are taken as given, and everything after is checked from there)."""
    _check_world(world)
    check_numbers(tolerance, resolution)
    if start not in ("scene", "plan"):
        raise ValueError("start must be 'scene' or 'plan'")
    if not isinstance(plan, Plan):
        plan = read_plan(plan)
    return Validator(world, tolerance, resolution, convention, strict, start).validate(plan)


def _check_world(world) -> None:
    if world.program is None or world.program.problem is None:
        raise InputError(error("E812", "validating a plan needs the domain and problem: give the "
                               "run configuration (manifest TOML, planet TOML, tmit-star spec) "
                               "the plan was made for", None))


def check_numbers(tolerance, resolution) -> None:
    if tolerance is not None and not (math.isfinite(tolerance) and tolerance >= 0):
        raise InputError(error("E813", f"--tolerance {tolerance}: a penetration depth is a "
                               "finite number >= 0 (metres)", None,
                               "planet used 0.021, tmit-star 0.029"))
    if not (math.isfinite(resolution) and resolution > 0):
        raise InputError(error("E813", f"--resolution {resolution}: the motion step is a finite "
                               "number > 0 (rad or m)", None, "e.g. 0.05"))


__all__ = [
    "Report",
    "Validator",
    "Violation",
    "check_numbers",
    "default_tolerance",
    "validate_plan",
]
