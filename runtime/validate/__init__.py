"""tmpc.runtime.validate: the independent plan checker. It imports no planner code: its own
kinematics (pinocchio-free URDF FK), its own fcl world and its own STRIPS simulator.
"""

from tmpc.runtime.validate.core import check_numbers as check_numbers
from tmpc.runtime.validate.core import validate_plan as validate_plan
from tmpc.runtime.validate.kinematics import Kinematics as Kinematics
from tmpc.runtime.validate.kinematics import full_joint_values as full_joint_values
from tmpc.runtime.validate.kinematics import heading as heading
from tmpc.runtime.validate.kinematics import quat_from_matrix as quat_from_matrix
from tmpc.runtime.validate.kinematics import quat_matrix as quat_matrix
from tmpc.runtime.validate.kinematics import read_urdf as read_urdf
from tmpc.runtime.validate.kinematics import scene_defaults as scene_defaults
from tmpc.runtime.validate.kinematics import straight_motion as straight_motion
from tmpc.runtime.validate.kinematics import urdf_path as urdf_path
