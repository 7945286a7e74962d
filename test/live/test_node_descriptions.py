"""The live node and robot descriptions as real robots ship them, over DDS: a Panda with its hand
from example-robot-data on the robot_description topic (transient local, as robot_state_publisher
gives it) with no tip, held until tip_link is set at run time; a switch to the UR5e on the topic;
FK of several links in one call; and robot_description_file (with xacro_args) from a params file
and from --ros-args.

Each node runs in a namespace of its own (/descriptions), so its robot_description topic meets no
latched description that another test of the session left behind. Answers are compared with the
core's FK in this process.
"""

from __future__ import annotations

import re
import signal
import subprocess
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from kin_testing import erd_path
from kinematics_service.srv import ComputeFK
from live_node import DOMAIN_ID, UR5E, UR5E_JOINTS, NodeProcess, wait_until
from std_msgs.msg import String
from test_node_topics import joint_state

from kinematics_node.core import SerialChain
from kinematics_node.ros.env import executable, local_ros_env
from msg_adapters import matrix_from_pose

NAMESPACE = "/descriptions"
NODE = f"{NAMESPACE}/kinematics_node"
FK = f"{NAMESPACE}/compute_fk"
PANDA_ARM = [f"panda_joint{k}" for k in range(1, 8)]
Q_PANDA = np.array([0.1, -0.4, 0.3, -2.0, 0.2, 1.7, 0.6])
FINGER = 0.025  # [m]
Q_UR5E = np.array([0.3, -1.1, 1.4, -0.6, 0.8, 0.2])


def write_params(params: dict[str, Any], directory: Path) -> Path:
    """A --params-file for the node in /descriptions (dotted names nest, as ROS reads them)."""
    import yaml

    nested: dict[str, Any] = {}
    for name, value in params.items():
        *parents, leaf = name.split(".")
        level = nested
        for part in parents:
            level = level.setdefault(part, {})
        level[leaf] = value
    path = directory / "params.yaml"
    path.write_text(yaml.safe_dump({NODE: {"ros__parameters": nested}}))
    return path


class NamespacedNode(NodeProcess):
    """The node in /descriptions, started with `ros_args` after --ros-args (and a params file
    when `params` are given)."""

    def __init__(self, params: dict[str, Any], directory: Path, ros_args: list[str]) -> None:
        argv = executable("kinematics_node")
        assert argv is not None
        self.log_path = directory / "node.log"
        self._log = self.log_path.open("wb")
        command = [*argv, "--ros-args", "-r", f"__ns:={NAMESPACE}", *ros_args]
        if params:
            command += ["--params-file", str(write_params(params, directory))]
        self.process = subprocess.Popen(
            command,
            env=local_ros_env(DOMAIN_ID),
            stdout=self._log,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )


@pytest.fixture
def start(client, tmp_path) -> Iterator[Callable[..., NamespacedNode]]:
    """Start a namespaced node (1 IK worker: quick to start) and wait for its compute_fk."""
    nodes: list[NamespacedNode] = []

    def run(ros_args: list[str] | None = None, **params: Any) -> NamespacedNode:
        directory = tmp_path / f"node{len(nodes)}"
        directory.mkdir()
        params = {"ik.workers": 1, "diagnostics_period": 0.1, **params}
        node = NamespacedNode(params, directory, ros_args or [])
        nodes.append(node)
        fk = client.node.create_client(ComputeFK, FK)
        ok = fk.wait_for_service(timeout_sec=20.0)
        client.node.destroy_client(fk)
        assert ok and node.alive(), f"node did not come up:\n{node.log()}"
        return node

    yield run
    for node in nodes:
        assert node.stop(signal.SIGINT) == 0, node.log()
        assert "Traceback" not in node.log(), node.log()


@pytest.fixture
def description_topic(client) -> Iterator[Any]:
    """A latched robot_description publisher in the namespace (as robot_state_publisher's),
    destroyed after the test so that no later node receives its description."""
    pub = client.publisher(String, f"{NAMESPACE}/robot_description", latched=True)
    yield pub
    client.node.destroy_publisher(pub)


def fk_request(names, positions, tip_link="", link_names=()) -> Any:
    req = ComputeFK.Request()
    req.joint_state = joint_state(names, positions)
    req.tip_link = tip_link
    req.link_names = list(link_names)
    return req


def answer_saying(client, needle: str, timeout: float = 10.0) -> Any:
    """The first compute_fk answer (empty request) whose message holds `needle`."""
    box: list[Any] = []

    def check() -> bool:
        box[:] = [client.call(ComputeFK, FK, ComputeFK.Request())]
        return needle in box[0].message

    try:
        wait_until(check, timeout, f"an answer saying {needle!r}")
    except AssertionError:
        raise AssertionError(f"last answer: {box[0].message if box else None!r}") from None
    return box[0]


def core_pose(description: Path | str, base: str, link: str, q: dict[str, float]) -> np.ndarray:
    """The core's FK of `link` in `base` at the joint values `q` (by name)."""
    if link == base:
        return np.eye(4)
    chain = SerialChain.from_urdf(description, base, link)
    return chain.fk([q[j] for j in chain.joint_names])


