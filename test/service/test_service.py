"""KinematicsService on real ROS 2 message classes (rosbags) and a real arm (UR5, Panda).

Checks: published pose/twist agree with Pinocchio and with finite differences; service answers agree
with the core; every bad request gives success=False with a message naming the problem; every
produced message survives CDR and has the Python types rclpy requires.
"""

from __future__ import annotations

import math
import threading
import time

import numpy as np
import pytest
from kin_testing import PinocchioOracle
from scipy.spatial.transform import Rotation
from service_testing import T_BASE_CAMERA, chain_of, check_message, ik_target, js

import msg_adapters as ma
from kinematics_node.core import SerialChain, se3
from kinematics_node.core.exceptions import InvalidInputError, KinematicsError
from kinematics_node.service.kinematics import KinematicsService


def pose_matrix(msg) -> np.ndarray:
    return ma.matrix_from_pose(msg.pose)


# =========================================================================== joint_states
def test_pose_matches_pinocchio_and_is_stamped_with_the_joint_state(ros, ur5, ur5_path, q_ur5):
    chain = chain_of(ur5)
    out = ur5.on_joint_state(js(ros, chain.joint_names, q_ur5, t=(1700000000, 123456789)))
    assert out.pose is not None
    check_message(ros, out.pose)
    assert out.pose.header.frame_id == "base_link"
    assert (out.pose.header.stamp.sec, out.pose.header.stamp.nanosec) == (1700000000, 123456789)
    expected = PinocchioOracle.from_urdf(ur5_path, chain.joint_names).pose(q_ur5, "tool0")
    np.testing.assert_allclose(pose_matrix(out.pose), expected, atol=1e-9)


def test_twist_from_given_velocities_matches_finite_differences(ros, ur5, q_ur5):
    chain = chain_of(ur5)
    qdot = np.array([0.5, -0.3, 0.2, 0.7, -0.4, 0.9])
    out = ur5.on_joint_state(js(ros, chain.joint_names, q_ur5, t=5.0, velocity=qdot))
    assert out.twist is not None and out.problem is None
    check_message(ros, out.twist)
    assert out.twist.header.frame_id == "base_link"
    h = 1e-6  # central differences of FK along q̇: the tip origin's velocity and ω in base axes
    T_plus, T_minus = chain.fk(q_ur5 + h * qdot), chain.fk(q_ur5 - h * qdot)
    v_fd = (T_plus[:3, 3] - T_minus[:3, 3]) / (2 * h)
    W = (T_plus[:3, :3] - T_minus[:3, :3]) / (2 * h) @ chain.fk(q_ur5)[:3, :3].T
    omega_fd = np.array([W[2, 1], W[0, 2], W[1, 0]])
    omega, v = ma.vectors_from_twist(out.twist.twist)
    np.testing.assert_allclose(v, v_fd, atol=1e-6)
    np.testing.assert_allclose(omega, omega_fd, atol=1e-6)


def test_body_twist_is_in_tip_axes(ros, ur5, q_ur5):
    chain = chain_of(ur5)
    qdot = np.array([0.5, -0.3, 0.2, 0.7, -0.4, 0.9])
    world = ur5.on_joint_state(js(ros, chain.joint_names, q_ur5, t=1.0, velocity=qdot)).twist
    ur5.configure({"twist_frame": "body"})
    body = ur5.on_joint_state(js(ros, chain.joint_names, q_ur5, t=2.0, velocity=qdot)).twist
    assert body.header.frame_id == "tool0"
    R = chain.fk(q_ur5)[:3, :3]
    for part in ("linear", "angular"):
        w = ma.core_from_twist(world.twist)
        b = ma.core_from_twist(body.twist)
        sl = slice(3, 6) if part == "linear" else slice(0, 3)
        np.testing.assert_allclose(R @ b[sl], w[sl], atol=1e-12)


