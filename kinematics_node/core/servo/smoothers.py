"""Which smoothing the servo uses: Ruckig's, jerk-limited (`smoothing`), where Ruckig is installed,
else the acceleration-limited one of our own (`acceleration_smoothing`); and what to say when the
jerk limits are missing.

`ServoConfig.smoothing` chooses: "auto" (the default: Ruckig's where it can be imported, else
ours, and the servo says once what is missing and how to install it), "ruckig" (refused with
`MissingDependencyError` where Ruckig is missing), "acceleration" (ours, even with Ruckig).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from .acceleration_smoothing import AccelerationLimitedIntegrator, AccelerationRamp
from .config import SMOOTHING_CHOICES
from .limits import ServoLimits
from .smoothing import JerkLimitedIntegrator, MissingDependencyError, VelocityRamp, ruckig_available

FloatArray = NDArray[np.float64]

RUCKIG_INSTALL = (
    "pip install ruckig (ROS 2 on Ubuntu 24.04, whose Python is externally managed: "
    "python3 -m pip install --user --break-system-packages ruckig)"
)
"""How to install Ruckig, for pip users and for a ROS 2 installation made with rosdep/apt."""

NO_RUCKIG_NOTE = (
    "Ruckig is not installed: the servo keeps the joints' position, velocity and acceleration "
    "limits but not their jerk limits. For jerk limits, install Ruckig and restart the servo: "
    + RUCKIG_INSTALL
)
"""What the servo says once where it runs without Ruckig."""


class JointSmoother(Protocol):
    """The commanded joint state the servo advances one period per `step` (both smoothings)."""

    q: FloatArray
    v: FloatArray
    a: FloatArray
    q_list: list[float]
    v_list: list[float]
    a_list: list[float]
    at_rest: bool

    def reset(self, positions: FloatArray) -> None: ...

    def step(
        self,
        target_velocity: Sequence[float],
        target_acceleration: Sequence[float] | None = None,
    ) -> list[bool] | None: ...

    def reachable(self, periods: float = 1.0) -> tuple[list[float], list[float]]: ...

    def follow(self, target_velocity: Sequence[float]) -> list[bool] | None: ...


class TwistRamp(Protocol):
    """The ramp of the commanded twist (both smoothings)."""

    v: list[float]
    a: list[float]
    zeros: Sequence[float]
    slowed: bool

    def reset(self, velocity: Sequence[float] | FloatArray) -> None: ...

    def slow(self, acceleration_factor: float, jerk_factor: float) -> None: ...

    def restore(self) -> None: ...

    def step(self, target: list[float]) -> list[float]: ...


@dataclass(frozen=True)
class Smoothing:
    """The smoothing a servo uses.

    Attributes:
        name: "ruckig" or "acceleration".
        label: what the servo's status says ("ruckig (jerk-limited)", "acceleration-limited (no
            Ruckig)", or "acceleration-limited (chosen)" where Ruckig is there but not used).
        jerk_limited: whether the joints' jerk limits are kept.
        note: what to tell the user once (Ruckig missing under "auto"), else None.
    """

    name: str
    label: str
    jerk_limited: bool
    note: str | None

    def integrator(
        self, limits: ServoLimits, period_s: float, positions: FloatArray
    ) -> JointSmoother:
        """The commanded joint state, at rest at `positions`."""
        if self.jerk_limited:
            return JerkLimitedIntegrator(limits, period_s, positions)
        return AccelerationLimitedIntegrator(limits, period_s, positions)

    def ramp(self, acceleration: FloatArray, jerk: FloatArray, period_s: float) -> TwistRamp:
        """The ramp of the commanded twist."""
        if self.jerk_limited:
            return VelocityRamp(acceleration, jerk, period_s)
        return AccelerationRamp(acceleration, jerk, period_s)


def choose_smoothing(kind: str = "auto") -> Smoothing:
    """The smoothing of `ServoConfig.smoothing` = `kind` (module docstring), on this installation.

    Raises:
        MissingDependencyError: "ruckig" where Ruckig cannot be imported.
        ValueError: `kind` is not one of `SMOOTHING_CHOICES` (ServoConfig refuses it first).
    """
    if kind not in SMOOTHING_CHOICES:
        raise ValueError(f"smoothing must be one of {SMOOTHING_CHOICES}, got {kind!r}")
    have = ruckig_available()
    if kind == "ruckig" and not have:
        raise MissingDependencyError(
            "smoothing 'ruckig' needs Ruckig, which is not installed: "
            + RUCKIG_INSTALL
            + "; or smoothing 'auto' to run without jerk limits"
        )
    if have and kind != "acceleration":
        return Smoothing("ruckig", "ruckig (jerk-limited)", True, None)
    if kind == "acceleration":
        label = "acceleration-limited (chosen)" if have else "acceleration-limited (no Ruckig)"
        return Smoothing("acceleration", label, False, None)
    return Smoothing("acceleration", "acceleration-limited (no Ruckig)", False, NO_RUCKIG_NOTE)
