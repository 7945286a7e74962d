"""msg_adapters against real ROS 2 message classes (rosbags): conversions, refusals, CDR, typing."""

from __future__ import annotations

import array
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import msg_adapters as ma
from kinematics_node.core.exceptions import InvalidInputError

JOINTS = ("j1", "j2", "j3")


def _random_T(rng: np.random.Generator) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = Rotation.random(random_state=rng).as_matrix()
    T[:3, 3] = rng.normal(size=3)
    return T


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


# --------------------------------------------------------------------------- Pose / Transform
def test_pose_round_trip_agrees_with_scipy(ros):
    rng = np.random.default_rng(1)
    for _ in range(20):
        T = _random_T(rng)
        msg = ma.pose_from_matrix(ros.types, T)
        assert ros.rclpy_type_problems(msg) == []
        q = [msg.orientation.x, msg.orientation.y, msg.orientation.z, msg.orientation.w]
        # SciPy (an independent implementation) uses the same (x, y, z, w) order.
        np.testing.assert_allclose(Rotation.from_quat(q).as_matrix(), T[:3, :3], atol=1e-12)
        np.testing.assert_allclose(ma.matrix_from_pose(ros.roundtrip(msg)), T, atol=1e-12)
        tf = ma.transform_from_matrix(ros.types, T)
        np.testing.assert_allclose(ma.matrix_from_transform(ros.roundtrip(tf)), T, atol=1e-12)


def test_pose_quaternion_is_normalised(ros):
    pose = ros.new("geometry_msgs/msg/Pose")
    pose.orientation.z, pose.orientation.w = 2.0, 2.0  # 90° about z, norm 2√2
    R = ma.matrix_from_pose(pose)[:3, :3]
    np.testing.assert_allclose(
        R, Rotation.from_euler("z", 90, degrees=True).as_matrix(), atol=1e-12
    )


@pytest.mark.parametrize(
    ("field", "value", "needle"),
    [
        ("orientation", (0.0, 0.0, 0.0, 0.0), "zero norm"),
        ("orientation", (math.nan, 0.0, 0.0, 1.0), "not finite"),
        ("position", (0.0, math.inf, 0.0), r"pose\.position\.y is inf"),
    ],
)
def test_pose_refuses_bad_values(ros, field, value, needle):
    pose = ros.new("geometry_msgs/msg/Pose")
    pose.orientation.w = 1.0
    for attr, v in zip("xyzw", value, strict=False):
        setattr(getattr(pose, field), attr, v)
    with pytest.raises(InvalidInputError, match=needle):
        ma.matrix_from_pose(pose)


# --------------------------------------------------------------------------- Twist
def test_twist_maps_core_omega_v_to_angular_linear_by_name(ros):
    V = np.array([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])  # (ω, v)
    stamp = ros.new("builtin_interfaces/msg/Time", sec=1, nanosec=2)
    msg = ma.twist_stamped_from_core(ros.types, V, "base", stamp)
    assert ros.rclpy_type_problems(msg) == []
    back = ros.roundtrip(msg)
    assert (back.twist.angular.x, back.twist.angular.z) == (1.0, 3.0)
    assert (back.twist.linear.x, back.twist.linear.z) == (4.0, 6.0)
    omega, v = ma.vectors_from_twist(back.twist)
    np.testing.assert_array_equal(np.r_[omega, v], V)
    np.testing.assert_array_equal(ma.core_from_twist(back.twist), V)


# --------------------------------------------------------------------------- Jacobian
def test_jacobian_fields_are_ros_ordered_row_major_and_invert(ros):
    rng = np.random.default_rng(2)
    J = rng.normal(size=(6, 4))  # core rows (ω, v)
    resp = ros.response("ComputeJacobian")
    ma.fill_jacobian_fields(resp, J, ["a", "b", "c", "d"])
    assert ros.rclpy_type_problems(resp) == []
    assert resp.rows == 6 and resp.cols == 4
    assert resp.row_labels[0] == "linear_x" and resp.row_labels[3] == "angular_x"
    assert resp.jacobian[1 * 4 + 2] == J[4, 2]  # ROS row 1 = linear y = core row 4
    assert resp.jacobian[3 * 4 + 0] == J[0, 0]  # ROS row 3 = angular x = core row 0
    np.testing.assert_array_equal(ma.jacobian_from_fields(ros.roundtrip(resp)), J)


def test_jacobian_fields_refuse_inconsistent_sizes(ros):
    resp = ros.response("ComputeJacobian")
    resp.rows, resp.cols, resp.jacobian = 6, 2, [0.0] * 11
    with pytest.raises(InvalidInputError, match="11 values"):
        ma.jacobian_from_fields(resp)
    with pytest.raises(InvalidInputError, match="2 joint names"):
        ma.fill_jacobian_fields(resp, np.zeros((6, 3)), ["a", "b"])


# --------------------------------------------------------------------------- Time
@pytest.mark.parametrize("seconds", [0.0, 1.5, 1_700_000_000.123456789, -2.25, 0.9999999999])
def test_time_round_trip(ros, seconds):
    t = ma.time_from_seconds(ros.types, seconds)
    assert 0 <= t.nanosec < 1_000_000_000
    assert ros.rclpy_type_problems(t) == []
    assert ma.seconds_from_time(ros.roundtrip(t)) == pytest.approx(seconds, abs=1e-9)


def test_time_refuses_nan(ros):
    with pytest.raises(InvalidInputError, match="finite"):
        ma.time_from_seconds(ros.types, math.nan)


def test_copy_time_keeps_every_nanosecond(ros):
    stamp = ros.new("builtin_interfaces/msg/Time", sec=1_700_000_000, nanosec=123_456_789)
    copy = ma.copy_time(ros.types, stamp)
    assert (copy.sec, copy.nanosec) == (1_700_000_000, 123_456_789)
    assert copy is not stamp


def test_float_sequences_accept_array_d_as_rclpy_does(ros):
    msg = ros.new("sensor_msgs/msg/JointState", name=["j1"], position=array.array("d", [0.5]))
    assert ma.q_from_joint_state(msg, ["j1"])[0] == 0.5
