"""Pure-Python kinematics core: PoE robot model, FK, Jacobians, analysis, IK. Never imports rclpy.

Conventions: twists and Jacobian rows (ω, v) as in Modern Robotics; quaternions (x, y, z, w);
lengths in m, angles in rad. See docs/conventions.md.
"""

from . import rotations, se3, so3
from .analysis import (
    condition_number,
    is_near_singular,
    manipulability,
    manipulability_ellipsoid,
)
from .chain import ChainSpec, JointModel, SerialChain
from .exceptions import (
    InvalidInputError,
    KinematicsError,
    RobotDescriptionError,
    UnknownNameError,
)
from .ik import IKBatchResult, IKOptions, IKResult

__all__ = [
    "ChainSpec",
    "IKBatchResult",
    "IKOptions",
    "IKResult",
    "InvalidInputError",
    "JointModel",
    "KinematicsError",
    "RobotDescriptionError",
    "SerialChain",
    "UnknownNameError",
    "condition_number",
    "is_near_singular",
    "manipulability",
    "manipulability_ellipsoid",
    "rotations",
    "se3",
    "so3",
]
