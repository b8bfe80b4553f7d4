-- tmpc's Lua values: the tracer (IR-recording proxies), dual numbers, `math`, the condition
-- combinators and predicate arguments. Trusted: sandbox.lua loads it with the full standard
-- library and passes its error helpers; user code only meets the values it makes.
--
-- Values a predicate function can meet:
--   number            a constant
--   traced number     (trace mode) a scalar IR node; arithmetic and `math` record IR
--   traced condition  (trace mode) a bool IR node, made by the planet combinators
--   name              (trace mode) an argument's identity, for Eq(a.name, b.name)
--   dual              (evaluation mode) value `v` and gradient `d` (array) w.r.t. the poses
--   dual condition    (evaluation mode) distances to satisfaction `t` and to violation `f`
--   boolean           a constant condition (True(), False(), a comparison of two numbers)
local fail, untraceable = ...

local type, select, setmetatable, rawget, rawset, tostring, pairs =
  type, select, setmetatable, rawget, rawset, tostring, pairs
local sformat, sfind, tconcat = string.format, string.find, table.concat
local M = math
local getmt = debug.getmetatable

local BIG = 1e6          -- the distance of a condition that cannot hold (as the JAX backend)
local V = {}

-------------------------------------------------------------------------------------------------
-- IR nodes, hash-consed; serialized one per line as "op vtype child-ids..." for Python.
local NODES, INDEX, NN

local function reset_nodes() NODES, INDEX, NN = {}, {}, 0 end
reset_nodes()

local function intern(key, op, args)
  local id = INDEX[key]
  if id then return id end
  NN = NN + 1
  INDEX[key] = NN
  NODES[NN] = { key = key, op = op, args = args }
  return NN
end

local function const(x) return intern(sformat("const %.17g", x), "const") end
local function bool_const(b) return intern(b and "bool 1" or "bool 0", "bool") end
local function arg_node(i) return intern("arg " .. i, "arg") end
local function entity_node(name) return intern("entity " .. name, "entity") end

local function op(name, vtype, args)
  return intern(name .. " " .. vtype .. " " .. tconcat(args, " "), name, args)
end

