"""Legacy Lua predicates: the sandbox, tracing into IR, and the direct-evaluation fallback.

Numbers are checked three ways: the traced IR evaluated by the JAX backend, tmpc's own direct
evaluation (dual numbers), and an independent plain Lua run of the same file (a bare lupa
runtime with a distance prelude written here from planet's/tmit-star's documented semantics).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.support import EXAMPLES, FIXTURES, LEGACY
from tmpc.compiler import ir
from tmpc.compiler.lua_trace import LuaFallback, trace_module
from tmpc.lang import SourceFile, parse_source
from tmpc.lang.diagnostics import LuaError, render
from tmpc.lang.lua import LuaLimits, load_lua_predicates

FIX = FIXTURES / "lua"


# ------------------------------------------------------------------------------------------------
# helpers

def P(i, k):
    return f"(component (position (pose $arg{i})) {float(k)})"


def Q(i, k):
    return f"(component (orientation (pose $arg{i})) {float(k)})"


def line_of(diag) -> int:
    return SourceFile(diag.span.path, Path(diag.span.path).read_text()).line_col(
        diag.span.start)[0] if Path(diag.span.path).exists() else -1


def raises(src: str, tmp_path, name="f.lua", **kw) -> tuple[str, int]:
    """Load `src` from a file; return (code, line) of the LuaError's first diagnostic."""
    path = tmp_path / name
    path.write_text(src)
    with pytest.raises(LuaError) as ei:
        m = load_lua_predicates(path, **kw)
        trace_module(m)
    d = ei.value.diagnostics[0]
    assert render(d, ei.value.files)          # renders with the Lua line
    line = ei.value.files[str(path)].line_col(d.span.start)[0] if d.span else None
    return d.code, line


def random_poses(rng, k):
    pos = rng.uniform(-0.6, 0.6, (k, 3))
    quat = rng.normal(size=(k, 4)) * [0.2, 0.2, 0.4, 1.0]
    quat[:, 3] = np.abs(quat[:, 3]) + 0.5            # w > 0: the backend's canonical sign
    quat /= np.linalg.norm(quat, axis=1, keepdims=True)
    return np.hstack([pos, quat])


def R_of(q):
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


BOX = ((-0.3, -0.25, 0.0), (0.35, 0.2, 0.05))


def jax_distance(node, poses, boxes):
    """(truth, distance) of an IR condition by the JAX backend, arguments = objects 0..k-1."""
    from tmpc.compiler.kernels import build_tables, condition_kernel
    from tmpc.lang.world.scene import Box, Pose, Scene, SceneObject
    objs = tuple(SceneObject(f"o{i}", Pose(tuple(p[:3]), tuple(p[3:])),
                             support=Box(*b) if b is not None else None)
                 for i, (p, b) in enumerate(zip(poses, boxes)))
    world = build_tables(Scene("test", ((-5, 5),) * 3, None, objs), None)
    T = np.tile(np.eye(4), (len(poses), 1, 1))
    for i, p in enumerate(poses):
        T[i, :3, :3], T[i, :3, 3] = R_of(p[3:]), p[:3]
    k = len(poses)
    truth, dist = condition_kernel(node, world)(np.zeros(0), T, np.full(k, -1), np.arange(k))
    return bool(truth), float(dist)


