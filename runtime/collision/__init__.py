"""tmpc.runtime.collision: the python-fcl collision world of a scene, its geometry, and the sound
batched bounding-sphere first pass.
"""

from tmpc.runtime.collision.batch import CHUNK as CHUNK
from tmpc.runtime.collision.batch import PAD_SIZES as PAD_SIZES
from tmpc.runtime.collision.batch import pad_batch as pad_batch
from tmpc.runtime.collision.exact import aabbs as aabbs
from tmpc.runtime.collision.floor import FloorMap as FloorMap
from tmpc.runtime.collision.floor import floor_bounds as floor_bounds
from tmpc.runtime.collision.kernel import prepare_kernel as prepare_kernel
from tmpc.runtime.collision.world import CollisionWorld as CollisionWorld
from tmpc.runtime.collision.world import collision_world as collision_world
