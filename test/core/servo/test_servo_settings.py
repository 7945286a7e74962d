"""The servo's building blocks: settings, limits, braking, damped least squares, task axes.

Oracles: Ruckig's own braking trajectories (a library nobody here wrote) for the braking
distances and reaches; numpy's pseudo-inverse for the undamped solution; the definitions
(inverse functions, continuity) for the rest.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import ruckig
from servo_testing import robot

from kinematics_node.core.exceptions import InvalidInputError, UnknownNameError
from kinematics_node.core.servo import (
    Servo,
    ServoConfig,
    ServoLimits,
    braking_distance,
    braking_speed,
    dls,
)
from kinematics_node.core.servo.axes import select_axes
from kinematics_node.core.servo.limits import braking_reach, braking_speed_one, free_distances
from kinematics_node.core.servo.smoothing import VelocityRamp


# ---------------------------------------------------------------------- settings
def test_defaults_follow_moveit_servo_where_it_has_them():
    cfg = ServoConfig()
    assert cfg.period_s == 0.01
    assert cfg.command_timeout_s == 0.1
    assert cfg.position_margin_rad == 0.1


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("period_s", 0.0),
        ("period_s", 0.0001),  # below 0.5 ms
        ("period_s", math.nan),
        ("command_timeout_s", -1.0),
        ("velocity_scale", 1.5),
        ("velocity_scale", 0.0),
        ("max_damping", math.inf),
        ("max_damping", 1e-200),  # its square underflows: 0/0 at an exact singularity
        ("tracking_gain_1_per_s", "10"),
        ("position_margin_rad", True),
    ],
)
def test_a_bad_setting_is_refused_naming_the_field(field, value):
    with pytest.raises(InvalidInputError, match=f"ServoConfig.{field}"):
        ServoConfig(**{field: value})


def test_periods_down_to_a_millisecond_are_accepted():
    assert ServoConfig(period_s=0.001).period_s == 0.001


@pytest.mark.parametrize(
    "kwargs",
    [
        {"velocity_limits": {"j": 0.0}},
        {"acceleration_limits": {"j": math.inf}},
        {"jerk_limits": [("j", 1.0)]},
        {"task_axes": ("vx", "vx")},
        {"task_axes": ("vw",)},
        {"task_axes": ()},
        {"task_axes_frame": "world"},
    ],
)
def test_bad_overrides_and_axes_are_refused(kwargs):
    with pytest.raises(InvalidInputError):
        ServoConfig(**kwargs)


def test_the_overrides_cannot_be_changed_afterwards():
    overrides = {"elbow_joint": 1.0}
    cfg = ServoConfig(velocity_limits=overrides)
    overrides["elbow_joint"] = 5.0
    assert cfg.velocity_limits["elbow_joint"] == 1.0
    with pytest.raises(TypeError):
        cfg.velocity_limits["elbow_joint"] = 2.0  # type: ignore[index]


# ---------------------------------------------------------------------- limits
def test_limits_come_from_the_description_with_margins_and_overrides():
    chain = robot("scara")  # revolute and prismatic joints
    cfg = ServoConfig(
        velocity_scale=0.5,
        velocity_limits={"joint1": 2.0},
        acceleration_limits={"joint2": 7.0},
        jerk_limits={"joint4": 99.0},
    )
    lim = ServoLimits.from_chain(chain, cfg)
    prismatic = np.array([t == "prismatic" for t in chain.joint_types])
    margin = np.where(prismatic, cfg.position_margin_m, cfg.position_margin_rad)
    np.testing.assert_allclose(lim.lower, chain.lower + margin)
    np.testing.assert_allclose(lim.upper, chain.upper - margin)
    expected_v = np.array(chain.velocity_limit, dtype=float)
    expected_v[0] = 2.0
    np.testing.assert_allclose(lim.velocity, 0.5 * expected_v)
    assert lim.acceleration[1] == 7.0
    np.testing.assert_allclose(lim.acceleration[[0, 2, 3]], lim.velocity[[0, 2, 3]] / 0.25)
    assert lim.jerk[3] == 99.0
    np.testing.assert_allclose(lim.jerk[:3], lim.acceleration[:3] / cfg.jerk_time_s)
    assert not lim.upper.flags.writeable


def test_an_override_of_an_unknown_joint_is_refused_listing_the_joints():
    with pytest.raises(UnknownNameError, match="shoulder_pan_joint"):
        ServoLimits.from_chain(robot("ur5e"), ServoConfig(jerk_limits={"wrist_4_joint": 1.0}))


def test_a_margin_wider_than_half_the_range_is_refused():
    with pytest.raises(InvalidInputError, match="joint3"):  # the SCARA's 0.2 m prismatic joint
        ServoLimits.from_chain(robot("scara"), ServoConfig(position_margin_m=0.15))


# ---------------------------------------------------------------------- braking
def _ruckig_stop(v: float, a: float, A: float, J: float) -> tuple[np.ndarray, float]:
    """Positions of Ruckig's time-optimal stop from (0, v, a), sampled densely, and its end."""
    otg = ruckig.Ruckig(1)
    inp = ruckig.InputParameter(1)
    inp.control_interface = ruckig.ControlInterface.Velocity
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = [100.0], [A], [J]
    inp.current_position, inp.current_velocity, inp.current_acceleration = [0.0], [v], [a]
    inp.target_velocity, inp.target_acceleration = [0.0], [0.0]
    traj = ruckig.Trajectory(1)
    otg.calculate(inp, traj)
    times = np.linspace(0.0, traj.duration, 4001)
    xs = np.array([traj.at_time(t)[0][0] for t in times])
    return xs, xs[-1]


