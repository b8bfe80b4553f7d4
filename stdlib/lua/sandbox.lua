-- tmpc's trusted Lua core: the sandbox, limits and the entry points Python calls.
--
-- Python (tmpc.lang.lua) runs this chunk once per sandbox, before any user code, with the full
-- standard library; it keeps what it needs in locals and returns an API table, then Python
-- removes the dangerous globals. User files run in their own environment table (`new_env`) and
-- never see this chunk's globals. values.lua (the tracer and dual numbers) and the compatibility
-- modules planet.lua and tmit-star.lua are passed in as source texts.
local values_src, plan_src, tmit_src = ...

local type, error, setmetatable, rawequal, rawget, rawset, tostring, pairs =
  type, error, setmetatable, rawequal, rawget, rawset, tostring, pairs
local xpcall, pcall, load = xpcall, pcall, load
local sformat, tunpack, tpack = string.format, table.unpack, table.pack
local getinfo, sethook, getmt = debug.getinfo, debug.sethook, debug.getmetatable
local clock, srep = os.clock, string.rep

local core = {}

-------------------------------------------------------------------------------------------------
-- Instruction limit: a count hook, reset for every guarded call. Once the budget is spent the
-- hook fires on every instruction, so a `pcall` in user code cannot swallow the limit for long.
-- With `track`, a line hook also remembers the last line of user code that ran: a tail call
-- (`return And(...)`) removes the user's frame from the stack, so the stack alone cannot say
-- where a combinator was called from. Python repeats a failed call with tracking on.
-- A CPU-time limit per call too, checked by the same hook: work inside a C function (a loop of
-- string.rep, a table.sort) costs few instructions and much time.
local budget, used, STEP = 10000000, 0, 1000
local seconds, started, timed_out = 10.0, 0, false
local LIMIT = setmetatable({}, { __name = "tmpc instruction limit" })
local USER = {}          -- chunk source ("=name") -> true
local last_line          -- the last user line that ran (tracked calls only)

local LINE_COST = 20     -- budget charged per line event: tracking is slow, keep it bounded

local function hook(event, line)
  if event == "line" then
    if USER[getinfo(2, "S").source] then last_line = line end
    used = used + LINE_COST
    if used <= budget then return end
  else
    used = used + STEP
    if clock() - started > seconds then timed_out = true end
  end
  if used > budget or timed_out then
    sethook(hook, "", 1)
    error(LIMIT, 0)
  end
end

function core.set_budget(n, s) budget, seconds = n, s or seconds end

-- Where in the user's file are we? The last user line run if tracked, else the innermost
-- frame of a user chunk on the stack.
local function user_line()
  if last_line then return last_line end
  local level = 2
  while true do
    local info = getinfo(level, "Sl")
    if not info then return nil end
    if USER[info.source] then return info.currentline end
    level = level + 1
  end
end

-- Error markers: UNTRACE = tracing cannot capture this (fall back to evaluation);
-- FAIL = a genuine error in the user's code, with a message written for users.
local UNTRACE, FAIL = {}, {}

local function untraceable(reason)
  error(setmetatable({ reason = reason, line = user_line() }, UNTRACE), 0)
end

local function fail(msg, kind)
  error(setmetatable({ msg = msg, line = user_line(), kind = kind or "error" }, FAIL), 0)
end

local function is_marker(e)
  if rawequal(e, LIMIT) then return true end
  if type(e) ~= "table" then return false end
  local mt = getmt(e)
  return rawequal(mt, UNTRACE) or rawequal(mt, FAIL)
end

local function handler(e)
  sethook()
  if rawequal(e, LIMIT) then
    return { kind = timed_out and "time" or "limit", line = user_line() }
  end
  if type(e) == "table" then
    local mt = getmt(e)
    if rawequal(mt, UNTRACE) then
      return { kind = "untraceable", msg = rawget(e, "reason"), line = rawget(e, "line") }
    end
    if rawequal(mt, FAIL) then
      return { kind = rawget(e, "kind"), msg = rawget(e, "msg"), line = rawget(e, "line") }
    end
    return { kind = "error", msg = "an error was raised with a table, not a message",
             line = user_line() }
  end
  if type(e) == "string" then return { kind = "error", msg = e, line = user_line() } end
  return { kind = "error", msg = "an error was raised with a " .. type(e), line = user_line() }
end

