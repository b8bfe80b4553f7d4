"""JAX condition kernels against the independent numpy interpreter, finite differences, and the
NaN-free-gradient requirement at the singular points."""

from __future__ import annotations

import numpy as np
import pytest

from tests.support import EXAMPLES
from tmpc.compiler.compile import compile_world

EXTRA = """
    (fancy ?g - gripper ?c - cube ?s - surface :semantics
      (let ((?p (position ?g)) (?r (support-region ?s)))
        (and (inside ?p (grow ?r 0.05 0.05 0.4))
             (or (<= (distance ?p (position ?c)) 0.3) (not (>= (z ?p) 0.5)))
             (implies (= ?s tray) (<= (abs (- (yaw ?g) (atan2 (y ?c) (x ?c)))) 1.5))
             (<= (norm (cross (z-axis ?g) (vec3 0 0 -1))) (sin 0.8))
             (>= (dot (x-axis ?g) (rotate (orientation ?c) (vec3 1 0 0))) -2)
             (if (= ?s bench) (<= (z (relative ?g ?c)) 1.0) (>= (roll ?g) -4))
             (forall (?o - cube) (or (= ?o ?c) (>= (distance (position ?o) ?p) 0.02)))
             (<= (joint panda_joint1) (max 2.5 (x (extent ?c)))))))
    (touching ?g - gripper ?c - cube :semantics (= (distance (position ?g) (position ?c)) 0))
    (away ?g - gripper ?c - cube :semantics (not (<= (distance (position ?g) (position ?c)) 0.1)))
"""


@pytest.fixture(scope="module")
def tabletop(tmp_path_factory):
    from tmpc.compiler.artifact import open_world
    from tmpc.compiler.kernels import build_tables
    d = tmp_path_factory.mktemp("tt")
    domain = (EXAMPLES / "tabletop" / "domain.pddl").read_text()
    domain = domain.replace("  (:predicates\n", "  (:constants bench tray - surface)\n"
                            "  (:predicates\n" + EXTRA, 1)
    (d / "domain.pddl").write_text(domain)
    problem = (EXAMPLES / "tabletop" / "problem.pddl").read_text()
    (d / "problem.pddl").write_text(problem.replace("    bench tray - surface\n", ""))
    (d / "scene.json").write_text((EXAMPLES / "tabletop" / "scene.json").read_text())
    (d / "t.toml").write_text('[problem]\ndomain = "domain.pddl"\nproblem = "problem.pddl"\n'
                              'scene = "scene.json"\n')
    world = open_world(d / "t.toml")
    return world, build_tables(world.scene, compile_world(world).model, world.program.scope)


CASES = [("reach", ("panda_hand_tcp", "red_cube")), ("over", ("panda_hand_tcp", "tray")),
         ("fancy", ("panda_hand_tcp", "blue_cube", "tray")),
         ("fancy", ("panda_hand_tcp", "red_cube", "bench")),
         ("touching", ("panda_hand_tcp", "red_cube")), ("away", ("panda_hand_tcp", "blue_cube"))]


def _kernel(tabletop, name, and_mode="l2"):
    from tmpc.compiler.jaxcfg import configured
    from tmpc.compiler.kernels import Options, condition_kernel
    from tmpc.compiler.lower import Lowerer
    world, kw = tabletop
    scope = world.program.scope
    low = Lowerer(scope).predicate(scope.predicates[name])
    jax = configured()
    return jax.jit(condition_kernel(low.body, kw, Options(and_mode=and_mode)))


def _states(world, n, seed):
    """Random configurations, with the red cube held by the hand in every other state."""
    from tmpc.compiler.state import grasp, initial_state
    rng = np.random.default_rng(seed)
    st0 = initial_state(world.scene, compile_world(world).model)
    held = grasp(st0, compile_world(world).model, "panda_hand_tcp", "red_cube", compile_world(world).fk(st0.q))
    for i in range(n):
        q = rng.uniform(compile_world(world).model.lower, compile_world(world).model.upper)
        base = held if i % 2 else st0
        yield type(base)(q, base.poses, base.held, base.atoms)


@pytest.mark.parametrize("and_mode", ["l2", "max"])
@pytest.mark.parametrize("name, args", CASES)
def test_kernel_matches_numpy_interpreter(tabletop, name, args, and_mode):
    from tmpc.compiler.kernels import state_inputs
    from tmpc.compiler.state import world_poses
    from tmpc.lang import ast as A
    from tmpc.runtime.evaluate import Evaluator
    world, kw = tabletop
    k = _kernel(tabletop, name, and_mode)
    ids = np.array([kw.entity(a) for a in args])
    call = A.Call(A.Name(name), tuple(A.ExprName(A.Name(a)) for a in args))
    for st in _states(world, 40, 1):
        frames = compile_world(world).fk(st.q)
        ev = Evaluator(world.scene, compile_world(world).model, st.q, frames, world_poses(st, compile_world(world).model, frames),
                       world.program.scope)
        truth, dist = k(*state_inputs(kw, st), ids)
        assert float(dist) == pytest.approx(ev.distance(call, and_mode=and_mode), abs=1e-9)
        assert bool(truth) == ev.value(call)