class PlainLua:
    """An independent evaluation: a bare Lua runtime, numbers only, distance semantics."""

    PRELUDE = """
    function True() return 0 end
    function False() return 1e6 end
    function Eq(a, b) return math.abs(a - b) end
    function Le(a, b) return math.max(a - b, 0) end
    Lt = Le
    function Ge(a, b) return math.max(b - a, 0) end
    Gt = Ge
    function And(a, b) return math.sqrt(math.max(a, 0) ^ 2 + math.max(b, 0) ^ 2) end
    function Or(a, b) return math.min(a, b) end
    math.pow = function(a, b) return a ^ b end
    math.atan2 = math.atan
    package.preload['tmit-star'] = function() return { dual = function(x) return x end,
                                                       math = math } end
    """

    def __init__(self, path):
        from lupa import lua54
        self.rt = lua54.LuaRuntime()
        self.rt.execute(self.PRELUDE)
        ret = self.rt.execute(Path(path).read_text())
        self.fns = ret if ret is not None else self.rt.globals()

    def obj(self, p, box, dialect):
        o = dict(zip(("px", "py", "pz", "rx", "ry", "rz", "rw"), map(float, p)))
        if box is not None and dialect == "planet":
            lo, hi = box
            region = {a: self.rt.table_from({"low": lo[i], "high": hi[i]})
                      for i, a in enumerate("xyz")}
            o["sssp"] = self.rt.table_from({"region": self.rt.table_from(region)})
        if box is not None and dialect == "tmit-star":
            o["pose"] = self.rt.table_from(dict(o))
            corners = np.array([[x, y, z] for x in (box[0][0], box[1][0])
                                for y in (box[0][1], box[1][1]) for z in (box[0][2], box[1][2])])
            world = corners @ R_of(p[3:]).T
            for i, a in enumerate("xyz"):
                o[f"{a}_low"], o[f"{a}_high"] = world[:, i].min(), world[:, i].max()
        return self.rt.table_from(o)

    def __call__(self, name, poses, boxes, dialect="planet"):
        args = [self.obj(p, b, dialect) for p, b in zip(poses, boxes)]
        return float(self.fns[name](*args))


# ------------------------------------------------------------------------------------------------
# loading and the sandbox

def test_lang_does_not_import_lupa():
    code = ("import sys, tmpc.lang, tmpc.lang.lua, tmpc.compiler.lua_trace; "
            "assert 'lupa' not in sys.modules, 'lupa imported'")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_styles_are_detected():
    planet = load_lua_predicates(FIX / "planet_world.lua")
    assert planet.dialect == "planet"
    assert {"stacked", "over", "close", "taxicab", "level", "apart"} <= set(planet.names)
    assert "And" not in planet.names and "gap" not in planet.names      # prelude; local
    tmit = load_lua_predicates(FIX / "tmit_world.lua")
    assert tmit.dialect == "tmit-star"
    assert set(tmit.names) == {"near", "on-top", "flat", "in-box", "heading"}
    assert tmit.lookup("ON-TOP") == "on-top" and planet.lookup("same-thing") == "same_thing"


@pytest.mark.parametrize("src,line,what", [
    ("function p(x) return True() end\n\nos.execute('ls')\n", 3, "`os`"),
    ("local f = io.open('/etc/passwd')\n", 1, "`io`"),
    ("\nload('return 1')()\n", 2, "`load`"),
    ("dofile('/etc/passwd')\n", 1, "`dofile`"),
    ("local x = 1\nlocal os = require('os')\n", 2, "module 'os'"),
    ("local s = string.dump(function() end)\n", 1, "string.dump"),
    ("local s = ('x').dump(function() end)\n", 1, "string.dump"),
    ("debug.sethook()\n", 1, "`debug`"),
    ("python.eval('1')\n", 1, "`python`"),
    ("package.path = ''\n", 1, "`package`"),
    ("local i = ('aaaa'):find('a*a*a*b')\n", 1, "string.find"),
    ("local x = 1\nsetmetatable({}, { __gc = function() while true do end end })\n", 2, "__gc"),
    ("function p(x)\n  os.remove('/tmp/x')\n  return True()\nend\n", 2, "`os`"),
])
def test_sandbox_denials(src, line, what, tmp_path):
    path = tmp_path / "deny.lua"
    path.write_text(src)
    with pytest.raises(LuaError, match="not available in tmpc's Lua sandbox") as ei:
        trace_module(load_lua_predicates(path))
    d = ei.value.diagnostics[0]
    assert d.code == "E703" and what in d.message
    assert ei.value.files[str(path)].line_col(d.span.start)[0] == line


