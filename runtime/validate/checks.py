"""The validator's checks of one resolved state, of the motion or action to the next, and of the
goal: the methods :class:`tmpc.runtime.validate.core.Validator` runs state by state (a mixin: the
validator holds the world, kinematics, fcl checker and STRIPS simulator they use)."""

from __future__ import annotations

import math

import numpy as np

from tmpc.runtime.plans import PlanState
from tmpc.runtime.validate.kinematics import (
    full_joint_values,
    heading,
    joint_delta,
    planar_base,
    straight_motion,
)
from tmpc.runtime.validate.report import Report
from tmpc.runtime.validate.state import (
    JOINT_TOL,
    POSE_TOL,
    SUPPORT_EDGE,
    SUPPORT_GAP,
    SUPPORT_SINK,
    SUPPORT_SLACK,
    SUPPORT_TILT,
    ResolvedState,
    action_text,
    held_order,
    num_text,
    pose_gap,
    pose_text,
)


class StateChecks:
    """The checks, mixed into :class:`tmpc.runtime.validate.core.Validator`."""

    # ---- checks ---------------------------------------------------------------------------------
    def _check_state(self, ps: PlanState, st: ResolvedState, prev: ResolvedState | None,
                     rep: Report) -> None:
        if prev is None and self.start == "scene":
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

    def _check_initial(self, ps: PlanState, st: ResolvedState) -> None:
        for name, v in sorted(st.values.items()):
            d0 = self.defaults.get(name)
            if d0 is not None and abs(joint_delta(self.desc, name, v, d0)) > POSE_TOL:
                self.add(0, "initial", f"joint `{name}` is {v:.6g}, the scene starts it at "
                         f"{d0:.6g}")
        if pose_gap(st.T_root, self.T_base0) > POSE_TOL:
            self.add(0, "initial", "base_pose differs from the scene's base pose by "
                     f"{pose_text(st.T_root, self.T_base0)}")
        init = self._initial_objects(st)
        for name, T in st.objects.items():
            if pose_gap(T, init[name]) > POSE_TOL:
                self.add(0, "initial", f"object `{name}` is {pose_text(T, init[name])} away "
                         "from its place in the scene")

    def _check_joints(self, ps: PlanState, st: ResolvedState) -> None:
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
                         f"[{num_text(j.lower)}, {num_text(j.upper)}]", joint=name, value=v)

    def _check_base(self, st: ResolvedState) -> None:
        T, T0 = st.T_root, self.T_base0
        if not self.mobile:
            if pose_gap(T, T0) > POSE_TOL:
                self.add(st.index, "base", "the robot's base is fixed, but base_pose is "
                         f"{pose_text(T, T0)} away from the scene's")
            return
        planar = planar_base(T0, T[0, 3], T[1, 3], heading(T))
        if pose_gap(T, planar) > POSE_TOL:
            self.add(st.index, "base", "base_pose is not a planar move of the scene's base pose "
                     f"(height or tilt differ: {pose_text(T, planar)})")
        (xlo, xhi), (ylo, yhi) = self.scene.bounds[0], self.scene.bounds[1]
        x, y = T[0, 3], T[1, 3]
        tol = JOINT_TOL
        if not (xlo - tol <= x <= xhi + tol and ylo - tol <= y <= yhi + tol):
            self.add(st.index, "bounds", f"the base at ({x:.4g}, {y:.4g}) is outside the scene's "
                     f"bounds x [{xlo:g}, {xhi:g}], y [{ylo:g}, {yhi:g}]")

    def _check_objects(self, st: ResolvedState, prev: ResolvedState | None) -> None:
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
                if pose_gap(T, want) > POSE_TOL:
                    self.add(st.index, "held", f"grasped object `{o.name}` is "
                             f"{pose_text(T, want)} away from where `{parent}` carries it")
            elif parent is not None and prev.held.get(o.name) == parent:
                want = self._carried(st, prev, o.name)
                if want is not None and pose_gap(T, want) > POSE_TOL:
                    self.add(st.index, "held", f"held object `{o.name}` is "
                             f"{pose_text(T, want)} away from where `{parent}` carries it")
            elif pose_gap(T, prev.objects[o.name]) > POSE_TOL:
                what = "static " if not o.movable else ""
                self.add(st.index, "object", f"{what}object `{o.name}` moved "
                         f"{pose_text(T, prev.objects[o.name])} but is not held")

    def _check_support(self, st: ResolvedState, name: str) -> None:
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

    def _support_floor(self, st: ResolvedState, o, point: np.ndarray) -> float | None:
        """The height ``o`` offers under ``point`` (world): its support region's floor when it
        is a surface and ``point`` is over the region, else its top when ``point`` is over its
        bounds; None when ``point`` is not over it."""
        T = st.objects.get(o.name)
        if T is None:
            return None
        if o.support is not None:
            local = np.linalg.inv(T) @ np.append(point, 1.0)
            lo, hi = o.support.lower, o.support.upper
            slack = [SUPPORT_SLACK if hi[i] - lo[i] < 2 * SUPPORT_SLACK else SUPPORT_EDGE
                     for i in (0, 1)]
            if lo[0] - slack[0] <= local[0] <= hi[0] + slack[0] and \
                    lo[1] - slack[1] <= local[1] <= hi[1] + slack[1]:
                return float((T @ np.array([local[0], local[1], lo[2], 1.0]))[2])
        box = self.checker.object_aabb(o.name, T)
        if box is not None and np.all(box[0][:2] <= point[:2]) and np.all(point[:2] <= box[1][:2]):
            return float(box[1][2])
        return None

    def _moved(self, prev: ResolvedState, st: ResolvedState) -> list[str]:
        """The coordinates that differ between two states (``base_pose`` first)."""
        moved = [n for n in sorted(set(prev.values) | set(st.values))
                 if abs(joint_delta(self.desc, n, st.values.get(n, 0.0),
                                    prev.values.get(n, 0.0))) > JOINT_TOL]
        if pose_gap(prev.T_root, st.T_root) > POSE_TOL:
            moved.insert(0, "base_pose")
        return moved

    def _after_action(self, prev: ResolvedState, st: ResolvedState) -> ResolvedState:
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
                if pose_gap(st.objects[o], kept) > POSE_TOL:
                    self._legacy["snaps"].append(
                        float(np.linalg.norm(F[:3, 3] - prev.objects[o][:3, 3])))
                    objects[o] = F
        after = ResolvedState(prev.index, prev.values, prev.T_root, prev.link_T, objects, st.facts,
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

    def _check_unchanged(self, prev: ResolvedState, st: ResolvedState) -> None:
        moved = self._moved(prev, st)
        if moved:
            self.add(prev.index, "configuration", f"the configuration changes across action "
                     f"{action_text(prev.action)} ({', '.join(moved[:4])}"
                     f"{', ...' if len(moved) > 4 else ''})", to=st.index)

    def _check_motion(self, a: ResolvedState, b: ResolvedState) -> int:
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
            mid = ResolvedState(-1, vals, T_root, self.link_poses(T_root, vals), dict(a.objects),
                         a.facts, a.held)
            for o in held_order(a.held):
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
    def _bound(self, st: ResolvedState):
        b = self.logic.bind(*st.action)
        return None if isinstance(b, str) else b

    def _check_action(self, st: ResolvedState) -> None:
        b = self.logic.bind(*st.action)
        if isinstance(b, str):
            self.add(st.index, "action", f"action {action_text(st.action)}: {b}")
            return
        act, env = b
        geo = self._geo_fn(st)
        facts = self.logic.closure(st.facts, geo)
        for why in self.logic.failures(act.precondition, env, facts, geo):
            self.add(st.index, "precondition", f"precondition {why} "
                     f"(action {action_text(st.action)})")

    def _check_goal(self, last: ResolvedState) -> None:
        goal = self.logic.goal()
        geo = self._geo_fn(last)
        facts = self.logic.closure(last.facts, geo)
        for why in self.logic.failures(goal, {}, facts, geo):
            self.add(last.index, "goal", f"goal {why} at the last state (state {last.index})")

    def _geo_fn(self, st: ResolvedState):
        def geo(decl, args):
            key = (decl.name.key, args)
            if key not in st.geo_cache:
                st.geo_cache[key] = self._geometric(st, decl, args)
            return st.geo_cache[key]
        return geo

    def _geometric(self, st: ResolvedState, decl, args) -> tuple[bool, float]:
        names = [self.logic.name(a) for a in args]
        truth, dist, problem = self.predicates.evaluate(st, decl, names)
        if problem is not None:
            self.add(st.index, "precondition", problem)
        return truth, dist


__all__ = ["StateChecks"]
