"""Requests with finite values so large that the arithmetic overflows: refused or answered with a
message, never an exception, never a non-finite field (found by an adversarial hunt)."""

from __future__ import annotations

import numpy as np
import pytest
from service_testing import check_message, ik_target, js

from kinematics_node.service.kinematics import KinematicsService

Q = [0.3, -1.1, 1.4, -0.6, 0.8, 0.2]


def _ik_request(ros, position, frame_id="", max_solutions=1):
    T = np.eye(4)
    T[:3, 3] = position
    target = ik_target(ros, T, frame_id)
    return ros.request("ComputeIK", target=target, timeout=0.05, max_solutions=max_solutions)


def test_a_target_that_overflows_in_the_base_is_refused_saying_so(ros, ur5):
    ur5.on_joint_state(js(ros, ur5.model.chain.joint_names, Q, t=1.0))
    req = _ik_request(ros, (1.7e308, 1.7e308, 1.7e308), frame_id="tool0")
    resp = ur5.compute_ik(ros.roundtrip(req), ros.response("ComputeIK"))
    assert resp.success is False and "too large to express in base_link" in resp.message
    check_message(ros, resp)


@pytest.mark.parametrize("max_solutions", [1, 2])
@pytest.mark.parametrize("x", [1e160, 1e308])
def test_a_target_absurdly_far_is_beyond_reach_in_a_short_message(ros, ur5, x, max_solutions):
    req = _ik_request(ros, (x, x, 0.0), max_solutions=max_solutions)
    resp = ur5.compute_ik(ros.roundtrip(req), ros.response("ComputeIK"))
    assert resp.success is False and "reaches at most" in resp.message, resp.message
    assert f"{np.hypot(x, x):.3g} m" in resp.message and len(resp.message) < 200
    check_message(ros, resp)


# revolute about z, revolute about x, then a prismatic joint along y: the lever arms of the first
# two grow with the third's value, so at 1e160 the product of singular values overflows
LEVER = """<robot name="lever"><link name="a"/><link name="b"/><link name="c"/><link name="d"/>
<joint name="j1" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>
<limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
<joint name="j2" type="revolute"><parent link="b"/><child link="c"/><axis xyz="1 0 0"/>
<limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
<joint name="j3" type="prismatic"><parent link="c"/><child link="d"/><axis xyz="0 1 0"/>
<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>"""


def test_a_jacobian_whose_manipulability_overflows_is_refused_saying_so(ros, clock):
    svc = KinematicsService(ros.types, {"robot_description": LEVER}, clock=clock)
    state = js(ros, ["j1", "j2", "j3"], [0.1, 0.2, 1e160], t=1.0)
    req = ros.request("ComputeJacobian", joint_state=state)
    resp = svc.compute_jacobian(ros.roundtrip(req), ros.response("ComputeJacobian"))
    assert resp.success is False and "manipulability is not finite" in resp.message
    check_message(ros, resp)
    state = js(ros, ["j1", "j2", "j3"], [0.1, 0.2, 0.5], t=1.0)  # the same arm, sane values
    req = ros.request("ComputeJacobian", joint_state=state)
    resp = svc.compute_jacobian(ros.roundtrip(req), ros.response("ComputeJacobian"))
    assert resp.success and resp.manipulability > 0


def test_a_timeout_below_what_a_solve_needs_says_so(ros, ur5):
    ur5.on_joint_state(js(ros, ur5.model.chain.joint_names, Q, t=1.0))
    req = ros.request(
        "ComputeIK", timeout=1e-4, max_solutions=2
    )  # (2: not the closed form at once)
    req.target.pose.position.x = 0.4
    req.target.pose.orientation.w = 1.0
    resp = ur5.compute_ik(ros.roundtrip(req), ros.response("ComputeIK"))
    assert (
        resp.success is False and "0.1 ms is shorter than the 0.5 ms a solve needs" in resp.message
    )
    assert "worker" not in resp.message
    check_message(ros, resp)
