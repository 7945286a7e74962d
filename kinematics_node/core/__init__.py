"""Pure-Python kinematics core: PoE robot model, FK, Jacobians, analysis, IK. Never imports rclpy.

Conventions: twists and Jacobian rows (ω, v) as in Modern Robotics; quaternions (x, y, z, w);
lengths in m, angles in rad. See docs/conventions.md.

The IK names (`IKOptions`, `IKResult`, `IKBatchResult` and the closed-form results) are imported
on first use (PEP 562): the solver needs scipy.linalg, whose import costs more than numpy's, and
FK/Jacobians do not need it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from . import rotations, se3, so3
from .analysis import (
    Conditioning,
    condition_number,
    conditioning,
    is_near_singular,
    manipulability,
    manipulability_ellipsoid,
    singular_values,
)
from .chain import SerialChain
from .exceptions import (
    InvalidInputError,
    KinematicsError,
    NoClosedFormError,
    RobotDescriptionError,
    UnknownNameError,
)
from .model import ChainSpec, JointModel, MimicJoint

if TYPE_CHECKING:
    from .ik import IKBatchResult, IKOptions, IKResult
    from .ik.closed_form import ClosedFormBatchResult, ClosedFormFamily, ClosedFormResult

_LAZY_IK = ("IKBatchResult", "IKOptions", "IKResult")
_LAZY_CLOSED_FORM = ("ClosedFormBatchResult", "ClosedFormFamily", "ClosedFormResult")


def __getattr__(name: str) -> Any:
    if name in _LAZY_IK:
        from . import ik

        return getattr(ik, name)
    if name in _LAZY_CLOSED_FORM:
        from .ik import closed_form

        return getattr(closed_form, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "ChainSpec",
    "ClosedFormBatchResult",
    "ClosedFormFamily",
    "ClosedFormResult",
    "Conditioning",
    "IKBatchResult",
    "IKOptions",
    "IKResult",
    "InvalidInputError",
    "JointModel",
    "KinematicsError",
    "MimicJoint",
    "NoClosedFormError",
    "RobotDescriptionError",
    "SerialChain",
    "UnknownNameError",
    "condition_number",
    "conditioning",
    "is_near_singular",
    "manipulability",
    "manipulability_ellipsoid",
    "rotations",
    "se3",
    "singular_values",
    "so3",
]