@pytest.mark.parametrize("name, args", CASES)
def test_gradients_match_finite_differences(tabletop, name, args):
    from tmpc.compiler.jaxcfg import configured
    from tmpc.compiler.kernels import state_inputs
    jax = configured()
    world, kw = tabletop
    k = _kernel(tabletop, name)
    ids = np.array([kw.entity(a) for a in args])
    for st in list(_states(world, 6, 2)):
        q, T, par = state_inputs(kw, st)
        f = jax.jit(lambda q: k(q, T, par, ids)[1])
        g = np.asarray(jax.grad(lambda q: k(q, T, par, ids)[1])(q))
        assert np.isfinite(g).all()
        h = 1e-6
        fd = np.array([(float(f(q + h * e)) - float(f(q - h * e))) / (2 * h)
                       for e in np.eye(len(q))])
        if float(f(q)) > 1e-4:          # away from kinks of max(., 0)
            assert np.allclose(g, fd, atol=1e-5), np.abs(g - fd).max()


def test_gradients_are_finite_at_zero_distance_and_touching_contact(tabletop):
    """At a satisfied state every distance is 0 and sqrt/norm sit at their singular point."""
    from tmpc.compiler.jaxcfg import configured
    from tmpc.compiler.kernels import state_inputs
    from tmpc.compiler.state import initial_state
    jax = configured()
    world, kw = tabletop
    st = initial_state(world.scene, compile_world(world).model)
    q, T, par = state_inputs(kw, st)
    hand = np.asarray(compile_world(world).fk(q).p[compile_world(world).model.frame("panda_hand_tcp")])
    T = T.copy()
    T[[o.name for o in world.scene.objects].index("red_cube"), :3, 3] = hand   # exact contact
    for name, args in [("touching", ("panda_hand_tcp", "red_cube")),
                       ("over", ("panda_hand_tcp", "bench")),
                       ("reach", ("panda_hand_tcp", "red_cube"))]:
        k = _kernel(tabletop, name)
        ids = np.array([kw.entity(a) for a in args])
        truth, dist = k(q, T, par, ids)
        g = jax.grad(lambda q: k(q, T, par, ids)[1])(q)
        assert np.isfinite(np.asarray(g)).all(), name
        batch = jax.vmap(jax.grad(lambda q: k(q, T, par, ids)[1]))(np.stack([q, q + 0.01]))
        assert np.isfinite(np.asarray(batch)).all(), name
        assert bool(truth) and float(dist) == 0.0, name   # all three hold at this state


def test_truth_at_constructed_states(tabletop):
    """Both outcomes of each predicate, at states built by hand."""
    from tmpc.compiler.kernels import state_inputs
    from tmpc.compiler.state import initial_state
    world, kw = tabletop
    st = initial_state(world.scene, compile_world(world).model)
    q, T, par = state_inputs(kw, st)
    ids = lambda *names: np.array([kw.entity(n) for n in names])   # noqa: E731
    over = _kernel(tabletop, "over")
    assert bool(over(q, T, par, ids("panda_hand_tcp", "bench"))[0])
    truth, dist = over(q, T, par, ids("panda_hand_tcp", "tray"))
    assert not bool(truth) and float(dist) > 0.1
    away = _kernel(tabletop, "away")
    assert bool(away(q, T, par, ids("panda_hand_tcp", "blue_cube"))[0])
    T2 = T.copy()
    T2[[o.name for o in world.scene.objects].index("blue_cube"), :3, 3] = \
        np.asarray(compile_world(world).fk(q).p[compile_world(world).model.frame("panda_hand_tcp")]) + 0.03
    truth, dist = away(q, T2, par, ids("panda_hand_tcp", "blue_cube"))
    assert not bool(truth) and float(dist) == pytest.approx(0.1 - np.sqrt(3) * 0.03)


def test_unknown_entity_or_joint_is_a_clear_error(tabletop):
    from tmpc.compiler import ir
    from tmpc.compiler.kernels.emit import KernelError, condition_kernel
    _, kw = tabletop
    bad = ir.op("le", (ir.Joint("elbow_of_nobody"), ir.Const(1.0)), ir.BOOL)
    with pytest.raises(KernelError, match="elbow_of_nobody"):
        condition_kernel(bad, kw)
    bad = ir.op("le", (ir.op("component", (ir.op("position", (ir.op(
        "pose", (ir.Entity("ghost"),), ir.TRANSFORM),), ir.VEC3), ir.Const(0.0)), ir.SCALAR),
        ir.Const(1.0)), ir.BOOL)
    with pytest.raises(KernelError, match="ghost"):
        condition_kernel(bad, kw)


