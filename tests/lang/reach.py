"""PR2 arm reach for the tests of the kitchen reconstruction: forward kinematics of one arm
from the URDF (numpy, independent of the compiler's kernels) and a damped least-squares
inverse kinematics for a gripper pose."""

from __future__ import annotations

import math

import numpy as np

from tmpc.lang.world import KinematicTree, Scene, load_urdf


def rot_z(theta: float) -> np.ndarray:
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _axis_angle(axis, angle: float) -> np.ndarray:
    k = np.asarray(axis, float)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


class Arm:
    """The chain from the robot's root to ``tip``; ``fk(q)`` is the tip's 4x4 pose in the world
    for the arm's joint values ``q`` (other joints at the scene's values)."""

    def __init__(self, scene: Scene, tip: str):
        tree: KinematicTree = load_urdf(scene.robot.urdf)
        by_child = {j.child: j for j in tree.joints}
        chain, link = [], tip
        while link in by_child:
            chain.append(by_child[link])
            link = by_child[link].parent
        self.chain = chain[::-1]
        self.values = dict(scene.robot.joint_values)
        self.active = [j for j in self.chain if j.type in ("revolute", "continuous")
                       and j.mimic is None and not j.name.startswith("torso")]
        self.lower = np.array([j.lower if j.lower is not None and j.type == "revolute"
                               else -math.pi for j in self.active])
        self.upper = np.array([j.upper if j.upper is not None and j.type == "revolute"
                               else math.pi for j in self.active])
        b = scene.robot.base_pose
        x, y, z, w = b.rotation
        R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                      [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                      [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
        self.base = np.eye(4)
        self.base[:3, :3], self.base[:3, 3] = R, b.translation
        self.base0 = self.base.copy()

    def q0(self) -> np.ndarray:
        return np.array([min(max(self.values.get(j.name, 0.0), lo), hi)
                         for j, lo, hi in zip(self.active, self.lower, self.upper)])

    def fk(self, q) -> np.ndarray:
        T = self.base.copy()
        values = dict(self.values)
        values.update({j.name: v for j, v in zip(self.active, q)})
        for j in self.chain:
            T = T @ np.asarray(j.origin, float)
            if j.type in ("revolute", "continuous"):
                M = np.eye(4)
                M[:3, :3] = _axis_angle(j.axis, values.get(j.name, 0.0))
                T = T @ M
            elif j.type == "prismatic":
                M = np.eye(4)
                M[:3, 3] = np.asarray(j.axis) * values.get(j.name, 0.0)
                T = T @ M
        return T

    def ik(self, target: np.ndarray, q=None, iters: int = 200) -> tuple[np.ndarray, float]:
        """Joint values bringing the tip to the 4x4 ``target`` (position and orientation), and
        the remaining error (metres + radians)."""
        q = self.q0() if q is None else np.array(q, float)
        err = 1e9
        for _ in range(iters):
            e = self._error(self.fk(q), target)
            err = float(np.linalg.norm(e[:3]) + np.linalg.norm(e[3:]))
            if err < 1e-4:
                break
            J = np.zeros((6, len(q)))
            for i in range(len(q)):
                dq = np.zeros(len(q))
                dq[i] = 1e-6
                J[:, i] = (self._error(self.fk(q + dq), target) - e) / -1e-6
            step = J.T @ np.linalg.solve(J @ J.T + 1e-3 * np.eye(6), e)
            q = np.clip(q + step, self.lower, self.upper)
        return q, err

    @staticmethod
    def _error(T: np.ndarray, target: np.ndarray) -> np.ndarray:
        dp = target[:3, 3] - T[:3, 3]
        return np.concatenate([dp, rotation_log(target[:3, :3] @ T[:3, :3].T)])


def rotation_log(R: np.ndarray) -> np.ndarray:
    """The rotation vector (axis times angle) of ``R``, also near a half turn (where the skew
    part alone vanishes and an inverse kinematics would stop at a flipped gripper)."""
    angle = math.acos(max(-1.0, min(1.0, (np.trace(R) - 1) / 2)))
    skew = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    if angle < 1e-9:
        return 0.5 * skew
    if angle > math.pi - 1e-3:
        i = int(np.argmax(np.diag(R)))
        axis = (R[:, i] + np.eye(3)[i]) / math.sqrt(2 * (1 + R[i, i]))
        return axis * angle
    return skew * angle / (2 * math.sin(angle))


def side_grasp_reachable(arm: Arm, point, yaws, tol: float = 2e-3,
                         restarts: int = 4) -> float | None:
    """The first approach yaw (world frame) from which the tip reaches ``point`` with a
    horizontal gripper (tool x along the yaw, z up), or None (from the arm's start, the middle
    of its joint ranges and ``restarts`` seeded random starts)."""
    rng = np.random.default_rng(0)
    starts = [arm.q0(), (arm.lower + arm.upper) / 2] + \
        [rng.uniform(arm.lower, arm.upper) for _ in range(restarts)]
    for yaw in yaws:
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = rot_z(yaw), point
        for start in starts:
            _, err = arm.ik(T, start)
            if err < tol:
                return yaw
    return None


def place_base(arm: Arm, point, facing: float, ahead: float = 0.6, aside: float = -0.1) -> None:
    """Stand the robot's base (on its floor) so that ``point`` is ``ahead`` metres in front of
    it and ``aside`` to its left, facing the yaw ``facing``."""
    c, s = math.cos(facing), math.sin(facing)
    x = point[0] - c * ahead + s * aside
    y = point[1] - s * ahead - c * aside
    arm.base[:3, :3] = rot_z(facing) @ arm.base0[:3, :3]
    arm.base[:3, 3] = (x, y, arm.base0[2, 3])


def footprint(obj_box, pose) -> tuple[float, float, float, float]:
    """The world x-y box (xmin, xmax, ymin, ymax) of a mesh's bounds ``obj_box`` (lower, upper)
    under an unrotated pose."""
    (x0, y0, _), (x1, y1, _) = obj_box
    tx, ty, _ = pose.translation
    return (x0 + tx, x1 + tx, y0 + ty, y1 + ty)


#: the PR2 base's half size (m) and the gap kept to furniture
BASE_HALF, BASE_GAP = 0.335, 0.03


def reach_from_a_side(arm: Arm, point, box, facings, grasp_aside: float = -0.1) -> float | None:
    """Stand the base before the furniture footprint ``box`` (xmin, xmax, ymin, ymax), facing
    each yaw of ``facings`` in turn (0: the base looks along +x at the box's -x side, ...),
    clear of the box, with ``point`` ahead of the right arm; the approach yaw of a horizontal
    side grasp that reaches it, else None."""
    x0, x1, y0, y1 = box
    depth = {0.0: point[0] - x0, math.pi: x1 - point[0], math.pi / 2: point[1] - y0,
             -math.pi / 2: y1 - point[1]}
    for facing in facings:
        ahead = max(0.6, BASE_HALF + BASE_GAP + depth[facing])
        if ahead > 0.8:
            continue
        place_base(arm, point, facing, ahead, grasp_aside)
        yaw = side_grasp_reachable(arm, point, [facing, facing + 0.3, facing - 0.3], restarts=2)
        if yaw is not None:
            return yaw
    return None
