"""`kinematics ros` against a real node over DDS, where it does not simply succeed (the quick
start, test_quickstart.py, covers the pose and an IK call that work): nothing running, a node
without joint_states, an unreachable target, a service that does not exist. Each answer is one
line on stderr that says what was seen, and the status is 1; an IK answer in JSON reaches its
target. `kinematics ros param` chooses the tip of a Panda with its hand, as `ros2 param` would."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
from kin_testing import erd_path
from live_node import DOMAIN_ID, UR5E, ur5e_description

from kinematics_node.core import SerialChain
from kinematics_node.core.rotations import matrix_from_quaternion
from kinematics_node.core.so3 import quaternion_from_matrix
from kinematics_node.ros.env import local_ros_env

#: A pose the UR5e reaches (tool0 pointing down), and one 5 m away, beyond its reach.
REACHABLE = "0.4,0.1,0.4,1,0,0,0"
UNREACHABLE = "5,0,0,0,0,0,1"


def _start(*args: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "kinematics_node.cli", "ros", *args],
        env=local_ros_env(DOMAIN_ID),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _finish(process: subprocess.Popen[str]) -> tuple[int, str, str]:
    out, err = process.communicate(timeout=60)
    return process.returncode, out, err


def test_with_no_node_it_says_nothing_publishes_the_pose():
    status, out, err = _finish(_start("pose", "--wait", "1"))
    assert status == 1 and out == ""
    assert err.count("\n") == 1
    assert err.startswith("kinematics: error: no message on /ee_pose within 1 s: nothing publishes")
    assert f"ROS_DOMAIN_ID={DOMAIN_ID}" in err and "ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST" in err


def test_against_a_node_without_joint_states(start_node):
    start_node(robot_description=ur5e_description())
    # independent calls, run at once (each process starts rclpy: ~1 s)
    pose = _start("pose", "--wait", "10")
    # a new process sees the node started before it after up to ~3 s (Fast DDS's discovery with
    # the package's profile, measured here), longer with four processes starting rclpy at once
    # on a busy machine (this test failed once beside a benchmark): 10 s to name it
    missing = _start("ik", "--target", REACHABLE, "--service", "no_such_service", "--wait", "10")
    far = _start("ik", "--target", UNREACHABLE)
    near = _start("ik", "--target", REACHABLE, "--json")

    status, out, err = _finish(pose)
    assert status == 1 and out == "" and err.count("\n") == 1
    assert "no message on /ee_pose within 10 s: 1 node(s) offer it but sent nothing" in err
    assert "joint_states" in err

    status, out, err = _finish(missing)
    assert status == 1 and out == "" and err.count("\n") == 1
    assert "no /no_such_service service within 10 s: nodes seen: " in err
    assert "/kinematics_node" in err

    status, out, err = _finish(far)
    assert status == 1
    # the reason once, on stderr; stdout holds the best effort, marked as not a solution
    assert out.startswith("best effort (not a solution):\n") and "position error" in out
    assert "reaches at most" not in out
    assert err.startswith("kinematics: error: /compute_ik: ") and "reaches at most" in err
    assert err.count("\n") == 1

    status, out, err = _finish(near)
    assert status == 0, err
    answer = json.loads(out)
    assert answer["success"] is True
    chain = SerialChain.from_urdf(UR5E)
    assert answer["joint_names"] == list(chain.joint_names)
    T = chain.fk(np.array(answer["q"]))
    target = [float(v) for v in REACHABLE.split(",")]
    assert np.linalg.norm(T[:3, 3] - target[:3]) <= 1e-5
    R_error = T[:3, :3].T @ matrix_from_quaternion(target[3:])
    assert np.arccos(np.clip((np.trace(R_error) - 1.0) / 2.0, -1.0, 1.0)) <= 1e-4
    assert answer["position_error"] <= 1e-5 and answer["orientation_error"] <= 1e-4


def test_param_sets_the_tip_of_a_description_with_a_gripper(start_node):
    """A Panda with its hand has three leaves: the node waits for a tip. `kinematics ros param`
    sets it (a typo refused with the node's reason), reads it back, lists it, fits a whole number
    to a double parameter (ros2 param set refuses 1 for a double), and the node then solves IK for
    that tip."""
    panda = erd_path("panda_description/urdf/panda.urdf")
    start_node(robot_description_file=str(panda))

    status, out, err = _finish(_start("param", "set", "kinematics_node", "tip_link", "panda_hnd"))
    assert status == 1 and out == "" and err.count("\n") == 1
    assert (
        "/kinematics_node refused tip_link = panda_hnd: tip_link 'panda_hnd' is not a link" in err
    )
    status, out, err = _finish(_start("param", "set", "kinematics_node", "tip_link", "panda_hand"))
    assert status == 0, err
    assert out == "/kinematics_node: tip_link set to panda_hand\n"
    status, out, err = _finish(_start("param", "set", "/kinematics_node", "ik.timeout", "1"))
    assert status == 0, err
    status, out, err = _finish(_start("param", "get", "kinematics_node", "ik.timeout"))
    assert (status, out) == (0, "ik.timeout: 1.0\n"), err
    status, out, err = _finish(_start("param", "get", "kinematics_node", "no_such_parameter"))
    assert status == 1 and "/kinematics_node has no parameter 'no_such_parameter'" in err
    status, out, err = _finish(_start("param", "list", "kinematics_node"))
    assert status == 0, err
    rows = out.splitlines()
    assert "tip_link: panda_hand" in rows and "base_link: ''" in rows
    assert rows == sorted(rows) and any(r.startswith("robot_description_file: ") for r in rows)

    chain = SerialChain.from_urdf(panda, tip_link="panda_hand")
    q = np.array([0.1, -0.3, 0.2, -2.0, 0.1, 1.8, 0.6])
    T = chain.fk(q)
    target = ",".join(f"{v:.12f}" for v in [*T[:3, 3], *quaternion_from_matrix(T[:3, :3])])
    status, out, err = _finish(_start("ik", "--target", target, "--json"))
    assert status == 0, err
    answer = json.loads(out)
    assert answer["success"] is True and answer["joint_names"] == list(chain.joint_names)
    reached = chain.fk(np.array(answer["q"]))
    assert np.linalg.norm(reached[:3, 3] - T[:3, 3]) <= 1e-5