-- n-ary and/or, flattening nested ones (same value under both l2 and max semantics)
local function nary(name, ids)
  local flat = {}
  for _, id in pairs(ids) do
    local n = NODES[id]
    if n.op == name then
      for _, c in pairs(n.args) do flat[#flat + 1] = c end
    else
      flat[#flat + 1] = id
    end
  end
  if #flat == 1 then return flat[1] end
  return op(name, "bool", flat)
end

local function serialize()
  local lines = {}
  for i = 1, NN do lines[i] = NODES[i].key end
  return tconcat(lines, "\n")
end

-------------------------------------------------------------------------------------------------
-- Value kinds
local SCAL = { __metatable = "tmpc traced number", __name = "traced number" }
local COND = { __metatable = "tmpc condition", __name = "condition" }
local NAME = { __metatable = "tmpc object name", __name = "object name" }
local DUAL = { __metatable = "tmpc dual", __name = "dual" }
local DCOND = { __metatable = "tmpc condition", __name = "condition" }
local ID = setmetatable({}, { __mode = "k" })   -- traced value -> node id, arg index, ...
local EMPTY = {}                                   -- the zero gradient (never written)
local MODE, NGRAD = "plain", 0

local function kind(x)
  local t = type(x)
  if t == "number" then return "n" end
  if t == "table" then
    local mt = getmt(x)
    if mt == SCAL then return "s" elseif mt == DUAL then return "d"
    elseif mt == COND or mt == DCOND then return "c" elseif mt == NAME then return "name" end
  end
  return t
end

local DESCRIBE = { n = "a number", s = "a traced number", d = "a number", c = "a condition",
                   name = "an object name" }
local function describe(x)
  local k = kind(x)
  if DESCRIBE[k] then return DESCRIBE[k] end
  if k == "nil" then return "nil" end
  return "a " .. k
end

local function TS(id) local p = setmetatable({}, SCAL); ID[p] = id; return p end
local function TC(id) local p = setmetatable({}, COND); ID[p] = id; return p end
local function D(v, d) return setmetatable({ v = v, d = d }, DUAL) end

-- node id of a number or traced number (trace mode)
local function sid(x, what)
  local k = kind(x)
  if k == "s" then return ID[x] end
  if k == "n" then return const(x) end
  if k == "c" then fail((what or "arithmetic") .. " on a condition (a combinator's result)") end
  if k == "name" then untraceable((what or "arithmetic") .. " on an object name") end
  fail((what or "arithmetic") .. " on " .. describe(x))
end

-- value and gradient of a number or dual (evaluation mode)
local function vd(x, what)
  local k = kind(x)
  if k == "n" then return x, EMPTY end
  if k == "d" then return rawget(x, "v"), rawget(x, "d") end
  if k == "c" then fail((what or "arithmetic") .. " on a condition (a combinator's result)") end
  fail((what or "arithmetic") .. " on " .. describe(x))
end

-- a * da + b * db, skipping zero terms so an infinite coefficient times a zero stays 0
local function lin(a, da, b, db)
  local d = {}
  for i = 1, NGRAD do
    local g, u, w = 0, da[i], db[i]
    if u and u ~= 0 then g = g + a * u end
    if w and w ~= 0 then g = g + b * w end
    d[i] = g
  end
  return d
end

-------------------------------------------------------------------------------------------------
-- Arithmetic: numbers compute, traced numbers record, duals differentiate.
local NUM2 = {
  add = function(a, b) return a + b end, sub = function(a, b) return a - b end,
  mul = function(a, b) return a * b end, div = function(a, b) return a / b end,
  pow = function(a, b) return a ^ b end,
  min = function(a, b) return a <= b and a or b end,
  max = function(a, b) return a >= b and a or b end,
  atan2 = function(a, b) return M.atan(a, b) end,
}

-- (value, coefficient of da, coefficient of db)
local DUAL2 = {
  add = function(a, b) return a + b, 1, 1 end,
  sub = function(a, b) return a - b, 1, -1 end,
  mul = function(a, b) return a * b, b, a end,
  div = function(a, b) return a / b, 1 / b, -a / (b * b) end,
  pow = function(a, b)
    local v = a ^ b
    local db = 0
    if a > 0 then db = v * M.log(a) end
    return v, (b == 0) and 0 or b * a ^ (b - 1), db
  end,
  atan2 = function(y, x)
    local r = x * x + y * y
    if r == 0 then return 0, 0, 0 end
    return M.atan(y, x), x / r, -y / r
  end,
}

local WHAT = { add = "arithmetic", sub = "arithmetic", mul = "arithmetic", div = "arithmetic",
               pow = "arithmetic", min = "math.min", max = "math.max", atan2 = "math.atan" }

local function binary(name, a, b)
  local ka, kb = kind(a), kind(b)
  if ka == "n" and kb == "n" then return NUM2[name](a, b) end
  local what = WHAT[name]
  if ka == "s" or kb == "s" then
    return TS(op(name, "scalar", { sid(a, what), sid(b, what) }))
  end
  local av, da = vd(a, what)
  local bv, db = vd(b, what)
  if name == "min" or name == "max" then
    local first = (name == "min") == (av <= bv)
    return first and a or b
  end
  local v, ca, cb = DUAL2[name](av, bv)
  return D(v, lin(ca, da, cb, db))
end

local function sqrt_d(v) return v > 0 and 0.5 / M.sqrt(v) or 0 end    -- sqrt'(0) := 0
local function sign(v) return v > 0 and 1 or (v < 0 and -1 or 0) end

-- name -> {numeric function, derivative (nil: no IR operator, tracing gives up)}
local UNARY = {
  sqrt = { M.sqrt, sqrt_d },
  abs = { M.abs, sign },
  exp = { M.exp, M.exp },
  log = { M.log, function(v) return 1 / v end },
  sin = { M.sin, M.cos },
  cos = { M.cos, function(v) return -M.sin(v) end },
  tan = { M.tan, function(v) local t = M.tan(v); return 1 + t * t end },
  asin = { M.asin, function(v) return 1 / M.sqrt(1 - v * v) end },
  acos = { M.acos, function(v) return -1 / M.sqrt(1 - v * v) end },
  floor = { M.floor, function() return 0 end, untraced = true },
  ceil = { M.ceil, function() return 0 end, untraced = true },
}

local function unary(name, x)
  local k = kind(x)
  local u = UNARY[name]
  if k == "n" then return u[1](x) end
  if k == "s" then
    if u.untraced then untraceable("math." .. name .. " of a traced value has no IR operator") end
    return TS(op(name, "scalar", { ID[x] }))
  end
  local v, d = vd(x, "math." .. name)
  return D(u[1](v), lin(u[2](v), d, 0, EMPTY))
end

SCAL.__add = function(a, b) return binary("add", a, b) end
SCAL.__sub = function(a, b) return binary("sub", a, b) end
SCAL.__mul = function(a, b) return binary("mul", a, b) end
SCAL.__div = function(a, b) return binary("div", a, b) end
SCAL.__pow = function(a, b) return binary("pow", a, b) end
SCAL.__unm = function(a) return TS(op("neg", "scalar", { ID[a] })) end
SCAL.__tostring = function() return "<traced number>" end
local function branch() untraceable("compares a traced value with `<`, `<=`, `>` or `>=` " ..
                                    "(a branch on the state)") end
SCAL.__lt, SCAL.__le = branch, branch
SCAL.__eq = function() untraceable("compares traced values with `==` or `~=`") end
SCAL.__index = function(_, key)
  untraceable(sformat("reads field %s of a number", tostring(key)))
end
SCAL.__newindex = function() fail("assigns a field of a number") end
for _, mm in pairs({ "mod", "idiv", "concat", "len", "call", "band", "bor", "bxor", "shl", "shr",
                     "bnot", "close" }) do
  SCAL["__" .. mm] = function() untraceable("applies `" .. mm .. "` to a traced value") end
end

DUAL.__add = SCAL.__add
DUAL.__sub = SCAL.__sub
DUAL.__mul = SCAL.__mul
DUAL.__div = SCAL.__div
DUAL.__pow = SCAL.__pow
DUAL.__unm = function(a) return D(-a.v, lin(-1, a.d, 0, EMPTY)) end
DUAL.__lt = function(a, b) return vd(a, "`<`") < vd(b, "`<`") end
DUAL.__le = function(a, b) return vd(a, "`<=`") <= vd(b, "`<=`") end
DUAL.__eq = function(a, b) return vd(a) == vd(b) end
DUAL.__mod = function(a, b)
  local av, da = vd(a, "`%`")
  local bv, db = vd(b, "`%`")
  local q = M.floor(av / bv)
  return D(av - q * bv, lin(1, da, -q, db))
end
DUAL.__idiv = function(a, b) return M.floor(vd(a, "`//`") / vd(b, "`//`")) end
DUAL.__tostring = function(a) return sformat("dual(%.17g)", a.v) end
DUAL.__newindex = function() fail("assigns a field of a number") end
for _, mm in pairs({ "concat", "len", "call", "band", "bor", "bxor", "shl", "shr", "bnot" }) do
  DUAL["__" .. mm] = function() fail("applies `" .. mm .. "` to a number") end
end

local function cond_misuse() fail("uses a condition (the result of a combinator) as a value") end
for _, t in pairs({ COND, DCOND }) do
  for _, mm in pairs({ "add", "sub", "mul", "div", "mod", "pow", "unm", "idiv", "concat", "len",
                       "call", "lt", "le", "index", "newindex", "band", "bor", "bxor", "shl",
                       "shr", "bnot" }) do
    t["__" .. mm] = cond_misuse
  end
  t.__tostring = function() return "<condition>" end
end
NAME.__eq = function()
  untraceable("compares object names with `==` (Eq(a.name, b.name) traces)")
end
NAME.__concat = function() untraceable("builds a string from an object name") end
NAME.__index = function() untraceable("indexes an object name") end
NAME.__tostring = function() return "<object name>" end

-------------------------------------------------------------------------------------------------
-- `math`: the same names as Lua's, dispatching on the kind of value.
local TMATH = { pi = M.pi, huge = M.huge, maxinteger = M.maxinteger, mininteger = M.mininteger }
for name in pairs(UNARY) do TMATH[name] = function(x) return unary(name, x) end end

local function fold(name)
  return function(a, ...)
    local n = select("#", ...)
    if n == 0 then fail("math." .. name .. " needs at least two arguments") end
    local acc = a
    for i = 1, n do acc = binary(name, acc, (select(i, ...))) end
    return acc
  end
end
TMATH.min, TMATH.max = fold("min"), fold("max")
TMATH.pow = function(a, b) return binary("pow", a, b) end
TMATH.atan2 = function(y, x) return binary("atan2", y, x) end
TMATH.atan = function(y, x) return binary("atan2", y, x == nil and 1 or x) end
TMATH.log = function(x, base)
  if base == nil then return unary("log", x) end
  return binary("div", unary("log", x), unary("log", base))
end
TMATH.fmod = function(a, b)
  if kind(a) == "n" and kind(b) == "n" then return M.fmod(a, b) end
  if kind(a) == "s" or kind(b) == "s" then
    untraceable("math.fmod of a traced value has no IR operator")
  end
  local av, da = vd(a, "math.fmod")
  local bv, db = vd(b, "math.fmod")
  local q = (av / bv >= 0) and M.floor(av / bv) or M.ceil(av / bv)
  return D(av - q * bv, lin(1, da, -q, db))
end
TMATH.tointeger = function(x)
  if kind(x) == "n" then return M.tointeger(x) end
  if kind(x) == "s" then untraceable("math.tointeger of a traced value") end
  return nil
end
TMATH.type = function(x)
  local k = kind(x)
  if k == "n" then return M.type(x) end
  if k == "s" or k == "d" then return "float" end
  return nil
end

-------------------------------------------------------------------------------------------------
-- Conditions (the planet combinators call these)
local function dcond(t, f) return setmetatable({ t = t, f = f }, DCOND) end

local function as_pair(c, who)
  if c == true then return 0, BIG end
  if c == false then return BIG, 0 end
  if type(c) == "table" and getmt(c) == DCOND then return rawget(c, "t"), rawget(c, "f") end
  fail(who .. " expects conditions (results of Eq, Le, Lt, Ge, Gt, And, Or, Not, True, False), got "
       .. describe(c))
end

local function cond_id(c, who)
  if c == true or c == false then return bool_const(c) end
  if type(c) == "table" and getmt(c) == COND then return ID[c] end
  fail(who .. " expects conditions (results of Eq, Le, Lt, Ge, Gt, And, Or, Not, True, False), got "
       .. describe(c))
end

local function pos(x) return binary("max", x, 0) end

local function l2(ts)
  local acc = 0
  for _, t in pairs(ts) do acc = binary("add", acc, binary("pow", pos(t), 2)) end
  return unary("sqrt", acc)
end

local function minimum(ts)
  local acc = ts[1]
  for i = 2, #ts do acc = binary("min", acc, ts[i]) end
  return acc
end

local CMP_NUM = {
  le = function(a, b) return a <= b end, lt = function(a, b) return a < b end,
  ge = function(a, b) return a >= b end, gt = function(a, b) return a > b end,
  eq = function(a, b) return a == b end,
}

local function entity_of(x, who)
  if kind(x) == "name" then return arg_node(ID[x]) end
  if type(x) == "string" and not sfind(x, "%s") and x ~= "" then return entity_node(x) end
  fail(who .. " compares an object name with " .. describe(x))
end

local function compare(name, a, b)
  local who = ({ le = "Le", lt = "Lt", ge = "Ge", gt = "Gt", eq = "Eq" })[name]
  local ka, kb = kind(a), kind(b)
  if name == "eq" and (ka == "name" or kb == "name") then
    return TC(op("same", "bool", { entity_of(a, who), entity_of(b, who) }))
  end
  if name == "eq" and type(a) == "string" and type(b) == "string" then return a == b end
  if ka == "n" and kb == "n" then return CMP_NUM[name](a, b) end
  if ka == "s" or kb == "s" then return TC(op(name, "bool", { sid(a, who), sid(b, who) })) end
  local d = binary("sub", a, b)                          -- a - b
  if name == "eq" then return dcond(unary("abs", d), 0) end
  if name == "le" or name == "lt" then return dcond(pos(d), pos(binary("sub", 0, d))) end
  return dcond(pos(binary("sub", 0, d)), pos(d))
end

local function combine(name, ...)
  local who = name == "and" and "And" or "Or"
  local n = select("#", ...)
  if n == 0 then fail(who .. " needs at least one argument") end
  local absorbing = name == "or"              -- a constant that decides the result
  local parts = {}
  for i = 1, n do
    local c = select(i, ...)
    if c == absorbing then return absorbing end
    if c ~= not absorbing then parts[#parts + 1] = c end
  end
  if #parts == 0 then return not absorbing end
  if MODE == "trace" then
    local ids = {}
    for i, c in pairs(parts) do ids[i] = cond_id(c, who) end
    return TC(nary(name, ids))
  end
  local ts, fs = {}, {}
  for i, c in pairs(parts) do ts[i], fs[i] = as_pair(c, who) end
  if name == "and" then return dcond(l2(ts), minimum(fs)) end
  return dcond(minimum(ts), l2(fs))
end

local function negate(c)
  if c == true or c == false then return not c end
  if MODE == "trace" then return TC(op("not", "bool", { cond_id(c, "Not") })) end
  local t, f = as_pair(c, "Not")
  return dcond(f, t)
end

-------------------------------------------------------------------------------------------------
-- Arguments: trace proxies and evaluation objects. Field access is recorded per argument.
local SURFACE_USED = {}          -- argument index (0-based) -> true when support fields are read
local AXES = { x = 0, y = 1, z = 2 }
local POSE_FIELDS = { px = { "p", 0 }, py = { "p", 1 }, pz = { "p", 2 },
                      rx = { "q", 0 }, ry = { "q", 1 }, rz = { "q", 2 }, rw = { "q", 3 } }
local TMIT_BOUNDS = { x_low = { 0, "lower" }, x_high = { 0, "upper" }, y_low = { 1, "lower" },
                      y_high = { 1, "upper" }, z_low = { 2, "lower" }, z_high = { 2, "upper" } }
local PLANET_HELP = "planet objects have px py pz rx ry rz rw name sssp"
local TMIT_HELP = "tmit-star objects have px py pz rw rx ry rz; surfaces pose x_low x_high " ..
  "y_low y_high z_low z_high"

local function readonly() fail("assigns a field of a predicate argument (they are read-only)") end

-- A table whose fields come from `get(key)` (cached); unknown keys are errors.
local FIELDS = {}
local function lazy(get, label)
  local t = setmetatable({}, FIELDS)
  ID[t] = { get = get, label = label }
  return t
end
FIELDS.__metatable = "tmpc object"
FIELDS.__index = function(t, key)
  local v = ID[t].get(key)
  if v == nil then
    fail(sformat("unknown field `%s` of %s", tostring(key), ID[t].label), "field")
  end
  rawset(t, key, v)
  return v
end
FIELDS.__newindex = readonly
FIELDS.__tostring = function(t) return "<" .. ID[t].label .. ">" end

-- The value sources: trace mode builds IR, evaluation mode reads numbers.
local function trace_source(i)
  local a = arg_node(i)
  local pose = op("pose", "transform", { a })
  local vec = { p = op("position", "vec3", { pose }), q = op("orientation", "quat", { pose }) }
  local src = {}
  function src.pose(f) return TS(op("component", "scalar", { vec[f[1]], const(f[2]) })) end
  function src.name() local p = setmetatable({}, NAME); ID[p] = i; return p end
  function src.local_bound(axis, side)        -- planet: support box in the object frame
    local box = op("support_local", "box", { a })
    return TS(op("component", "scalar", { op(side, "vec3", { box }), const(axis) }))
  end
  function src.world_offset(axis, side)       -- tmit-star: world-aligned box minus position
    local box = op("support", "box", { a })
    local b = op("component", "scalar", { op(side, "vec3", { box }), const(axis) })
    return TS(op("sub", "scalar", { b, op("component", "scalar", { vec.p, const(axis) }) }))
  end
  return src
end

local function quat_R(q)   -- rotation matrix rows of a quaternion (x, y, z, w) of duals
  local x, y, z, w = q[1], q[2], q[3], q[4]
  local function m(a, b) return binary("mul", a, b) end
  local function s(a, b) return binary("add", a, b) end
  local function two(v) return binary("mul", 2, v) end
  return {
    { binary("sub", 1, two(s(m(y, y), m(z, z)))), two(binary("sub", m(x, y), m(z, w))),
      two(s(m(x, z), m(y, w))) },
    { two(s(m(x, y), m(z, w))), binary("sub", 1, two(s(m(x, x), m(z, z)))),
      two(binary("sub", m(y, z), m(x, w))) },
    { two(binary("sub", m(x, z), m(y, w))), two(s(m(y, z), m(x, w))),
      binary("sub", 1, two(s(m(x, x), m(y, y)))) },
  }
end

local function eval_source(i, p, q, box, name)
  local src = {}
  local function need_box()
    if not box then fail(sformat("argument %d has no support region", i + 1), "field") end
    return box
  end
  function src.pose(f) return (f[1] == "p" and p or q)[f[2] + 1] end
  function src.name()
    if name == nil then fail(sformat("the name of argument %d is not known here", i + 1)) end
    return name
  end
  function src.local_bound(axis, side)
    local b = need_box()
    return b[(side == "lower" and 0 or 3) + axis + 1]
  end
  local R
  function src.world_offset(axis, side)   -- sum over the box's axes of the extreme R * corner
    local b = need_box()
    R = R or quat_R(q)
    local acc = 0
    for j = 1, 3 do
      local lo, hi = binary("mul", R[axis + 1][j], b[j]), binary("mul", R[axis + 1][j], b[j + 3])
      acc = binary("add", acc, binary(side == "lower" and "min" or "max", lo, hi))
    end
    return acc
  end
  return src
end

local function argument(i, dialect, src)
  local label = sformat("argument %d", i + 1)
  local function pose_get(key)
    local f = POSE_FIELDS[key]
    return f and src.pose(f)
  end
  if dialect == "planet" then
    local function axis_table(k)
      return lazy(function(side)
        if side == "low" or side == "high" then
          SURFACE_USED[i] = true
          return src.local_bound(k, side == "low" and "lower" or "upper")
        end
      end, label .. "'s sssp.region." .. ({ "x", "y", "z" })[k + 1] .. " (it has low high)")
    end
    local region = lazy(function(key)
      local k = AXES[key]
      return k and axis_table(k)
    end, label .. "'s sssp.region (it has x y z)")
    local sssp = lazy(function(key)
      if key == "region" then return region end
      if key == "plane" then
        fail("`sssp.plane` (a planet iterator) is not supported by tmpc", "field")
      end
    end, label .. "'s sssp (tmpc supports sssp.region)")
    return lazy(function(key)
      if key == "name" then return src.name() end
      if key == "sssp" then return sssp end
      if key == "sop" or key == "grasps" then
        fail(sformat("`%s` (a planet iterator) is not supported by tmpc", key), "field")
      end
      return pose_get(key)
    end, label .. " (" .. PLANET_HELP .. ")")
  end
  local pose = lazy(pose_get, label .. "'s pose (it has px py pz rw rx ry rz)")
  return lazy(function(key)
    if key == "pose" then SURFACE_USED[i] = true; return pose end
    local b = TMIT_BOUNDS[key]
    if b then SURFACE_USED[i] = true; return src.world_offset(b[1], b[2]) end
    return pose_get(key)
  end, label .. " (" .. TMIT_HELP .. ")")
end

local function surfaces_used(n)
  local out = {}
  for i = 0, n - 1 do out[i + 1] = SURFACE_USED[i] and "surface" or "object" end
  return tconcat(out, " ")
end

-------------------------------------------------------------------------------------------------
-- Modes, results and the module's exports

-- tmit-star's `dual(x)`: a constant as a value of the current kind
local function dual(v, d)
  if d ~= nil and d ~= 0 then fail("dual(v, d) with a derivative is not supported by tmpc") end
  local k = kind(v)
  if k == "n" then return MODE == "eval" and D(v, EMPTY) or v end
  if k == "s" or k == "d" then return v end
  fail("dual expects a number, got " .. describe(v))
end

-- Start a call: "trace" (proxies) or "eval" (duals with `ngrad` gradient entries); "plain" after.
function V.begin(mode, ngrad)
  MODE, NGRAD, SURFACE_USED = mode, ngrad or 0, {}
  reset_nodes()
end

-- The arguments of a traced call
function V.trace_args(nargs, dialect)
  local args = {}
  for i = 1, nargs do args[i] = argument(i - 1, dialect, trace_source(i - 1)) end
  return args
end

-- The arguments of an evaluation: flat poses (7 per argument), boxes and names per argument.
function V.eval_args(nargs, dialect, poses, boxes, names)
  local args = {}
  for i = 0, nargs - 1 do
    local p, q = {}, {}
    for k = 1, 7 do
      local d = EMPTY
      if NGRAD > 0 then d = {}; for j = 1, NGRAD do d[j] = 0 end; d[7 * i + k] = 1 end
      local x = D(poses[7 * i + k], d)
      if k <= 3 then p[k] = x else q[k - 3] = x end
    end
    args[i + 1] = argument(i, dialect, eval_source(i, p, q, boxes[i + 1] or nil,
                                                   names[i + 1] or nil))
  end
  return args
end

-- Is `r` the right kind of result? (true | false, what was expected)
function V.check_result(r, dialect)
  if dialect == "planet" then
    if r == true or r == false then return true end
    if type(r) == "table" and (getmt(r) == COND or getmt(r) == DCOND) then return true end
    return false, "planet predicates return a condition (Eq, Le, Lt, Ge, Gt, And, Or, Not, " ..
      "True, False)"
  end
  local k = kind(r)
  if k == "n" or k == "s" or k == "d" then return true end
  return false, "tmit-star predicates return a distance (a number)"
end

-- A traced result: serialized nodes and the result's id
function V.traced(r, dialect)
  local id = dialect == "planet" and cond_id(r, "return") or sid(r)
  return serialize(), id
end

-- An evaluated result: distance and gradient
function V.evaluated(r, dialect)
  if dialect == "planet" then r = as_pair(r, "return") end
  return vd(r)
end

V.describe, V.surfaces_used, V.math = describe, surfaces_used, TMATH
V.internal = { compare = compare, combine = combine, negate = negate, math = TMATH, dual = dual }

return V
