"""ArmSimulator: limits, exact integration, trajectory tracking, demo motion, refused commands."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import CubicHermiteSpline

from kinematics_node.core import InvalidInputError, UnknownNameError
from kinematics_node.sim import robots
from kinematics_node.sim.arm import ArmSimulator, urdf_actuated_joints

DT = 0.01


def ur5e_sim(**kwargs) -> ArmSimulator:
    return ArmSimulator.from_chain(robots.load_robot("ur5e"), DT, **kwargs)


def assert_within_limits(sim: ArmSimulator, q: np.ndarray, qdot: np.ndarray) -> None:
    assert np.all(q >= sim.lower) and np.all(q <= sim.upper), q
    assert np.all(np.abs(qdot) <= sim.velocity_limit), qdot


@pytest.mark.parametrize("name", ["ur5e", "panda", "planar3r", "scara"])
def test_random_command_sequences_never_exceed_the_limits(name):
    sim = ArmSimulator.from_urdf(robots.robot_path(name), DT, command_timeout=0.2)
    rng = np.random.default_rng(2024)
    n = sim.dof
    span = np.where(np.isfinite(sim.upper - sim.lower), sim.upper - sim.lower, 4 * np.pi)
    finite = np.isfinite(sim.lower)
    center = 0.5 * (np.where(finite, sim.lower, 0) + np.where(finite, sim.upper, 0))
    q_prev = sim.q
    for _ in range(60):
        kind = rng.integers(4)
        if kind == 0:  # velocities up to 3× the limit, both signs
            sim.command_velocity(rng.uniform(-3, 3, n) * sim.velocity_limit)
        elif kind == 1:  # waypoints partly outside the limits, some too fast to follow
            m = int(rng.integers(1, 5))
            times = np.cumsum(rng.uniform(0.05, 1.0, m))
            pos = center + rng.uniform(-0.8, 0.8, (m, n)) * span
            vel = rng.uniform(-2, 2, (m, n)) * sim.velocity_limit if rng.random() < 0.5 else None
            sim.command_trajectory(times, pos, vel)
        elif kind == 2:
            sim.start_demo()
        for _ in range(int(rng.integers(1, 80))):
            t, q, qdot = sim.step()
            assert_within_limits(sim, q, qdot)
            np.testing.assert_allclose(q - q_prev, qdot * DT, atol=1e-12)
            q_prev = q
    assert t == pytest.approx(sim.time)


def test_constant_velocity_is_integrated_exactly_then_stops_after_the_timeout():
    sim = ur5e_sim(command_timeout=0.5)
    q0 = sim.q
    v = np.array([0.3, -0.2, 0.1, 0.5, -0.4, 1.0])
    sim.command_velocity(v)
    t0 = sim.time
    for k in range(1, 51):  # 0.5 s / 0.01 s = 50 steps of motion
        t, q, qdot = sim.step()
        np.testing.assert_allclose(q, q0 + v * (t - t0), rtol=0, atol=1e-12)
        np.testing.assert_allclose(qdot, v, atol=1e-12)
        assert t == pytest.approx(t0 + k * DT)
    q_stop = sim.q
    for _ in range(20):
        _, q, qdot = sim.step()
        np.testing.assert_array_equal(q, q_stop)
        np.testing.assert_array_equal(qdot, 0.0)
    assert sim.mode == "hold"


def test_a_new_velocity_command_restarts_the_timeout():
    sim = ur5e_sim(command_timeout=0.1)
    v = np.full(6, 0.1)
    for _ in range(5):
        sim.command_velocity(v)
        for _ in range(8):
            sim.step()
    assert sim.mode == "velocity"  # 5 × 8 steps of 0.01 s > 0.1 s, but refreshed every 0.08 s


def test_velocity_commands_are_clamped_to_the_velocity_limit():
    sim = ur5e_sim()
    sim.command_velocity(-10 * sim.velocity_limit)
    _, _, qdot = sim.step()
    np.testing.assert_allclose(qdot, -sim.velocity_limit)


def test_positions_stop_at_the_limits():
    chain = robots.load_robot("panda")
    sim = ArmSimulator.from_chain(chain, DT, command_timeout=10.0)
    sim.command_velocity(chain.velocity_limit)
    for _ in range(400):
        _, q, qdot = sim.step()
    np.testing.assert_array_equal(q, chain.upper)
    np.testing.assert_array_equal(qdot, 0.0)


def test_trajectory_with_velocities_matches_an_independent_hermite_spline():
    sim = ur5e_sim(demo=False)
    q0 = sim.q
    times = np.array([0.5, 1.2, 2.0])
    pos = q0 + np.array(
        [[0.2, -0.3, 0.4, 0.1, -0.2, 0.3], [0.5, -0.1, 0.6, 0.2, 0.1, 0.0], [0.3] * 6]
    )
    vel = np.array([[0.4, -0.2, 0.3, 0.1, 0.0, 0.2], [0.0, 0.3, -0.2, 0.1, 0.2, -0.3], [0.0] * 6])
    sim.command_trajectory(times, pos, vel)
    oracle = CubicHermiteSpline(np.r_[0.0, times], np.vstack((q0, pos)), np.vstack((0 * q0, vel)))
    for _ in range(250):
        t, q, _ = sim.step()
        expected = oracle(min(t, times[-1]))
        np.testing.assert_allclose(q, expected, atol=1e-9)
    np.testing.assert_allclose(sim.q, pos[-1], atol=1e-12)
    assert sim.mode == "hold"


def test_trajectory_positions_only_passes_the_waypoints_without_overshoot():
    sim = ur5e_sim(demo=False)
    q0 = sim.q
    times = np.array([0.4, 1.0, 1.5, 2.5])
    pos = q0 + np.array([[0.3] * 6, [0.5] * 6, [0.2] * 6, [-0.4] * 6]) * np.linspace(0.5, 1, 6)
    sim.command_trajectory(times, pos)
    knots = np.vstack((q0, pos))
    tk = np.r_[0.0, times]
    history = np.array([sim.step()[1] for _ in range(260)])
    t_hist = DT * np.arange(1, 261)
    for k, t_k in enumerate(tk[1:], start=1):
        np.testing.assert_allclose(history[round(t_k / DT) - 1], knots[k], atol=1e-9)
    for k in range(len(tk) - 1):  # shape-preserving: each segment stays between its end points
        seg = history[(t_hist > tk[k]) & (t_hist < tk[k + 1])]
        lo, hi = np.minimum(knots[k], knots[k + 1]), np.maximum(knots[k], knots[k + 1])
        assert np.all(seg >= lo - 1e-12) and np.all(seg <= hi + 1e-12)
    np.testing.assert_allclose(sim.qdot, 0.0, atol=1e-12)


def test_trajectory_for_a_subset_of_joints_holds_the_others():
    sim = ArmSimulator.from_urdf(robots.robot_path("panda"), DT, demo=False)
    assert sim.joint_names[-1] == "panda_finger_joint1"
    q0 = sim.q
    names = ["panda_finger_joint1", "panda_joint2"]
    sim.command_trajectory([1.0], [[0.01, -1.0]], joint_names=names)
    for _ in range(120):
        _, q, _ = sim.step()
    np.testing.assert_allclose(q[[7, 1]], [0.01, -1.0], atol=1e-12)
    others = [0, 2, 3, 4, 5, 6]
    np.testing.assert_array_equal(q[others], q0[others])


def test_infeasible_trajectory_is_followed_at_the_velocity_limit_and_reaches_the_goal():
    sim = ur5e_sim(demo=False)
    goal = sim.q + 1.0
    sim.command_trajectory([0.01], [goal])  # 1 rad in 10 ms: far beyond π rad/s
    for _ in range(60):
        _, _, qdot = sim.step()
        assert np.all(np.abs(qdot) <= sim.velocity_limit)
    np.testing.assert_allclose(sim.q, goal, atol=1e-12)


@pytest.mark.parametrize("name", ["ur5e", "panda", "iiwa14", "scara", "planar3r"])
def test_demo_motion_is_periodic_smooth_and_within_the_limits(name):
    sim = ArmSimulator.from_urdf(robots.robot_path(name), DT)
    assert sim.mode == "demo"
    q0 = sim.q
    history = np.array([sim.step()[1:] for _ in range(3000)])  # 30 s
    q, qdot = history[:, 0], history[:, 1]
    assert np.all(q >= sim.lower) and np.all(q <= sim.upper)
    assert np.all(np.abs(qdot) <= 0.8 * sim.velocity_limit + 1e-9)
    excursion = q.max(axis=0) - q.min(axis=0)
    assert np.all(excursion > 0.01), excursion  # every joint visibly moves
    assert np.all(excursion <= 1.0 + 1e-9)  # bounded, also for continuous joints
    np.testing.assert_allclose(qdot[0], 0.0, atol=0.05 * sim.velocity_limit.max())  # starts at rest
    acc = np.diff(qdot, axis=0) / DT
    assert np.all(np.abs(acc) < 10 * sim.velocity_limit)  # no velocity jumps
    # periodic: every joint comes back to its start (the minimum of 1 − cos) after t = 1 s
    back = np.abs(q[100:] - q0).min(axis=0)
    assert np.all(back < 1e-3 * np.maximum(excursion, 1e-9) + 1e-6), back


def test_demo_resumes_after_idle_time_when_configured():
    sim = ur5e_sim(command_timeout=0.1, demo_resume_after=0.5)
    sim.command_velocity(np.full(6, 0.1))
    modes = [sim.step() and sim.mode for _ in range(100)]
    assert "hold" in modes and modes[-1] == "demo"
    never = ur5e_sim(command_timeout=0.1)
    never.command_velocity(np.full(6, 0.1))
    for _ in range(20):
        never.step()
    assert all(never.step() and never.mode == "hold" for _ in range(300))


@pytest.mark.parametrize(
    ("command", "match"),
    [
        (lambda s: s.command_velocity([0.1] * 5), "6 values"),
        (lambda s: s.command_velocity([0.1] * 5 + [float("nan")]), "non-finite"),
        (lambda s: s.command_velocity([0.1] * 5 + [float("inf")]), "non-finite"),
        (lambda s: s.command_velocity("fast"), "numeric"),
        (lambda s: s.command_trajectory([], np.zeros((0, 6))), "≥ 1 waypoint"),
        (lambda s: s.command_trajectory([1.0, 1.0], np.zeros((2, 6))), "strictly increasing"),
        (lambda s: s.command_trajectory([2.0, 1.0], np.zeros((2, 6))), "strictly increasing"),
        (lambda s: s.command_trajectory([-1.0], np.zeros((1, 6))), "≥ 0"),
        (lambda s: s.command_trajectory([float("nan")], np.zeros((1, 6))), "non-finite"),
        (lambda s: s.command_trajectory([1.0], np.zeros((1, 5))), "shape"),
        (lambda s: s.command_trajectory([1.0], np.full((1, 6), np.inf)), "non-finite"),
        (lambda s: s.command_trajectory([1.0], np.zeros((1, 6)), np.zeros((2, 6))), "shape"),
        (lambda s: s.command_trajectory([1.0], [[0, 0]], joint_names=["elbow_joint"] * 2), "dup"),
        (lambda s: s.command_trajectory([1.0], [[]], joint_names=[]), "at least one"),
    ],
)
def test_malformed_commands_are_refused_and_leave_the_state_alone(command, match):
    sim = ur5e_sim()
    sim.step()
    before = (sim.mode, sim.q, sim.time)
    with pytest.raises(InvalidInputError, match=match):
        command(sim)
    assert (sim.mode, sim.time) == before[::2] and np.array_equal(sim.q, before[1])


def test_unknown_joint_names_are_refused_with_the_valid_names():
    sim = ur5e_sim()
    with pytest.raises(UnknownNameError, match="shoulder_pan_joint"):
        sim.command_trajectory([1.0], [[0.0]], joint_names=["gripper"])


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"dt": 0.0}, "dt"),
        ({"dt": float("nan")}, "dt"),
        ({"lower": [2.0, 0.0]}, "lower limit"),
        ({"velocity_limit": [1.0, 0.0]}, "velocity limit"),
        ({"q0": [5.0, 0.0]}, "outside"),
        ({"q0": [0.0]}, "2 values"),
        ({"joint_names": ["a", "a"]}, "duplicate"),
        ({"command_timeout": -1.0}, "command_timeout"),
    ],
)
def test_bad_construction_is_refused(kwargs, match):
    args = {
        "joint_names": ["a", "b"],
        "lower": [-1.0, -1.0],
        "upper": [1.0, 1.0],
        "velocity_limit": [1.0, 1.0],
        "dt": 0.01,
    }
    args.update(kwargs)
    with pytest.raises(InvalidInputError, match=match):
        ArmSimulator(**args)


def test_urdf_joints_skip_fixed_and_mimic_joints():
    names, lower, upper, vel = urdf_actuated_joints(robots.robot_path("panda"))
    assert names == [f"panda_joint{i}" for i in range(1, 8)] + ["panda_finger_joint1"]
    assert (lower[-1], upper[-1], vel[-1]) == (0.0, 0.04, 0.2)
    names, lower, upper, _ = urdf_actuated_joints(robots.robot_path("planar3r"))
    assert np.isinf(upper[0]) and np.isinf(lower[0])