-- Call f under the instruction limit; returns true, packed results | false, error info table.
local function guarded(track, f, ...)
  used, last_line, started, timed_out = 0, nil, clock(), false
  sethook(hook, track and "l" or "", STEP)
  local res = tpack(xpcall(f, handler, ...))
  sethook()
  if res[1] then return true, res end
  local e = res[2]
  if type(e) ~= "table" then      -- the handler does not run for memory errors
    if e == "not enough memory" then
      e = { kind = "memory", msg = e }
    else
      e = { kind = "error", msg = tostring(e) }
    end
  end
  return false, e
end

local V = assert(load(values_src, "=tmpc/values.lua", "t", _ENV))(fail, untraceable)

-- After an error that escaped the guard (memory): no hook, no mode left behind.
function core.reset() sethook(); V.begin("plain") end

local TMATH = V.math

-------------------------------------------------------------------------------------------------
-- The sandbox environment
local DENIED = { os = true, io = true, debug = true, load = true, loadstring = true, dofile = true,
                 loadfile = true, package = true, collectgarbage = true, coroutine = true,
                 jit = true, ffi = true, python = true, module = true, setfenv = true,
                 getfenv = true, newproxy = true }

local function deny(what)
  fail(sformat("`%s` is not available in tmpc's Lua sandbox", what), "denied")
end

-- string.dump makes bytecode; pattern matching can run for a very long time inside one C call,
-- where the instruction hook never fires. Both go (values.lua keeps its own `sfind`).
local STRING_DENIED = { dump = true, find = true, match = true, gmatch = true, gsub = true }
for key in pairs(STRING_DENIED) do string[key] = nil end
setmetatable(string, { __index = function(_, key)
  if STRING_DENIED[key] then deny("string." .. key) end
end, __metatable = "string" })
getmt("").__metatable = "string"

-- string.rep builds its whole result inside one C call, where no hook fires: cap what one call
-- may build (the memory cap alone lets a loop build and drop big strings for hours)
local REP_CAP = 16 * 1024 * 1024
function core.set_string_cap(n) REP_CAP = n end
string.rep = function(s, n, sep)
  local size = #tostring(s) * (n or 0) + (sep and #tostring(sep) * ((n or 1) - 1) or 0)
  if type(n) == "number" and size > REP_CAP then
    fail(sformat("string.rep would build %d bytes, more than the %d one call may build",
                 size, REP_CAP), "size")
  end
  return srep(s, n, sep)
end

-- table.sort sorts inside one C call, where the count hook fires only while a Lua comparator
-- runs: each call is charged n*log2(n) instructions of the budget up front, and looks at the
-- clock, so one huge sort, or a loop of big ones, ends with E704 at its line (before, a loop
-- of sorts ran for minutes between two looks at the clock).
local tsort, mlog = table.sort, math.log
table.sort = function(t, comp)
  if type(t) == "table" then
    local n = rawlen(t)
    if n > 1 then used = used + n * (mlog(n, 2) + 1) end
    if clock() - started > seconds then timed_out = true end
    if used > budget or timed_out then
      sethook(hook, "", 1)
      error(LIMIT, 0)
    end
  end
  return tsort(t, comp)
end

-- A finalizer would run user code at some later garbage collection, outside any budget.
local function user_setmetatable(t, mt)
  if type(mt) == "table" and rawget(mt, "__gc") ~= nil then deny("a __gc metamethod") end
  return setmetatable(t, mt)
end

local function rethrow_markers(ok, ...)
  if not ok and is_marker((...)) then error((...), 0) end
  return ok, ...
end

local function user_pcall(f, ...) return rethrow_markers(pcall(f, ...)) end

local function user_xpcall(f, msgh, ...)
  return rethrow_markers(xpcall(f, function(e)
    if is_marker(e) then return e end
    return msgh(e)
  end, ...))
end

local ENV_MT = {
  __index = function(_, key) if DENIED[key] then deny(key) end end,
  __metatable = "tmpc sandbox",
}

local PRELUDE_NAMES = {}
local MODULES = {}               -- require name -> module table (built once per sandbox)

