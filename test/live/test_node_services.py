"""The live node's services: answers checked against the core and Pinocchio, every bad-request
class refused with a message naming the culprit, IK deadlines under concurrent clients, and pose
publishing during a long IK call."""

from __future__ import annotations

import math
import re
import time

import numpy as np
import pytest
from geometry_msgs.msg import PoseStamped
from kin_testing import PinocchioOracle, check_nearest_solutions
from kinematics_service.srv import ComputeFK, ComputeIK, ComputeJacobian
from live_node import ROBOTS, UR5E_JOINTS, ur5e_description, wait_until
from test_node_topics import Stream, joint_state

from kinematics_node.core import SerialChain
from msg_adapters import jacobian_from_fields, matrix_from_pose

CHAIN = SerialChain.from_urdf(ROBOTS / "ur5e.urdf")
Q = np.array([0.3, -1.1, 1.4, -0.6, 0.8, 0.2])


@pytest.fixture(scope="module")
def pinocchio() -> PinocchioOracle:
    return PinocchioOracle.from_xml(ur5e_description(), CHAIN.joint_names)


@pytest.fixture(scope="module")
def node(client, tmp_path_factory):
    """One UR5e node for the module (the tests here do not change its parameters)."""
    import signal

    from live_node import NodeProcess

    directory = tmp_path_factory.mktemp("services")
    # the joint state is published once, here: its age is not these tests' concern (no limit;
    # test_node_joint_state_age.py tests the limit)
    process = NodeProcess(
        {"robot_description": ur5e_description(), "joint_states_max_age": 0.0}, directory
    )
    fk = client.node.create_client(ComputeFK, "compute_fk")
    assert fk.wait_for_service(timeout_sec=20.0), process.log()
    client.node.destroy_client(fk)
    stream = Stream(client)
    stream.connected(process)
    stream.pub.publish(joint_state(UR5E_JOINTS, Q, stamp_ns=5_000_000_000))
    wait_until(lambda: stream.poses, 5, "the node to take the current joint state")
    yield process
    assert process.stop(signal.SIGINT) == 0
    assert "Traceback" not in process.log(), process.log()


def fk_request(names, positions, tip_link=""):
    req = ComputeFK.Request()
    req.joint_state = joint_state(names, positions)
    req.tip_link = tip_link
    return req


def ik_request(T, frame_id="base_link", timeout=0.5, **fields):
    req = ComputeIK.Request()
    req.target = PoseStamped()
    req.target.header.frame_id = frame_id
    x, y, z = (float(v) for v in T[:3, 3])
    req.target.pose.position.x, req.target.pose.position.y, req.target.pose.position.z = x, y, z
    from kinematics_node.core.so3 import quaternion_from_rows

    qx, qy, qz, qw = quaternion_from_rows(T[:3, :3].ravel().tolist())
    o = req.target.pose.orientation
    o.x, o.y, o.z, o.w = qx, qy, qz, qw
    req.timeout = float(timeout)
    for key, value in fields.items():
        setattr(req, key, value)
    return req


def test_fk_matches_pinocchio_for_the_tip_and_another_link(node, client, pinocchio):
    q = np.array([0.1, -0.7, 1.2, 0.4, -0.9, 2.5])
    resp = client.call(ComputeFK, "compute_fk", fk_request(UR5E_JOINTS, q))
    assert resp.success, resp.message
    assert resp.pose.header.frame_id == "base_link"
    T_pin = pinocchio.pose(q, "tool0")
    np.testing.assert_allclose(matrix_from_pose(resp.pose.pose), T_pin, atol=1e-9)
    # a subset: the other joints keep the node's current joint_states (Q)
    resp = client.call(ComputeFK, "compute_fk", fk_request(["elbow_joint"], [0.5], "forearm_link"))
    assert resp.success, resp.message
    q_mixed = Q.copy()
    q_mixed[2] = 0.5
    T_pin = pinocchio.pose(q_mixed, "forearm_link")
    np.testing.assert_allclose(matrix_from_pose(resp.pose.pose), T_pin, atol=1e-9)