def test_no_python_objects_reachable(tmp_path):
    src = ("for _, lib in pairs({ _G, math, string, table, require('tmit-star') }) do\n"
           "  for k, v in pairs(lib) do assert(type(v) ~= 'userdata', k) end\n"
           "end\nreturn 1\n")
    assert raises(src, tmp_path) == ("E710", 4)     # only the bad return value failed


def test_instruction_limit(tmp_path):
    assert raises("function spin(x)\n  while true do end\nend\n", tmp_path) == ("E704", 2)
    # pcall cannot swallow the limit
    assert raises("while true do\n  pcall(function() while true do end end)\nend\n", tmp_path,
                  limits=LuaLimits(instructions=200_000))[0] == "E704"


def test_memory_limit(tmp_path):
    path = tmp_path / "mem.lua"
    path.write_text("local t = {}\nfor i = 1, 1e8 do t[i] = {i} end\n")
    with pytest.raises(LuaError, match="memory limit") as ei:
        load_lua_predicates(path, limits=LuaLimits(memory=8 * 2**20))
    assert ei.value.diagnostics[0].code == "E705"


def test_memory_limit_in_a_predicate_leaves_the_module_usable(tmp_path):
    path = tmp_path / "hog.lua"
    path.write_text("function hog(x)\n  local t = {}\n  for i = 1, 1e8 do t[i] = {i} end\n"
                    "  return True()\nend\nfunction fine(x) return Le(x.pz, 1) end\n")
    module = load_lua_predicates(path, limits=LuaLimits(memory=8 * 2**20))
    res = trace_module(module, {"hog": 1, "fine": 1}, strict=False)
    assert [d.code for d in res.diagnostics] == ["E705"]
    assert ir.show(res.traced["fine"]) == f"(le {P(0, 2)} 1.0)"


def test_syntax_error_reports_file_and_line(tmp_path):
    path = tmp_path / "syn.lua"
    path.write_text("function on(x, y)\n  return And(Le(x.pz, y.pz),\nend\n")
    with pytest.raises(LuaError) as ei:
        load_lua_predicates(path)
    text = render(ei.value.diagnostics[0], ei.value.files)
    assert ei.value.diagnostics[0].code == "E700"
    assert text.startswith(f"{path}:3:1: error[E700]: Lua syntax error") and "3 | end" in text


def test_runtime_errors_in_predicates(tmp_path):
    src = "function on(x, y)\n  local t = nil\n  return Le(t.pz, y.pz)\nend\n"
    assert raises(src, tmp_path) == ("E702", 3)
    assert raises("function on(x, y)\n  return 'yes'\nend\n", tmp_path) == ("E706", 1)
    assert raises("return { at = function(a, b) return true end }\n", tmp_path) == ("E706", 1)
    assert raises("function on(x, y)\n  return Le(x.mass, 1)\nend\n", tmp_path) == ("E709", 2)
    assert raises("function on(x, y)\n  return And(x.pz, 1)\nend\n", tmp_path) == ("E702", 2)
    assert raises("function on(x, y)\n  return Le(x.pz + Le(x.pz, 1), 1)\nend\n",
                  tmp_path) == ("E702", 2)
    assert raises("function on(x, y)\n  return Le(#x.grasps, 1)\nend\n", tmp_path)[0] == "E709"
    assert raises("return 42\n", tmp_path) == ("E710", 1)
    assert raises("function on(x, y) return True() end\n", tmp_path,
                  dialect="tmit-star")[0] == "E710"


