"""Joints a request leaves out come from joint_states: the answer says which and how old they
were, and compute_fk / compute_jacobian refuse values older than joint_states_max_age (default
1 s, 0 = no limit) or never received; an IK seed from joint_states is only reported. Age = the
node's clock now − when the node received the joint_states that last gave the joint (the fake
clock of service_testing)."""

from __future__ import annotations

import re

import numpy as np
import pytest
from service_testing import chain_of, ik_target, js

from kinematics_node.core.exceptions import InvalidInputError
from kinematics_node.service.kinematics import KinematicsService
from msg_adapters import matrix_from_pose

ELBOW = "elbow_joint"


def _fk(ros, svc, names=(), positions=(), **fields):
    req = ros.request("ComputeFK", joint_state=js(ros, names, positions, t=7.0), **fields)
    return svc.compute_fk(req, ros.response("ComputeFK"))


def _jacobian(ros, svc, names=(), positions=()):
    req = ros.request("ComputeJacobian", joint_state=js(ros, names, positions, t=7.0))
    return svc.compute_jacobian(req, ros.response("ComputeJacobian"))


def _ages(message: str) -> dict[str, float]:
    """{joint: age [s]} as the answer's message states them."""
    ages = {}
    for joints, age in re.findall(r"([\w, ]+) \(received ([\d.e+-]+) s ago\)", message):
        for joint in joints.split(", "):
            ages[joint.strip().rpartition(" ")[2]] = float(age)
    return ages


def test_fk_says_which_joints_came_from_joint_states_and_how_old(ros, ur5, clock, q_ur5):
    chain = chain_of(ur5)
    clock.now = 100.0
    ur5.on_joint_state(js(ros, chain.joint_names, q_ur5, t=3.0))
    clock.now = 100.25
    resp = _fk(ros, ur5, [ELBOW], [0.25])
    assert resp.success, resp.message
    others = [j for j in chain.joint_names if j != ELBOW]
    assert resp.message.startswith("ok; from joint_states: ")
    assert _ages(resp.message) == pytest.approx(dict.fromkeys(others, 0.25))
    q = q_ur5.copy()
    q[2] = 0.25
    np.testing.assert_allclose(matrix_from_pose(resp.pose.pose), chain.fk(q), atol=1e-12)
    # a request that gives every joint takes nothing from joint_states: a plain "ok"
    assert _fk(ros, ur5, chain.joint_names, q_ur5).message == "ok"


def test_fk_and_jacobian_refuse_joints_older_than_the_limit_naming_them(ros, ur5, clock, q_ur5):
    chain = chain_of(ur5)
    clock.now = 100.0
    ur5.on_joint_state(js(ros, chain.joint_names, q_ur5, t=3.0))
    clock.now = 160.0  # the joint_states stopped a minute ago (the case)
    others = [j for j in chain.joint_names if j != ELBOW]
    for resp in (_fk(ros, ur5, [ELBOW], [0.25]), _jacobian(ros, ur5, [ELBOW], [0.25])):
        assert not resp.success
        assert f"joint_state leaves out {others}" in resp.message, resp.message
        assert "older than joint_states_max_age (1 s)" in resp.message
        assert _ages(resp.message) == pytest.approx(dict.fromkeys(others, 60.0))
    # the limit is the parameter's: 0 = none (the age is still said), and 100 s lets 60 s pass
    for limit in (0.0, 100.0):
        ur5.configure({"joint_states_max_age": limit})
        resp = _fk(ros, ur5, [ELBOW], [0.25])
        assert resp.success and _ages(resp.message) == pytest.approx(dict.fromkeys(others, 60.0))
    ur5.configure({"joint_states_max_age": 59.0})
    assert not _fk(ros, ur5, [ELBOW], [0.25]).success


