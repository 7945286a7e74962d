"""msg_adapters.geometry against real ROS 2 message classes (rosbags): poses, transforms and
twists, refusals, CDR, typing."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import msg_adapters as ma
from kinematics_node.core.exceptions import InvalidInputError


def _random_T(rng: np.random.Generator) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = Rotation.random(random_state=rng).as_matrix()
    T[:3, 3] = rng.normal(size=3)
    return T


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


@pytest.mark.parametrize("scale", [1e-8, 0.3, 1.0, 7.0, 1e200])
def test_pose_of_any_nonzero_quaternion_is_scipys_rotation(ros, scale):
    """Quaternions of any norm, tiny to huge (no overflow), give SciPy's rotation of the
    normalised quaternion: a proper rotation matrix."""
    rng = np.random.default_rng(7)
    for q in rng.normal(size=(50, 4)):
        pose = ros.new("geometry_msgs/msg/Pose")
        o = pose.orientation
        o.x, o.y, o.z, o.w = (float(v) for v in scale * q)
        R = ma.matrix_from_pose(pose)[:3, :3]
        np.testing.assert_allclose(R, Rotation.from_quat(q).as_matrix(), atol=1e-12)
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)


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