def test_missing_function_and_arity(tmp_path):
    path = tmp_path / "p.lua"
    path.write_text("function on(x, y, z)\n  return Le(x.pz, y.pz)\nend\n")
    domain = parse_source(SourceFile("d.pddl", "(define (domain d) (:requirements :strips)"
                                     " (:predicates (on ?x ?y) (at ?m ?x) (held ?x :discrete)))")
                          ).definitions[0]
    preds = {p.name.text: p for p in domain.predicates}
    res = trace_module(load_lua_predicates(path, "planet"), preds, strict=False)
    codes = sorted(d.code for d in res.diagnostics)
    assert codes == ["E707", "E708"] and not res.traced          # `held` is skipped


def test_missing_function_error_shows_the_pddl_line(tmp_path):
    """A strict trace error carries the domain file too, so E707 renders `domain.pddl:L:C` with
    the declaration's line, not only the domain's path."""
    lua = tmp_path / "p.lua"
    lua.write_text("function on(x, y)\n  return Le(x.pz, y.pz)\nend\n")
    dom = tmp_path / "domain.pddl"
    dom.write_text("(define (domain d) (:requirements :strips)\n (:predicates (on ?x ?y)\n"
                   "  (at ?m ?x) (held ?x :discrete)))\n")
    domain = parse_source(SourceFile.read(dom)).definitions[0]
    with pytest.raises(LuaError) as info:
        trace_module(load_lua_predicates(lua, "planet"), {p.name.text: p for p in
                                                         domain.predicates})
    assert str(dom) in info.value.files
    text = render(info.value.diagnostics[0], info.value.files)
    assert f"{dom}:3:3: error[E707]" in text and "(at ?m ?x)" in text


# ------------------------------------------------------------------------------------------------
# tracing

def test_planet_traces_to_expected_ir():
    module = load_lua_predicates(FIX / "planet_world.lua")
    helper = trace_module(module, {"taxicab": 2}, strict=False).diagnostics   # a number
    assert [d.code for d in helper] == ["E706"] and "got a traced number" in helper[0].message
    res = trace_module(module, {n: f.nparams for n, f in module.functions.items()
                                if n != "taxicab"})
    assert not res.fallbacks and not res.diagnostics
    dz = f"(sub {P(0, 2)} {P(1, 2)})"
    assert ir.show(res.traced["stacked"]) == f"(and (ge {dz} 0.02) (le {dz} 0.2))"
    assert ir.show(res.traced["same_thing"]) == "(same $arg0 $arg1)"
    assert ir.show(res.traced["is_table"]) == "(same $arg0 table)"
    assert ir.show(res.traced["always"]) == f"(ge {P(0, 2)} -10.0)"
    assert ir.show(res.traced["tilt"]) == f"(le (mul (atan2 {Q(0, 2)} {Q(0, 3)}) 2.0) 0.5)"
    assert ir.show(res.traced["apart"]).startswith("(or (gt (abs (sub") and "(not (lt" in \
        ir.show(res.traced["apart"])
    over = ir.show(res.traced["over"])
    assert over.startswith("(and (ge ") and over.count("(ge ") == 3 and over.count("(le ") == 3
    assert f"(add {P(1, 0)} (component (lower (support_local $arg1)) 0.0))" in over
    assert res.arg_kinds["over"] == ("object", "surface")
    assert res.arg_kinds["close"] == ("object", "object")
    assert all(n.type == ir.BOOL for n in res.traced.values() if n is not None)


def test_tmit_traces_to_holds():
    res = trace_module(load_lua_predicates(FIX / "tmit_world.lua"))
    assert not res.fallbacks and set(res.traced) == {"near", "on-top", "flat", "in-box", "heading"}
    flat = res.traced["flat"]
    assert ir.show(flat) == (f"(holds (add (add (add (pow {Q(0, 0)} 2.0) (pow {Q(0, 1)} 2.0)) "
                             f"(pow {Q(0, 2)} 2.0)) (pow (sub {Q(0, 3)} 1.0) 2.0)))")
    top = ir.show(res.traced["on-top"])
    assert f"(sub (component (lower (support $arg1)) 0.0) {P(1, 0)})" in top
    assert res.arg_kinds["on-top"] == ("object", "surface")