@pytest.mark.parametrize("speed", [0.01, 0.3, 1.0, 3.0])
def test_braking_distance_is_rucKigs_stop_from_rest_acceleration(speed):
    A, J = 8.0, 60.0  # A²/J ≈ 1.07: both the short and the long profile are covered
    _, end = _ruckig_stop(speed, 0.0, A, J)
    d = braking_distance(np.array([speed]), np.array([A]), np.array([J]))[0]
    assert d == pytest.approx(end, rel=1e-9, abs=1e-12)


def test_braking_speed_inverts_braking_distance():
    rng = np.random.default_rng(7)
    A = rng.uniform(1.0, 20.0, 200)
    J = rng.uniform(10.0, 500.0, 200)
    d = rng.uniform(0.0, 2.0, 200)
    v = braking_speed(d, A, J)
    np.testing.assert_allclose(braking_distance(v, A, J), d, rtol=1e-9, atol=1e-12)
    assert braking_speed(np.array([np.inf]), np.array([1.0]), np.array([1.0]))[0] == np.inf
    assert braking_speed(np.array([-1.0]), np.array([1.0]), np.array([1.0]))[0] == 0.0


def _braking_speeds(d: np.ndarray, A: np.ndarray, J: np.ndarray) -> list[float]:
    pairs = zip(d.tolist(), A.tolist(), J.tolist(), strict=True)
    return [braking_speed_one(x, a, j, a * a / j) for x, a, j in pairs]


def test_braking_speed_on_floats_is_the_same_floats_as_on_arrays():
    rng = np.random.default_rng(8)
    A = rng.uniform(1.0, 20.0, 300)
    J = rng.uniform(10.0, 500.0, 300)
    d = np.r_[rng.uniform(-0.5, 3.0, 297), 0.0, np.inf, 1e-300]
    assert _braking_speeds(d, A, J) == braking_speed(d, A, J).tolist()  # exactly
    # where the short and the long profile meet ((d²J)^⅓ = A²/J), to the last bits
    A, J = np.repeat(A[:20], 41), np.repeat(J[:20], 41)
    b = A * A / J
    d = np.sqrt(b**3 / J) * (1.0 + np.tile(np.arange(-20, 21), 20) * 2.2e-16)
    assert _braking_speeds(d, A, J) == braking_speed(d, A, J).tolist()


