"""ComputeIK.max_solutions: several solutions in one answer (KinematicsService on rosbags messages).

Oracles: forward kinematics (every returned solution must reach the target within the request's
tolerances), `chain.ik_all` for arms with a closed form (the answer is its set, nearest the seed
first, cut to max_solutions), and the configuration a target was made from (a complete set holds
it). The numeric path runs on a UR5 whose wrist is offset by 1 cm, which has no closed form.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from kin_testing import check_nearest_solutions
from scipy.spatial.transform import Rotation
from service_testing import Clock, chain_of, check_message, fake_tf, js

import msg_adapters as ma
from kinematics_node.core import IKOptions, SerialChain
from kinematics_node.service.kinematics import MAX_SOLUTIONS, KinematicsService

Q_GOAL = np.array([0.5, -1.0, 1.1, -0.4, 0.9, -0.3])
SEED = Q_GOAL + np.array([0.15, -0.1, 0.2, 0.1, -0.15, 0.2])
# The UR5's last joint moved 1 cm along x of wrist_2_link: axes 5 and 6 no longer meet.
WRIST_3_ORIGIN = '<origin rpy="0.0 0.0 0.0" xyz="0.0 0.0 0.09465"/>\n    <axis xyz="0 1 0"/>'


def _target(ros, T):
    return ma.pose_stamped_from_matrix(
        ros.types, T, "", ros.new("builtin_interfaces/msg/Time", sec=4, nanosec=5)
    )


def _ask(ros, svc, T, seed, **fields):
    chain = chain_of(svc)
    req = ros.request(
        "ComputeIK",
        target=_target(ros, T),
        seed=js(ros, chain.joint_names, seed),
        **{"timeout": 0.5, **fields},
    )
    resp = svc.compute_ik(ros.roundtrip(req), ros.response("ComputeIK"))
    check_message(ros, resp)
    return resp


def _solutions(resp) -> np.ndarray:
    return np.array([s.position for s in resp.solutions], dtype=float).reshape(
        len(resp.solutions), -1
    )


def _errors(chain, Q, T):
    """(position [m], rotation angle [rad]) of FK of each row of Q against T."""
    pos, ori = [], []
    for q in Q:
        Tq = chain.fk(q)
        pos.append(float(np.linalg.norm(Tq[:3, 3] - T[:3, 3])))
        ori.append(float(Rotation.from_matrix(Tq[:3, :3].T @ T[:3, :3]).magnitude()))
    return np.array(pos), np.array(ori)


def _check_layout(ros, chain, resp):
    """Every solution names the chain's joints in order and carries the target's stamp;
    solutions[0] is `solution`."""
    for s in resp.solutions:
        assert list(s.name) == list(chain.joint_names)
        assert (s.header.stamp.sec, s.header.stamp.nanosec, s.header.frame_id) == (4, 5, "")
        assert list(s.velocity) == [] and list(s.effort) == []
    assert list(resp.solutions[0].position) == list(resp.solution.position)


def _separated(Q, separation=1e-2) -> bool:
    return all(
        np.max(np.abs(Q[i] - Q[j])) > separation
        for i in range(len(Q))
        for j in range(i + 1, len(Q))
    )


@pytest.fixture
def ur5_offset_wrist(ros, ur5_path) -> KinematicsService:
    xml = ur5_path.read_text()
    assert xml.count(WRIST_3_ORIGIN) == 1
    xml = xml.replace(WRIST_3_ORIGIN, WRIST_3_ORIGIN.replace("0.0 0.0 0.09465", "0.01 0.0 0.09465"))
    params = {"robot_description": xml, "base_link": "base_link", "tip_link": "tool0"}
    svc = KinematicsService(ros.types, params, lookup_transform=fake_tf, clock=Clock())
    # (no named family: since issue 24 the general 6R closed form, which leaves a set cut to
    # max_solutions incomplete as the numeric search did)
    assert chain_of(svc).ik_family == "general_6r"
    return svc


# =========================================================================== closed form
@pytest.mark.parametrize("n", [2, 7, 100, MAX_SOLUTIONS])
def test_closed_form_arm_returns_the_ik_all_set_nearest_the_seed_first(ros, ur5, n):
    chain = chain_of(ur5)
    assert chain.ik_family == "three_parallel"
    T = chain.fk(Q_GOAL)
    resp = _ask(ros, ur5, T, SEED, max_solutions=n)
    assert resp.success, resp.message
    _check_layout(ros, chain, resp)
    Q = _solutions(resp)
    every = np.array(chain.ik_all(T, q_seed=SEED).solutions)
    assert len(every) > 7  # a UR5 with ±2π limits: many solutions per pose
    assert len(Q) == min(n, len(every))
    check_nearest_solutions(Q, every, SEED)
    pos, ori = _errors(chain, Q, T)
    assert np.all(pos <= 1e-9) and np.all(ori <= 1e-9)
    assert resp.position_error == pytest.approx(pos[0], abs=1e-12)
    assert resp.orientation_error == pytest.approx(ori[0], abs=1e-12)
    assert _separated(Q, 1e-6)
    # complete exactly when nothing was cut off; then the configuration the target came from
    # is among them
    assert resp.complete is (n >= len(every))
    if resp.complete:
        assert np.min(np.max(np.abs(Q - Q_GOAL), axis=1)) <= 1e-8


@pytest.mark.parametrize("n", [0, 1])
def test_zero_or_one_asks_for_one_solution_as_before(ros, ur5, n):
    chain = chain_of(ur5)
    T = chain.fk(Q_GOAL)
    resp = _ask(ros, ur5, T, SEED, max_solutions=n)
    assert resp.success, resp.message
    assert len(resp.solutions) == 1 and resp.complete is False
    _check_layout(ros, chain, resp)
    pos, ori = _errors(chain, _solutions(resp), T)
    assert pos[0] <= 1e-5 and ori[0] <= 1e-4


def test_tolerances_tighter_than_the_closed_forms_keep_only_the_solutions_that_meet_them(
    ros, ur5, monkeypatch
):
    """ik_all promises 1e-9: asked for 1e-11, the service must drop solutions that are only
    within 1e-9. Solutions with q1 > 0 get 1e-9 rad more on the last joint to make some."""
    chain = chain_of(ur5)
    T = chain.fk(Q_GOAL)
    exact_ik_all = SerialChain.ik_all

    def ik_all_to_1e_9(self, *args, **kwargs):
        result = exact_ik_all(self, *args, **kwargs)
        nudge = np.zeros(self.dof)
        nudge[-1] = 1e-9
        moved = [s + nudge if s[0] > 0 else s for s in result.solutions]
        return replace(result, solutions=tuple(moved))

    monkeypatch.setattr(SerialChain, "ik_all", ik_all_to_1e_9)
    every = np.array(ik_all_to_1e_9(chain, T, q_seed=SEED).solutions)
    pos_every, ori_every = _errors(chain, every, T)
    assert np.all(pos_every <= 1e-9) and np.all(ori_every <= 1.5e-9)  # what ik_all promises
    tight = (pos_every <= 1e-11) & (ori_every <= 1e-11)
    assert 0 < tight.sum() < len(every)

    resp = _ask(
        ros,
        ur5,
        T,
        SEED,
        max_solutions=MAX_SOLUTIONS,
        position_tolerance=1e-11,
        orientation_tolerance=1e-11,
    )
    assert resp.success, resp.message
    Q = _solutions(resp)
    pos, ori = _errors(chain, Q, T)
    assert np.all(pos <= 1e-11) and np.all(ori <= 1e-11)
    # with them, the one solution the request asking for one gets (exact: the closed form, not
    # the nudged ik_all), in place of its nudged copy
    single = chain.ik(T, SEED, IKOptions(position_tolerance=1e-11, orientation_tolerance=1e-11))
    assert single.success
    copies = np.max(np.abs(every - single.q), axis=1) <= 1e-2
    assert copies.sum() == 1 and not tight[copies][0]  # its copy was nudged
    expected = np.vstack((single.q, every[tight]))
    check_nearest_solutions(Q, expected, SEED)
    assert len(Q) == len(expected)
    assert resp.complete is False  # exact solutions were left out for round-off
    # the default tolerances (1e-5 m, 1e-4 rad) keep them all
    resp = _ask(ros, ur5, T, SEED, max_solutions=MAX_SOLUTIONS)
    assert len(resp.solutions) == len(every) and resp.complete is True


def test_a_singular_target_is_never_complete(ros, ur5):
    chain = chain_of(ur5)
    q = Q_GOAL.copy()
    q[4] = 0.0  # wrist_2 at zero: axes 4 and 6 aligned, only q4 + q6 matters
    T = chain.fk(q)
    resp = _ask(ros, ur5, T, SEED, max_solutions=MAX_SOLUTIONS)
    assert resp.success, resp.message
    assert resp.complete is False
    pos, ori = _errors(chain, _solutions(resp), T)
    assert np.all(pos <= 1e-9) and np.all(ori <= 1e-9)


def test_a_7r_arm_sweeps_the_held_joint_and_is_not_complete(ros, panda_path):
    svc = KinematicsService(
        ros.types,
        {"robot_description": panda_path.read_text(), "tip_link": "panda_hand"},
        clock=Clock(),
    )
    chain = chain_of(svc)
    assert chain.ik_family is not None and chain.ik_family.startswith("7r")
    q = np.array([0.3, -0.4, 0.2, -2.0, 0.1, 1.6, 0.5])
    T = chain.fk(q)
    resp = _ask(ros, svc, T, q + 0.05, max_solutions=50)
    assert resp.success, resp.message
    Q = _solutions(resp)
    # the swept set, and the solution with panda_joint7 held at the seed's value (what a request
    # for one solution gets), which is none of the swept values and nearer the seed than them all
    swept = np.array(chain.ik_all(T, q_seed=q + 0.05).solutions)
    single = chain.ik(T, q + 0.05).q
    assert single[6] == pytest.approx(q[6] + 0.05, abs=1e-12)
    every = np.vstack((single, swept))
    assert np.linalg.norm(single - q - 0.05) < np.linalg.norm(swept[0] - q - 0.05)
    assert 1 < len(Q) == min(50, len(every))
    check_nearest_solutions(Q, every, q + 0.05)
    pos, ori = _errors(chain, Q, T)
    assert np.all(pos <= 1e-9) and np.all(ori <= 1e-9)
    assert resp.complete is False  # solutions between the swept held values are not listed


@pytest.mark.parametrize(
    "fields",
    [
        {"position_only": True},
        {"axis_tolerances": np.array([1e-4, 1e-4, np.inf, 1e-5, 1e-5, 1e-5])},
    ],
    ids=["position_only", "axis_tolerances"],
)
def test_a_free_axis_makes_the_set_infinite_so_the_numeric_solver_samples_it(
    ros, ur5, monkeypatch, fields
):
    chain = chain_of(ur5)
    T = chain.fk(Q_GOAL)

    def no_closed_form(*args, **kwargs):
        raise AssertionError("ik_all cannot give a set where an axis is free")

    monkeypatch.setattr(SerialChain, "ik_all", no_closed_form)
    resp = _ask(ros, ur5, T, SEED, max_solutions=3, timeout=0.3, **fields)
    assert resp.success, resp.message
    Q = _solutions(resp)
    assert 1 <= len(Q) <= 3 and resp.complete is False
    assert _separated(Q)
    for q in Q:
        assert np.linalg.norm(chain.fk(q)[:3, 3] - T[:3, 3]) <= 2e-5


# =========================================================================== numeric only
def test_arm_without_closed_form_returns_distinct_valid_solutions(ros, ur5_offset_wrist):
    chain = chain_of(ur5_offset_wrist)
    T = chain.fk(Q_GOAL)
    resp = _ask(ros, ur5_offset_wrist, T, SEED, max_solutions=4)
    assert resp.success, resp.message
    _check_layout(ros, chain, resp)
    Q = _solutions(resp)
    assert 2 <= len(Q) <= 4  # half a second of restarts finds more than one
    assert resp.complete is False
    assert _separated(Q)
    pos, ori = _errors(chain, Q, T)
    assert np.all(pos <= 1e-5) and np.all(ori <= 1e-4)
    assert np.all(chain.lower <= Q) and np.all(chain.upper >= Q)
    d = np.linalg.norm(Q - SEED, axis=1)
    assert np.all(np.diff(d) >= -1e-12)  # nearest the seed first


# =========================================================================== failures
def test_unreachable_target_gives_no_solutions(ros, ur5):
    T = np.eye(4)
    T[:3, 3] = [5.0, 0.0, 0.0]  # the UR5 reaches < 1 m
    resp = _ask(ros, ur5, T, SEED, max_solutions=5, timeout=0.05)
    assert resp.success is False and "no solution" in resp.message
    assert list(resp.solutions) == [] and resp.complete is False
    assert np.all(np.isfinite(resp.solution.position))  # the best configuration, as before


@pytest.mark.parametrize("n", [MAX_SOLUTIONS + 1, 2**32 - 1])
def test_absurd_max_solutions_is_refused_naming_the_field(ros, ur5, n):
    chain = chain_of(ur5)
    resp = _ask(ros, ur5, chain.fk(Q_GOAL), SEED, max_solutions=n)
    assert resp.success is False
    assert "max_solutions" in resp.message and str(MAX_SOLUTIONS) in resp.message, resp.message
    assert list(resp.solutions) == [] and resp.complete is False


@pytest.mark.parametrize("value", [2.5, -1, "3", None])
def test_max_solutions_that_is_not_a_count_is_refused(ros, ur5, value):
    """What rclpy's uint32 setter would refuse, should a request object carry it anyway."""
    chain = chain_of(ur5)
    req = ros.request(
        "ComputeIK", target=_target(ros, chain.fk(Q_GOAL)), seed=js(ros, chain.joint_names, SEED)
    )
    req.max_solutions = value
    resp = ur5.compute_ik(req, ros.response("ComputeIK"))
    assert resp.success is False and "max_solutions" in resp.message, resp.message