def test_velocity_estimated_from_successive_positions_when_empty_or_nan(ros, ur5, q_ur5):
    chain = chain_of(ur5)
    names = chain.joint_names
    first = ur5.on_joint_state(js(ros, names, q_ur5, t=10.0))
    assert first.pose is not None and first.twist is None  # nothing to difference yet
    qdot = np.array([0.1, 0.2, -0.1, 0.3, 0.0, -0.2])
    q1 = q_ur5 + 0.01 * qdot
    second = ur5.on_joint_state(js(ros, names, q1, t=10.01, velocity=[math.nan] * 6))
    assert second.twist is not None
    expected = chain.jacobian(q1, "world") @ qdot
    np.testing.assert_allclose(ma.core_from_twist(second.twist.twist), expected, atol=1e-6)


def test_subsets_reordering_and_other_joints(ros, ur5, q_ur5):
    names = list(chain_of(ur5).joint_names)
    first = ur5.on_joint_state(js(ros, names[:3] + ["gripper"], list(q_ur5[:3]) + [0.04], t=1.0))
    assert first.pose is None and "wrist_1_joint" in first.problem
    order = [5, 3, 4]
    second = ur5.on_joint_state(js(ros, [names[i] for i in order], q_ur5[order], t=1.0))
    assert second.pose is not None
    np.testing.assert_allclose(pose_matrix(second.pose), chain_of(ur5).fk(q_ur5), atol=1e-12)


def test_stale_and_out_of_order_samples_are_not_published(ros, ur5, q_ur5):
    names = chain_of(ur5).joint_names
    assert ur5.on_joint_state(js(ros, names, q_ur5, t=20.0)).pose is not None
    old = ur5.on_joint_state(js(ros, names, q_ur5 + 0.1, t=19.5))
    assert old.pose is None and "stale" in old.problem
    newer = ur5.on_joint_state(js(ros, names, q_ur5 + 0.2, t=20.5))
    np.testing.assert_allclose(pose_matrix(newer.pose), chain_of(ur5).fk(q_ur5 + 0.2), atol=1e-12)


@pytest.mark.parametrize(
    ("positions", "velocity", "needle"),
    [
        ([0.0, math.nan, 0, 0, 0, 0], (), "shoulder_lift_joint"),
        ([0.0] * 5, (), "6 names but 5 positions"),
        ([0.0] * 6, [0.0] * 2, "6 names but 2 velocities"),
    ],
)
def test_bad_joint_states_publish_nothing(ros, ur5, positions, velocity, needle):
    out = ur5.on_joint_state(js(ros, chain_of(ur5).joint_names, positions, 1.0, velocity))
    assert out.pose is None and out.twist is None and needle in out.problem
    diag = ur5.diagnostics()
    assert diag.status[0].level == ros.cls("diagnostic_msgs/msg/DiagnosticStatus").ERROR
    assert needle in diag.status[0].message


def test_nothing_published_before_a_description(ros, clock):
    svc = KinematicsService(ros.types, {}, clock=clock)
    out = svc.on_joint_state(js(ros, ["a"], [0.0]))
    assert out.pose is None and "robot_description" in out.problem
    resp = svc.compute_fk(ros.request("ComputeFK"), ros.response("ComputeFK"))
    assert not resp.success and "robot_description" in resp.message


def test_load_description_from_topic_and_reload(ros, ur5_path, clock, q_ur5):
    svc = KinematicsService(ros.types, {"base_link": "base_link", "tip_link": "tool0"}, clock=clock)
    text = ur5_path.read_text()
    svc.load_description(text)
    assert chain_of(svc).dof == 6
    with pytest.raises(KinematicsError):
        svc.load_description("<robot name='broken'><link name='a'/>")
    assert chain_of(svc).dof == 6  # a bad description keeps the old model
    longer = text.replace('xyz="0.0 0.0 0.39225"', 'xyz="0.0 0.0 0.5"')  # longer forearm
    assert longer != text
    svc.load_description(longer)
    out = svc.on_joint_state(js(ros, chain_of(svc).joint_names, q_ur5, t=1.0))
    expected = SerialChain.from_urdf(longer, "base_link", "tool0").fk(q_ur5)
    np.testing.assert_allclose(pose_matrix(out.pose), expected, atol=1e-12)
    assert not np.allclose(expected, SerialChain.from_urdf(text, "base_link", "tool0").fk(q_ur5))


