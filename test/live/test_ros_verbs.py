"""`kinematics ros fk|jacobian|twist|diagnostics` and `pose` on a topic of another type, run as a
user runs them (a process each) against the real node over DDS: the printed numbers against the
core's SerialChain to 1e-9, and the bad inputs (an unknown joint, the wrong number of values,
nothing running), each one line on stderr and status 1.

One node serves every test of the module (UR5e, tip tool0), fed joint_states at 50 Hz from this
process: positions Q0, velocities QD (ee_twist is then J(Q0) QD, from the message's velocities).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from live_node import DOMAIN_ID, UR5E, Client, NodeProcess, ur5e_description, wait_until

from kinematics_node.core import SerialChain
from kinematics_node.core.analysis import manipulability
from kinematics_node.core.rotations import matrix_from_quaternion
from kinematics_node.ros.env import local_ros_env

CHAIN = SerialChain.from_urdf(UR5E, tip_link="tool0")
Q0 = np.array([0.3, -1.1, 1.4, -0.6, 0.8, 0.2])
QD = np.array([0.05, -0.1, 0.2, 0.1, -0.3, 0.4])
#: Values given on the command line (different from Q0, so an answer at Q0 would show).
Q = np.array([0.1, -1.2, 1.5, -0.4, 0.5, -0.3])
Q_TEXT = ",".join(repr(float(v)) for v in Q)
#: A domain where nothing runs (the run's own are 100..199): "no node running".
EMPTY_DOMAIN = 200 + os.getpid() % 30


def _start(*args: str, domain: int = DOMAIN_ID) -> subprocess.Popen[str]:
    # Up to six of these start rclpy at once on two cores, beside the node: on a loaded machine
    # one waited more than the default 10 s for its service; 30 s unless the test says otherwise.
    wait = () if "--wait" in args else ("--wait", "30")
    return subprocess.Popen(
        [sys.executable, "-m", "kinematics_node.cli", "ros", *args, *wait],
        env=local_ros_env(domain),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _finish(process: subprocess.Popen[str]) -> tuple[int, str, str]:
    out, err = process.communicate(timeout=60)
    return process.returncode, out, err


def _json(process: subprocess.Popen[str]) -> dict:
    status, out, err = _finish(process)
    assert status == 0, err
    return json.loads(out)


def _pose_matrix(answer: dict) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = matrix_from_quaternion(answer["quaternion_xyzw"])
    T[:3, 3] = answer["position"]
    return T


@pytest.fixture(scope="module")
def node(client: Client) -> Iterator[NodeProcess]:
    """The node, once it publishes ee_pose for the joint_states this fixture keeps sending."""
    from sensor_msgs.msg import JointState

    directory = tempfile.TemporaryDirectory(prefix="kinematics_live_")
    process = NodeProcess(
        {"robot_description": ur5e_description(), "tip_link": "tool0"}, Path(directory.name)
    )
    publisher = client.publisher(JointState, "joint_states")
    lock = threading.Lock()

    def publish() -> None:
        msg = JointState()
        msg.header.stamp = client.node.get_clock().now().to_msg()
        msg.name = list(CHAIN.joint_names)
        msg.position = Q0.tolist()
        msg.velocity = QD.tolist()
        with lock:
            publisher.publish(msg)

    timer = client.node.create_timer(0.02, publish)
    from geometry_msgs.msg import PoseStamped

    poses = client.collect(PoseStamped, "ee_pose")
    try:
        wait_until(lambda: bool(poses) or not process.alive(), 30.0, "the node's first ee_pose")
        assert process.alive(), process.log()
        yield process
    finally:
        client.node.destroy_timer(timer)
        process.stop(signal.SIGINT)
        directory.cleanup()


def test_fk_prints_the_core_s_poses(node):
    """Values in chain order, and by name (the other joints from joint_states: Q0), with
    --links: every pose equals SerialChain's FK to 1e-9."""
    in_order = _start("fk", "--q", Q_TEXT, "--links", "wrist_1_link,base_link", "--json")
    by_name = _start("fk", "--q", "elbow_joint=0.5,wrist_3_joint=-1", "--json")
    text = _start("fk", "--q", Q_TEXT)

    answer = _json(in_order)
    assert answer["service"] == "/compute_fk" and answer["frame_id"] == "base_link"
    assert np.abs(_pose_matrix(answer) - CHAIN.fk(Q)).max() < 1e-9
    wrist, base = answer["links"]
    assert (wrist["link"], base["link"]) == ("wrist_1_link", "base_link")
    to_wrist = SerialChain.from_urdf(UR5E, tip_link="wrist_1_link")
    q_wrist = [Q[CHAIN.joint_names.index(j)] for j in to_wrist.joint_names]
    assert np.abs(_pose_matrix(wrist) - to_wrist.fk(np.array(q_wrist))).max() < 1e-9
    assert np.abs(_pose_matrix(base) - np.eye(4)).max() < 1e-12

    answer = _json(by_name)
    q = Q0.copy()
    q[CHAIN.joint_names.index("elbow_joint")] = 0.5
    q[CHAIN.joint_names.index("wrist_3_joint")] = -1.0
    assert np.abs(_pose_matrix(answer) - CHAIN.fk(q)).max() < 1e-9

    status, out, err = _finish(text)
    assert status == 0, err
    position = next(line for line in out.splitlines() if line.startswith("position [m]"))
    printed = [float(v) for v in position.split()[2:]]
    assert np.abs(np.array(printed) - CHAIN.fk(Q)[:3, 3]).max() <= 5e-7  # six decimals


