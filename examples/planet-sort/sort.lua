-- Geometric predicates of the sort domain, in planet's style: one global function per PDDL
-- predicate without :discrete or :kinematic, named like it. planet calls them with its objects:
-- every frame and object has a position px py pz and an orientation quaternion rx ry rz rw;
-- a surface also has sssp.region.{x,y,z}.{low,high}, its support region in its own frame.
-- Le, Ge and And are the combinators of planet's prelude; math is rebound by the planner when it
-- needs gradients, so take what is needed from it at load time.

local And = And
local Le = Le
local Ge = Ge

-- the gripper holds a block from just above it: its tool frame this far over the block's centre
HOVER = 0.05
AT_TOLERANCE = 0.01
-- to put a block down, the tool frame is between these heights over the support region: a 5 cm
-- block held within AT_TOLERANCE of HOVER below it then ends between 0 and 3.5 cm over it
PLACE_LOW = 0.085
PLACE_HIGH = 0.1

-- the tool frame's z axis points down, within about 20 degrees: the z component of the rotated
-- z axis is 1 - 2 (rx^2 + ry^2)
local function points_down(m)
  return Ge(m.rx ^ 2.0 + m.ry ^ 2.0, 0.97)
end

-- (at ?m ?x): the manipulator is in position to hold the block
function at(m, x)
  local d2 = (m.px - x.px) ^ 2.0 + (m.py - x.py) ^ 2.0 + (m.pz - x.pz - HOVER) ^ 2.0
  return And(Le(d2, AT_TOLERANCE ^ 2.0), points_down(m))
end

-- (above ?m ?s): the manipulator is over the surface's support region, low enough to let go
function above(m, s)
  local r = s.sssp.region
  local in_x = And(Ge(m.px, s.px + r.x.low), Le(m.px, s.px + r.x.high))
  local in_y = And(Ge(m.py, s.py + r.y.low), Le(m.py, s.py + r.y.high))
  local top = s.pz + r.z.high
  local in_z = And(Ge(m.pz, top + PLACE_LOW), Le(m.pz, top + PLACE_HIGH))
  return And(And(in_x, in_y), And(in_z, points_down(m)))
end