def _points(rng, n, k, boxes):
    for _ in range(n):
        yield random_poses(rng, k), boxes


@pytest.mark.parametrize("name,k,surf", [("stacked", 2, None), ("over", 2, 1), ("close", 2, None),
                                         ("closeish", 2, None), ("level", 1, None),
                                         ("always", 1, None), ("tilt", 1, None)])
def test_planet_traced_ir_agrees_numerically(name, k, surf):
    module = load_lua_predicates(FIX / "planet_world.lua")
    node = trace_module(module, {name: k}).traced[name]
    plain = PlainLua(FIX / "planet_world.lua")
    boxes = [BOX if i == surf else None for i in range(k)]
    direct = LuaFallback(module, name, tuple("surface" if b else "object" for b in boxes))
    rng = np.random.default_rng(len(name))
    for poses, bx in _points(rng, 6, k, boxes):
        if name == "over":
            poses[0, :3] = poses[1, :3] + rng.uniform(-0.4, 0.4, 3) * [1, 1, 0.5] + [0, 0, 0.1]
        truth, dist = jax_distance(node, poses, bx)
        expected = plain(name, poses, bx)
        assert dist == pytest.approx(expected, abs=1e-9)
        assert truth == (expected <= 1e-3) or abs(expected - 1e-3) < 1e-6
        assert direct(poses, bx, gradient=False)[0] == pytest.approx(expected, abs=1e-9)


def test_planet_negation_agrees_with_direct_evaluation():
    module = load_lua_predicates(FIX / "planet_world.lua")
    node = trace_module(module, {"apart": 2}).traced["apart"]
    direct = LuaFallback(module, "apart", ("object", "object"))
    rng = np.random.default_rng(7)
    for _ in range(8):
        poses = random_poses(rng, 2)
        truth, dist = jax_distance(node, poses, [None, None])
        value, _ = direct(poses)
        assert dist == pytest.approx(value, abs=1e-9)
        a, b = poses
        assert truth == (abs(a[0] - b[0]) > 0.3 - 1e-3 or abs(a[1] - b[1]) >= 0.3 - 1e-3)


@pytest.mark.parametrize("name,k,surf", [("near", 2, None), ("on-top", 2, 1), ("flat", 1, None),
                                         ("in-box", 1, None), ("heading", 1, None)])
def test_tmit_traced_ir_agrees_numerically(name, k, surf):
    module = load_lua_predicates(FIX / "tmit_world.lua")
    node = trace_module(module, {name: k}).traced[name]
    plain = PlainLua(FIX / "tmit_world.lua")
    boxes = [BOX if i == surf else None for i in range(k)]
    direct = LuaFallback(module, name, tuple("surface" if b else "object" for b in boxes))
    rng = np.random.default_rng(len(name) + 100)
    for _ in range(6):
        poses = random_poses(rng, k)
        truth, dist = jax_distance(node, poses, boxes)
        expected = max(plain(name, poses, boxes, "tmit-star"), 0.0)
        assert dist == pytest.approx(expected, rel=1e-9, abs=1e-12)
        assert truth == (expected <= 1e-3)
        value, grad = direct(poses, boxes)
        assert value == pytest.approx(expected, rel=1e-9, abs=1e-12)
        fd = _finite_differences(lambda x: max(plain(name, x, boxes, "tmit-star"), 0.0), poses)
        assert np.allclose(grad, fd, atol=1e-5), (grad, fd)


# ------------------------------------------------------------------------------------------------
# the fallback

def _finite_differences(f, poses, h=1e-6):
    g = np.zeros_like(poses)
    for idx in np.ndindex(*poses.shape):
        up, dn = poses.copy(), poses.copy()
        up[idx] += h
        dn[idx] -= h
        g[idx] = (f(up) - f(dn)) / (2 * h)
    return g