@pytest.mark.parametrize("name", ["ur5e", "panda", "iiwa14", "scara"])
@pytest.mark.parametrize("period_s", [0.0005, 0.002, 0.01, 0.1])
def test_beyond_the_free_distances_braking_never_limits_a_joint(name, period_s):
    # the servo's velocity planning skips the sides of joints this far from their bounds: the
    # speed it would compute there must be the velocity limit itself, to the last bit
    lim = ServoLimits.from_chain(robot(name), ServoConfig(period_s=period_s))
    A, J, vmax, lead = 0.5 * lim.acceleration, 0.5 * lim.jerk, lim.velocity, 2.0 * period_s
    free, rest = free_distances(vmax, A, J, lead)
    rng = np.random.default_rng(9)
    for _ in range(200):
        speed = vmax * rng.uniform(0.0, 1.0 + 1e-12, vmax.shape)
        start = np.maximum(free, rest + lead * speed)
        for d in (start, start * rng.uniform(1.0, 10.0, vmax.shape)):
            allowed = braking_speed(d - lead * np.maximum(speed, braking_speed(d, A, J)), A, J)
            assert np.array_equal(np.minimum(vmax, allowed), vmax)
    # and the distances are no larger than they need be: a little nearer, a joint at rest is
    # limited (rest is the braking distance from full speed)
    assert np.all(braking_speed(0.999 * rest, A, J) < vmax)


def test_braking_reach_bounds_rucKigs_stop_from_any_state():
    rng = np.random.default_rng(3)
    A, J = 10.0, 100.0
    for _ in range(150):
        v, a = rng.uniform(-2, 2), rng.uniform(-A, A)
        xs, _ = _ruckig_stop(v, a, A, J)
        lo, hi = braking_reach(
            np.array([0.5]), np.array([v]), np.array([a]), np.array([A]), np.array([J])
        )
        # dense samples stay inside the reach, and come within the sampling step of both ends
        step = 2.0 * max(abs(v), 1.0) * 1e-3
        assert lo[0] - 1e-12 <= 0.5 + xs.min() <= lo[0] + step
        assert hi[0] - step <= 0.5 + xs.max() <= hi[0] + 1e-12


def test_the_twist_ramp_is_rucKigs_velocity_interface_step_by_step():
    # each step of the ramp, steady stretches included (where it answers without Ruckig), is
    # what a fresh Ruckig plan from the same state gives for one period
    acc, jerk, dt = (
        np.array([3.0, 3.0, 3.0, 1.0, 1.0, 1.0]),
        np.array([30.0] * 3 + [10.0] * 3),
        0.01,
    )
    ramp = VelocityRamp(acc, jerk, dt)
    rng = np.random.default_rng(4)
    targets = [rng.normal(size=6).tolist() for _ in range(4)] + [[0.0] * 6]
    v, a = [0.0] * 6, [0.0] * 6
    steady = 0
    for target in targets:
        for _ in range(150):  # long enough to arrive and stay
            otg, out = ruckig.Ruckig(6, dt), ruckig.OutputParameter(6)
            inp = ruckig.InputParameter(6)
            inp.control_interface = ruckig.ControlInterface.Velocity
            inp.synchronization = ruckig.Synchronization.Phase
            inp.max_velocity, inp.max_acceleration = [math.inf] * 6, acc.tolist()
            inp.max_jerk, inp.current_position = jerk.tolist(), [0.0] * 6
            inp.current_velocity, inp.current_acceleration = v, a
            inp.target_velocity, inp.target_acceleration = target, [0.0] * 6
            otg.update(inp, out)
            v, a = out.new_velocity, out.new_acceleration
            if not any(target) and max(map(abs, v)) < 1e-12 and max(map(abs, a)) < 1e-9:
                v, a = [0.0] * 6, [0.0] * 6  # the ramp ends a stop at exactly zero
            steady += v == ramp.v and not any(a)
            assert ramp.step(list(target)) == v
            assert ramp.a == a or (not any(ramp.a) and not any(a))
    assert steady > 50  # the steady stretches were exercised


# ---------------------------------------------------------------------- damped least squares
def test_far_from_singularities_the_solution_is_the_pseudo_inverse():
    chain = robot("panda")
    rng = np.random.default_rng(11)
    for _ in range(20):
        q = rng.uniform(chain.lower, chain.upper)
        J = chain.jacobian(q, frame="world")
        x = rng.normal(size=6)
        sol = dls.solve(J, x, threshold=1e-4, max_damping=0.05)
        if sol.singular_values[-1] < 1e-3:
            continue
        np.testing.assert_allclose(sol.undamped, np.linalg.pinv(J) @ x, atol=1e-9)
        assert not sol.damped.any()
        # the null-space projector from the row basis annihilates J
        N = np.eye(7) - sol.row_basis.T @ sol.row_basis
        np.testing.assert_allclose(J @ N, 0.0, atol=1e-9)


