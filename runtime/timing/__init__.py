"""tmpc.runtime.timing: time-optimal timing of plans (toppra) and their export as ROS
``trajectory_msgs/JointTrajectory``-shaped documents (docs/robot-export.md)."""

from tmpc.runtime.timing.limits import BASE_JOINTS as BASE_JOINTS
from tmpc.runtime.timing.limits import DEFAULT_ACCELERATION as DEFAULT_ACCELERATION
from tmpc.runtime.timing.limits import DEFAULT_VELOCITY as DEFAULT_VELOCITY
from tmpc.runtime.timing.limits import JointLimit as JointLimit
from tmpc.runtime.timing.limits import joint_limits as joint_limits
from tmpc.runtime.timing.limits import mimic_joints as mimic_joints
from tmpc.runtime.timing.parameterize import DEFAULT_DT as DEFAULT_DT
from tmpc.runtime.timing.parameterize import base_pose_values as base_pose_values
from tmpc.runtime.timing.parameterize import moving_joints as moving_joints
from tmpc.runtime.timing.parameterize import time_plan as time_plan
from tmpc.runtime.timing.parameterize import time_segment as time_segment
from tmpc.runtime.timing.timed import time_world_plan as time_world_plan
from tmpc.runtime.timing.ros import duration_msg as duration_msg
from tmpc.runtime.timing.ros import duration_seconds as duration_seconds
from tmpc.runtime.timing.ros import ros_document as ros_document
from tmpc.runtime.timing.ros import total_seconds as total_seconds
from tmpc.runtime.timing.ros import write_ros as write_ros
from tmpc.runtime.timing.limits import urdf_path as urdf_path
from tmpc.runtime.timing.ros import events as events