def test_branching_falls_back_with_a_warning():
    module = load_lua_predicates(FIX / "branching.lua")
    res = trace_module(module)
    assert not res.traced and set(res.fallbacks) == {"reach", "guarded", "grid"}
    warnings = {d.message.split("`")[1]: d for d in res.diagnostics}
    assert all(d.code == "W700" and not d.is_error for d in res.diagnostics)
    assert "branch on the state" in warnings["reach"].message
    assert "math.floor" in warnings["grid"].message
    src = module.source
    assert src.line_col(warnings["reach"].span.start)[0] == 5        # the `if d > 0` line
    assert src.line_col(warnings["guarded"].span.start)[0] == 13


@pytest.mark.parametrize("file,name,k,dialect", [
    ("branching.lua", "reach", 2, "planet"), ("branching.lua", "grid", 1, "planet"),
    ("branching.lua", "guarded", 2, "planet"), ("tmit_branching.lua", "side-of", 2, "tmit-star")])
def test_fallback_value_and_gradient(file, name, k, dialect):
    module = load_lua_predicates(FIX / file)
    fb = trace_module(module).fallbacks[name]
    assert fb.arg_kinds == ("object",) * k and fb.reason
    plain = PlainLua(FIX / file)

    def f(poses):
        v = plain(name, poses, [None] * k, dialect)
        return max(v, 0.0)

    rng = np.random.default_rng(3)
    checked = 0
    for _ in range(12):
        poses = random_poses(rng, k) * [2, 2, 2, 1, 1, 1, 1]
        value, grad = fb(poses)
        assert grad.shape == (k, 7)
        assert value == pytest.approx(f(poses), abs=1e-12)
        assert fb.truth(poses) == (value <= 1e-3)
        if value > 1e-4:
            assert np.allclose(grad, _finite_differences(f, poses), atol=1e-5)
            checked += 1
    assert checked >= 3


def test_fallback_runtime_error_is_a_lua_error(tmp_path):
    path = tmp_path / "b.lua"
    path.write_text("function f(x)\n  if x.px > 0 then\n    return Le(x.py, 1)\n  end\n"
                    "  return Le(x.nothing, 1)\nend\n")
    module = load_lua_predicates(path)
    fb = trace_module(module).fallbacks["f"]        # the probe point takes the first branch
    assert fb(np.array([[0.5, 2, 0, 0, 0, 0, 1.0]]))[0] == pytest.approx(1.0)
    with pytest.raises(LuaError, match="unknown field `nothing`") as ei:
        fb(np.array([[-0.5, 0, 0, 0, 0, 0, 1.0]]))
    assert module.source.line_col(ei.value.diagnostics[0].span.start)[0] == 5


# ------------------------------------------------------------------------------------------------
# legacy predicate files with their domains: the fixtures' planet and tmit-star trees (one Lua
# file for two domains each, as in the original repositories) and the bundled legacy examples

def _external(domain_path):
    dom = parse_source(SourceFile.read(domain_path)).definitions[0]
    return {p.name.text: p for p in dom.predicates if p.external}


