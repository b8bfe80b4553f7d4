"""Geometric predicates for the validator: inline ``:semantics`` bodies by the numpy AST
interpreter (:mod:`tmpc.runtime.evaluate`), Lua-defined (legacy) ones by calling the Lua function
directly at the state — never the compiled JAX kernels the planner samples with.

A state is given as world poses: robot links from the validator's own kinematics, every object,
the root frame and the joint values (for the interpreter's ``joint`` operator).
"""

from __future__ import annotations

import math

import numpy as np

from tmpc.compiler.lua_trace import LuaFallback
from tmpc.compiler.robot import Frames, robot_model
from tmpc.compiler.rotations import quat_from_matrix
from tmpc.lang.diagnostics import TmpcError
from tmpc.lang.lua import load_lua_predicates, lua_limits
from tmpc.runtime.evaluate import Evaluator, Obj
from tmpc.runtime.validate.kinematics import heading

#: a Lua predicate holds when its distance is at most this (as the compiled kernels decide)
LUA_TOLERANCE = 1e-3


class Predicates:
    """``evaluate(st, decl, names) -> (truth, distance, problem or None)`` at a resolved state
    ``st`` (``link_T``, ``T_root``, ``values``, ``objects``); ``frame_T(st, name)`` gives the
    world pose of a robot frame or an object."""

    def __init__(self, world, link_index: dict[str, int], frame_T):
        self.world, self.scene = world, world.scene
        self.link_index, self.frame_T = link_index, frame_T
        self._module = None
        #: the robot's kinematic structure (configuration and frame names) the evaluator reads;
        #: the link poses themselves come from the validator's own kinematics
        self.model = robot_model(world.scene)
        #: names of the Lua predicates evaluated so far
        self.lua_used: set[str] = set()

    def evaluate(self, st, decl, names: list[str]) -> tuple[bool, float, str | None]:
        if decl.semantics is None:
            return self._lua(st, decl, names)
        ev = self._evaluator(st)
        env = {p.name.key: Obj(n) for p, n in zip(decl.params, names)}
        try:
            truth = bool(ev.value(decl.semantics, env))
            return truth, 0.0 if truth else float(ev.distance(decl.semantics, env)), None
        except TmpcError as exc:
            return False, math.inf, (f"({decl.name.text} {' '.join(names)}) cannot be "
                                     f"evaluated: {exc.diagnostics[0].message}")

    def _evaluator(self, st):
        model = self.model
        if model is None:
            frames, q = None, None
        else:
            T = np.stack([st.link_T[self.link_index[n]] for n in model.frames])
            frames = Frames(T[:, :3, :3], T[:, :3, 3])
            base = {"base_x": st.T_root[0, 3], "base_y": st.T_root[1, 3],
                    "base_yaw": heading(st.T_root)}
            q = np.array([base.get(n, st.values.get(n, 0.0)) for n in model.q_names])
        return Evaluator(self.scene, model, q, frames, st.objects, self.world.program.scope)

    def _lua(self, st, decl, names) -> tuple[bool, float, str | None]:
        """A legacy geometric predicate: its Lua function evaluated directly at the state."""
        cfg = self.world.config
        if self._module is None:
            self._module = (load_lua_predicates(cfg.semantics, limits=lua_limits(cfg))
                            if cfg and cfg.semantics else None,)
        module = self._module[0]
        fn = module.lookup(decl.name.text) if module is not None else None
        if fn is None:
            return False, math.inf, (f"({decl.name.text} {' '.join(names)}) has no semantics: "
                                     "no inline body and no Lua function of that name")
        self.lua_used.add(decl.name.text)
        poses, supports = [], []
        for n in names:
            T = self.frame_T(st, n)
            T = np.eye(4) if T is None else T
            poses.append(list(T[:3, 3]) + quat_from_matrix(T[:3, :3]).tolist())
            o = self.scene.object(n)
            supports.append(None if o is None or o.support is None else
                            (tuple(o.support.lower), tuple(o.support.upper)))
        d, _ = LuaFallback(module, fn, ("object",) * len(names))(np.array(poses), supports,
                                                                 names, gradient=False)
        return d <= LUA_TOLERANCE, float(d), None
