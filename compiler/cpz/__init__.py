"""tmpc.compiler.cpz: constrained polynomial zonotopes (docs/math.md §C). ``sets`` holds the CPZ
type, its constructors and the closed-form operations in numpy; ``solve`` answers containment,
distance, signed distance, sampling, support and emptiness queries as batched JAX solves (JAX is
loaded on the first query, z3 by :func:`is_empty` only).
"""

from tmpc.compiler.cpz.sets import CPZ as CPZ
from tmpc.compiler.cpz.sets import affine as affine
from tmpc.compiler.cpz.sets import cartesian as cartesian
from tmpc.compiler.cpz.sets import compact as compact
from tmpc.compiler.cpz.sets import dependent as dependent
from tmpc.compiler.cpz.sets import intersect as intersect
from tmpc.compiler.cpz.sets import intersect_halfspace as intersect_halfspace
from tmpc.compiler.cpz.sets import intersect_sparse as intersect_sparse
from tmpc.compiler.cpz.sets import interval_hull as interval_hull
from tmpc.compiler.cpz.sets import lift as lift
from tmpc.compiler.cpz.sets import minkowski_sum as minkowski_sum
from tmpc.compiler.cpz.sets import translate as translate
from tmpc.compiler.cpz.sets import union as union
from tmpc.compiler.cpz.solve import contains as contains
from tmpc.compiler.cpz.solve import distance as distance
from tmpc.compiler.cpz.solve import f as f
from tmpc.compiler.cpz.solve import h as h
from tmpc.compiler.cpz.solve import inner_distance as inner_distance
from tmpc.compiler.cpz.solve import is_empty as is_empty
from tmpc.compiler.cpz.solve import monomials as monomials
from tmpc.compiler.cpz.solve import nearest as nearest
from tmpc.compiler.cpz.solve import sample as sample
from tmpc.compiler.cpz.solve import sample_uniform as sample_uniform
from tmpc.compiler.cpz.solve import signed_distance as signed_distance
from tmpc.compiler.cpz.solve import support as support
from tmpc.compiler.cpz.solve import witness as witness