@pytest.mark.parametrize("frame", ["world", "body", "space"])
def test_jacobian_matches_the_core_and_pinocchio(node, client, pinocchio, frame):
    q = np.array([0.1, -0.7, 1.2, 0.4, -0.9, 2.5])
    req = ComputeJacobian.Request()
    req.joint_state = joint_state(UR5E_JOINTS, q)
    req.frame = frame
    resp = client.call(ComputeJacobian, "compute_jacobian", req)
    assert resp.success, resp.message
    J = jacobian_from_fields(resp)  # core rows (ω, v)
    np.testing.assert_allclose(J, CHAIN.jacobian(q, frame), atol=1e-12)
    if frame == "world":
        _, J_pin = pinocchio.pose_and_jacobians(q, "tool0")
        np.testing.assert_allclose(J, J_pin["world"], atol=1e-9)
    assert math.isfinite(resp.manipulability) and resp.manipulability > 0


def test_ik_solves_a_reachable_target_in_the_base_and_in_a_link_frame(node, client):
    q_goal = np.array([0.5, -1.0, 1.1, -0.4, 0.9, -0.3])
    T = CHAIN.fk(q_goal)
    resp = client.call(ComputeIK, "compute_ik", ik_request(T))
    assert resp.success, resp.message
    q = np.array(resp.solution.position)
    assert list(resp.solution.name) == list(CHAIN.joint_names)
    np.testing.assert_allclose(CHAIN.fk(q), T, atol=1e-4)
    assert resp.position_error <= 1e-5 and resp.orientation_error <= 1e-4
    # the same target, given in the frame of a robot link (FK of the current joint_states)
    T_base_link3 = CHAIN.link_pose(Q, "forearm_link")
    resp = client.call(
        ComputeIK, "compute_ik", ik_request(np.linalg.inv(T_base_link3) @ T, "forearm_link")
    )
    assert resp.success, resp.message
    np.testing.assert_allclose(CHAIN.fk(np.array(resp.solution.position)), T, atol=1e-4)


def test_ik_returns_several_solutions_of_a_ur5e_target_from_the_closed_form(node, client):
    """max_solutions over DDS: the answer is the nearest of the closed-form set (the core's
    ik_all in this process is the oracle), each solution reproduces the target by FK, and only
    the whole set is marked complete."""
    q_goal = np.array([0.5, -1.0, 1.1, -0.4, 0.9, -0.3])
    seed = q_goal + 0.1
    T = CHAIN.fk(q_goal)
    assert CHAIN.ik_family == "three_parallel"
    every = np.array(CHAIN.ik_all(T, q_seed=seed).solutions)
    assert len(every) > 8
    # timeout: room for each worker's first detection of the family (~50 ms) on a busy machine
    for n, complete in ((8, False), (10000, True)):
        req = ik_request(T, timeout=2.0, max_solutions=n, seed=joint_state(UR5E_JOINTS, seed))
        resp = client.call(ComputeIK, "compute_ik", req)
        assert resp.success, resp.message
        assert resp.complete is complete
        Q = np.array([s.position for s in resp.solutions])
        assert Q.shape == (min(n, len(every)), CHAIN.dof)
        assert all(list(s.name) == list(CHAIN.joint_names) for s in resp.solutions)
        assert list(resp.solutions[0].position) == list(resp.solution.position)
        check_nearest_solutions(Q, every, seed)
        for q in Q:
            np.testing.assert_allclose(CHAIN.fk(q), T, atol=1e-9)
    assert np.min(np.max(np.abs(Q - q_goal), axis=1)) <= 1e-8  # the whole set holds q_goal


def _bad_fk(**f):
    req = fk_request(f.get("names", UR5E_JOINTS), f.get("positions", Q), f.get("tip_link", ""))
    return req