@pytest.mark.parametrize("shape", ["ball", "halving"])
def test_projector_stops_early_with_the_fixed_loops_result(shape):
    """The projector leaves its loop once a start's distance is 0 (a batch once all have):
    every start ends where the plain loop of Newton steps, all ``n`` of them, ends. ``ball``:
    Newton overshoots into the set at once (distance exactly 0) but from the centre (no
    gradient); ``halving``: the distance shrinks fourfold a step and is never 0."""
    from tmpc.compiler.jaxcfg import configured
    from tmpc.compiler.kernels.project import projector_fn
    jnp = configured().numpy
    lo, hi = np.full(3, -2.0), np.full(3, 2.0)

    def kernel(q, T, par, args):         # the set: outside the unit ball
        r2 = (q * q).sum()
        d = jnp.maximum(0.0, 1.0 - r2) if shape == "ball" else \
            jnp.maximum(0.0, 1.0 - jnp.sqrt(r2 + 1e-300)) ** 2
        return d <= 0.0, d

    def distance_grad(q):
        r = float(np.sqrt(q @ q))
        if shape == "ball":
            d = max(0.0, 1.0 - r * r)
            return d, (-2.0 * q if d > 0 else np.zeros(3))
        d = max(0.0, 1.0 - r) ** 2
        return d, (-2.0 * (1.0 - r) * q / r if d > 0 else np.zeros(3))

    def plain(q, n):
        q = np.clip(q, lo, hi)
        for _ in range(n):
            d, g = distance_grad(q)
            stuck = ((q <= lo + 1e-9) & (g > 0)) | ((q >= hi - 1e-9) & (g < 0))
            g = np.where(stuck, 0.0, g)
            gg = float(g @ g)
            q = np.clip(q + (-d * g / gg if gg > 1e-12 else 0.0), lo, hi)
        return q

    starts = np.array([[0.0, 0.0, 0.0], [0.9, 0.1, 0.0], [0.05, -0.02, 0.01],
                       [1.5, 0.0, 0.0], [0.3, 0.3, 0.3]])
    if shape == "halving":
        starts[0] = [0.2, 0.1, -0.1]
    project = configured().jit(projector_fn(kernel, lo, hi))
    for n in (0, 1, 3, 12):
        Q, holds, _ = project(starts, None, None, None, np.int64(n))
        want = np.array([plain(q, n) for q in starts])
        assert np.allclose(np.asarray(Q), want, rtol=0, atol=1e-9), (n, np.asarray(Q), want)
        assert np.array_equal(np.asarray(holds), [distance_grad(q)[0] <= 0 for q in want])
    if shape == "ball":
        assert not np.asarray(holds)[0] and np.asarray(holds)[1:].all()
    else:                                     # only the start outside holds
        assert np.array_equal(np.asarray(holds), [False, False, False, True, False])


def test_projector_wraps_continuous_coordinates():
    """A coordinate that wraps (a continuous joint, the base's yaw) is taken modulo its period,
    never pinned at a bound: from just above -pi, the Newton steps toward 3.0 go down through
    the seam and arrive; clipped (no ``wraps``), they stall at -pi."""
    from tmpc.compiler.jaxcfg import configured
    from tmpc.compiler.kernels.project import projector_fn
    jnp = configured().numpy
    lo, hi = np.array([-np.pi, -1.0]), np.array([np.pi, 1.0])

    def kernel(q, T, par, args):                  # zero at (3.0 mod 2 pi, 0.5)
        d = jnp.abs(jnp.sin((q[0] - 3.0) / 2)) + jnp.abs(q[1] - 0.5)
        return d <= 1e-6, d

    starts = np.array([[-3.0, 0.0], [-2.9, -0.8], [2.0, 0.9], [3.0 - 2 * np.pi, 0.2]])
    n = np.int64(60)
    wrapped = configured().jit(projector_fn(kernel, lo, hi, wraps=[True, False]))
    Q, holds, _ = (np.asarray(x) for x in wrapped(starts, None, None, None, n))
    assert holds.all(), Q
    assert np.allclose(np.cos(Q[:, 0] - 3.0), 1.0) and np.allclose(Q[:, 1], 0.5, atol=1e-5)
    assert ((Q[:, 0] >= -np.pi) & (Q[:, 0] < np.pi)).all()
    clipped = configured().jit(projector_fn(kernel, lo, hi))
    Q, holds, _ = (np.asarray(x) for x in clipped(starts, None, None, None, n))
    # pinned at -pi: the first two on their way, the last (3 - 2 pi) from the start
    assert not holds[[0, 1, 3]].any() and np.allclose(Q[[0, 1, 3], 0], -np.pi)
    assert holds[2]                               # no seam on its way
