"""Simulated-arm messages ↔ simulator commands and state, without rclpy (nor the simulator).

Duck-typed on the ROS 2 field names, so the same functions take rclpy message objects in the node
and rosbags message classes in the tests:

* trajectory_msgs/JointTrajectory → `TrajectoryCommand` (waypoint times [s] from
  ``time_from_start``, positions, optional velocities);
* std_msgs/Float64MultiArray → joint velocity or position vector (order = the published joint
  names, or the commanded joints given), as ros2_control's forward command controllers take them
  (their `joints` parameter: e.g. an arm's joints, not its gripper's);
* simulator state → sensor_msgs/JointState fields (lists of Python floats, as rclpy requires).

Every malformed message raises `InvalidInputError` (or `UnknownNameError` for unknown joints)
with a message that says what was wrong; callers log it and carry on.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from kinematics_node.core.exceptions import InvalidInputError, UnknownNameError

FloatArray = NDArray[np.float64]


class CommandableArm(Protocol):
    """What `apply_trajectory_msg` and `apply_velocity_msg` drive: `ArmSimulator`'s command
    interface (adapters import only the core, so the simulator is described, not imported)."""

    @property
    def joint_names(self) -> tuple[str, ...]: ...

    @property
    def q(self) -> FloatArray: ...

    def command_trajectory(
        self,
        times: ArrayLike,
        positions: ArrayLike,
        velocities: ArrayLike | None = None,
        *,
        joint_names: Sequence[str] | None = None,
    ) -> None: ...

    def command_velocity(self, qdot: ArrayLike) -> None: ...

    def command_position(self, q: ArrayLike) -> None: ...


@dataclass(frozen=True)
class TrajectoryCommand:
    """A JointTrajectory in numbers: times (m,) [s], positions (m, j), velocities (m, j) or None."""

    joint_names: tuple[str, ...]
    times: FloatArray
    positions: FloatArray
    velocities: FloatArray | None


def _finite_row(values: Any, n: int, what: str) -> list[float]:
    row = [float(v) for v in values]
    if len(row) != n:
        raise InvalidInputError(f"{what} has {len(row)} values, expected {n}")
    for j, v in enumerate(row):
        if not math.isfinite(v):
            raise InvalidInputError(f"{what} value {j} is {v}")
    return row


def trajectory_from_msg(msg: Any) -> TrajectoryCommand:
    """Convert a trajectory_msgs/JointTrajectory (header stamp ignored: it starts on receipt).

    Raises:
        InvalidInputError: no joint names, no points, a point with the wrong number of positions
            or velocities, velocities given for only some points, or NaN/inf values.
    """
    names = tuple(str(n) for n in msg.joint_names)
    if not names:
        raise InvalidInputError("joint_trajectory has no joint_names")
    points = list(msg.points)
    if not points:
        raise InvalidInputError("joint_trajectory has no points")
    n = len(names)
    times, positions, velocities = [], [], []
    with_velocity = [len(p.velocities) > 0 for p in points]
    if any(with_velocity) and not all(with_velocity):
        missing = with_velocity.index(False)
        raise InvalidInputError(
            f"joint_trajectory gives velocities for some points but not for point {missing}; "
            "give them for every point or for none"
        )
    for k, p in enumerate(points):
        d = p.time_from_start
        times.append(int(d.sec) + int(d.nanosec) * 1e-9)
        where = f"joint_trajectory point {k}"
        positions.append(_finite_row(p.positions, n, f"{where} positions"))
        if with_velocity[0]:
            velocities.append(_finite_row(p.velocities, n, f"{where} velocities"))
    return TrajectoryCommand(
        joint_names=names,
        times=np.array(times),
        positions=np.array(positions),
        velocities=np.array(velocities) if with_velocity[0] else None,
    )


def velocity_from_msg(
    msg: Any, joint_names: Sequence[str], topic: str = "joint_velocity_commands"
) -> FloatArray:
    """Joint velocities from a std_msgs/Float64MultiArray, one value per joint in `joint_names`
    (`topic` names the message in errors).

    Raises:
        InvalidInputError: wrong number of values or NaN/inf.
    """
    n = len(joint_names)
    data = _finite_row(msg.data, n, f"{topic} (joints {list(joint_names)})")
    return np.array(data)


def position_from_msg(msg: Any, joint_names: Sequence[str], topic: str) -> FloatArray:
    """Joint positions from a std_msgs/Float64MultiArray, one value per joint in `joint_names`
    (`topic` names the message in errors).

    Raises:
        InvalidInputError: wrong number of values or NaN/inf.
    """
    return velocity_from_msg(msg, joint_names, topic)


def apply_trajectory_msg(sim: CommandableArm, msg: Any) -> TrajectoryCommand:
    """Validate a JointTrajectory message and start following it; returns the converted command."""
    cmd = trajectory_from_msg(msg)
    sim.command_trajectory(cmd.times, cmd.positions, cmd.velocities, joint_names=cmd.joint_names)
    return cmd


def apply_velocity_msg(
    sim: CommandableArm,
    msg: Any,
    topic: str = "joint_velocity_commands",
    joint_names: Sequence[str] | None = None,
) -> FloatArray:
    """Validate a Float64MultiArray velocity command and apply it; returns the velocities.
    `joint_names`: the joints they are for (`_for_every_joint`); the others get velocity 0."""
    v = velocity_from_msg(msg, sim.joint_names if joint_names is None else joint_names, topic)
    sim.command_velocity(_for_every_joint(sim, v, joint_names, np.zeros(len(sim.joint_names))))
    return v


def apply_position_msg(
    sim: CommandableArm, msg: Any, topic: str, joint_names: Sequence[str] | None = None
) -> FloatArray:
    """Validate a Float64MultiArray position command and apply it; returns the positions.
    `joint_names`: the joints they are for (`_for_every_joint`); the others hold where they are."""
    q = position_from_msg(msg, sim.joint_names if joint_names is None else joint_names, topic)
    sim.command_position(_for_every_joint(sim, q, joint_names, np.array(sim.q, dtype=np.float64)))
    return q


def _for_every_joint(
    sim: CommandableArm,
    values: FloatArray,
    joint_names: Sequence[str] | None,
    others: FloatArray,
) -> FloatArray:
    """`values` of `joint_names` (in its order, as forward_command_controller's `joints`
    parameter; None: every joint of `sim`, in its order) spread over `sim`'s joints, `others`
    (one per joint of `sim`, overwritten) for the rest.

    Raises:
        UnknownNameError: a name in `joint_names` that `sim` lacks.
    """
    if joint_names is None:
        return values
    index = {name: k for k, name in enumerate(sim.joint_names)}
    for name in joint_names:
        if name not in index:
            raise UnknownNameError("joint", name, sim.joint_names)
    others[[index[name] for name in joint_names]] = values
    return others


def fill_joint_state(
    msg: Any, joint_names: Sequence[str], q: Any, qdot: Any, stamp: Any = None
) -> Any:
    """Write names, positions and velocities (lists of Python floats) into a JointState message.

    `stamp` (a builtin_interfaces/Time) goes to ``header.stamp`` when given. Effort is left empty.
    Returns `msg`.
    """
    msg.name = [str(n) for n in joint_names]
    msg.position = [float(x) for x in q]
    msg.velocity = [float(x) for x in qdot]
    msg.effort = []
    if stamp is not None:
        msg.header.stamp = stamp
    return msg