BAD = [
    (
        ComputeFK,
        "compute_fk",
        lambda: _bad_fk(names=["bogus_joint"], positions=[0.0]),
        "'bogus_joint'",
    ),
    (ComputeFK, "compute_fk", lambda: _bad_fk(positions=[0.0] * 5), "6 names but 5 positions"),
    (ComputeFK, "compute_fk", lambda: _bad_fk(positions=[0, math.nan, 0, 0, 0, 0]), "nan"),
    (ComputeFK, "compute_fk", lambda: _bad_fk(positions=[0, math.inf, 0, 0, 0, 0]), "inf"),
    (ComputeFK, "compute_fk", lambda: _bad_fk(tip_link="nope"), "'nope'"),
    (ComputeFK, "compute_fk", lambda: _bad_fk(tip_link="base_link"), "no moving joint"),
    (ComputeJacobian, "compute_jacobian", lambda: _jac(frame="tool"), "'tool'"),
    (ComputeIK, "compute_ik", lambda: _ik(quaternion=(0.0, 0.0, 0.0, 0.0)), "zero norm"),
    (ComputeIK, "compute_ik", lambda: _ik(quaternion=(math.nan, 0.0, 0.0, 1.0)), "orientation"),
    (ComputeIK, "compute_ik", lambda: _ik(position=math.inf), "target.pose.position"),
    (ComputeIK, "compute_ik", lambda: _ik(timeout=-0.1), "timeout"),
    (ComputeIK, "compute_ik", lambda: _ik(timeout=math.nan), "timeout"),
    (ComputeIK, "compute_ik", lambda: _ik(position_tolerance=-1e-3), "position_tolerance"),
    (
        ComputeIK,
        "compute_ik",
        lambda: _ik(seed=joint_state(["bogus_joint"], [0.0])),
        "'bogus_joint'",
    ),
    (ComputeIK, "compute_ik", lambda: _ik(tip_link="nope"), "'nope'"),
    (ComputeIK, "compute_ik", lambda: _ik(axis_tolerances=[0.1, 0.2]), "axis_tolerances"),
    (ComputeIK, "compute_ik", lambda: _ik(max_solutions=10001), "max_solutions"),
    # not a robot link, and no tf2_ros to look it up (the PyPI ROS 2 has none)
    (ComputeIK, "compute_ik", lambda: _ik(frame_id="map"), "tf2_ros"),
]


def _jac(frame):
    req = ComputeJacobian.Request()
    req.joint_state = joint_state(UR5E_JOINTS, Q)
    req.frame = frame
    return req


def _ik(quaternion=(0.0, 0.0, 0.0, 1.0), position=0.4, frame_id="base_link", **fields):
    req = ik_request(np.eye(4), frame_id, **{"timeout": 0.1, **fields})
    req.target.pose.position.x = position
    o = req.target.pose.orientation
    o.x, o.y, o.z, o.w = quaternion
    return req


@pytest.mark.parametrize(("srv", "name", "make", "needle"), BAD, ids=[b[3] for b in BAD])
def test_bad_requests_answer_failure_naming_the_culprit(node, client, srv, name, make, needle):
    try:
        import tf2_ros  # noqa: F401

        if needle == "tf2_ros":
            pytest.skip("tf2_ros is installed: TF frames are looked up (tested by the launch test)")
    except ImportError:
        pass
    resp = client.call(srv, name, make())
    assert resp.success is False
    assert needle in resp.message, resp.message
    assert node.alive()


def test_pose_stream_keeps_flowing_during_a_2_s_ik_call(node, client):
    """The launch test's assertion, live: joint_states at 100 Hz during a 2 s IK call still give
    a pose each (more than 10, and in fact nearly all)."""
    stream = Stream(client)
    wait_until(lambda: stream.pub.get_subscription_count() > 0, 10, "subscription")
    req = _ik(position=0.0)
    req.target.pose.position.z = (
        0.3  # inside the reach but unreachable: the search uses its timeout
    )
    req.timeout = 2.0
    cli = client.node.create_client(ComputeIK, "compute_ik")
    assert cli.wait_for_service(timeout_sec=10.0)
    time.sleep(0.2)
    stream.poses.clear()
    future = cli.call_async(req)
    t0 = time.monotonic()
    sent = 0
    while not future.done() and time.monotonic() - t0 < 10.0:
        sent += 1
        stream.pub.publish(
            joint_state(UR5E_JOINTS, Q + 1e-3 * sent, stamp_ns=10**12 + sent * 10**7)
        )
        time.sleep(0.01)
    elapsed = time.monotonic() - t0
    assert future.done()
    resp = future.result()
    assert not resp.success and 1.9 <= elapsed <= 2.2, (elapsed, resp.message)
    # the message says the request's timeout, and the time since the request was sent (not the
    # worker's share of it): once, between the timeout and what this client waited
    took = re.search(r"the timeout of 2 s ran out after ([\d.]+) s, \d+ restarts", resp.message)
    assert took is not None and resp.message.count("timeout") == 1, resp.message
    assert 1.95 <= float(took[1]) <= elapsed + 0.01, (elapsed, resp.message)
    time.sleep(0.1)
    got = len(stream.poses)
    assert got > 10, "poses stalled during a 2 s IK call"
    assert got >= 0.95 * sent, f"{got} poses for {sent} joint states during the IK call"
    assert math.isfinite(resp.position_error)