# =========================================================================== diagnostics
def test_diagnostics_report_rate_latency_and_singularity(ros, ur5, clock):
    S = ros.cls("diagnostic_msgs/msg/DiagnosticStatus")
    names = chain_of(ur5).joint_names
    for k in range(11):  # 100 Hz, received 2 ms after the stamp
        clock.now = 50.0 + 0.01 * k + 0.002
        ur5.on_joint_state(js(ros, names, [0.0, -1.0, 1.0, 0.0, 0.5, 0.0], t=50.0 + 0.01 * k))
    diag = ur5.diagnostics()
    check_message(ros, diag)
    values = {kv.key: kv.value for kv in diag.status[0].values}
    assert float(values["joint_states_rate_hz"]) == pytest.approx(100.0, rel=1e-6)
    assert float(values["joint_states_latency_s"]) == pytest.approx(0.002, abs=1e-6)
    assert diag.status[0].level == S.OK
    # Wrist singularity of the UR5: q5 = 0 aligns the axes of joints 4 and 6.
    clock.now = 51.0
    ur5.on_joint_state(js(ros, names, [0.0, -1.0, 1.0, 0.0, 0.0, 0.0], t=51.0))
    diag = ur5.diagnostics()
    assert diag.status[0].level == S.WARN and "singular" in diag.status[0].message
    assert {kv.key: kv.value for kv in diag.status[0].values}["near_singular"] == "true"
    clock.now = 60.0  # no joint_states for 9 s
    assert "no recent joint_states" in ur5.diagnostics().status[0].message


def test_diagnostics_are_named_after_the_node_s_full_name(ros, ur5_path):
    """Two nodes in different namespaces publish distinct statuses on the one /diagnostics."""
    params = {"robot_description": ur5_path.read_text(), "tip_link": "tool0"}
    names = {
        KinematicsService(ros.types, params, node_name=fqn).diagnostics().status[0].name
        for fqn in ("/arm1/kinematics_node", "/arm2/kinematics_node")
    }
    assert names == {"/arm1/kinematics_node: end effector", "/arm2/kinematics_node: end effector"}


# =========================================================================== FK / Jacobian
def test_fk_service_agrees_with_the_core_and_fills_missing_joints(ros, ur5, q_ur5):
    chain = chain_of(ur5)
    ur5.on_joint_state(js(ros, chain.joint_names, q_ur5, t=3.0))
    req = ros.request("ComputeFK", joint_state=js(ros, ["elbow_joint"], [0.25], t=7.5))
    resp = ur5.compute_fk(req, ros.response("ComputeFK"))
    assert resp.success, resp.message
    check_message(ros, resp)
    q = q_ur5.copy()
    q[2] = 0.25
    np.testing.assert_allclose(pose_matrix(resp.pose), chain.fk(q), atol=1e-12)
    assert resp.pose.header.frame_id == "base_link" and resp.pose.header.stamp.sec == 7


def test_fk_service_for_another_tip_link(ros, ur5, ur5_path, q_ur5):
    chain = chain_of(ur5)
    req = ros.request(
        "ComputeFK", joint_state=js(ros, chain.joint_names, q_ur5), tip_link="forearm_link"
    )
    resp = ur5.compute_fk(req, ros.response("ComputeFK"))
    assert resp.success, resp.message
    expected = PinocchioOracle.from_urdf(ur5_path, chain.joint_names).pose(q_ur5, "forearm_link")
    np.testing.assert_allclose(pose_matrix(resp.pose), expected, atol=1e-9)


