"""The servo's commands: a twist to follow, joint velocities to jog, a pose to reach.

Plain frozen records: building one never raises, so that whatever a message carried can be handed
to `Servo.submit`, which checks it and refuses it with a status that says why (a non-finite or
huge value, an unknown frame or joint name, a stale stamp). Stamps are seconds on the clock that
the caller also passes to `Servo.submit` and `Servo.step` (e.g. ROS time, or `time.monotonic()`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class TwistCommand:
    """Move the tip with twist (ω, v), expressed in the axes of link `frame`, about the tip origin.

    Attributes:
        angular: ω [rad/s], 3 values, in `frame`'s axes.
        linear: v [m/s], 3 values: the velocity of the tip origin, in `frame`'s axes.
        frame: a link of the chain (the base link, the tip link or any link between), whose axes
            at the current configuration express ω and v.
        stamp_s: when the command was issued [s].
    """

    angular: Sequence[float]
    linear: Sequence[float]
    frame: str
    stamp_s: float


@dataclass(frozen=True)
class JointJogCommand:
    """Move the named joints at the given velocities; joints not named hold still.

    Attributes:
        joint_names: names of actuated joints of the chain, each at most once, in any order.
        velocities: [rad/s or m/s], one per name.
        stamp_s: when the command was issued [s].
    """

    joint_names: Sequence[str]
    velocities: Sequence[float]
    stamp_s: float


@dataclass(frozen=True)
class PoseCommand:
    """Bring the tip to pose `T_frame_tip` (4×4 homogeneous transform) given in link `frame`.

    The target is converted to the base frame when the command is accepted (with the link's pose at
    the current configuration), and approached along a straight line at a bounded speed that
    decreases to zero at the target, so it is reached without overshoot. Stream the command (like
    twists, it times out after `ServoConfig.command_timeout_s`); a new target replaces the old.

    Attributes:
        T_frame_tip: (4, 4) target pose of the tip in `frame` [m].
        frame: a link of the chain.
        stamp_s: when the command was issued [s].
    """

    T_frame_tip: Any
    frame: str
    stamp_s: float


Command = TwistCommand | JointJogCommand | PoseCommand
"""Any of the servo's commands."""