def test_at_a_singularity_the_speed_is_bounded_and_good_directions_are_exact():
    chain = robot("ur5e")
    q = np.array([0.3, -1.3, 1.6, -1.9, 0.0, 0.4])  # wrist singular: σ_min = 0
    J = chain.jacobian(q, frame="world")
    U, s, _ = np.linalg.svd(J)
    eps, lam = 0.05, 0.05
    rng = np.random.default_rng(5)
    for _ in range(50):
        x = rng.normal(size=6)
        sol = dls.solve(J, x, eps, lam)
        qd = sol.undamped + sol.damped
        assert np.all(np.isfinite(qd))
        # components along well-conditioned directions are reached exactly
        good = s >= eps
        np.testing.assert_allclose((U.T @ J @ qd)[good], (U.T @ x)[good], atol=1e-9)
        # the damped directions ask at most |uᵀx| / (2λ) of joint speed
        assert np.linalg.norm(sol.damped) <= np.abs(U.T @ x)[~good].sum() / (2 * lam) + 1e-9
        np.testing.assert_allclose(dls.apply(sol, x), qd, atol=1e-12)


def test_near_a_singularity_each_direction_gets_chiaverinis_damping():
    chain = robot("ur5e")
    q = np.array([0.3, -1.3, 1.6, -1.9, 0.004, 0.4])  # σ_min ≈ 0.002, inside ε
    J = chain.jacobian(q, frame="world")
    U, s, Vt = np.linalg.svd(J)
    eps, lam = 0.05, 0.05
    assert 0 < s[-1] < eps
    x = np.random.default_rng(2).normal(size=6)
    sol = dls.solve(J, x, eps, lam)
    lam2 = np.where(s < eps, (1 - (s / eps) ** 2) * lam**2, 0.0)
    expected = s / (s**2 + lam2) * (U.T @ x)  # coordinates along the right singular vectors
    np.testing.assert_allclose(Vt @ (sol.undamped + sol.damped), expected, rtol=1e-6, atol=1e-9)


def test_the_damping_is_continuous_where_it_starts():
    eps, lam = 0.05, 0.05
    sig = np.array([eps * (1 - 1e-9), eps, eps * (1 + 1e-9), 0.0])
    lam2 = dls.variable_damping(sig, eps, lam)
    assert lam2[0] == pytest.approx(0.0, abs=1e-11) and lam2[1] == 0.0 and lam2[2] == 0.0
    assert lam2[3] == pytest.approx(lam * lam)


# ---------------------------------------------------------------------- task axes
def test_all_six_axes_for_six_joints_or_more():
    for name in ("ur5e", "panda", "iiwa14"):
        rows, dropped = select_axes(robot(name), ServoConfig())
        assert rows == tuple(range(6)) and dropped == ()


def test_arms_with_fewer_joints_follow_the_axes_they_can_move():
    rows, dropped = select_axes(robot("scara"), ServoConfig())
    assert dropped == ("wx", "wy")
    assert rows == (2, 3, 4, 5)
    rows, dropped = select_axes(robot("planar3r"), ServoConfig())
    assert len(rows) == 3 and len(dropped) == 3


def test_too_many_axes_for_the_joints_are_refused():
    with pytest.raises(InvalidInputError, match="4 joints"):
        select_axes(robot("scara"), ServoConfig(task_axes=("wx", "wz", "vx", "vy", "vz")))


def test_a_chosen_subset_is_followed_and_the_rest_dropped():
    servo = Servo(robot("ur5e"), [0.3, -1.3, 1.6, -1.9, 1.2, 0.4], ServoConfig(task_axes=("vz",)))
    assert servo.task_axes == ("vz",)
    assert servo.dropped_axes == ("wx", "wy", "wz", "vx", "vy")
