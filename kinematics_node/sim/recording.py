"""A rosbag2 recording of the simulated arm, to try `kinematics bag` without a robot:
`kinematics record-demo OUT [--robot ur5e] [--duration 60]`.

Every moving joint of a bundled robot (its gripper too) follows the simulator's demo motion
(`ArmSimulator`, as `sim_arm` publishes it) at `rate_hz`; the recording holds /joint_states
(positions and velocities, stamped with the simulated time from an epoch start) and the robot's
/robot_description (transient local, as robot_state_publisher offers it), in MCAP storage.
Written with rosbags (the `bags` extra), the joint_states in batches (`msg_adapters.cdr`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from msg_adapters.cdr import joint_state_cdr

from ..core import InvalidInputError
from ..jobs.recordings.job import latched_qos
from ..jobs.recordings.mcap_batches import write_rows
from .arm import ArmSimulator
from .robots import robot_path

#: The recording's first stamp: 2024-12-01 00:00 UTC, an epoch time as real recordings have.
START_NS = 1_733_011_200 * 10**9


def write_demo_recording(
    path: Path, robot: str = "ur5e", duration: float = 60.0, rate_hz: float = 1000.0
) -> int:
    """Write the recording; return the number of joint_states.

    Raises:
        InvalidInputError: duration or rate out of range, or `path` exists.
        UnknownNameError: `robot` is not a bundled robot.
    """
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    if not 0 < duration <= 24 * 3600 or not 1 <= rate_hz <= 10_000:
        raise InvalidInputError(
            f"duration {duration:g} s at {rate_hz:g} Hz: expected 0 < duration <= 86400 s and "
            "1 to 10000 Hz"
        )
    if path.exists():
        raise InvalidInputError(f"{path} exists")
    urdf = robot_path(robot)
    text = urdf.read_text(encoding="utf-8")
    sim = ArmSimulator.from_urdf(text, dt=1.0 / rate_hz, demo=True)
    count = int(round(duration * rate_hz))
    store = get_typestore(Stores.ROS2_JAZZY)
    String = store.types["std_msgs/msg/String"]
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        description = writer.add_connection(
            "/robot_description",
            "std_msgs/msg/String",
            typestore=store,
            offered_qos_profiles=latched_qos(),
        )
        writer.write(
            description, START_NS, store.serialize_cdr(String(data=text), "std_msgs/msg/String")
        )
        states = writer.add_connection(
            "/joint_states", "sensor_msgs/msg/JointState", typestore=store
        )
        step_ns = int(round(1e9 / rate_hz))
        for start in range(0, count, 10_000):
            k = np.arange(start, min(count, start + 10_000))
            Q = np.empty((len(k), sim.dof))
            V = np.empty((len(k), sim.dof))
            for i in range(len(k)):
                state = sim.step()
                Q[i], V[i] = state.q, state.qdot
            stamp = START_NS + (k + 1) * step_ns
            rows = joint_state_cdr(stamp, sim.joint_names, Q, V)
            write_rows(writer, states, stamp, rows)
    return count
