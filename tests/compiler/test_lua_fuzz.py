"""Fuzzing legacy Lua files (issue L): random chunks of hostile code (loops inside and outside C
functions, memory bombs, deep recursion, sandbox escapes, syntax and runtime errors) at the top
level and inside predicate bodies. Loading and tracing a file either works or raises a LuaError
with an E7xx code (the Lua codes), within the sandbox's budgets: never another exception, never
a hang. A small budget here; `-m slow` runs many more examples."""

from __future__ import annotations

import time

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tmpc.compiler.lua_trace import trace_module
from tmpc.lang.diagnostics import LuaError
from tmpc.lang.lua import LuaLimits, load_lua_predicates

HOSTILE = [
    "for i = 1, 1e9 do end",
    "while true do end",
    "repeat local x = 1 until false",
    'local s = ("x"):rep(1e6) for i = 1, 100 do s = s .. s end',
    'local s = ("x"):rep(2^31)',
    'local s = ("ab"):rep(1e6):rep(1e3)',
    "local t = {} for i = 1, 1e8 do t[i] = i end",
    "local t = {} for i = 1, 2e5 do t[i] = (i * 7919) % 100003 end table.sort(t)",
    "local t = {} for i = 1, 2e4 do t[i] = -i end table.sort(t, function(a, b) return a < b end)",
    "local t = {} for i = 1, 2e5 do t[i] = i % 977 end for k = 1, 1e6 do table.sort(t) end",
    "local t = {} for i = 1, 3e5 do t[i] = tostring(i) end local s = table.concat(t):rep(100)",
    "local function f() return f() end f()",
    "local function g() return 1 + g() end g()",
    "local t = setmetatable({}, {__index = function(t, k) return t[k + 1] end}) local x = t[1]",
    'os.execute("true")', 'io.open("/etc/passwd")', 'load("return 1")()', "debug.getinfo(1)",
    'require("os")', 'dofile("/etc/passwd")', 'collectgarbage("stop")', "string.dump(print)",
    "coroutine.wrap(function() while true do end end)()",
    "setmetatable({}, {__gc = function() while true do end end})",
    'string.format("%099d", 1)', 'error("boom")', "x = nil + 1", "x = 1 +", "end",
    "local a = {} a[a] = a", "return 5", "return {}", "goto nowhere",
]
BODIES = ["return true", "return a[1] > 0", "while true do end", "return f2(a, b)",
          'return ("x"):rep(2^30)', "local t = {} for i = 1, 1e8 do t[i] = i end return true",
          "return a.x.y.z", "return nil"]


@st.composite
def lua_file(draw) -> str:
    parts = draw(st.lists(st.sampled_from(HOSTILE), max_size=3))
    for name in draw(st.lists(st.sampled_from(["at", "near", "f2"]), max_size=2, unique=True)):
        parts.append(f"function {name}(a, b)\n  {draw(st.sampled_from(BODIES))}\nend")
    return "\n".join(parts) + "\n"


LIMITS = LuaLimits(instructions=2_000_000, memory=32 << 20, seconds=0.5)


def _load_and_trace(path, text: str) -> None:
    path.write_text(text)
    t = time.perf_counter()
    try:
        trace_module(load_lua_predicates(path, limits=LIMITS), strict=False)
    except LuaError as exc:
        codes = [d.code for d in exc.diagnostics]
        assert codes and all(c.startswith("E7") for c in codes), codes
    # a hang would show here (the budgets are 0.5 s of CPU per call and 2e6 instructions)
    assert time.perf_counter() - t < 30.0, text


@settings(max_examples=60, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(lua_file())
def test_hostile_lua_files_give_lua_errors_within_the_budget(tmp_path, text):
    _load_and_trace(tmp_path / "predicates.lua", text)


@pytest.mark.slow
@settings(max_examples=600, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(lua_file())
def test_many_hostile_lua_files(tmp_path, text):
    _load_and_trace(tmp_path / "predicates.lua", text)