@pytest.mark.parametrize("lua,domains,dialect,helpers", [
    (LEGACY / "planet" / "predicates.lua", [LEGACY / "planet" / "two-table-sort" / "domain.pddl",
                                            LEGACY / "planet" / "cupboard-shelf" / "domain.pddl"],
     "planet", {"gap"}),
    (LEGACY / "tmit-star" / "lua" / "predicates.lua",
     [LEGACY / "tmit-star" / "bin-picking" / "domain.pddl",
      LEGACY / "tmit-star" / "shelf-restock" / "domain.pddl"], "tmit-star", set()),
    (EXAMPLES / "planet-sort" / "sort.lua", [EXAMPLES / "planet-sort" / "domain.pddl"], "planet",
     set()),
    (EXAMPLES / "tmit-star-sort" / "predicates.lua", [EXAMPLES / "tmit-star-sort" / "domain.pddl"],
     "tmit-star", set()),
], ids=["planet-fixtures", "tmit-star-fixtures", "planet-sort", "tmit-star-sort"])
def test_legacy_predicates_trace(lua, domains, dialect, helpers):
    module = load_lua_predicates(lua)
    assert module.dialect == dialect
    declared = {}
    for d in domains:
        declared.update(_external(d))
    assert declared
    res = trace_module(module, declared)
    # every geometric predicate of these files traces (none needs the direct fallback)
    assert set(res.traced) == set(declared) and not res.fallbacks and not res.diagnostics
    plain, rng = PlainLua(lua), np.random.default_rng(11)
    for name, node in res.traced.items():        # the traced IR computes what the file does
        boxes = [BOX if kind == "surface" else None for kind in res.arg_kinds[name]]
        for _ in range(4):
            poses = random_poses(rng, len(boxes))
            expected = max(plain(module.lookup(name), poses, boxes, module.dialect), 0.0)
            assert jax_distance(node, poses, boxes)[1] == pytest.approx(expected, abs=1e-9)
    # the file's other functions are helpers: each traces or is reported, none is lost
    rest = {n: f.nparams for n, f in module.functions.items() if n not in declared}
    assert set(rest) == helpers
    others = trace_module(module, rest, strict=False)
    reported = {d.message.split("`")[1] for d in others.diagnostics}
    assert set(others.traced) | reported == helpers


def test_untraceable_lua_predicate_points_at_its_function(untraceable_sort):
    """An untraceable predicate compiles to a `lua` node (kernels call its fallback, see
    tests/compiler/test_lua_fallback_kernels.py); its record names the Lua function's line."""
    compiled, lua = untraceable_sort.fallback, untraceable_sort.lua
    assert ir.show(compiled.predicate("at").body) == "(lua 'at' $arg0 $arg1)"
    bad = compiled.external["at"]
    assert bad.span.path.endswith("sort.lua") and bad.span.path in bad.files
    new = lua.read_text()
    assert new[bad.span.start:].startswith("function at(")


def test_table_sort_is_charged_to_the_budget(tmp_path):
    """`table.sort` runs in one C call the instruction hook cannot interrupt (L 4): a loop of
    big sorts took minutes between two looks at the clock. Each sort now costs n*log2(n) of the
    budget, so the loop ends at once with E704 at the sort's line."""
    import time
    src = ("local t = {}\nfor i = 1, 3e5 do t[i] = (i * 7919) % 100003 end\n"
           "for k = 1, 1e6 do\n  table.sort(t)\nend\n")
    t = time.perf_counter()
    assert raises(src, tmp_path, limits=LuaLimits(seconds=2.0)) == ("E704", 4)
    assert time.perf_counter() - t < 3.0
    # a sort within the budget still sorts, with a comparator too
    path = tmp_path / "ok.lua"
    path.write_text("local t = {3, 1, 2}\ntable.sort(t, function(a, b) return a > b end)\n"
                    "assert(t[1] == 3 and t[3] == 1)\nlocal u = {3, 1, 2}\ntable.sort(u)\n"
                    "assert(u[1] == 1)\nfunction f(a) return true end\n")
    assert load_lua_predicates(path).names == ("f",)


def test_work_inside_c_functions_is_bounded(tmp_path):
    """`string.rep` in a loop costs few instructions and hours of time (L 1): a CPU-time budget
    per call and a cap on what one string.rep may build stop it, at the line."""
    src = 'for i = 1, 3e6 do\n  local s = ("x"):rep(1e7)\nend\n'
    code, line = raises(src, tmp_path, limits=LuaLimits(seconds=0.5))
    assert (code, line) == ("E704", 2)
    path = tmp_path / "big.lua"
    path.write_text('local s = ("x"):rep(2^30)\n')
    with pytest.raises(LuaError, match="string.rep would build 1073741824 bytes") as ei:
        load_lua_predicates(path)
    assert ei.value.diagnostics[0].code == "E705"
