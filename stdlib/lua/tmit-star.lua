-- tmpc's stand-in for tmit-star's Lua module, served by `require('tmit-star')`.
--
-- tmit-star's predicate files take `.dual` (a dual-number constructor) and `.math` (math that
-- accepts dual numbers) from it. Here `.math` is tmpc's dispatching math library (the same table
-- as the sandbox's `math`): it records IR while tmpc traces a predicate and differentiates while
-- tmpc evaluates one directly. `.dual(x)` turns a constant into a value of the current kind.
-- tmit-star's `dist` and `grad` wrapped predicates for its C++ side; tmpc calls predicates
-- itself, so they are not provided.
local tmpc = tmpc

return {
  dual = tmpc.dual,
  math = tmpc.math,
}
