"""msg_adapters.servo_messages with real ROS 2 message definitions (rosbags): commands in by field
name, joint commands and status out in messages that survive CDR (what DDS carries).

control_msgs/JointJog is not in rosbags' stores: servo_node_testing.joint_jog registers its definition."""

from __future__ import annotations

import math

import numpy as np
import pytest
from servo_node_testing import joint_jog, joint_state, pose_msg, twist_msg

from kinematics_node.core.servo import JointJogCommand, PoseCommand, TwistCommand
from msg_adapters import matrix_from_pose
from msg_adapters.servo_messages import (
    SERVO_MESSAGE_NAMES,
    ServoMessageTypes,
    command_stamp,
    diagnostic_status,
    float64_multi_array,
    jog_command_from_joint_jog,
    jog_command_from_joint_state,
    joint_trajectory,
    pose_command_from_msg,
    twist_command_from_msg,
)


@pytest.fixture(scope="module")
def types(ros) -> ServoMessageTypes:
    return ServoMessageTypes.from_typestore(ros.store)


def test_every_type_name_is_a_real_interface(ros):
    for full in SERVO_MESSAGE_NAMES.values():
        assert full in ros.store.types


def test_a_twist_becomes_a_command_by_field_name(ros):
    msg = twist_msg(ros, linear=(1.0, 2.0, 3.0), angular=(4.0, 5.0, 6.0), frame="tool0", t=7.25)
    cmd = twist_command_from_msg(ros.roundtrip(msg), now_s=9.0, base_link="base")
    assert cmd == TwistCommand((4.0, 5.0, 6.0), (1.0, 2.0, 3.0), "tool0", 7.25)


def test_an_unstamped_command_is_stamped_now_and_an_empty_frame_is_the_base(ros):
    cmd = twist_command_from_msg(twist_msg(ros, linear=(0.1, 0, 0)), now_s=12.5, base_link="b")
    assert (cmd.stamp_s, cmd.frame) == (12.5, "b")
    assert command_stamp(twist_msg(ros, t=3.0).header, 12.5) == 3.0


def test_non_finite_values_go_through_for_the_core_to_refuse(ros):
    cmd = twist_command_from_msg(twist_msg(ros, linear=(math.nan, 0, 0)), 0.0, "b")
    assert math.isnan(cmd.linear[0])


def test_a_pose_becomes_the_messages_transform(ros):
    q = np.array([0.1, -0.2, 0.3, 0.9])
    msg = pose_msg(ros, (0.4, 0.5, 0.6), q * 2.0, frame="world", t=1.5)  # not normalised
    cmd = pose_command_from_msg(msg, 0.0, "base")
    assert isinstance(cmd, PoseCommand) and (cmd.frame, cmd.stamp_s) == ("world", 1.5)
    assert np.allclose(cmd.T_frame_tip, matrix_from_pose(msg.pose), atol=1e-12)


@pytest.mark.parametrize("quaternion", [(0, 0, 0, 0), (math.nan, 0, 0, 1), (math.inf, 0, 0, 1)])
def test_a_bad_quaternion_gives_a_matrix_that_is_no_rotation(ros, quaternion):
    T = pose_command_from_msg(pose_msg(ros, (0, 0, 0), quaternion), 0.0, "b").T_frame_tip
    R = T[:3, :3]
    assert not np.isfinite(R).all() or not np.allclose(R.T @ R, np.eye(3))


def test_a_joint_jog_takes_names_and_velocities(ros):
    msg = joint_jog(ros, ["a", "b"], [0.5, -0.25], t=2.0)
    cmd = jog_command_from_joint_jog(ros.roundtrip(msg), 0.0)
    assert cmd == JointJogCommand(["a", "b"], [0.5, -0.25], 2.0)


def test_a_joint_state_jog_takes_names_and_velocities_not_positions(ros):
    msg = joint_state(ros, ["a", "b"], positions=[9.0, 9.0], velocities=[0.1, 0.2])
    cmd = jog_command_from_joint_state(ros.roundtrip(msg), 4.0)
    assert cmd == JointJogCommand(["a", "b"], [0.1, 0.2], 4.0)


def test_float64_multi_array_carries_the_values_in_order(ros, types):
    msg = ros.roundtrip(float64_multi_array(types, np.array([0.5, -1.0, 2.25])))
    assert list(msg.data) == [0.5, -1.0, 2.25]
    assert list(msg.layout.dim) == [] and msg.layout.data_offset == 0


def test_joint_trajectory_is_one_point_at_the_given_time(ros, types):
    msg = joint_trajectory(types, ["a", "b"], [1.0, 2.0], [0.1, 0.2], [0.0, -1.0], 0.001)
    msg = ros.roundtrip(msg)
    assert list(msg.joint_names) == ["a", "b"]
    (point,) = msg.points
    assert list(point.positions) == [1.0, 2.0] and list(point.velocities) == [0.1, 0.2]
    assert list(point.accelerations) == [0.0, -1.0] and list(point.effort) == []
    assert (point.time_from_start.sec, point.time_from_start.nanosec) == (0, 1_000_000)
    late = joint_trajectory(types, ["a"], [1.0], [0.0], [0.0], 2.5).points[0].time_from_start
    assert (late.sec, late.nanosec) == (2, 500_000_000)


def test_diagnostic_status_levels_and_values(ros, types):
    S = types.DiagnosticStatus
    for level, expected in ((0, S.OK), (1, S.WARN), (2, S.ERROR)):
        msg = ros.roundtrip(diagnostic_status(types, level, "n", "m", "hw", [("k", "v")]))
        assert msg.level == expected
        assert (msg.name, msg.message, msg.hardware_id) == ("n", "m", "hw")
        assert [(kv.key, kv.value) for kv in msg.values] == [("k", "v")]
