"""sensor_msgs/JointState ↔ joint vectors q, matched by joint name.

A JointState may name a subset of a chain's joints, in any order, and joints of other chains; only
`name` decides which value goes where, never the index. Positions are [rad] for revolute joints and
[m] for prismatic ones.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from kinematics_node.core.exceptions import InvalidInputError

from .stamps import header
from .types import MessageTypes

FloatArray = NDArray[np.float64]


class JointStateSample(NamedTuple):
    """The fields of a sensor_msgs/JointState the node tracks, read once at the boundary.

    Attributes:
        names, positions, velocities: as in the message (velocities may be empty); sequences of
            str and float, not copied (rclpy gives lists and array('d')).
        stamp: header stamp [s]; exactly 0.0 when the stamp is unset (sec = nanosec = 0, as
            `ros2 topic pub` and simple drivers send it), which the tracker tells apart.
    """

    names: Sequence[str]
    positions: Sequence[float]
    velocities: Sequence[float]
    stamp: float


def sample_from_joint_state(msg: Any) -> JointStateSample:
    """`JointStateSample` of a sensor_msgs/JointState (values are checked by the tracker that
    merges them, `kinematics_node.service.ee_state.JointStateTracker`, not here: this runs at 1 kHz)."""
    stamp = msg.header.stamp
    return JointStateSample(
        msg.name, msg.position, msg.velocity, int(stamp.sec) + int(stamp.nanosec) * 1e-9
    )


def positions_by_name(
    msg: Any, known_names: Collection[str] | None = None, name: str = "joint_state"
) -> dict[str, float]:
    """{joint name: position} of a JointState, validated.

    Args:
        msg: anything with `name` and `position` sequences.
        known_names: if given, every name must be one of them (e.g. all joints of the robot).
        name: how to call `msg` in error messages.

    Raises:
        InvalidInputError: len(position) != len(name), a repeated name, a name not in
            `known_names`, or a NaN/infinite position, naming the joint.
    """
    names = [str(n) for n in msg.name]
    positions = list(msg.position)
    if len(positions) != len(names):
        raise InvalidInputError(
            f"{name} has {len(names)} names but {len(positions)} positions; "
            "they must have the same length"
        )
    out: dict[str, float] = {}
    for joint, value in zip(names, positions, strict=True):
        if joint in out:
            raise InvalidInputError(f"{name} names joint {joint!r} more than once")
        if known_names is not None and joint not in known_names:
            valid = ", ".join(repr(n) for n in sorted(known_names))
            raise InvalidInputError(
                f"{name} names unknown joint {joint!r}; joints of the robot are: {valid}"
            )
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise InvalidInputError(f"{name} position of joint {joint!r} is not a number") from None
        if not math.isfinite(v):
            raise InvalidInputError(f"{name} position of joint {joint!r} is {v}; expected finite")
        out[joint] = v
    return out


def q_from_joint_state(
    msg: Any,
    joint_names: Sequence[str],
    *,
    q_default: ArrayLike | None = None,
    known_names: Collection[str] | None = None,
    name: str = "joint_state",
) -> FloatArray:
    """Joint vector q (n,) in the order of `joint_names`, from a JointState.

    Joints of `joint_names` missing from `msg` take their value from `q_default` (NaN entries of
    `q_default` count as unknown); names in `msg` that are not in `joint_names` are ignored (but
    must be in `known_names` when that is given).

    Raises:
        InvalidInputError: see `positions_by_name`; or a joint of `joint_names` has no value.
    """
    values = positions_by_name(msg, known_names, name)
    n = len(joint_names)
    q = np.full(n, np.nan) if q_default is None else np.array(q_default, dtype=np.float64)
    if q.shape != (n,):
        raise InvalidInputError(f"q_default must have {n} values, got shape {q.shape}")
    for i, joint in enumerate(joint_names):
        if joint in values:
            q[i] = values[joint]
    missing = [j for j, v in zip(joint_names, q, strict=True) if not math.isfinite(v)]
    if missing:
        raise InvalidInputError(
            f"{name} has no position for joint(s) {missing} and no current value is known for them"
        )
    return q


def _float_list(values: ArrayLike) -> list[float]:
    """A list of Python floats (what rclpy accepts for float64[]; numpy arrays are rejected)."""
    return [float(v) for v in np.asarray(values, dtype=np.float64).reshape(-1)]


def joint_state_from_q(
    types: MessageTypes,
    joint_names: Sequence[str],
    q: ArrayLike,
    header: Any,
    qdot: ArrayLike | None = None,
) -> Any:
    """sensor_msgs/JointState with `name` = joint_names, `position` = q and, if given, `velocity`.

    `effort` is empty. `header` is a std_msgs/Header message (used as given).
    """
    position = _float_list(q)
    if len(position) != len(joint_names):
        raise InvalidInputError(f"{len(joint_names)} joint names but {len(position)} positions")
    velocity = [] if qdot is None else _float_list(qdot)
    if velocity and len(velocity) != len(joint_names):
        raise InvalidInputError(f"{len(joint_names)} joint names but {len(velocity)} velocities")
    return types.JointState(
        header=header,
        name=[str(n) for n in joint_names],
        position=position,
        velocity=velocity,
        effort=[],
    )


def joint_states_from_qs(
    types: MessageTypes,
    joint_names: Sequence[str],
    qs: ArrayLike,
    stamp: Any,
    frame_id: str = "",
) -> list[Any]:
    """One sensor_msgs/JointState per row of `qs` (K, n): `name` = joint_names, `position` = the
    row, velocity and effort empty, and a header of its own (a copy of the builtin_interfaces/Time
    `stamp`, `frame_id`) in each; no rows (an empty sequence) give [].

    Raises:
        InvalidInputError: a row's length differs from len(joint_names).
    """
    rows = np.asarray(qs, dtype=np.float64)
    if rows.size == 0:
        return []
    if rows.ndim != 2:
        raise InvalidInputError(
            f"qs must be a (K, n) array of joint vectors, got shape {rows.shape}"
        )
    return [
        joint_state_from_q(types, joint_names, row, header(types, stamp, frame_id)) for row in rows
    ]
