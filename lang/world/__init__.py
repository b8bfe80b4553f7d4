"""tmpc.lang.world: scene formats (native JSON, tmit-star JSON, planet XML) behind one loader
registry, run configurations, URDF robots, rotations (pure Python) and the small readers they
share.
"""

from tmpc.lang.world.configs import PARAM_CHOICES as PARAM_CHOICES
from tmpc.lang.world.configs import is_run_config as is_run_config
from tmpc.lang.world.configs import load_config as load_config
from tmpc.lang.world.configs import load_config_scene as load_config_scene
from tmpc.lang.world.loaders import LoadReport as LoadReport
from tmpc.lang.world.loaders import load_allowed_pairs as load_allowed_pairs
from tmpc.lang.world.loaders import load_scene as load_scene
from tmpc.lang.world.robot import KinematicTree as KinematicTree
from tmpc.lang.world.robot import example_robot_data_dir as example_robot_data_dir
from tmpc.lang.world.robot import find_file as find_file
from tmpc.lang.world.native import extras_json as extras_json
from tmpc.lang.world.robot import find_srdf as find_srdf
from tmpc.lang.world.robot import hand_chain as hand_chain
from tmpc.lang.world.robot import import_yourdfpy as import_yourdfpy
from tmpc.lang.world.robot import load_urdf as load_urdf
from tmpc.lang.world.robot import mesh_search_dirs as mesh_search_dirs
from tmpc.lang.world.robot import tree_from_data as tree_from_data
from tmpc.lang.world.robot import tree_to_data as tree_to_data
from tmpc.lang.world.rotations import matrix_from_quat as matrix_from_quat
from tmpc.lang.world.rotations import orthonormality_error as orthonormality_error
from tmpc.lang.world.rotations import quat_from_matrix as quat_from_matrix
from tmpc.lang.world.scene import Pose as Pose
from tmpc.lang.world.scene import RobotSpec as RobotSpec
from tmpc.lang.world.scene import RunConfig as RunConfig
from tmpc.lang.world.scene import Scene as Scene
from tmpc.lang.world.scene import SHAPE_KINDS as SHAPE_KINDS
from tmpc.lang.world.scene import Shape as Shape
from tmpc.lang.world.scene import ShapeKindError as ShapeKindError
from tmpc.lang.world.scene import collision_tolerance as collision_tolerance
from tmpc.lang.world.scene import dispatch_shape as dispatch_shape
