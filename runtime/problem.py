"""A task-and-motion problem ready for the planners: the world, its ground symbolic problem, the
compiled kernels and the collision checker, with the operations every TMP planner needs.

* **Modes** (thesis ch. 2 §2.3): a symbolic state (an ``int`` bitset of the ground problem) plus
  a *pose set*: where the free objects are and which robot frame holds which object (with the
  grasp transform). :meth:`PlanningProblem.successor_mode` applies an action at a configuration:
  discrete effects by the ground problem, kinematic ``link``/``unlink`` effects by forward
  kinematics at that configuration (an object keeps its world pose when grasped or released).
* **Projection** onto an action's geometric precondition (or the goal's), in a mode, from a batch
  of start configurations, with the compiler's projection sampler; one jitted projector per action
  schema (arguments are bound at call time, so nothing recompiles per ground action).
* **Validity**: collision checks of states and straight motions in a mode (held objects move with
  their frame; objects are checked against the robot and against each other).

The checks of *why* a problem cannot be planned — a start in collision, an object in the PDDL but
not in the scene, a symbolic goal unreachable even in the delete relaxation — raise clear errors
(E820–E829) before any sampling.
"""

from __future__ import annotations

import collections
import threading
import time
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from tmpc.compiler.compile import compile_world
from tmpc.compiler.ground import SYMBOL, geo_atoms, is_symbol
from tmpc.compiler.kernels import state_inputs
from tmpc.compiler.robot import Frames
from tmpc.compiler.state import WorldState, grasp, initial_state, release
from tmpc.lang.diagnostics import InputError, error
from tmpc.lang.world import collision_tolerance
from tmpc.runtime.collision import CHUNK, PAD_SIZES, FloorMap, collision_world, prepare_kernel
from tmpc.runtime.evaluate import Evaluator, Obj
from tmpc.runtime.explain import Evidence
from tmpc.runtime.setup_checks import SetupChecks
from tmpc.runtime.start_atoms import settled_placements

#: projection starts per call (a fixed batch shape: the projector compiles once per schema)
PROJECTION_BATCH = 16


@dataclass(eq=False)
class Mode:
    """A mode: symbolic state ``sym`` and pose set; ``parent``/``action`` record how it was
    first reached (None for the initial mode)."""

    id: int
    sym: int
    poses: dict[str, np.ndarray]
    held: dict[str, tuple[str, np.ndarray]]
    parent: int | None = None
    action: object | None = None
    obj_T: np.ndarray | None = field(default=None, repr=False)
    obj_parent: np.ndarray | None = field(default=None, repr=False)


@dataclass
class Timers:
    """Seconds spent per activity (the time split `tmpc run -v` and `tmpc bench` report)."""

    projection: float = 0.0
    collision: float = 0.0
    heuristic: float = 0.0
    sampling: float = 0.0
    compile: float = 0.0
    task_planning: float = 0.0
    search: float = 0.0

    def as_dict(self) -> dict:
        return {k: round(v, 4) for k, v in vars(self).items()}


def batch_shapes(compiled) -> None:
    """The batch sizes planning calls kernels with, for the bank to export concretely: the
    projection batch of every action schema's and the goal's projector. Called before exporting
    (``tmpc compile``, the run cache) and by every problem, so a run from an artifact calls the
    concrete kernels. (The collision checker's kinematics is a compiled loop of its own,
    :mod:`tmpc.runtime.collision.kinematics`, not an exported kernel.)"""
    if compiled.model is None or compiled.program is None:
        return
    for act in compiled.program.domain.actions:
        compiled.projector(compiled.action(act.name.text)).specialize((PROJECTION_BATCH,))
    if compiled.program.problem is not None and compiled.goal is not None:
        compiled.projector(compiled.goal).specialize((PROJECTION_BATCH,))


def register_run_kernels(world, compiled) -> None:
    """``build_artifact``'s ``register``: what a run needs beyond the compiler's own list."""
    batch_shapes(compiled)


