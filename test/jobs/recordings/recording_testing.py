"""Recordings for the tests, written with rosbags (sqlite3 or MCAP storage) as a robot's driver
and robot_state_publisher would leave them: joint_states of a moving arm, the robot description
(transient local), and a topic of another kind."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from kinematics_node.jobs.recordings.job import latched_qos
from kinematics_node.sim.robots import robot_path

typesys = __import__("pytest").importorskip("rosbags.typesys", reason="pip install rosbags")
rosbag2 = __import__("pytest").importorskip("rosbags.rosbag2", reason="pip install rosbags")
STORE = typesys.get_typestore(typesys.Stores.ROS2_JAZZY)
T = STORE.types
EPOCH_NS = 1_733_000_000 * 10**9


def header(stamp_ns: int, frame: str = "") -> Any:
    sec, nanosec = divmod(stamp_ns, 10**9)
    return T["std_msgs/msg/Header"](
        stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec), frame_id=frame
    )


def joint_state(stamp_ns: int, names: Sequence[str], pos, vel=()) -> Any:
    return T["sensor_msgs/msg/JointState"](
        header=header(stamp_ns),
        name=list(names),
        position=np.asarray(pos, dtype=np.float64),
        velocity=np.asarray(vel, dtype=np.float64),
        effort=np.zeros(0),
    )


def arm_motion(
    lower: np.ndarray, upper: np.ndarray, count: int, rate_hz: float = 1000.0
) -> tuple[np.ndarray, np.ndarray]:
    """(positions, velocities) (count, dof) of a smooth motion within the limits (continuous
    joints: about 0) and its exact derivative."""
    lo = np.where(np.isfinite(lower), lower, -np.pi)
    hi = np.where(np.isfinite(upper), upper, np.pi)
    mid, half = (lo + hi) / 2, 0.45 * (hi - lo)
    dof = len(lo)
    t = np.arange(count)[:, None] / rate_hz
    w = 0.5 + 0.1 * np.arange(dof)
    phase = np.arange(dof)
    return mid + half * np.sin(w * t + phase), half * w * np.cos(w * t + phase)


def write_recording(
    path: Path,
    robot: str = "panda",
    tip: str | None = "panda_hand_tcp",
    count: int = 500,
    storage: str = "mcap",
    velocities: bool = True,
    description: bool = True,
    edit: Callable[[int, Any], Any | None] | None = None,
    joint_names: Sequence[str] | None = None,
) -> Path:
    """A recording of `count` joint_states at 1 kHz of `robot` (a bundled one), with its
    description on /robot_description and a /chatter String beside them. `edit(i, msg)` may
    change or (returning None) drop the i-th joint_states."""
    from kinematics_node.core import SerialChain

    text = robot_path(robot).read_text(encoding="utf-8")
    chain = SerialChain.from_urdf(text, None, tip)
    names = list(joint_names or chain.joint_names)
    Q, V = arm_motion(chain.lower, chain.upper, count)
    plugin = rosbag2.StoragePlugin.MCAP if storage == "mcap" else rosbag2.StoragePlugin.SQLITE3
    with rosbag2.Writer(path, version=9, storage_plugin=plugin) as w:
        if description:
            c = w.add_connection(
                "/robot_description",
                "std_msgs/msg/String",
                typestore=STORE,
                offered_qos_profiles=latched_qos(),
            )
            msg = T["std_msgs/msg/String"](data=text)
            w.write(c, EPOCH_NS - 10**9, STORE.serialize_cdr(msg, "std_msgs/msg/String"))
        js = w.add_connection("/joint_states", "sensor_msgs/msg/JointState", typestore=STORE)
        chatter = w.add_connection("/chatter", "std_msgs/msg/String", typestore=STORE)
        for i in range(count):
            stamp = EPOCH_NS + i * 1_000_000
            msg = joint_state(stamp, names, Q[i], V[i] if velocities else ())
            if edit is not None:
                msg = edit(i, msg)
            if msg is not None:
                raw = STORE.serialize_cdr(msg, "sensor_msgs/msg/JointState")
                w.write(js, stamp + 50_000, raw)
            if i % 100 == 0:
                s = T["std_msgs/msg/String"](data=f"tick {i} {math.pi}")
                w.write(chatter, stamp + 10, STORE.serialize_cdr(s, "std_msgs/msg/String"))
    return path
