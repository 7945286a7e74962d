"""What the servo did on a cycle: a `StatusCode` and the details behind it (`ServoStatus`)."""

from __future__ import annotations

import enum
from dataclasses import dataclass


class StatusCode(enum.IntEnum):
    """The servo's state on one cycle, most severe first when several apply (see `ServoStatus`).

    The integer values are stable (a ROS status topic can carry them as an int8).
    """

    OK = 0
    """Following the command."""
    NEAR_SINGULARITY = 1
    """Following, but slowed in the ill-conditioned directions (damped least squares active);
    `ServoStatus.condition_number` says how close. Never a stop: well-conditioned directions go on."""
    AT_JOINT_LIMIT = 2
    """A joint stopped (or is braking) at its position limit less the margin; the others go on.
    `ServoStatus.joints_at_limit` names it."""
    TIMEOUT_STOP = 3
    """No fresh command within the timeout: stopping smoothly, or stopped."""
    COMMAND_STALE = 4
    """The last command arrived with a stamp older than the timeout (or far in the future); it was
    refused and the arm stops smoothly."""
    COMMAND_REFUSED = 5
    """The last command was refused (`ServoStatus.message` says why); the arm stops smoothly."""
    PAUSED = 6
    """Paused: stopping smoothly, or stopped; commands are refused until `Servo.resume`."""
    NOT_FOLLOWING = 7
    """The measured joint positions are farther from the commanded ones than
    `ServoConfig.max_following_error` (the arm is blocked or lags): stopping smoothly."""
    STATE_REFUSED = 8
    """The measured joint positions given to `Servo.step` were unusable (wrong length,
    non-finite); the servo went on from its own state and stops smoothly."""
    IDLE = 9
    """No command yet (or since `Servo.resume`); holding."""


@dataclass(frozen=True)
class ServoStatus:
    """The servo's status on one cycle (or the answer to `Servo.submit`).

    Attributes:
        code: the most severe condition that applies.
        message: one sentence for people, naming what the code refers to.
        condition_number: σ_max / σ_min of the followed rows of the Jacobian (∞ at a singularity).
        joints_at_limit: joints held (or braking) at a position limit while asked to go further.
        dropped_axes: twist components the arm does not follow (`ServoConfig.task_axes`).
        position_error_m, orientation_error_rad: how far the arm (the servo's last commanded
            joint positions, which this step starts from) is from where it is asked to be, in the
            followed directions (`ServoConfig.task_axes`): pose targets: the distance [m] and
            rotation angle [rad] to the target; twists: to the integrated commanded pose. Along
            the commanded motion that pose is pulled back to within `max_kept_error_*` of the arm
            (a blocked arm does not wind up); across it, it stays on the commanded path, so an
            arm held off the path (near a singularity, at the edge of the workspace) reports its
            whole deviation, which may exceed those bounds.
        target_reached: a pose target is within the tolerances of `ServoConfig`.
        velocity_scaled: the command was slowed to respect a speed or joint velocity limit.
    """

    code: StatusCode
    message: str
    condition_number: float = 1.0
    joints_at_limit: tuple[str, ...] = ()
    dropped_axes: tuple[str, ...] = ()
    position_error_m: float = 0.0
    orientation_error_rad: float = 0.0
    target_reached: bool = False
    velocity_scaled: bool = False

    @property
    def refused(self) -> bool:
        """True when this status refuses a command (stale or refused)."""
        return self.code in (StatusCode.COMMAND_STALE, StatusCode.COMMAND_REFUSED)