class KernelLoads:
    """Calls (kernel loads) run by one background thread and, from :meth:`finish` on, by the
    calling thread as well: each call runs once, on whichever thread takes it first."""

    def __init__(self, calls: list) -> None:
        self._todo = collections.deque()
        self._total, self._finished, self._errors = 0, 0, []
        self._cv = threading.Condition()
        self._working = False              # is the background thread taking calls?
        self.add(calls)

    def __len__(self) -> int:
        return self._total

    def add(self, calls) -> None:
        """More calls, after those given before; the background thread (again, if it had run
        out of calls) takes them, one at a time as ever."""
        with self._cv:
            self._todo.extend(calls)
            self._total += len(calls)
            start = bool(self._todo) and not self._working
            if start:
                self._working = True
        if start:
            threading.Thread(target=self._work, name="tmpc-warm-up", daemon=True).start()

    def _take(self, worker: bool = False):
        with self._cv:
            if self._todo:
                return self._todo.popleft()
            if worker:
                self._working = False      # under the lock: add() starts a new thread
            return None

    def _run(self, call) -> None:
        try:
            call()
        except BaseException as exc:       # noqa: BLE001 - raised again by finish()
            with self._cv:
                self._errors.append(exc)
        finally:
            with self._cv:
                self._finished += 1
                self._cv.notify_all()

    def _work(self) -> None:
        while (call := self._take(worker=True)) is not None:
            self._run(call)

    def finish(self, progress=None) -> None:
        """Run the calls not yet taken here, wait for the rest; raise the first error.
        ``progress(k)`` hears the number finished."""
        while (call := self._take()) is not None:
            if progress is not None:
                progress(self._finished)
            self._run(call)
        with self._cv:
            while self._finished < self._total:
                if progress is not None:
                    progress(self._finished)
                self._cv.wait()
            if self._errors:
                raise self._errors[0]


