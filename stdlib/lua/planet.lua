-- tmpc's planet prelude: the combinators planet's predicate files call.
--
-- tmpc installs these as globals before it runs a planet-style file. Each combinator works on
-- whatever values a call sees: when tmpc traces a predicate they build IR conditions, when it
-- evaluates one directly they compute distances (to satisfaction and to violation), and on two
-- plain numbers they give a boolean, as planet's boolean prelude did.
local tmpc = tmpc
local compare, combine, negate = tmpc.compare, tmpc.combine, tmpc.negate

local P = {}

function P.True() return true end
function P.False() return false end

function P.Eq(a, b) return compare("eq", a, b) end
function P.Le(a, b) return compare("le", a, b) end
function P.Lt(a, b) return compare("lt", a, b) end
function P.Ge(a, b) return compare("ge", a, b) end
function P.Gt(a, b) return compare("gt", a, b) end

-- planet's And/Or take two conditions; any number of them is accepted here.
function P.And(...) return combine("and", ...) end
function P.Or(...) return combine("or", ...) end
function P.Not(a) return negate(a) end

return P