def test_a_panda_with_its_hand_on_the_topic_waits_for_a_tip_then_a_ur5e_replaces_it(
    start, client, description_topic
):
    panda = erd_path("panda_description/urdf/panda.urdf")
    diagnostics = client.collect(DiagnosticArray, "/diagnostics")
    node = start()  # no description parameter: the topic
    description_topic.publish(String(data=panda.read_text(encoding="utf-8")))

    # held, waiting: every answer names the tips and how to choose one
    tips = ["panda_hand_tcp", "panda_leftfinger", "panda_rightfinger"]
    resp = answer_saying(client, "waiting for a tip")
    assert resp.success is False
    assert f"ros2 param set {NODE} tip_link <link>" in resp.message
    assert all(tip in resp.message for tip in tips), resp.message
    assert "waiting for a tip" in node.log()

    def waiting_status() -> dict[str, str] | None:
        for msg in reversed(list(diagnostics)):
            values = {kv.key: kv.value for kv in msg.status[0].values}
            if values.get("description") == "waiting" and values.get("robot_name") == "panda":
                return values
        return None

    wait_until(lambda: waiting_status() is not None, 5, "diagnostics saying 'waiting'")
    assert waiting_status()["candidate_tips"].split(", ") == tips

    # tip_link at run time: a typo refused naming it, then the hand
    (result,) = client.set_parameters(NODE.lstrip("/"), tip_link="panda_hnd")
    assert not result.successful and "'panda_hnd' is not a link of 'panda'" in result.reason
    (result,) = client.set_parameters(NODE.lstrip("/"), tip_link="panda_hand")
    assert result.successful, result.reason
    q = dict(zip(PANDA_ARM, Q_PANDA, strict=True)) | {"panda_finger_joint1": FINGER}
    links = ["panda_hand", "panda_leftfinger", "panda_rightfinger", "panda_hand_tcp", "panda_link0"]
    resp = client.call(ComputeFK, FK, fk_request(list(q), list(q.values()), link_names=links))
    assert resp.success, resp.message
    np.testing.assert_allclose(
        matrix_from_pose(resp.pose.pose),
        core_pose(panda, "panda_link0", "panda_hand", q),
        atol=1e-12,
    )
    assert len(resp.poses) == len(links)
    for link, pose in zip(links, resp.poses, strict=True):
        assert pose.header.frame_id == "panda_link0"
        expected = core_pose(panda, "panda_link0", link, q)
        np.testing.assert_allclose(matrix_from_pose(pose.pose), expected, atol=1e-12, err_msg=link)
    # the two fingers open symmetrically about the hand (the mimic joint followed its leader)
    T_left, T_right = (matrix_from_pose(p.pose) for p in resp.poses[1:3])
    assert np.linalg.norm(T_left[:3, 3] - T_right[:3, 3]) == pytest.approx(2 * FINGER, abs=1e-9)

    # another robot on the topic: the UR5e is held for a tip of its own, then serves
    description_topic.publish(String(data=UR5E.read_text(encoding="utf-8")))
    resp = answer_saying(client, "tip_link 'panda_hand' is not a link of 'ur5e'")
    assert "tool0" in resp.message
    (result,) = client.set_parameters(NODE.lstrip("/"), tip_link="tool0")
    assert result.successful, result.reason
    resp = client.call(ComputeFK, FK, fk_request(UR5E_JOINTS, Q_UR5E, link_names=["forearm_link"]))
    assert resp.success, resp.message
    q = dict(zip(UR5E_JOINTS, Q_UR5E, strict=True))
    np.testing.assert_allclose(
        matrix_from_pose(resp.pose.pose), core_pose(UR5E, "base_link", "tool0", q), atol=1e-12
    )
    np.testing.assert_allclose(
        matrix_from_pose(resp.poses[0].pose),
        core_pose(UR5E, "base_link", "forearm_link", q),
        atol=1e-12,
    )
    assert "loaded 'ur5e' from the robot_description topic" in node.log()


@pytest.fixture
def prefixed_xacro(tmp_path) -> Path:
    """The UR5e as a xacro file whose links and joints take a `prefix` argument (without a
    default: the file cannot be expanded without it)."""
    pytest.importorskip("xacro", reason="xacro (pip install xacro) expands the file")
    text = UR5E.read_text(encoding="utf-8")
    text = re.sub(r'(<(?:link|joint) name="|<(?:parent|child) link=")', r"\1$(arg prefix)", text)
    path = tmp_path / "ur5e_prefixed.urdf.xacro"
    path.write_text(text, encoding="utf-8")
    return path


def check_prefixed_ur5e(client, prefix: str) -> None:
    names = [prefix + j for j in UR5E_JOINTS]
    resp = client.call(ComputeFK, FK, fk_request(names, Q_UR5E))
    assert resp.success, resp.message
    assert resp.pose.header.frame_id == prefix + "base_link"
    q = dict(zip(UR5E_JOINTS, Q_UR5E, strict=True))
    np.testing.assert_allclose(
        matrix_from_pose(resp.pose.pose), core_pose(UR5E, "base_link", "tool0", q), atol=1e-12
    )


def test_robot_description_file_and_xacro_args_from_a_params_file(start, client, prefixed_xacro):
    node = start(robot_description_file=str(prefixed_xacro), xacro_args="prefix:=left_")
    check_prefixed_ur5e(client, "left_")
    assert f"the robot_description_file parameter ('{prefixed_xacro}'" in node.log()


def test_robot_description_file_and_xacro_args_from_ros_args(start, client, prefixed_xacro):
    start(["-p", f"robot_description_file:={prefixed_xacro}", "-p", "xacro_args:=prefix:=r_"])
    check_prefixed_ur5e(client, "r_")


def test_a_bad_robot_description_file_from_ros_args_is_named_in_the_answers(start, client):
    node = start(["-p", "robot_description_file:=/no/such/arm.urdf"])
    resp = answer_saying(client, "'/no/such/arm.urdf': no such file")
    assert "robot_description_file" in resp.message and not resp.success
    time.sleep(0.1)
    assert "cannot use the robot description" in node.log()