def test_each_joint_s_age_is_that_of_the_message_that_last_gave_it(ros, ur5, clock, q_ur5):
    chain = chain_of(ur5)
    names = list(chain.joint_names)
    clock.now = 100.0
    ur5.on_joint_state(js(ros, names, q_ur5, t=3.0))
    clock.now = 101.5  # a partial message (another publisher): the wrist joints only
    ur5.on_joint_state(js(ros, names[3:], q_ur5[3:], t=3.1))
    clock.now = 101.6  # an older stamp: ignored, so it refreshes nothing
    ur5.on_joint_state(js(ros, names[:3], q_ur5[:3], t=2.9))
    clock.now = 102.0
    resp = _jacobian(ros, ur5)
    assert not resp.success
    assert f"joint_state leaves out {names[:3]}" in resp.message, resp.message
    ages = _ages(resp.message)
    assert ages == pytest.approx({**dict.fromkeys(names[:3], 2.0), **dict.fromkeys(names[3:], 0.5)})
    # the fresh ones given, the old ones taken: still refused; the old ones given: served
    assert not _jacobian(ros, ur5, names[3:], q_ur5[3:]).success
    resp = _jacobian(ros, ur5, names[:3], q_ur5[:3])
    assert resp.success and _ages(resp.message) == pytest.approx(dict.fromkeys(names[3:], 0.5))


def test_the_age_is_from_the_receive_time_not_the_stamp(ros, ur5, clock, q_ur5):
    chain = chain_of(ur5)
    clock.now = 5000.0  # stamped ~1.4 h before it arrived (a bag, a simulator's own clock)
    ur5.on_joint_state(js(ros, chain.joint_names, q_ur5, t=3.0))
    clock.now = 5000.5
    resp = _fk(ros, ur5)
    assert resp.success and _ages(resp.message) == pytest.approx(
        dict.fromkeys(chain.joint_names, 0.5)
    )


def test_a_joint_never_received_is_refused_naming_it(ros, ur5, clock, q_ur5):
    chain = chain_of(ur5)
    names = list(chain.joint_names)
    ur5.on_joint_state(js(ros, names[1:], q_ur5[1:], t=3.0))  # the first joint never came
    resp = _fk(ros, ur5, [ELBOW], [0.25])
    assert not resp.success and repr(names[0]) in resp.message, resp.message


def test_an_ik_seed_from_old_joint_states_is_reported_not_refused(ros, ur5, clock, q_ur5):
    chain = chain_of(ur5)
    clock.now = 100.0
    ur5.on_joint_state(js(ros, chain.joint_names, q_ur5 + 0.05, t=3.0))
    clock.now = 160.0
    req = ros.request("ComputeIK", target=ik_target(ros, chain.fk(q_ur5)), timeout=0.5)
    resp = ur5.compute_ik(req, ros.response("ComputeIK"))
    assert resp.success, resp.message
    assert resp.message.startswith("ok; seed from joint_states: ")
    assert _ages(resp.message) == pytest.approx(dict.fromkeys(chain.joint_names, 60.0))
    # a failure says it too, after its reason
    far = np.eye(4)
    far[0, 3] = 5.0
    req = ros.request("ComputeIK", target=ik_target(ros, far), timeout=0.05)
    resp = ur5.compute_ik(req, ros.response("ComputeIK"))
    assert not resp.success and resp.message.startswith("no solution: unreachable")
    assert "; seed from joint_states: " in resp.message


def test_an_ik_target_in_a_moving_link_s_frame_needs_fresh_joint_states(ros, ur5, clock, q_ur5):
    chain = chain_of(ur5)
    clock.now = 100.0
    ur5.on_joint_state(js(ros, chain.joint_names, q_ur5, t=3.0))
    clock.now = 160.0
    T = np.eye(4)
    T[2, 3] = 0.05  # 5 cm along the forearm's z, from where joint_states last put it
    req = ros.request("ComputeIK", target=ik_target(ros, T, "forearm_link"), timeout=0.2)
    resp = ur5.compute_ik(req, ros.response("ComputeIK"))
    assert not resp.success
    assert "target frame 'forearm_link' (a robot link) leaves out" in resp.message, resp.message


def test_the_limit_is_validated_like_the_other_parameters(ros, ur5_path):
    text = ur5_path.read_text()
    for good in (0.0, 0.5, 3600.0):
        svc = KinematicsService(
            ros.types, {"robot_description": text, "joint_states_max_age": good}
        )
        assert svc.params["joint_states_max_age"] == good
    for bad in (-1.0, 1e9, "1", True):
        with pytest.raises(InvalidInputError, match="joint_states_max_age"):
            KinematicsService(
                ros.types,
                {"robot_description": ur5_path.read_text(), "joint_states_max_age": bad},
            )