class PlanningProblem:
    """Everything a TMP planner needs about one problem (see the module docstring)."""

    def __init__(self, world, tolerance: float | None = None, iterations: int = 15,
                 warm_rng: np.random.Generator | None = None):
        """``warm_rng``: begin :meth:`start_warm_up`'s kernel loads with it as soon as the
        kernels exist, before the collision world is built (a run's setup: the loads, which
        mostly wait on XLA, overlap that work and the planner's making)."""
        if world.program is None or world.program.problem is None:
            raise InputError(error("E820", "`tmpc run` needs a domain and a problem: give a run "
                                   "configuration (manifest TOML, planet TOML, tmit-star spec)",
                                   None))
        self.compiled = compile_world(world)
        if self.compiled.model is None:
            raise InputError(error("E821", "the scene has no robot to plan for", None))
        batch_shapes(self.compiled)
        self.world = world
        self.model = self.compiled.model
        self.timers = Timers()
        self.iterations = iterations
        self.ground = self.compiled.ground
        self.setup_checks = SetupChecks(world, self.ground, self.model)
        self._check_objects()
        self.tolerance = collision_tolerance(world.config) if tolerance is None else tolerance
        s0 = initial_state(world.scene, self.model)
        self.ground = self.with_start_symbols(self.ground, s0)
        self.q0 = np.asarray(s0.q, float)
        self.initial = self.make_mode(0, self.ground.init, s0.poses, s0.held)
        #: what planning tried, for "why no plan" (:func:`tmpc.runtime.explain.explain`)
        self.evidence = Evidence()
        self.evidence.reached(self.ground.init)
        self.lower, self.upper = np.asarray(self.model.lower), np.asarray(self.model.upper)
        #: a mobile base's reachable floor, ``(xlo, xhi, ylo, yhi)`` (None: all the bounds);
        #: the base's bounds are narrowed to it (:meth:`narrow_to_floor`)
        self.floor: tuple[float, float, float, float] | None = None
        #: its grid, made once (:class:`tmpc.runtime.collision.floor.FloorMap`; a replan looks
        #: its start's region up)
        self.floor_map: FloorMap | None = None
        self.wraps = np.asarray(self.model.wraps, bool)
        self._wrap_columns = np.flatnonzero(self.wraps)
        self._projectors: dict[str, tuple] = {}
        self._raw_projectors: dict[str, object] = {}
        self._goal = None
        #: where setup time went (filled by :func:`tmpc.runtime.solve.plan_problem`)
        self.setup: dict = {}
        self._warming: KernelLoads | None = None    # the warm-up's kernel loads, once begun
        #: how the collision first pass runs (:meth:`warm_up` says), None before / without one
        self.collision_pass: str | None = None
        if warm_rng is not None:
            self.start_warm_up(warm_rng)
        t = time.perf_counter()
        self.collision = collision_world(world, self.compiled, self.tolerance)
        self.narrow_to_floor()
        self.timers.compile += time.perf_counter() - t

    def restart(self, state: WorldState | None = None, sym: int | None = None) -> None:
        """Plan again from ``state`` (None: the scene's start) with the symbolic state ``sym``
        (derived atoms recomputed; None: the problem's initial one), keeping the kernels, the
        projectors and the collision world; the evidence and timers start afresh."""
        base = self.compiled.ground
        if state is None:
            state = initial_state(self.world.scene, self.model)
        self.ground = self.with_start_symbols(base, state) if sym is None else base.with_init(sym)
        self.q0 = np.asarray(state.q, float)
        self.initial = self.make_mode(0, self.ground.init, dict(state.poses), dict(state.held))
        self.evidence = Evidence()
        self.evidence.reached(self.ground.init)
        self.timers = Timers()
        self.narrow_to_floor()

    def narrow_to_floor(self) -> None:
        """A mobile base's x and y bounds narrowed to the floor it can reach from
        :attr:`q0` (:class:`tmpc.runtime.collision.floor.FloorMap`, made once: inside a wall
        around the scene); the model's bounds where nothing encloses it, and for a fixed base.
        Projections whose base lands off that floor do not hold (:meth:`project_raw`)."""
        if self.floor_map is None and self.model.mobile_base:     # once: a replan looks up
            self.floor_map = FloorMap(self.collision, self.model.lower, self.model.upper)
        self.floor = None if self.floor_map is None else self.floor_map.bounds(self.q0)
        lower, upper = np.array(self.model.lower, float), np.array(self.model.upper, float)
        if self.floor is not None:           # within the model's bounds (FloorMap.boxes)
            lower[:2] = self.floor[0], self.floor[2]
            upper[:2] = self.floor[1], self.floor[3]
        self.lower, self.upper = lower, upper

    def with_start_symbols(self, ground, state: WorldState):
        """``ground`` with its geometric symbols true where they hold at ``state``'s object
        poses (:func:`true_symbols`)."""
        bits = true_symbols(ground, self.world.scene, self.model, self.world.program.scope,
                            state.poses)
        init = ground.init | bits
        for s in self.settled:
            i, j = ground.atom_id(s.old[0], *s.old[1]), ground.atom_id(s.new[0], *s.new[1])
            if i is not None and j is not None:
                init = init & ~(1 << i) | (1 << j)
        return ground.with_init(init) if init != ground.init else ground

    @cached_property
    def settled(self) -> list:
        """The file's `:init` placement atoms the scene replaces where plans start
        (:func:`~tmpc.runtime.start_atoms.settled_placements`)."""
        return settled_placements(self.world)

    # ---- checks before planning ----------------------------------------------------------------
    def _check_objects(self) -> None:
        """The setup errors that need no collision world (:mod:`tmpc.runtime.setup_checks`):
        unknown objects (E822), missing support regions (E581), static objects held (E566)."""
        self._setup_error(self.setup_checks.objects() + self.setup_checks.support_regions()
                          + self.setup_checks.static_holds())

    def _setup_error(self, diagnostics) -> None:
        if diagnostics:
            raise InputError(diagnostics, self.world.files)

    def check_start(self) -> None:
        """The start must be within the joint limits (E829, before any collision check: a
        joint at 99 rad is not "in collision") and collision-free; name the colliding pairs
        otherwise (E823)."""
        self._setup_error(self.setup_checks.start_limits(self.q0))
        self._setup_error(self.setup_checks.start_collisions(
            self.collision, self.q0, self.initial.poses, self.initial.held, self.tolerance))

    def check_goal_reachable(self) -> None:
        self._setup_error(self.setup_checks.goal() + self.setup_checks.fixed_goal_atoms())

    def start_warm_up(self, rng: np.random.Generator, also=()) -> None:
        """Begin :meth:`warm_up`'s projector calls on a background thread: loading a kernel is
        mostly XLA reading its executable, which releases the GIL, so it overlaps the start
        checks and the collision warm-up on this thread, and :meth:`warm_up` then takes the
        projectors not yet begun on this thread too (:class:`KernelLoads`). Never more than two
        executables load at once: three at once set the run's peak memory. This thread takes
        projectors too rather than waiting for the background thread alone, which shortens
        setup for a little more peak memory. ``also``: more
        calls, after the projectors (a planner's own set-up, ``warm_up_calls``); given once the
        loads have begun, they follow them."""
        if self._warming is not None:
            self._warming.add(list(also))
            return
        prepare_kernel()   # a machine's first run: the collision kernels build meanwhile
        starts = self.uniform(rng, PROJECTION_BATCH)
        mode = self.initial
        calls, kernels = [], set()
        for action in {a.schema: a for a in self.ground.actions
                       if self.has_geometry(a)}.values():
            formula, proj, _ = self.projector(action.schema)
            # schemas whose projectors are the same kernel share its executable: one load
            same = self._raw_projectors[formula.key].exported(PROJECTION_BATCH)
            if same is not None and same in kernels:
                continue
            kernels.add(same)
            calls.append((proj, self.compiled.bind_args(formula, list(action.args))))
        if self.goal_formula() is not None:
            calls.append((self.goal_formula()[1], np.zeros(0, np.int64)))
        loads = [lambda f=f, a=a: np.asarray(f(starts, mode.obj_T, mode.obj_parent, a)[0])
                 for f, a in calls]
        self._warming = KernelLoads(loads + list(also))

    def warm_up(self, rng: np.random.Generator, progress=None) -> float:
        """Load (or, without an artifact, trace and compile) what planning will call, so planning
        time is planning: every action schema's projector at the projection batch shape, the
        goal's, and the collision checker's compiled kernels. Returns the seconds spent here,
        waiting included (also in ``compile``). ``progress(phase, done, total, detail)`` hears
        how many of the calls are done."""
        t = time.perf_counter()
        self.start_warm_up(rng)
        mode = self.initial
        first_pass = self.collision.first_pass()
        total = 1 + len(self._warming) + (first_pass is not None)
        done = 0
        if first_pass is not None:
            if progress is not None:       # built on a machine's first run (aot)
                progress("loading kernels", done, total, "collision pass")
            why = first_pass.load_kernel()
            self.collision_pass = "built ahead of time" if why is None else \
                f"numba's JIT ({why})"
            done += 1
        if progress is not None:
            progress("loading kernels", done, total, "collision checks")
        self.collision.check_batch(np.repeat(self.q0[None], PAD_SIZES[0], 0),
                                   poses=mode.poses, attached=mode.held)
        done += 1
        self._warming.finish(None if progress is None else lambda k: progress(
            "loading kernels", done + k, total, "projectors"))
        spent = time.perf_counter() - t
        self.timers.compile += spent
        return spent

    def frames_of(self, Q: np.ndarray) -> list[Frames]:
        """Forward kinematics (numpy :class:`Frames`) of states Q (B, n), through the collision
        checker's (no kernel of its own to load)."""
        out = []
        for start in range(0, len(Q), CHUNK):
            chunk = np.asarray(Q[start:start + CHUNK], float)
            R, p = self.collision.kinematics(chunk)
            out += [Frames(R[..., i], p[..., i]) for i in range(len(chunk))]
        return out

    # ---- modes -----------------------------------------------------------------------------------
    def make_mode(self, mode_id: int, sym: int, poses, held, parent=None, action=None) -> Mode:
        _, obj_T, obj_parent = state_inputs(self.compiled.tables,
                                            WorldState(self.q0, poses, held))
        return Mode(mode_id, sym, poses, held, parent, action, obj_T, obj_parent)

    def successor_mode(self, mode: Mode, action, q: np.ndarray, mode_id: int) -> Mode:
        """The mode after ``action`` at configuration ``q`` in ``mode``."""
        geo = self.geo_oracle(mode, q) if _needs_geo(action) else None
        sym = self.ground.apply(mode.sym, action, geo)
        state = WorldState(q, dict(mode.poses), dict(mode.held))
        effects = self.ground.kinematic_effects(mode.sym, action, geo)
        if effects:
            frames = self.frames_of(np.asarray(q, float)[None])[0]
            for eff in effects:
                if eff.op == "link":
                    state = grasp(state, self.model, eff.parent, eff.child, frames)
                elif eff.child in state.held:
                    state = release(state, self.model, eff.child, frames)
        self.evidence.reached(sym, action)
        return self.make_mode(mode_id, sym, state.poses, state.held, mode.id, action)

    # ---- geometry --------------------------------------------------------------------------------
    def projector(self, schema: str):
        """(formula, jitted projector, truth kernel) of an action schema's geometric condition."""
        if schema not in self._projectors:
            t = time.perf_counter()
            formula = self.compiled.action(schema)
            kernel, _ = self.compiled.kernels(formula)
            raw = self._raw_projectors[formula.key] = self.compiled.projector(formula)
            proj = self._iterated(raw)
            self._projectors[schema] = (formula, proj, kernel)
            self.timers.compile += time.perf_counter() - t
        return self._projectors[schema]

    def goal_formula(self):
        """(formula, projector, kernel) of the goal's geometric literals, None if it has none."""
        if self._goal is None:
            formula = self.compiled.goal
            if formula is None:
                self._goal = (None,)
            else:
                kernel, _ = self.compiled.kernels(formula)
                raw = self._raw_projectors[formula.key] = self.compiled.projector(formula)
                self._goal = (formula, self._iterated(raw), kernel)
        return None if self._goal[0] is None else self._goal

    def _iterated(self, project):
        """``project`` with the planner's iteration count bound."""
        n = np.int64(self.iterations)
        return lambda Q0, T, par, args: project(Q0, T, par, args, n)

    def has_geometry(self, action) -> bool:
        """Does ``action``'s precondition have geometric literals the projector must satisfy?"""
        if action.pre_geometric:
            return True
        return action.pre.extra is not None and _has_geo(action.pre.extra)

    def project(self, mode: Mode, action, starts: np.ndarray) -> np.ndarray:
        """Configurations (k, n) from ``starts`` where ``action``'s geometric precondition (the
        goal's, for ``action=None``) holds in ``mode`` and that are collision-free."""
        if action is None and self.goal_formula() is None:
            return starts[:1]
        Q, holds, _ = self.project_raw(mode, action, starts)
        Q = Q[holds]
        if not len(Q):
            return Q
        return Q[self.valid_batch(mode, Q)]

    def project_raw(self, mode: Mode, action, starts: np.ndarray,
                    iterations: int | None = None):
        """The projector of ``action``'s geometric precondition (the goal's for None) from
        ``starts`` (B, n) in ``mode``, any B (calls of PROJECTION_BATCH starts, the last one
        padded): ``(Q, holds, distance)`` after ``iterations`` steps (default the problem's;
        0: the distance at the starts themselves, one batched kernel call per 16 states)."""
        if action is None:
            formula, proj, _ = self.goal_formula()
            args = np.zeros(0, np.int64)
        else:
            formula, proj, _ = self.projector(action.schema)
            args = self.compiled.bind_args(formula, list(action.args))
        raw = self._raw_projectors[formula.key]
        n = np.int64(self.iterations if iterations is None else iterations)
        starts = np.asarray(starts, float)
        t = time.perf_counter()
        out = [[], [], []]
        for lo in range(0, len(starts), PROJECTION_BATCH):
            chunk = starts[lo:lo + PROJECTION_BATCH]
            pad = np.concatenate([chunk, np.repeat(chunk[-1:], PROJECTION_BATCH - len(chunk), 0)])
            Q, holds, d = raw(pad, mode.obj_T, mode.obj_parent, args, n)
            for acc, x in zip(out, (Q, holds, d)):
                acc.append(np.asarray(x)[:len(chunk)])
        self.timers.projection += time.perf_counter() - t
        if not out[0]:
            return (np.zeros((0, len(self.lower))), np.zeros(0, bool), np.zeros(0))
        result = tuple(np.concatenate(acc) for acc in out)
        if self.floor is not None:           # a base off its floor: no motion gets there
            xlo, xhi, ylo, yhi = self.floor
            Q = result[0]
            result[1][(Q[:, 0] < xlo) | (Q[:, 0] > xhi) | (Q[:, 1] < ylo) | (Q[:, 1] > yhi)] \
                = False
        if iterations != 0:
            self.evidence.projected(mode, action, *result)
        return result

    def distances(self, mode: Mode, action, Q: np.ndarray) -> np.ndarray:
        """The unsatisfaction distance (B,) of ``action``'s geometric precondition (the goal's
        for None) at states Q (B, n) in ``mode``: 0 where it holds; 0 everywhere for an action
        (or a goal) without geometric literals."""
        if (action is None and self.goal_formula() is None) or \
                (action is not None and not self.has_geometry(action)):
            return np.zeros(len(Q))
        return self.project_raw(mode, action, Q, iterations=0)[2]

    def cost(self, Q: np.ndarray, q: np.ndarray) -> np.ndarray:
        """tmit-star's composite path length of the straight motions from ``q`` to each of Q
        (B, n): L2 over the joints + the base's planar distance + its yaw the short way round
        (``../shared/baselines/tmit-star/cost.py``; continuous joints the short way, as tmpc's
        motions interpolate them)."""
        d = self.difference(Q, q)
        if not self.model.mobile_base:
            return _norm(d)
        return _norm(d[..., 3:]) + _norm(d[..., :2]) + np.abs(d[..., 2])

    def cost_subgradient(self, q: np.ndarray, a: np.ndarray) -> np.ndarray:
        """A subgradient in ``q`` of :meth:`cost` (q, a): each of its norms' unit vector (0
        where that part of the motion is 0)."""
        d = self.difference(q, a)

        def unit(x):
            n = np.linalg.norm(x)
            return x / n if n > 1e-12 else np.zeros_like(x)
        if not self.model.mobile_base:
            return unit(d)
        return np.concatenate([unit(d[:2]), np.sign(d[2:3]), unit(d[3:])])

    def holds(self, mode: Mode, action, q: np.ndarray) -> bool:
        """Does ``action``'s geometric precondition (the goal's for None) hold at ``q``?"""
        if action is None:
            goal = self.goal_formula()
            if goal is None:
                return True
            kernel, args = goal[2], np.zeros(0, np.int64)
        else:
            formula, _, kernel = self.projector(action.schema)
            args = self.compiled.bind_args(formula, list(action.args))
        truth, _ = kernel(q, mode.obj_T, mode.obj_parent, args)
        return bool(truth)

    def geo_oracle(self, mode: Mode, q: np.ndarray):
        """``geo(predicate, args) -> bool`` at ``q`` in ``mode`` (for conditional effects and
        derived predicates over geometry)."""
        def geo(pred: str, args: tuple[str, ...]) -> bool:
            formula = self.compiled.predicate(pred)
            kernel, _ = self.compiled.kernels(formula)
            ids = self.compiled.bind_args(formula, list(args))
            return bool(kernel(q, mode.obj_T, mode.obj_parent, ids)[0])
        return geo

    def valid_batch(self, mode: Mode, Q: np.ndarray) -> np.ndarray:
        t = time.perf_counter()
        ok = np.asarray(self.collision.check_batch(Q, poses=mode.poses, attached=mode.held))
        self.timers.collision += time.perf_counter() - t
        return ok

    def motion(self, mode: Mode, q0: np.ndarray, q1: np.ndarray, resolution: float):
        """Fraction of the straight motion q0 -> q1 that is valid: 1.0 when all of it is, else
        the parameter of the last valid state before the first collision (0.0: none)."""
        t = time.perf_counter()
        rep = self.collision.check_motion(q0, q1, resolution, poses=mode.poses,
                                          attached=mode.held, details=False)
        self.timers.collision += time.perf_counter() - t
        if rep.valid:
            return 1.0
        return max(0.0, rep.t_first_collision - 1.0 / max(rep.steps, 1))

    def motions_valid(self, mode: Mode, Q0: np.ndarray, Q1: np.ndarray, resolution: float,
                      ends: bool = False) -> np.ndarray:
        """Validity (k,) of the straight motions Q0[i] -> Q1[i] in ``mode``, all their states
        in one batched check (:meth:`~tmpc.runtime.collision.world.CollisionWorld.check_segments`:
        the first pass over all of them at once; exact fcl stops confirming a motion at its
        first colliding state, middle first). ``ends``: check the end states too (else they
        are known valid)."""
        return self.motions_valid_many([(mode, Q0, Q1)], resolution, ends)[0]

    def motions_valid_many(self, items, resolution: float, ends: bool = False
                           ) -> list[np.ndarray]:
        """:meth:`motions_valid` of several ``(mode, Q0, Q1)``: every state of every mode in
        one batched check, the kinematics shared (a search's lookahead spans a few modes)."""
        groups = []
        for mode, Q0, Q1 in items:
            Q, lens = self.collision.interpolate_many(np.reshape(Q0, (-1, len(self.lower))),
                                                      np.reshape(Q1, (-1, len(self.lower))),
                                                      resolution, ends)
            groups.append((Q, mode.poses, mode.held, lens))
        t = time.perf_counter()
        out = self.collision.check_segments(groups)
        self.timers.collision += time.perf_counter() - t
        return out

    def uniform(self, rng: np.random.Generator, n: int) -> np.ndarray:
        return rng.uniform(self.lower, self.upper, (n, len(self.lower)))

    def difference(self, Q: np.ndarray, q: np.ndarray) -> np.ndarray:
        """``Q - q`` with wrapping coordinates (yaw, continuous joints) the short way round
        (column by column, in place: a boolean-mask copy and scatter took half the time of
        the graph's cost blocks)."""
        d = np.asarray(Q, float) - q
        for j in self._wrap_columns:
            c = d[..., j]
            c += np.pi
            np.remainder(c, 2 * np.pi, out=c)
            c -= np.pi
        return d

    def distance(self, Q: np.ndarray, q: np.ndarray) -> np.ndarray:
        return _norm(self.difference(Q, q))

    def wrap(self, Q: np.ndarray) -> np.ndarray:
        """Wrapping coordinates brought into their bounds."""
        Q = np.array(Q, float)
        w = self.wraps
        Q[..., w] = (Q[..., w] + np.pi) % (2 * np.pi) - np.pi
        return np.clip(Q, self.lower, self.upper)