def test_jacobian_prints_the_core_s_matrix_in_ros_row_order(node):
    """Rows linear x, y, z then angular x, y, z (the srv's order; the core's is (ω, v)), equal to
    SerialChain.jacobian to 1e-9 in each convention; the text says the row order and prints the
    same numbers."""
    # Two processes at a time (each starts rclpy: ~1 s): six at once, on Kilted's Fast DDS 3, met
    # "Failed init_port ... open_and_lock_file failed" on its shared-memory ports in a CI dry run,
    # and one of them never reached the node within 30 s
    for frame in ("world", "space", "body"):
        as_json = _start("jacobian", "--q", Q_TEXT, "--frame", frame, "--json")
        text = _start("jacobian", "--q", Q_TEXT, "--frame", frame)
        answer = _json(as_json)
        J = CHAIN.jacobian(Q, frame)  # rows (ω, v)
        J_ros = np.vstack([J[3:], J[:3]])
        assert answer["row_labels"] == [
            "linear_x",
            "linear_y",
            "linear_z",
            "angular_x",
            "angular_y",
            "angular_z",
        ]
        assert answer["joint_names"] == list(CHAIN.joint_names)
        assert answer["frame"] == frame and answer["tip_link"] == "tool0"
        assert np.abs(np.array(answer["jacobian"]) - J_ros).max() < 1e-9, frame
        J_world = CHAIN.jacobian(Q, "world")
        linear = manipulability(J_world, "linear")
        assert answer["manipulability"] == pytest.approx(linear, rel=1e-9)

        status, out, err = _finish(text)
        assert status == 0, err
        assert "rows in ROS order (as geometry_msgs/Twist): linear x, y, z [m/s], then" in out
        rows = {
            line.split()[0]: line.split()[1:] for line in out.splitlines() if line[:1].isalpha()
        }
        printed = np.array([[float(v) for v in rows[label]] for label in answer["row_labels"]])
        assert np.abs(printed - J_ros).max() <= 5e-7, frame


def test_twist_prints_the_tip_s_velocity(node):
    """ee_twist for joint_states with velocities QD at Q0: J_world(Q0) QD, linear then angular."""
    answer = _json(_start("twist", "--json"))
    assert answer["topic"] == "/ee_twist" and answer["frame_id"] == "base_link"
    V = CHAIN.jacobian(Q0, "world") @ QD  # (ω, v)
    assert np.abs(np.array(answer["linear"]) - V[3:]).max() < 1e-9
    assert np.abs(np.array(answer["angular"]) - V[:3]).max() < 1e-9