local function new_env()
  local env = {
    assert = assert, error = error, ipairs = ipairs, next = next, pairs = pairs,
    pcall = user_pcall, xpcall = user_xpcall, print = function() end, rawequal = rawequal,
    rawget = rawget, rawlen = rawlen, rawset = rawset, select = select,
    setmetatable = user_setmetatable, getmetatable = getmetatable, tonumber = tonumber,
    tostring = tostring, type = type, unpack = tunpack, _VERSION = _VERSION,
    math = TMATH, string = string, table = table, utf8 = utf8,
  }
  env.require = function(name)
    if type(name) ~= "string" then fail("require expects a module name") end
    local m = MODULES[name]
    if m == nil then
      fail(sformat("module '%s' is not available in tmpc's Lua sandbox (tmpc provides " ..
                   "'tmit-star')", name), "denied")
    end
    return m
  end
  env._G = env
  return setmetatable(env, ENV_MT)
end

-- The compatibility modules run with access to the internals they need.
local INTERNAL = V.internal
local function run_module(src, name)
  local chunk = assert(load(src, "=" .. name, "t", setmetatable({ tmpc = INTERNAL }, ENV_MT)))
  return chunk()
end

local PRELUDE = run_module(plan_src, "tmpc/planet.lua")
for k in pairs(PRELUDE) do PRELUDE_NAMES[k] = true end
MODULES["tmit-star"] = run_module(tmit_src, "tmpc/tmit-star.lua")

-------------------------------------------------------------------------------------------------
-- Loading a user file
local FUNCS = {}                 -- predicate name -> function

local function info_of(f)
  local i = getinfo(f, "uS")
  return { nparams = i.nparams, vararg = i.isvararg, line = i.linedefined }
end

-- Returns "ok", style, {name -> info} | "syntax", msg | "error", kind, msg, line
function core.load(src, label, dialect, track)
  USER["=" .. label] = true
  local env = new_env()
  if dialect ~= "tmit-star" then
    for k, v in pairs(PRELUDE) do rawset(env, k, v) end
  end
  local chunk, err = load(src, "=" .. label, "t", env)
  if not chunk then return "syntax", err end
  local ok, res = guarded(track, chunk)
  if not ok then return "error", res.kind, res.msg, res.line end
  local ret = res[2]
  local infos = {}
  if ret == nil then
    for k, v in pairs(env) do
      if type(k) == "string" and type(v) == "function" and not PRELUDE_NAMES[k]
         and getinfo(v, "S").source == "=" .. label then
        FUNCS[k] = v
        infos[k] = info_of(v)
      end
    end
    return "ok", "planet", infos
  end
  if type(ret) ~= "table" or getmt(ret) ~= nil then
    return "badreturn", V.describe(ret)
  end
  for k, v in pairs(ret) do
    if type(k) == "string" and type(v) == "function" then
      FUNCS[k] = v
      infos[k] = info_of(v)
    end
  end
  return "ok", "tmit-star", infos
end

local function call(name, nargs, dialect, args, track)
  local f = FUNCS[name]
  local ok, res = guarded(track, f, tunpack(args, 1, nargs))
  if not ok then return false, res end
  local r = res[2]
  local good, expected = V.check_result(r, dialect)
  if not good then return false, { kind = "badreturn", msg = expected .. ", got " .. V.describe(r),
                                   line = getinfo(f, "S").linedefined } end
  return true, r
end

-- Returns "ok", nodes, result id, arg kinds | kind, msg, line
function core.trace(name, nargs, dialect, track)
  V.begin("trace")
  local ok, r = call(name, nargs, dialect, V.trace_args(nargs, dialect), track)
  local text, id
  if ok then text, id = V.traced(r, dialect) end
  local kinds = V.surfaces_used(nargs)
  V.begin("plain")
  if not ok then return r.kind, r.msg, r.line end
  return "ok", text, id, kinds
end

-- Evaluate at concrete poses: flat {px py pz rx ry rz rw per argument}, boxes {lo3 hi3 | false},
-- names {string | false}. Returns "ok", distance, gradient table, arg kinds | kind, msg, line.
-- `track` locates errors precisely (slower): Python repeats a failed call with it.
function core.evaluate(name, nargs, dialect, poses, boxes, names, with_grad, track)
  V.begin("eval", with_grad and 7 * nargs or 0)
  local args = V.eval_args(nargs, dialect, poses, boxes, names)
  local ok, r = call(name, nargs, dialect, args, track)
  local v, d
  if ok then v, d = V.evaluated(r, dialect) end
  local kinds = V.surfaces_used(nargs)
  V.begin("plain")
  if not ok then return r.kind, r.msg, r.line end
  return "ok", v, d, kinds
end

return core