def _norm(d: np.ndarray) -> np.ndarray:
    """The L2 norm over the last axis (einsum: without ``linalg.norm``'s temporaries)."""
    return np.sqrt(np.einsum("...i,...i->...", d, d))


def _needs_geo(action) -> bool:
    return any(ce.condition is not None and _has_geo(ce.condition) for ce in action.conditional)


def _has_geo(f) -> bool:
    return next(geo_atoms(f), None) is not None


def true_symbols(ground, scene, model, scope, poses: dict[str, np.ndarray]) -> int:
    """The bitset of ``ground``'s geometric symbols (:mod:`tmpc.compiler.ground.symbols`) whose
    atom holds with the free objects at ``poses`` (world 4x4 by name), by this interpreter: no
    kernel is loaded for it. An atom naming an object not in ``poses`` (a held one), or one this
    interpreter cannot evaluate (a Lua predicate, one reading a robot frame), counts as false."""
    out = 0
    ev = Evaluator(scene, model, None, None, poses, scope)
    known = {k.lower() for k in poses}
    for i, atom in enumerate(ground.atoms):
        if not is_symbol(atom.predicate):
            continue
        decl = scope.predicates.get(atom.predicate[:-len(SYMBOL)].lower())
        if decl is None or decl.semantics is None or \
                any(a.lower() not in known for a in atom.args):
            continue
        env = {p.name.key: Obj(a) for p, a in zip(decl.params, atom.args)}
        try:
            if bool(ev.value(decl.semantics, env)):
                out |= 1 << i
        except InputError:
            continue
    return out
