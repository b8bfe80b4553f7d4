"""`tmpc validate INPUT PLAN.json`: an independent check of a plan (docs/plan-format.md).

Independent of the planner's acceptance code for every fact it checks:

* link poses: pinocchio (else a walk down the validator's own joint tree),
  :mod:`tmpc.runtime.validate.kinematics` — not the JAX forward kinematics of ``compiler/robot.py``;
* collisions: raw python-fcl objects built here from the URDF and the scene,
  :mod:`tmpc.runtime.validate.collision` — not ``CollisionWorld`` and its sphere pass;
* geometric predicates: the numpy AST interpreter :mod:`tmpc.runtime.evaluate` (Lua-defined ones: the Lua
  function evaluated directly) — not the compiled JAX kernels;
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
from dataclasses import dataclass, field

import numpy as np

from tmpc.lang.diagnostics import InputError, error
from tmpc.lang.world import collision_tolerance
from tmpc.runtime.plans import Plan, PlanState, parse_ground, pose_matrix, read_plan
from tmpc.runtime.validate.collision import Checker
from tmpc.runtime.validate.kinematics import (
    Kinematics,
    full_joint_values,
    heading,
    joint_delta,
    planar_base,
    read_urdf,
    scene_defaults,
    straight_motion,
    urdf_path,
)
from tmpc.runtime.validate.logic import Facts, Logic
from tmpc.runtime.validate.predicates import Predicates
from tmpc.runtime.validate.report import Report, Violation

#: how a plan is read (docs/validate.md "Conventions"): auto = tmpc for tmpc-plan/1 files, else
#: the planner a bare array's action spelling names
CONVENTIONS = ("auto", "tmpc", "tmit-star", "planet")
LEGACY_CONVENTIONS = ("tmpc", "tmit-star", "planet")
#: positions (m) and angles (rad) closer than this are the same
POSE_TOL = 1e-4
#: a released object rests on a support when its lowest point is at most this far above the
#: support's top (or the support region's floor) and this far into it (m), and its nearest axis
#: is within SUPPORT_TILT of vertical (rad)
SUPPORT_GAP, SUPPORT_SINK, SUPPORT_TILT = 0.01, 0.005, math.radians(5.0)
#: slack on joint limits and on values that must not change (rad or m)
JOINT_TOL = 1e-6
@dataclass
class _State:
    """A plan state resolved against the world."""

    index: int
    values: dict[str, float]          # independent movable joints
    T_root: np.ndarray
    link_T: np.ndarray                # (L, 4, 4)
    objects: dict[str, np.ndarray]    # scene name -> world pose
    facts: Facts
    held: dict[str, str]              # object (scene name) -> parent (frame or object name)
    action: tuple | None = None
    _geo: dict = field(default_factory=dict)


class Validator:
    """Validate plans for one world (a run configuration with a domain and a problem)."""

    def __init__(self, world, tolerance: float | None = None, resolution: float = 0.05,
                 convention: str = "auto", strict: bool = False):
        if convention not in CONVENTIONS:
            raise ValueError(f"convention must be one of {CONVENTIONS}")
        self.convention_option = convention
        self.strict = strict
        self.convention = "tmpc"
        self.world, self.scene = world, world.scene
        self.tolerance = default_tolerance(world) if tolerance is None else float(tolerance)
        self.resolution = float(resolution)
        self.logic = Logic(world.program)
        spec = self.scene.robot
        self.desc = read_urdf(urdf_path(world.scene)) if spec is not None else None
        self.kin = Kinematics(self.desc) if self.desc is not None else None
        self.checker = Checker(self.desc, self.scene, self.tolerance, list(world.allowed_pairs()))
        self.mobile = bool(spec is not None and spec.mobile_base)
        self.T_base0 = _pose(spec.base_pose) if spec is not None else np.eye(4)
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

    def frame_T(self, st: _State, name: str) -> np.ndarray | None:
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
        prev: _State | None = None
        for ps in plan.states:
            st = self._resolve(ps, prev)
            self._check_state(ps, st, prev, rep)
            prev = st
        if prev.action is not None:
            self.add(prev.index, "action", f"the plan ends with action {_action_text(prev.action)}"
                     ": its effects need a following state (same configuration, the new mode)")
        self._check_goal(prev)
        if self.convention != "tmpc":
            rep.notes.append(self._convention_note())
        rep.violations.sort(key=_order)
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
        if [_norm_action(a) for a in listed] != [_norm_action(a) for a in steps]:
            self.add(None, "actions", f"the plan's `actions` ({len(listed)}) differ from the "
                     f"actions of its states ({len(steps)})")

    # ---- resolving a state ----------------------------------------------------------------------
    def _resolve(self, ps: PlanState, prev: _State | None) -> _State:
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
        st = _State(i, values, T_root, link_T, {}, facts, held, ps.action)
        st.objects = self._objects(ps, st, prev)
        return st

    def _mode(self, ps: PlanState, prev: _State | None) -> tuple[Facts, dict[str, str]]:
        """The state's facts and held objects: the plan's mode when given (checked against what
        the previous state implies), else the simulated one."""
        L = self.logic
        i = ps.index
        if prev is None:
            expected = L.initial()
            why = "the problem's initial state"
        elif prev.action is not None and self._bound(prev) is None:
            # an action that is not one of the domain's (reported at its state): the plan's mode
            # is taken as it is
            expected, why = prev.facts, None
        elif prev.action is not None:
            act, env = self._bound(prev)
            expected = L.apply(act, env, prev.facts, self._geo_fn(prev))
            why = f"action {_action_text(prev.action)}"
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
                self.add(i, "mode", f"mode.held {_dict_text(given_held)} does not match the "
                         f"kinematic atoms of the mode {_dict_text(held)}")
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

    def _objects(self, ps: PlanState, st: _State, prev: _State | None) -> dict[str, np.ndarray]:
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

    def _initial_objects(self, st: _State) -> dict[str, np.ndarray]:
        """Object poses of the scene's start: parent chains composed; a chain ending at a robot
        frame (or the robot's name: its root) is carried by it in the state's configuration."""
        out = {}
        robot = self.scene.robot
        for o in self.scene.objects:
            T, anchor, seen = _pose(o.pose), o.parent, {o.name.lower()}
            while anchor is not None and self.scene.object(anchor) is not None \
                    and anchor.lower() not in seen:
                p = self.scene.object(anchor)
                seen.add(anchor.lower())
                T, anchor = _pose(p.pose) @ T, p.parent
            if anchor is not None and robot is not None and anchor.lower() == robot.name.lower():
                T = st.T_root @ T
            elif anchor is not None:
                F = self.frame_T(st, anchor)
                T = F @ T if F is not None else T
            out[o.name] = T
        return out

    def _carried(self, st: _State, prev: _State, obj: str) -> np.ndarray | None:
        """Where ``obj`` is in ``st`` if it keeps its pose relative to its parent since ``prev``."""
        parent = st.held[obj]
        Pp, Pn = self.frame_T(prev, parent), self.frame_T(st, parent)
        if Pp is None or Pn is None or prev.held.get(obj) != parent:
            return None
        return Pn @ np.linalg.inv(Pp) @ prev.objects[obj]

    # ---- checks ---------------------------------------------------------------------------------
    def _check_state(self, ps: PlanState, st: _State, prev: _State | None, rep: Report) -> None:
        if prev is None:
            self._check_initial(ps, st)
        self._check_joints(ps, st)
        self._check_base(st)
        self._check_objects(st, prev)
        if prev is not None:
            for o in sorted(set(prev.held) - set(st.held)):
                self._check_support(st, o)
        pairs = self.checker.collisions(st.link_T, st.objects, st.held)
        for a, b, d in pairs:
            self.add(st.index, "collision", f"{a} collides with {b} (penetration {d:.4f} m)",
                     pair=[a, b], depth=d)
        if prev is not None and prev.action is not None and self.convention != "tmpc":
            # planet/tmit-star: the action is on the state where it is executed, and the next
            # state may be anywhere in the new mode: a motion from the action's configuration
            after = self._after_action(prev, st)
            if self._moved(prev, st):
                self._legacy["motions"] += 1
                rep.motion_checks += self._check_motion(after, st)
        elif prev is not None and prev.action is not None:
            self._check_unchanged(prev, st)
        elif prev is not None:
            rep.motion_checks += self._check_motion(prev, st)
        if st.action is not None:
            self._check_action(st)

    def _check_initial(self, ps: PlanState, st: _State) -> None:
        for name, v in sorted(st.values.items()):
            d0 = self.defaults.get(name)
            if d0 is not None and abs(joint_delta(self.desc, name, v, d0)) > POSE_TOL:
                self.add(0, "initial", f"joint `{name}` is {v:.6g}, the scene starts it at "
                         f"{d0:.6g}")
        if _pose_gap(st.T_root, self.T_base0) > POSE_TOL:
            self.add(0, "initial", "base_pose differs from the scene's base pose by "
                     f"{_pose_text(st.T_root, self.T_base0)}")
        init = self._initial_objects(st)
        for name, T in st.objects.items():
            if _pose_gap(T, init[name]) > POSE_TOL:
                self.add(0, "initial", f"object `{name}` is {_pose_text(T, init[name])} away "
                         "from its place in the scene")

    def _check_joints(self, ps: PlanState, st: _State) -> None:
        if self.desc is None:
            return
        full = full_joint_values(self.desc, st.values)
        for name, v in ps.joints.items():
            j = self.desc.joint(name)
            if j is None or not j.movable:
                continue
            if j.mimic is not None:
                if abs(v - full[name]) > JOINT_TOL:
                    self.add(st.index, "joint", f"mimic joint `{name}` is {v:.6g}; its source "
                             f"`{j.mimic[0]}` makes it {full[name]:.6g}")
                continue
            if name not in self.controllable and abs(v - self.defaults[name]) > JOINT_TOL:
                self.add(st.index, "joint", f"joint `{name}` is not controllable (the scene "
                         f"fixes it at {self.defaults[name]:.6g}) but is {v:.6g}")
            if j.lower is not None and v < j.lower - JOINT_TOL or \
                    j.upper is not None and v > j.upper + JOINT_TOL:
                self.add(st.index, "bounds", f"joint `{name}` = {v:.6g} is outside its limits "
                         f"[{_num(j.lower)}, {_num(j.upper)}]", joint=name, value=v)

    def _check_base(self, st: _State) -> None:
        T, T0 = st.T_root, self.T_base0
        if not self.mobile:
            if _pose_gap(T, T0) > POSE_TOL:
                self.add(st.index, "base", "the robot's base is fixed, but base_pose is "
                         f"{_pose_text(T, T0)} away from the scene's")
            return
        planar = planar_base(T0, T[0, 3], T[1, 3], heading(T))
        if _pose_gap(T, planar) > POSE_TOL:
            self.add(st.index, "base", "base_pose is not a planar move of the scene's base pose "
                     f"(height or tilt differ: {_pose_text(T, planar)})")
        (xlo, xhi), (ylo, yhi) = self.scene.bounds[0], self.scene.bounds[1]
        x, y = T[0, 3], T[1, 3]
        tol = JOINT_TOL
        if not (xlo - tol <= x <= xhi + tol and ylo - tol <= y <= yhi + tol):
            self.add(st.index, "bounds", f"the base at ({x:.4g}, {y:.4g}) is outside the scene's "
                     f"bounds x [{xlo:g}, {xhi:g}], y [{ylo:g}, {yhi:g}]")

    def _check_objects(self, st: _State, prev: _State | None) -> None:
        """Held objects (since the previous state) where their parent carries them; every other
        object where it was (objects grasped or released keep their pose)."""
        if prev is None:
            return
        after = self._after_action(prev, st) if prev.action is not None and \
            self.convention != "tmpc" else None
        for o in self.scene.objects:
            T = st.objects[o.name]
            parent = st.held.get(o.name)
            if after is not None and parent is not None and prev.held.get(o.name) != parent:
                # grasped by the action: carried from where the planner put it
                Fa, Fs = self.frame_T(after, parent), self.frame_T(st, parent)
                want = Fs @ np.linalg.inv(Fa) @ after.objects[o.name]
                if _pose_gap(T, want) > POSE_TOL:
                    self.add(st.index, "held", f"grasped object `{o.name}` is "
                             f"{_pose_text(T, want)} away from where `{parent}` carries it")
            elif parent is not None and prev.held.get(o.name) == parent:
                want = self._carried(st, prev, o.name)
                if want is not None and _pose_gap(T, want) > POSE_TOL:
                    self.add(st.index, "held", f"held object `{o.name}` is "
                             f"{_pose_text(T, want)} away from where `{parent}` carries it")
            elif _pose_gap(T, prev.objects[o.name]) > POSE_TOL:
                what = "static " if not o.movable else ""
                self.add(st.index, "object", f"{what}object `{o.name}` moved "
                         f"{_pose_text(T, prev.objects[o.name])} but is not held")

    def _check_support(self, st: _State, name: str) -> None:
        """A released object should rest on something (W830, an error with --strict): its
        lowest point within SUPPORT_GAP above a surface's support-region floor (or another
        object's top) under its centre, and upright within SUPPORT_TILT."""
        T = st.objects.get(name)
        box = self.checker.object_aabb(name, T) if T is not None else None
        if box is None:
            return
        bottom, centre = box[0][2], T[:3, 3]
        tilt = math.acos(min(1.0, float(np.max(np.abs(T[2, :3])))))
        best = None                              # (gap, support) of the nearest support below
        for o in self.scene.objects:
            if o.name == name or o.name in st.held:
                continue
            floor = self._support_floor(st, o, centre)
            below = None if floor is None else bottom - floor
            if below is not None and below >= -SUPPORT_SINK and (best is None or below < best[0]):
                best = (below, o.name)
        if best is not None and best[0] <= SUPPORT_GAP and tilt <= SUPPORT_TILT:
            return
        where = (f"{best[0] * 100:.1f} cm above `{best[1]}`" if best is not None
                 else "over no support")
        self.warn(st.index, "support", f"released object `{name}` is {where}, tilted "
                  f"{math.degrees(tilt):.1f}° (resting means a gap <= {SUPPORT_GAP * 100:g} cm "
                  f"and a tilt <= {math.degrees(SUPPORT_TILT):g}°)", object=name,
                  gap=None if best is None else round(best[0], 4),
                  support=None if best is None else best[1],
                  tilt=round(math.degrees(tilt), 2))

    def _support_floor(self, st: _State, o, point: np.ndarray) -> float | None:
        """The height ``o`` offers under ``point`` (world): its support region's floor when it
        is a surface and ``point`` is over the region, else its top when ``point`` is over its
        bounds; None when ``point`` is not over it."""
        T = st.objects.get(o.name)
        if T is None:
            return None
        if o.support is not None:
            local = np.linalg.inv(T) @ np.append(point, 1.0)
            lo, hi = o.support.lower, o.support.upper
            if lo[0] <= local[0] <= hi[0] and lo[1] <= local[1] <= hi[1]:
                return float((T @ np.array([local[0], local[1], lo[2], 1.0]))[2])
        box = self.checker.object_aabb(o.name, T)
        if box is not None and np.all(box[0][:2] <= point[:2]) and np.all(point[:2] <= box[1][:2]):
            return float(box[1][2])
        return None

    def _moved(self, prev: _State, st: _State) -> list[str]:
        """The coordinates that differ between two states (``base_pose`` first)."""
        moved = [n for n in sorted(set(prev.values) | set(st.values))
                 if abs(joint_delta(self.desc, n, st.values.get(n, 0.0),
                                    prev.values.get(n, 0.0))) > JOINT_TOL]
        if _pose_gap(prev.T_root, st.T_root) > POSE_TOL:
            moved.insert(0, "base_pose")
        return moved

    def _after_action(self, prev: _State, st: _State) -> _State:
        """The state right after ``prev``'s action in a legacy plan: ``prev``'s configuration in
        ``st``'s mode. An object the action grasps is where the planner put it: tmit-star snaps
        it onto the frame (its mode_atlas.cc sets the grasp to the identity), planet keeps its
        world pose; a released one stays where it was."""
        got = self._legacy.get("after")
        if got is not None and got[0] == prev.index:
            return got[1]
        objects = dict(prev.objects)
        if self.convention == "tmit-star":
            for o, parent in st.held.items():
                F, Fs = self.frame_T(prev, parent), self.frame_T(st, parent)
                if prev.held.get(o) == parent or F is None or Fs is None:
                    continue
                # a plan that kept the grasp (tmpc's --legacy-output tmit-star) is read as such
                kept = Fs @ np.linalg.inv(F) @ prev.objects[o]
                if _pose_gap(st.objects[o], kept) > POSE_TOL:
                    self._legacy["snaps"].append(
                        float(np.linalg.norm(F[:3, 3] - prev.objects[o][:3, 3])))
                    objects[o] = F
        after = _State(prev.index, prev.values, prev.T_root, prev.link_T, objects, st.facts,
                       st.held)
        self._legacy["after"] = (prev.index, after)
        return after

    def _convention_note(self) -> str:
        snaps = self._legacy["snaps"]
        note = (f"read with {self.convention}'s conventions: an action is on the state where it "
                "is executed and the next state may be elsewhere in the new mode (checked as a "
                f"motion from the action's configuration: {self._legacy['motions']} such)")
        if self.convention == "tmit-star":
            note += ("; continuous joints move linearly in value; a grasped object snaps onto "
                     f"the gripper frame ({len(snaps)} grasps"
                     + (f", up to {max(snaps):.3f} m" if snaps else "") + ")")
        return note

    def _check_unchanged(self, prev: _State, st: _State) -> None:
        moved = self._moved(prev, st)
        if moved:
            self.add(prev.index, "configuration", f"the configuration changes across action "
                     f"{_action_text(prev.action)} ({', '.join(moved[:4])}"
                     f"{', ...' if len(moved) > 4 else ''})", to=st.index)

    def _check_motion(self, a: _State, b: _State) -> int:
        """Collision-check the straight motion a -> b; returns the configurations checked."""
        m = straight_motion(self.desc, self.mobile, a.values, a.T_root, b.values, b.T_root,
                            short_way=self.convention != "tmit-star")
        n = int(math.ceil(m.span / self.resolution - 1e-12))
        if n <= 1:
            return 0
        carried = {o: np.linalg.inv(self.frame_T(a, p)) @ a.objects[o]
                   for o, p in a.held.items() if self.frame_T(a, p) is not None}
        for k in range(1, n):
            t = k / n
            vals, T_root = m.at(t)
            mid = _State(-1, vals, T_root, self.link_poses(T_root, vals), dict(a.objects),
                         a.facts, a.held)
            for o in _held_order(a.held):
                if o in carried:
                    mid.objects[o] = self.frame_T(mid, a.held[o]) @ carried[o]
            if self.checker.collisions(mid.link_T, mid.objects, a.held, first_only=True):
                pairs = self.checker.collisions(mid.link_T, mid.objects, a.held)
                a_, b_, dep = pairs[0]
                more = f" (and {len(pairs) - 1} more pair{'s' if len(pairs) > 2 else ''})" \
                    if len(pairs) > 1 else ""
                self.add(a.index, "motion", f"{a_} collides with {b_} at t={t:.2f} (penetration "
                         f"{dep:.4f} m){more}", to=b.index, t=t,
                         pairs=[[x, y, dd] for x, y, dd in pairs])
                return k
        return n - 1

    # ---- actions, preconditions, goal -----------------------------------------------------------
    def _bound(self, st: _State):
        b = self.logic.bind(*st.action)
        return None if isinstance(b, str) else b

    def _check_action(self, st: _State) -> None:
        b = self.logic.bind(*st.action)
        if isinstance(b, str):
            self.add(st.index, "action", f"action {_action_text(st.action)}: {b}")
            return
        act, env = b
        geo = self._geo_fn(st)
        facts = self.logic.closure(st.facts, geo)
        for why in self.logic.failures(act.precondition, env, facts, geo):
            self.add(st.index, "precondition", f"precondition {why} "
                     f"(action {_action_text(st.action)})")

    def _check_goal(self, last: _State) -> None:
        goal = self.logic.goal()
        geo = self._geo_fn(last)
        facts = self.logic.closure(last.facts, geo)
        for why in self.logic.failures(goal, {}, facts, geo):
            self.add(last.index, "goal", f"goal {why} at the last state (state {last.index})")

    def _geo_fn(self, st: _State):
        def geo(decl, args):
            key = (decl.name.key, args)
            if key not in st._geo:
                st._geo[key] = self._geometric(st, decl, args)
            return st._geo[key]
        return geo

    def _geometric(self, st: _State, decl, args) -> tuple[bool, float]:
        names = [self.logic.name(a) for a in args]
        truth, dist, problem = self.predicates.evaluate(st, decl, names)
        if problem is not None:
            self.add(st.index, "precondition", problem)
        return truth, dist


# ---------------------------------------------------------------------------------------------
# helpers


def default_tolerance(world) -> float:
    """The run configuration's default penetration tolerance (the planner's too):
    :func:`tmpc.lang.world.collision_tolerance`."""
    return collision_tolerance(world.config)


def _pose(p) -> np.ndarray:
    return pose_matrix(p.translation, p.rotation)


def _pose_gap(A: np.ndarray, B: np.ndarray) -> float:
    """max(translation distance, rotation angle) between two poses."""
    dt = float(np.linalg.norm(A[:3, 3] - B[:3, 3]))
    fro = float(np.linalg.norm(A[:3, :3] - B[:3, :3]))
    return max(dt, 2 * math.asin(min(1.0, fro / (2 * math.sqrt(2)))))


def _pose_text(A: np.ndarray, B: np.ndarray) -> str:
    dt = float(np.linalg.norm(A[:3, 3] - B[:3, 3]))
    fro = float(np.linalg.norm(A[:3, :3] - B[:3, :3]))
    ang = 2 * math.asin(min(1.0, fro / (2 * math.sqrt(2))))
    return f"{dt:.4g} m" + (f", {math.degrees(ang):.3g} deg" if ang > POSE_TOL else "")


def _held_order(held: dict[str, str]) -> list[str]:
    """Held objects, parents before the objects linked to them."""
    out: list[str] = []

    def visit(o, depth=0):
        if o in out or depth > len(held):
            return
        if held.get(o) in held:
            visit(held[o], depth + 1)
        out.append(o)
    for o in held:
        visit(o)
    return out


def _order(v: Violation) -> tuple:
    """Report order: plan-wide first, then by state (a motion after its first state's own
    violations), the goal last; stable otherwise."""
    if v.state is None:
        return (0, 0, 0)
    if v.kind == "goal":
        return (2, 0, 0)
    return (1, v.state, 0 if v.to is None else 1)


def _norm_action(a):
    return None if a is None else (a[0].lower(), tuple(x.lower() for x in a[1]))


def _num(v) -> str:
    return "-inf" if v is None else f"{v:.6g}"


def _action_text(action) -> str:
    return "(" + " ".join((action[0],) + tuple(action[1])) + ")"


def _dict_text(d: dict) -> str:
    return "{" + ", ".join(f"{k}: {v}" for k, v in sorted(d.items())) + "}"


# ---------------------------------------------------------------------------------------------
# the command


def validate_plan(world, plan: Plan | str, tolerance: float | None = None,
                  resolution: float = 0.05, convention: str = "auto",
                  strict: bool = False) -> Report:
    """Validate ``plan`` (a :class:`Plan` or a path) in ``world``; see the module docstring.
    ``strict``: warnings (a released object that does not rest, W830) are violations."""
    _check_world(world)
    check_numbers(tolerance, resolution)
    if not isinstance(plan, Plan):
        plan = read_plan(plan)
    return Validator(world, tolerance, resolution, convention, strict).validate(plan)


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


__all__ = ["Validator", "Report", "Violation", "validate_plan", "check_numbers",
           "default_tolerance"]