def test_chain_cache_is_thread_safe(ros, ur5, q_ur5):
    chain = chain_of(ur5)
    links = ["forearm_link", "wrist_1_link", "wrist_2_link", "upper_arm_link"] * 4
    results: list = [None] * len(links)

    def call(i: int) -> None:
        req = ros.request(
            "ComputeFK", joint_state=js(ros, chain.joint_names, q_ur5), tip_link=links[i]
        )
        results[i] = ur5.compute_fk(req, ros.response("ComputeFK"))

    threads = [threading.Thread(target=call, args=(i,)) for i in range(len(links))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert all(r.success for r in results), [r.message for r in results]
    for link, r in zip(links, results, strict=True):
        expected = SerialChain.from_urdf(ur5.model.xml, "base_link", link).fk(
            q_ur5[: len(SerialChain.from_urdf(ur5.model.xml, "base_link", link).joint_names)]
        )
        np.testing.assert_allclose(pose_matrix(r.pose), expected, atol=1e-12)


@pytest.mark.parametrize("frame", ["", "world", "body", "space"])
def test_jacobian_service_agrees_with_the_core(ros, ur5, q_ur5, frame):
    chain = chain_of(ur5)
    req = ros.request("ComputeJacobian", joint_state=js(ros, chain.joint_names, q_ur5), frame=frame)
    resp = ur5.compute_jacobian(req, ros.response("ComputeJacobian"))
    assert resp.success, resp.message
    check_message(ros, resp)
    core_frame = frame or "world"
    np.testing.assert_allclose(
        ma.jacobian_from_fields(resp), chain.jacobian(q_ur5, core_frame), atol=1e-12
    )
    assert list(resp.joint_names) == list(chain.joint_names)
    assert resp.frame == core_frame
    assert resp.reference_frame == ("tool0" if core_frame == "body" else "base_link")
    assert resp.reference_point_frame == ("base_link" if core_frame == "space" else "tool0")
    J = chain.jacobian(q_ur5, "world")
    s = np.linalg.svd(J, compute_uv=False)
    assert resp.condition_number == pytest.approx(s[0] / s[-1])
    assert resp.manipulability == pytest.approx(math.sqrt(np.linalg.det(J[3:] @ J[3:].T)))


def test_jacobian_at_an_exact_singularity_stays_finite(ros, ur5):
    chain = chain_of(ur5)
    q = [0.0, -math.pi / 2, 0.0, -math.pi / 2, 0.0, 0.0]  # arm stretched up, wrist aligned
    req = ros.request("ComputeJacobian", joint_state=js(ros, chain.joint_names, q))
    resp = ur5.compute_jacobian(req, ros.response("ComputeJacobian"))
    assert resp.success and math.isfinite(resp.condition_number)
    assert resp.min_singular_value < 1e-9
    check_message(ros, resp)


# =========================================================================== bad requests
BAD = [
    ("ComputeFK", {"joint_state": (["bogus_joint"], [0.0])}, "'bogus_joint'"),
    ("ComputeFK", {"joint_state": (["elbow_joint", "wrist_1_joint"], [0.0])}, "2 names but 1"),
    ("ComputeFK", {"joint_state": (["elbow_joint"], [math.nan])}, "'elbow_joint' is nan"),
    ("ComputeFK", {"tip_link": "no_such_link"}, "'no_such_link'"),
    ("ComputeFK", {"tip_link": "base_link"}, "no moving joint"),
    ("ComputeJacobian", {"frame": "tool"}, "'tool'"),
    ("ComputeJacobian", {"joint_state": (["bogus_joint"], [0.0])}, "'bogus_joint'"),
    ("ComputeIK", {"quaternion": (0.0, 0.0, 0.0, 0.0)}, "zero norm"),
    ("ComputeIK", {"frame_id": "nowhere"}, "'nowhere'"),
    ("ComputeIK", {"timeout": -0.1}, "timeout"),
    ("ComputeIK", {"timeout": math.nan}, "timeout"),
    ("ComputeIK", {"position_tolerance": -1e-3}, "position_tolerance"),
    ("ComputeIK", {"seed": (["bogus_joint"], [0.0])}, "'bogus_joint'"),
    ("ComputeIK", {"tip_link": "nope"}, "'nope'"),
]


def _bad_request(ros, srv, spec):
    req = ros.request(srv)
    for key, value in spec.items():
        if key in ("joint_state", "seed"):
            setattr(req, key, js(ros, *value))
        elif key == "quaternion":
            o = req.target.pose.orientation
            o.x, o.y, o.z, o.w = value
        elif key == "frame_id":
            req.target.header.frame_id = value
        else:
            setattr(req, key, value)
    if srv == "ComputeIK" and "quaternion" not in spec:
        req.target.pose.orientation.w = 1.0
        req.target.pose.position.x = 0.4
    return req


@pytest.mark.parametrize(("srv", "spec", "needle"), BAD, ids=[f"{b[0]}-{b[2]}" for b in BAD])
def test_bad_requests_fail_with_a_message_naming_the_problem(ros, ur5, q_ur5, srv, spec, needle):
    ur5.on_joint_state(js(ros, chain_of(ur5).joint_names, q_ur5, t=1.0))
    resp = getattr(
        ur5,
        {
            "ComputeFK": "compute_fk",
            "ComputeJacobian": "compute_jacobian",
            "ComputeIK": "compute_ik",
        }[srv],
    )(_bad_request(ros, srv, spec), ros.response(srv))
    assert resp.success is False
    assert needle in resp.message, resp.message
    check_message(ros, resp)


def test_fk_without_joint_states_names_the_missing_joints(ros, ur5):
    req = ros.request("ComputeFK", joint_state=js(ros, ["elbow_joint"], [0.0]))
    resp = ur5.compute_fk(req, ros.response("ComputeFK"))
    assert not resp.success and "shoulder_pan_joint" in resp.message


def test_unexpected_errors_do_not_escape(ros, ur5):
    resp = ur5.compute_fk(object(), ros.response("ComputeFK"))  # not a request at all
    assert resp.success is False and "internal error" in resp.message


# =========================================================================== IK
def _ik(ros, svc, req):
    return svc.compute_ik(ros.roundtrip(req), ros.response("ComputeIK"))


@pytest.mark.parametrize("frame_id", ["", "base_link", "/base_link", "shoulder_link", "camera"])
def test_ik_reaches_targets_given_in_base_link_and_tf_frames(ros, ur5, q_ur5, frame_id):
    chain = chain_of(ur5)
    ur5.on_joint_state(js(ros, chain.joint_names, q_ur5, t=1.0))
    q_goal = q_ur5 + np.array([0.2, -0.1, 0.15, 0.1, -0.2, 0.3])
    T_base_goal = chain.fk(q_goal)
    if frame_id == "shoulder_link":
        T_base_frame = SerialChain.from_urdf(ur5.model.xml, "base_link", "shoulder_link").fk(
            q_ur5[:1]
        )
    elif frame_id == "camera":
        T_base_frame = T_BASE_CAMERA
    else:
        T_base_frame = np.eye(4)
    req = ros.request(
        "ComputeIK",
        target=ik_target(ros, np.linalg.inv(T_base_frame) @ T_base_goal, frame_id),
        timeout=0.5,
    )
    resp = _ik(ros, ur5, req)
    assert resp.success, resp.message
    check_message(ros, resp)
    assert list(resp.solution.name) == list(chain.joint_names)
    assert (resp.solution.header.stamp.sec, resp.solution.header.stamp.nanosec) == (4, 5)
    T_reached = chain.fk(np.asarray(resp.solution.position))  # FK∘IK = identity (within tolerance)
    assert np.linalg.norm(T_reached[:3, 3] - T_base_goal[:3, 3]) <= 1e-5 + 1e-12
    # the orientation too, measured here (the response's own errors are against the target the
    # service built from the frame: a wrong frame rotation would not show in them)
    R_error = T_reached[:3, :3].T @ T_base_goal[:3, :3]
    assert Rotation.from_matrix(R_error).magnitude() <= 1e-4 + 1e-12
    assert resp.position_error <= 1e-5 and resp.orientation_error <= 1e-4


def test_ik_position_only(ros, ur5, q_ur5):
    chain = chain_of(ur5)
    T = chain.fk(q_ur5)
    T[:3, :3] = np.eye(3)  # orientation to ignore
    req = ros.request("ComputeIK", target=ik_target(ros, T), position_only=True, timeout=0.5)
    resp = _ik(ros, ur5, req)
    assert resp.success, resp.message
    reached = chain.fk(np.asarray(resp.solution.position))[:3, 3]
    assert np.linalg.norm(reached - T[:3, 3]) <= 1e-5


def test_ik_axis_tolerances_free_a_spin_the_arm_cannot_make(ros, ur5_path, clock, q_ur5):
    # a UR5 without its last joint (tip wrist_2_link) cannot spin its tip about the tip's y axis:
    # the spun target fails as a full pose and is reached with that axis's bound infinite
    params = {"robot_description": ur5_path.read_text(), "tip_link": "wrist_2_link"}
    svc = KinematicsService(ros.types, params, clock=clock)
    chain = chain_of(svc)
    assert chain.dof == 5
    svc.on_joint_state(js(ros, chain.joint_names, q_ur5[:5], t=1.0))
    spun = chain.fk(q_ur5[:5] + 0.1) @ se3.exp(np.array([0.0, 0.8, 0.0, 0.0, 0.0, 0.0]))
    full = _ik(ros, svc, ros.request("ComputeIK", target=ik_target(ros, spun), timeout=0.05))
    assert full.success is False
    bounds = np.array([1e-4, np.inf, 1e-4, 1e-5, 1e-5, 1e-5])
    req = ros.request("ComputeIK", target=ik_target(ros, spun), axis_tolerances=bounds, timeout=0.5)
    resp = _ik(ros, svc, req)
    assert resp.success, resp.message
    check_message(ros, resp)
    T_got = chain.fk(np.asarray(resp.solution.position))
    assert np.linalg.norm(T_got[:3, 3] - spun[:3, 3]) <= 2e-5
    tip_y_angle = math.acos(min(1.0, float(T_got[:3, 1] @ spun[:3, 1])))
    assert tip_y_angle <= 2e-4  # the tip's y axis matches; the spin about it was free


@pytest.mark.parametrize(
    ("bounds", "needle"),
    [([1e-3] * 5, "6 values"), ([0.0] + [1e-3] * 5, "> 0"), ([math.nan] + [1e-3] * 5, "> 0")],
)
def test_ik_bad_axis_tolerances_are_refused_with_the_reason(ros, ur5, q_ur5, bounds, needle):
    chain = chain_of(ur5)
    req = ros.request(
        "ComputeIK", target=ik_target(ros, chain.fk(q_ur5)), axis_tolerances=np.array(bounds)
    )
    resp = _ik(ros, ur5, req)
    assert resp.success is False and "axis_tolerances" in resp.message and needle in resp.message
    check_message(ros, resp)


def test_ik_unreachable_target_fails_with_the_best_configuration(ros, ur5, q_ur5):
    chain = chain_of(ur5)
    T = np.eye(4)
    T[:3, 3] = [5.0, 0.0, 0.0]  # the UR5 reaches < 1 m
    req = ros.request("ComputeIK", target=ik_target(ros, T), timeout=0.05)
    resp = _ik(ros, ur5, req)
    assert resp.success is False and "no solution" in resp.message
    check_message(ros, resp)
    q = np.asarray(resp.solution.position)
    assert q.shape == (chain.dof,) and np.all(np.isfinite(q))
    assert resp.position_error == pytest.approx(
        np.linalg.norm(chain.fk(q)[:3, 3] - T[:3, 3]), rel=1e-6
    )


def test_ik_zero_timeout_means_the_node_default(ros, ur5, q_ur5):
    chain = chain_of(ur5)
    req = ros.request("ComputeIK", target=ik_target(ros, chain.fk(q_ur5 + 0.05)), timeout=0.0)
    resp = _ik(ros, ur5, req)
    assert resp.success, resp.message
    # The job the service builds: timeout 0 takes the parameter ik.timeout, any other its own.
    ur5.configure({"ik.timeout": 0.375})
    for asked, expected in ((0.0, 0.375), (0.125, 0.125)):
        req.timeout = asked
        pending = ur5.prepare_ik(ros.roundtrip(req), ros.response("ComputeIK"), now=50.0)
        assert pending is not None
        assert pending.options.timeout == expected
        assert pending.job.deadline == 50.0 + expected


def test_ik_time_waited_before_the_callback_counts_against_the_timeout(ros, ur5, q_ur5):
    """The deadline is the client's send + timeout: arrival − waited + timeout, for a wait
    shorter than the timeout; a wait of the timeout or more (or none to tell) is ignored."""
    chain = chain_of(ur5)
    req = ros.request("ComputeIK", target=ik_target(ros, chain.fk(q_ur5 + 0.05)), timeout=0.05)
    cases = ((0.0, 0.05), (0.012, 0.038), (0.0499, 0.0001), (0.05, 0.05), (3.0, 0.05),
             (-0.01, 0.05), (math.nan, 0.05))  # fmt: skip
    for waited, left in cases:
        pending = ur5.prepare_ik(
            ros.roundtrip(req), ros.response("ComputeIK"), now=50.0, waited=waited
        )
        assert pending is not None
        assert pending.job.deadline == pytest.approx(50.0 + left, abs=1e-12), waited
        assert pending.options.timeout == 0.05  # the request's own, for its messages


def test_diagnostics_count_ik_answers_against_their_deadlines(ros, ur5, q_ur5):
    """finish_ik compares the time it answers with the job's deadline (arrival + timeout); the
    diagnostics report the answers, those after their deadline, the worst, and the pool's counts."""
    from kinematics_node.service.ik_pool import solve_job

    chain = chain_of(ur5)
    req = ros.request("ComputeIK", target=ik_target(ros, chain.fk(q_ur5 + 0.05)), timeout=0.1)

    def answered_at(after_deadline: float) -> None:
        t0 = time.monotonic()
        pending = ur5.prepare_ik(ros.roundtrip(req), ros.response("ComputeIK"), now=t0)
        assert pending is not None
        resp = ur5.finish_ik(
            pending,
            solve_job(pending.job),
            ros.response("ComputeIK"),
            now=t0 + 0.1 + after_deadline,
        )
        assert resp.success, resp.message

    for after in (-0.09, -0.001, 0.004, 0.0125, 0.002):
        answered_at(after)
    diag = ur5.diagnostics({"expired_in_queue": 2, "overdue": 1})
    values = {kv.key: kv.value for kv in diag.status[0].values}
    assert values["ik_answered"] == "5"
    assert values["ik_after_deadline"] == "3"
    assert float(values["ik_worst_after_deadline_s"]) == pytest.approx(0.0125, abs=1e-9)
    assert values["ik_pool_expired_in_queue"] == "2" and values["ik_pool_overdue"] == "1"
    check_message(ros, diag)


# =========================================================================== parameters
@pytest.mark.parametrize(
    ("changes", "needle"),
    [
        ({"ik.timeout": 0.0}, "ik.timeout"),
        ({"ik.position_tolerance": -1.0}, "ik.position_tolerance"),
        ({"ik.orientation_tolerance": math.nan}, "ik.orientation_tolerance"),
        ({"twist_frame": "tool"}, "twist_frame"),
        ({"ik.max_restarts": 1.5}, "ik.max_restarts"),
        ({"publish_diagnostics": 1}, "publish_diagnostics"),
        ({"tip_link": "no_such_link"}, "no_such_link"),
        ({"bogus": 1}, "bogus"),
    ],
)
def test_bad_parameters_are_refused_and_change_nothing(ur5, changes, needle):
    before = ur5.params
    with pytest.raises((InvalidInputError, KinematicsError, LookupError), match=needle):
        ur5.configure(changes)
    assert ur5.params == before
    assert chain_of(ur5).tip_link == "tool0"


def test_changing_tip_link_rebuilds_the_chain(ros, ur5, q_ur5):
    ur5.configure({"tip_link": "wrist_3_link"})
    assert chain_of(ur5).tip_link == "wrist_3_link"
    out = ur5.on_joint_state(js(ros, chain_of(ur5).joint_names, q_ur5, t=1.0))
    assert out.pose is not None
