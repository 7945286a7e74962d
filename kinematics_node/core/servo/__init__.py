"""Servoing in the core, without ROS: twist, joint-jog and pose commands in, joint commands out.

One `Servo.step` per control period turns the latest command and the measured joint positions
into the next joint positions, velocities and accelerations, within the position (less a margin),
velocity, acceleration and jerk limits, through singularities (damped least squares), without
drift (the commanded pose is integrated and tracked), with a status on every cycle.

    from kinematics_node.core.servo import Servo, ServoConfig, TwistCommand

The joint motion is smoothed by Ruckig within the jerk limits too where Ruckig is installed
(`pip install ruckig`, or the package's `servo` extra); without it, by an acceleration-limited
smoothing of our own (`smoothers`, `ServoConfig.smoothing`).
Conventions as in the rest of the core: twists (ω, v), lengths in m, angles in rad, time in s.
"""

from __future__ import annotations

from .commands import Command, JointJogCommand, PoseCommand, TwistCommand
from .config import SMOOTHING_CHOICES, TWIST_AXES, ServoConfig
from .limits import ServoLimits, braking_distance, braking_speed
from .servo import Servo, ServoOutput
from .smoothers import NO_RUCKIG_NOTE, RUCKIG_INSTALL, Smoothing, choose_smoothing
from .smoothing import MissingDependencyError, ruckig_available
from .status import ServoStatus, StatusCode

__all__ = [
    "NO_RUCKIG_NOTE",
    "RUCKIG_INSTALL",
    "SMOOTHING_CHOICES",
    "TWIST_AXES",
    "Command",
    "JointJogCommand",
    "MissingDependencyError",
    "PoseCommand",
    "Servo",
    "ServoConfig",
    "ServoLimits",
    "ServoOutput",
    "ServoStatus",
    "Smoothing",
    "StatusCode",
    "TwistCommand",
    "braking_distance",
    "braking_speed",
    "choose_smoothing",
    "ruckig_available",
]
