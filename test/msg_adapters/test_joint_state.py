"""msg_adapters.joint_state against real ROS 2 message classes (rosbags): conversions, refusals,
CDR, typing."""

from __future__ import annotations

import array
import math

import numpy as np
import pytest

import msg_adapters as ma
from kinematics_node.core.exceptions import InvalidInputError

JOINTS = ("j1", "j2", "j3")


def _js(ros, names, positions, velocity=()):
    return ros.new(
        "sensor_msgs/msg/JointState",
        name=list(names),
        position=np.asarray(positions, dtype=float),
        velocity=np.asarray(velocity, dtype=float),
    )


# --------------------------------------------------------------------------- JointState
def test_q_from_joint_state_matches_by_name_in_any_order_and_ignores_other_joints(ros):
    msg = _js(ros, ["finger", "j3", "j1", "j2"], [9.0, 0.3, 0.1, 0.2])
    q = ma.q_from_joint_state(msg, JOINTS)
    np.testing.assert_array_equal(q, [0.1, 0.2, 0.3])


def test_q_from_joint_state_fills_a_subset_from_the_default(ros):
    msg = _js(ros, ["j2"], [5.0])
    np.testing.assert_array_equal(
        ma.q_from_joint_state(msg, JOINTS, q_default=[1, 2, 3]), [1, 5, 3]
    )
    with pytest.raises(InvalidInputError, match="j1"):
        ma.q_from_joint_state(msg, JOINTS)


@pytest.mark.parametrize(
    ("names", "positions", "needle"),
    [
        (["j1", "j2"], [0.0], "2 names but 1 positions"),
        (["j1", "j1"], [0.0, 1.0], "'j1' more than once"),
        (["j1", "bogus"], [0.0, 1.0], "'bogus'"),
        (["j1", "j2", "j3"], [0.0, math.nan, 0.0], "'j2' is nan"),
        (["j1", "j2", "j3"], [0.0, 0.0, math.inf], "'j3' is inf"),
    ],
)
def test_q_from_joint_state_refuses_bad_input_naming_it(ros, names, positions, needle):
    with pytest.raises(InvalidInputError, match=needle):
        ma.q_from_joint_state(_js(ros, names, positions), JOINTS, known_names={"j1", "j2", "j3"})


def test_joint_state_round_trip_cdr_and_rclpy_types(ros):
    q, qdot = np.array([0.1, -0.2, 0.3]), np.array([1.0, 2.0, 3.0])
    stamp = ros.new("builtin_interfaces/msg/Time", sec=12, nanosec=345)
    msg = ma.joint_state_from_q(ros.types, JOINTS, q, ma.header(ros.types, stamp, "base"), qdot)
    assert ros.rclpy_type_problems(msg) == []
    back = ros.roundtrip(msg)
    np.testing.assert_array_equal(ma.q_from_joint_state(back, JOINTS), q)
    np.testing.assert_array_equal(back.velocity, qdot)
    assert (back.header.stamp.sec, back.header.stamp.nanosec) == (12, 345)


def test_float_sequences_accept_array_d_as_rclpy_does(ros):
    msg = ros.new("sensor_msgs/msg/JointState", name=["j1"], position=array.array("d", [0.5]))
    assert ma.q_from_joint_state(msg, ["j1"])[0] == 0.5


def test_joint_states_from_qs_one_message_per_row_each_with_its_own_header(ros):
    Q = np.array([[0.1, -0.2, 0.3], [1.0, 2.0, -3.0]])
    stamp = ros.new("builtin_interfaces/msg/Time", sec=7, nanosec=8)
    msgs = ma.joint_states_from_qs(ros.types, JOINTS, Q, stamp, "base")
    assert len(msgs) == 2
    for msg, q in zip(msgs, Q, strict=True):
        assert ros.rclpy_type_problems(msg) == []
        back = ros.roundtrip(msg)
        np.testing.assert_array_equal(ma.q_from_joint_state(back, JOINTS), q)
        assert list(back.velocity) == [] and list(back.effort) == []
        assert (back.header.stamp.sec, back.header.stamp.nanosec, back.header.frame_id) == (
            7,
            8,
            "base",
        )
    assert msgs[0].header is not msgs[1].header and msgs[0].header.stamp is not stamp
    assert ma.joint_states_from_qs(ros.types, JOINTS, [], stamp) == []
    with pytest.raises(InvalidInputError, match="3 joint names but 2 positions"):
        ma.joint_states_from_qs(ros.types, JOINTS, [[0.0, 1.0]], stamp)
    with pytest.raises(InvalidInputError, match=r"\(K, n\)"):
        ma.joint_states_from_qs(ros.types, JOINTS, [0.0, 1.0, 2.0], stamp)


def test_sample_from_joint_state_reads_the_fields_once_and_the_stamp_in_seconds(ros):
    msg = _js(ros, ["j2", "j1"], [0.2, 0.1], [1.5, -0.5])
    msg.header.stamp = ros.new("builtin_interfaces/msg/Time", sec=1700000000, nanosec=999999999)
    names, positions, velocities, stamp = ma.sample_from_joint_state(msg)
    assert list(names) == ["j2", "j1"] and list(positions) == [0.2, 0.1]
    assert list(velocities) == [1.5, -0.5]
    assert stamp == pytest.approx(1700000000.999999999, abs=3e-7)  # float64 resolves ~0.24 µs
    # an unset stamp is exactly 0.0: the tracker estimates over arrival times then
    msg.header.stamp = ros.new("builtin_interfaces/msg/Time", sec=0, nanosec=0)
    assert ma.sample_from_joint_state(msg).stamp == 0.0
    msg.header.stamp = ros.new("builtin_interfaces/msg/Time", sec=0, nanosec=1)
    assert ma.sample_from_joint_state(msg).stamp == 1e-9  # set, however small
