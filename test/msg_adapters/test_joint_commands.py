"""msg_adapters.joint_commands (sim_arm's message handling), tested with real ROS 2 message
definitions from rosbags (no rclpy)."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics_node.core import InvalidInputError, UnknownNameError
from kinematics_node.sim import robots
from kinematics_node.sim.arm import ArmSimulator
from msg_adapters.joint_commands import (
    apply_position_msg,
    apply_trajectory_msg,
    apply_velocity_msg,
    fill_joint_state,
    trajectory_from_msg,
    velocity_from_msg,
)

typesys = pytest.importorskip("rosbags.typesys")
ts = typesys.get_typestore(typesys.Stores.ROS2_HUMBLE)
JT = ts.types["trajectory_msgs/msg/JointTrajectory"]
JTP = ts.types["trajectory_msgs/msg/JointTrajectoryPoint"]
JS = ts.types["sensor_msgs/msg/JointState"]
F64MA = ts.types["std_msgs/msg/Float64MultiArray"]
Layout = ts.types["std_msgs/msg/MultiArrayLayout"]
Header = ts.types["std_msgs/msg/Header"]
Time = ts.types["builtin_interfaces/msg/Time"]
Duration = ts.types["builtin_interfaces/msg/Duration"]
EMPTY = np.array([], dtype=np.float64)


def header() -> object:
    return Header(stamp=Time(sec=0, nanosec=0), frame_id="")


def point(positions, t: float, velocities=()) -> object:
    sec = int(t)
    return JTP(
        positions=np.array(positions, dtype=np.float64),
        velocities=np.array(velocities, dtype=np.float64),
        accelerations=EMPTY,
        effort=EMPTY,
        time_from_start=Duration(sec=sec, nanosec=round((t - sec) * 1e9)),
    )


def trajectory(names, points) -> object:
    return JT(header=header(), joint_names=list(names), points=list(points))


def velocity_msg(values) -> object:
    return F64MA(layout=Layout(dim=[], data_offset=0), data=np.array(values, dtype=np.float64))


def roundtrip(msg, msgtype: str):
    return ts.deserialize_cdr(ts.serialize_cdr(msg, msgtype), msgtype)


@pytest.fixture
def sim() -> ArmSimulator:
    return ArmSimulator.from_urdf(robots.robot_path("panda"), 0.01, demo=False)


def test_trajectory_message_is_converted_and_followed(sim):
    names = ["panda_joint2", "panda_finger_joint1"]
    msg = roundtrip(
        trajectory(names, [point([0.2, 0.01], 0.5, [0.1, 0.0]), point([0.4, 0.03], 1.25, [0, 0])]),
        JT.__msgtype__,
    )
    cmd = trajectory_from_msg(msg)
    assert cmd.joint_names == tuple(names)
    np.testing.assert_allclose(cmd.times, [0.5, 1.25])
    np.testing.assert_allclose(cmd.positions, [[0.2, 0.01], [0.4, 0.03]])
    np.testing.assert_allclose(cmd.velocities, [[0.1, 0.0], [0.0, 0.0]])
    q0 = sim.q
    apply_trajectory_msg(sim, msg)
    for _ in range(125):
        _, q, _ = sim.step()
    np.testing.assert_allclose(q[[1, 7]], [0.4, 0.03], atol=1e-12)
    np.testing.assert_array_equal(q[[0, 2, 3, 4, 5, 6]], q0[[0, 2, 3, 4, 5, 6]])


def test_trajectory_without_velocities_gives_none(sim):
    cmd = trajectory_from_msg(trajectory(["panda_joint1"], [point([0.1], 1.0), point([0.2], 2.0)]))
    assert cmd.velocities is None


@pytest.mark.parametrize(
    ("msg", "match"),
    [
        (trajectory([], [point([], 1.0)]), "no joint_names"),
        (trajectory(["panda_joint1"], []), "no points"),
        (trajectory(["panda_joint1"], [point([0.1, 0.2], 1.0)]), "point 0 positions has 2"),
        (trajectory(["panda_joint1"], [point([np.nan], 1.0)]), "nan"),
        (trajectory(["panda_joint1"], [point([0.1], 1.0, [np.inf])]), "inf"),
        (
            trajectory(["panda_joint1"], [point([0.1], 1.0, [0.1]), point([0.2], 2.0)]),
            "some points but not for point 1",
        ),
        (trajectory(["panda_joint1"], [point([0.1], 2.0), point([0.2], 1.0)]), "increasing"),
        (trajectory(["panda_joint1"], [point([0.1], 1.0), point([0.2], 1.0)]), "increasing"),
        (trajectory(["panda_joint1"] * 2, [point([0.1, 0.1], 1.0)]), "duplicate"),
    ],
)
def test_malformed_trajectories_are_refused_without_changing_the_motion(sim, msg, match):
    sim.command_velocity(np.full(sim.dof, 0.01))
    with pytest.raises(InvalidInputError, match=match):
        apply_trajectory_msg(sim, msg)
    assert sim.mode == "velocity"


def test_trajectory_with_an_unknown_joint_lists_the_valid_ones(sim):
    msg = trajectory(["panda_finger_joint2"], [point([0.01], 1.0)])  # the mimic is not commandable
    with pytest.raises(UnknownNameError, match="panda_finger_joint1"):
        apply_trajectory_msg(sim, msg)


def test_velocity_command_message(sim):
    v = np.linspace(-0.1, 0.1, sim.dof)
    msg = roundtrip(velocity_msg(v), F64MA.__msgtype__)
    np.testing.assert_array_equal(velocity_from_msg(msg, sim.joint_names), v)
    q0 = sim.q
    apply_velocity_msg(sim, msg)
    _, q, qdot = sim.step()
    np.testing.assert_allclose(qdot, v, atol=1e-12)
    np.testing.assert_allclose(q, q0 + 0.01 * v, atol=1e-15)


@pytest.mark.parametrize(
    ("values", "match"),
    [([0.1] * 3, "has 3 values, expected 8"), ([0.0] * 7 + [np.nan], "value 7 is nan"), ([], "0")],
)
def test_malformed_velocity_commands_are_refused(sim, values, match):
    with pytest.raises(InvalidInputError, match=match):
        apply_velocity_msg(sim, velocity_msg(values))
    assert sim.mode == "hold"


def test_commands_for_some_joints_leave_the_others_alone(sim):
    """A Float64MultiArray for the arm's joints only (forward_command_controller's `joints`), in
    an order of their own, on a Panda whose finger is simulated too: the arm moves as commanded,
    the finger does not."""
    arm = [n for n in sim.joint_names if "finger" not in n][::-1]
    assert len(arm) == 7 and sim.dof == 8
    col = [sim.joint_names.index(n) for n in arm]
    finger = sim.joint_names.index("panda_finger_joint1")
    v = np.linspace(0.05, 0.11, 7)
    q0 = sim.q
    apply_velocity_msg(sim, roundtrip(velocity_msg(v), F64MA.__msgtype__), "cmd", arm)
    _, q, qdot = sim.step()
    np.testing.assert_allclose(qdot[col], v, atol=1e-12)
    assert qdot[finger] == 0.0 and q[finger] == q0[finger]
    target = q[col] + np.linspace(-1e-3, 1e-3, 7)  # within one step's reach
    apply_position_msg(sim, velocity_msg(target), "cmd", arm)
    _, q, _ = sim.step()
    np.testing.assert_allclose(q[col], target, atol=1e-12)
    assert q[finger] == q0[finger]


def test_commands_for_some_joints_are_checked_against_them(sim):
    arm = [n for n in sim.joint_names if "finger" not in n]
    with pytest.raises(InvalidInputError, match="has 8 values, expected 7"):
        apply_position_msg(sim, velocity_msg([0.0] * 8), "cmd", arm)
    with pytest.raises(UnknownNameError, match="'no_such_joint'.*panda_joint1"):
        apply_velocity_msg(sim, velocity_msg([0.0] * 7), "cmd", [*arm[:6], "no_such_joint"])
    assert sim.mode == "hold"


def test_joint_state_fields_are_python_floats_and_serialize(sim):
    sim.start_demo()
    for _ in range(10):
        _, q, qdot = sim.step()
    msg = JS(header=header(), name=[], position=EMPTY, velocity=EMPTY, effort=EMPTY)
    stamp = Time(sec=12, nanosec=345)
    fill_joint_state(msg, sim.joint_names, q, qdot, stamp)
    assert msg.name == list(sim.joint_names)
    for field in (msg.position, msg.velocity):  # rclpy float64[] wants Python floats, not numpy
        assert isinstance(field, list) and all(type(x) is float for x in field)
    assert msg.header.stamp == stamp
    # The field names and types are the real sensor_msgs/JointState ones: CDR round trip.
    wire = JS(
        header=msg.header,
        name=msg.name,
        position=np.array(msg.position),
        velocity=np.array(msg.velocity),
        effort=np.array(msg.effort, dtype=np.float64),
    )
    back = roundtrip(wire, JS.__msgtype__)
    assert back.name == list(sim.joint_names) and back.header.stamp.sec == 12
    np.testing.assert_array_equal(back.position, q)
    np.testing.assert_array_equal(back.velocity, qdot)
