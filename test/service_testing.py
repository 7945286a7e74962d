"""Helpers and fixtures of the KinematicsService tests: a UR5 service with a fake TF tree and a
settable clock, JointState messages, and the checks every produced message passes."""

from __future__ import annotations

import math

import numpy as np
import pytest

import msg_adapters as ma
from kinematics_node.core import SerialChain
from kinematics_node.service.kinematics import KinematicsService

T_BASE_CAMERA = np.array(  # the fake TF tree: camera 1 m above the base, rotated 90° about z
    [[0.0, -1.0, 0.0, 0.2], [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 1.0], [0.0, 0.0, 0.0, 1.0]]
)


def fake_tf(target: str, source: str) -> np.ndarray:
    if (target, source) == ("base_link", "camera"):
        return T_BASE_CAMERA
    raise LookupError(f'"{source}" passed to lookupTransform argument source_frame does not exist')


class Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


@pytest.fixture
def clock() -> Clock:
    return Clock()


@pytest.fixture
def ur5(ros, ur5_path, clock) -> KinematicsService:
    params = {
        "robot_description": ur5_path.read_text(),
        "base_link": "base_link",
        "tip_link": "tool0",
    }
    return KinematicsService(ros.types, params, lookup_transform=fake_tf, clock=clock)


@pytest.fixture
def q_ur5() -> np.ndarray:
    return np.array([0.3, -1.1, 1.4, -0.6, 0.8, 0.2])


def js(ros, names, positions, t=0.0, velocity=()):
    """A JointState stamped t [s] (or (sec, nanosec))."""
    sec, nanosec = t if isinstance(t, tuple) else (math.floor(t), round((t - math.floor(t)) * 1e9))
    return ros.new(
        "sensor_msgs/msg/JointState",
        header=ros.new(
            "std_msgs/msg/Header",
            stamp=ros.new("builtin_interfaces/msg/Time", sec=sec, nanosec=nanosec),
        ),
        name=list(names),
        position=np.asarray(positions, dtype=float),
        velocity=np.asarray(velocity, dtype=float),
    )


def ik_target(ros, T, frame_id=""):
    """A ComputeIK `target` (geometry_msgs/PoseStamped, stamped 4 s 5 ns) of the 4×4 pose T."""
    ps = ma.pose_stamped_from_matrix(
        ros.types, T, frame_id, ros.new("builtin_interfaces/msg/Time", sec=4, nanosec=5)
    )
    ps.pose = ros.new(
        "geometry_msgs/msg/Pose", position=ps.pose.position, orientation=ps.pose.orientation
    )
    return ps


def check_message(ros, msg) -> None:
    """rclpy would accept it, it is finite, and it survives CDR unchanged."""
    assert ros.rclpy_type_problems(msg) == []
    fields = ros.flatten(msg)
    nonfinite = [p for p, v in fields.items() if isinstance(v, float) and not math.isfinite(v)]
    assert nonfinite == [], f"non-finite fields: {nonfinite}"
    assert ros.flatten(ros.roundtrip(msg)) == fields


def chain_of(svc: KinematicsService) -> SerialChain:
    assert svc.model is not None
    return svc.model.chain