def test_diagnostics_prints_the_node_s_status(node):
    """The node's status, by its name and by its full name; another name: status 1, saying
    which statuses came instead."""
    by_name = _start("diagnostics", "--json")
    by_full_name = _start("diagnostics", "--node", "/kinematics_node")
    other = _start("diagnostics", "--node", "/arm/kinematics_node", "--wait", "4")

    answer = _json(by_name)
    (status,) = answer["status"]
    assert status["name"].endswith("kinematics_node: end effector")
    assert status["level"] in ("OK", "WARN"), status  # a level's name (a WARN: a loaded machine)
    values = status["values"]
    assert values["tip_link"] == "tool0" and values["dof"] == "6"
    expected = manipulability(CHAIN.jacobian(Q0, "world"), "linear")
    assert float(values["manipulability"]) == pytest.approx(expected, rel=1e-5)  # printed .6g

    code, out, err = _finish(by_full_name)
    assert code == 0, err
    assert "kinematics_node: end effector: " in out
    assert "\n  tip_link" in out and "tool0" in out

    code, out, err = _finish(other)
    assert code == 1 and out == "" and err.count("\n") == 1
    assert "no message on /diagnostics within 4 s" in err
    assert "sent statuses of " in err and "kinematics_node: end effector only" in err


def test_pose_on_a_topic_of_another_type_says_its_type(node):
    """`pose --topic /ee_twist` said "1 node(s) offer it but sent nothing"; now it says what the
    topic carries and which verb reads it (and `twist --topic /ee_pose` likewise)."""
    pose = _start("pose", "--topic", "/ee_twist")
    twist = _start("twist", "--topic", "ee_pose")
    status, out, err = _finish(pose)
    assert status == 1 and out == "" and err.count("\n") == 1
    assert err == (
        "kinematics: error: /ee_twist carries geometry_msgs/msg/TwistStamped, not "
        "geometry_msgs/msg/PoseStamped: try kinematics ros twist\n"
    )
    status, out, err = _finish(twist)
    assert status == 1 and "/ee_pose carries geometry_msgs/msg/PoseStamped, not " in err
    assert "try kinematics ros pose" in err


def test_bad_joint_values_are_one_line_and_status_1(node):
    unknown = _start("fk", "--q", "elbow_joint=0.5,elbo_joint=1")
    too_few = _start("jacobian", "--q", "0.1,0.2")
    status, out, err = _finish(unknown)
    assert status == 1 and out == "" and err.count("\n") == 1
    assert err.startswith("kinematics: error: /compute_fk: ") and "'elbo_joint'" in err
    status, out, err = _finish(too_few)
    assert status == 1 and out == "" and err.count("\n") == 1
    assert (
        "--q has 2 value(s) but the chain base_link -> tool0 has 6 joint(s): shoulder_pan_joint,"
        in err
    )


def test_with_no_node_running_each_verb_says_so():
    expected = [
        (["fk", "--q", "elbow_joint=0.5"], "no /compute_fk service within 1 s: "),
        (["fk", "--q", "0,1"], "no /compute_jacobian service within 1 s: "),
        (["jacobian"], "no /compute_jacobian service within 1 s: "),
        (["twist"], "no message on /ee_twist within 1 s: nothing publishes it"),
        (["diagnostics"], "no message on /diagnostics within 1 s: nothing publishes it"),
    ]
    runs = [_start(*args, "--wait", "1", domain=EMPTY_DOMAIN) for args, _ in expected]
    for (args, says), run in zip(expected, runs, strict=True):
        status, out, err = _finish(run)
        assert status == 1 and out == "" and err.count("\n") == 1, (args, err)
        assert says in err and f"ROS_DOMAIN_ID={EMPTY_DOMAIN}" in err, (args, err)
