-- Geometric predicates of the sort domain, in tmit-star's style: the file returns a table from
-- PDDL predicate names to functions, and each function returns a distance (0 when the predicate
-- holds). Objects carry px py pz and the quaternion rw rx ry rz; a surface carries its pose as
-- `pose` and its bounds x_low .. z_high, offsets from its position along the world axes.
-- Math that works on tmit-star's dual numbers comes from its module.
local ad_math = require('tmit-star').math
local max = ad_math.max

-- the tool frame holds a block from this far above its centre, within TOLERANCE
local HOVER = 0.05
local TOLERANCE = 0.01
-- to let go of a block, the tool frame is between these heights above a surface's bounds
local PLACE_LOW = 0.085
local PLACE_HIGH = 0.1

-- zero when both are satisfied
local function both(a, b)
  return max(a, 0.0) + max(b, 0.0)
end

-- zero when the tool frame's z axis points down within about 20 degrees
local function points_down(m)
  return max(0.97 - (m.rx ^ 2.0 + m.ry ^ 2.0), 0.0)
end

local function between(v, low, high)
  return both(low - v, v - high)
end

local function at(manipulator, object)
  local d2 = (object.px - manipulator.px) ^ 2.0 + (object.py - manipulator.py) ^ 2.0
    + (object.pz + HOVER - manipulator.pz) ^ 2.0
  return both(d2 - TOLERANCE ^ 2.0, points_down(manipulator))
end

local function above(manipulator, surface)
  local p = surface.pose
  local in_x = between(manipulator.px, p.px + surface.x_low, p.px + surface.x_high)
  local in_y = between(manipulator.py, p.py + surface.y_low, p.py + surface.y_high)
  local in_z = between(manipulator.pz, p.pz + surface.z_high + PLACE_LOW,
                       p.pz + surface.z_high + PLACE_HIGH)
  return both(both(in_x, in_y), both(in_z, points_down(manipulator)))
end

return {
  at = at,
  above = above,
}
