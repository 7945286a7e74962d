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
from .closed_form import ClosedFormBatchResult, ClosedFormFamily, ClosedFormResult
from .exceptions import (
    InvalidInputError,
    KinematicsError,
    NoClosedFormError,
    RobotDescriptionError,
    UnknownNameError,
)
from .ik import IKBatchResult, IKOptions, IKResult

__all__ = [
    "ChainSpec",
    "ClosedFormBatchResult",
    "ClosedFormFamily",
    "ClosedFormResult",
    "IKBatchResult",
    "IKOptions",
    "IKResult",
    "InvalidInputError",
    "JointModel",
    "KinematicsError",
    "NoClosedFormError",
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
