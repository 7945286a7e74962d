"""IK requests beyond the arm's reach fail saying so, with the best configuration found."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from service_testing import ik_target

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def service(ros):
    from kinematics_node.service.kinematics import KinematicsService

    urdf = (ROOT / "config" / "robots" / "ur5e.urdf").read_text(encoding="utf-8")
    return KinematicsService(ros.types, {"robot_description": urdf})


def request(ros, x, timeout=2.0):
    req = ros.request("ComputeIK", timeout=timeout)
    req.target.header.frame_id = "base_link"
    req.target.pose.position.x = float(x)
    req.target.pose.orientation.w = 1.0
    return req


def test_out_of_reach_fails_saying_so_with_the_best_configuration(ros, service):
    resp = service.compute_ik(request(ros, 3.0, timeout=0.05), ros.response("ComputeIK"))
    assert not resp.success
    assert "reaches at most" in resp.message and "3.000 m" in resp.message, resp.message
    chain = service.model.chain
    q = np.asarray(resp.solution.position)
    assert q.shape == (chain.dof,)
    reached = chain.fk(q)[:3, 3]
    # the best configuration points the arm at the target: nearer than the home pose is
    assert np.linalg.norm(reached - [3.0, 0, 0]) < np.linalg.norm(chain.M[:3, 3] - [3.0, 0, 0])
    assert resp.position_error == pytest.approx(np.linalg.norm(reached - [3.0, 0, 0]), rel=1e-6)


def test_a_target_just_inside_the_bound_is_searched_normally(ros, service):
    center, radius = service.model.chain.reach_sphere
    resp = service.compute_ik(
        request(ros, center[0] + radius - 1e-3, timeout=0.05), ros.response("ComputeIK")
    )
    assert "reaches at most" not in resp.message, resp.message


def test_no_reachable_target_is_refused_as_beyond_reach(ros, service):
    # targets the arm reaches (FK of random configurations, the farthest ones included) are all
    # searched and solved: the bound never refuses a reachable target
    chain = service.model.chain
    center, _ = chain.reach_sphere
    rng = np.random.default_rng(7)
    # and q = 0: a UR's home pose stretches the arm out horizontally, its farthest reach
    Q = np.vstack([np.zeros(chain.dof), rng.uniform(chain.lower, chain.upper, (40, chain.dof))])
    T = chain.fk(Q)
    distances = np.linalg.norm(T[:, :3, 3] - center, axis=1)
    for k in np.argsort(distances)[-10:]:  # the 10 farthest
        req = ros.request("ComputeIK", target=ik_target(ros, T[k], "base_link"), timeout=0.5)
        resp = service.compute_ik(ros.roundtrip(req), ros.response("ComputeIK"))
        assert resp.success, resp.message
