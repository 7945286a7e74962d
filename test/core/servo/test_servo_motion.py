"""The servo in closed loop with a simulated arm, over many cycles, on UR5e, Panda, iiwa14 and SCARA.

Each test asserts a property of issue 23 on every cycle of a scripted run (never a time): the tool
keeps moving through a wrist singularity, a pure rotation does not move the tool point, lines and
poses are followed, no joint passes a position, velocity, acceleration or jerk limit, a timeout
stops the arm at once and smoothly, singular configurations can be left, a redundant arm moves in
its null space, an arm with fewer joints follows the chosen directions.
"""

from __future__ import annotations

import numpy as np
import pytest
from servo_testing import (
    joined,
    limit_violations,
    random_script,
    robot,
    rotation_angle,
    run,
    ur5e_wrist_line,
)

from kinematics_node.core import so3
from kinematics_node.core.servo import (
    JointJogCommand,
    PoseCommand,
    Servo,
    ServoConfig,
    StatusCode,
    TwistCommand,
)

HOMES = {
    "ur5e": np.array([0.3, -1.3, 1.6, -1.9, 1.2, 0.4]),
    "panda": np.array([0.0, -0.4, 0.0, -2.2, 0.0, 1.9, 0.8]),
    "iiwa14": np.array([0.0, 0.5, 0.0, -1.2, 0.0, 0.8, 0.0]),
    "scara": np.array([0.3, 1.2, -0.1, 0.2]),
}
#: well-conditioned straight lines from HOMES (base axes)
LINES = {
    "ur5e": (1.0, 0.0, 0.0),
    "panda": (0.0, 1.0, 0.0),
    "iiwa14": (0.0, 0.0, 1.0),
    "scara": (0.0, -1.0, 0.0),
}
ARMS = list(HOMES)


def _servo(name: str, q0: np.ndarray | None = None, **settings: object) -> Servo:
    return Servo(robot(name), HOMES[name] if q0 is None else q0, ServoConfig(**settings))  # type: ignore[arg-type]


def _twist(w, v, frame):
    return lambda k, t: [TwistCommand(w, v, frame, t)]


# ---------------------------------------------------------------------- singularities
def test_through_the_wrist_singularity_the_tool_keeps_moving():
    chain = robot("ur5e")
    q0, d, _ = ur5e_wrist_line()
    servo = Servo(chain, q0)
    trace = run(servo, _twist((0, 0, 0), tuple(0.1 * d), "base_link"), 2.5)
    assert limit_violations(servo.limits, trace) == []
    # the path goes through the singularity: q5 changes sign, passing within 0.01 rad of 0
    q5 = trace.q[:, 4]
    assert q5[0] > 0.1 and q5[-1] < -0.1 and np.abs(q5).min() < 0.01
    kappa = max(s.condition_number for s in trace.statuses)
    assert kappa > 30  # moveit_servo's scheme halts above 30
    assert StatusCode.NEAR_SINGULARITY.name in trace.codes
    # the tool never stops: after the start ramp, every cycle advances along the line
    p = chain.fk(trace.q)[:, :3, 3]
    speed = np.diff(p @ d) / trace.dt
    assert speed[40:].min() > 0.09
    # and it stays on the line
    rel = p - chain.fk(q0)[:3, 3]
    cross = np.linalg.norm(rel - np.outer(rel @ d, d), axis=1)
    assert cross.max() < 1e-3


def _sigma_min(chain, q):
    return np.linalg.svd(chain.jacobian(q, frame="world"), compute_uv=False)[-1]


SINGULAR = [  # (arm, an exactly singular configuration)
    ("ur5e", np.array([0.3, -1.3, 1.6, -1.9, 0.0, 0.4])),  # wrist: q5 = 0
    ("ur5e", np.array([0.3, -1.0, 0.0, -1.5, 1.2, 0.4])),  # elbow straight: q3 = 0
    ("panda", np.array([1.81, 0.596, 2.662, -0.318, 1.571, 3.047, -1.465])),  # found numerically
    ("iiwa14", np.array([0.0, 0.5, 0.0, 0.0, 0.0, 0.8, 0.0])),  # elbow straight: q4 = 0
]


def _moved(chain, q_from, q_to):
    T0, T1 = chain.fk(q_from), chain.fk(q_to)
    return np.r_[so3.log(T1[:3, :3] @ T0[:3, :3].T), T1[:3, 3] - T0[:3, 3]]


@pytest.mark.parametrize(("name", "q_singular"), SINGULAR)
def test_a_singular_configuration_is_left_by_commanding_away_from_it(name, q_singular):
    """From an exact singularity, command (either way) the tool motion of the joint that raises
    the smallest singular value fastest: the tool follows at the commanded speed, and the arm is
    off the singularity. moveit_servo's scheme halts there whatever the command (κ = ∞ > 30)."""
    chain = robot(name)
    sigma0 = _sigma_min(chain, q_singular)
    assert sigma0 < 1e-5  # singular (the Panda's, found numerically, to 1e-6)
    rise = [_sigma_min(chain, q_singular + 1e-4 * e) - sigma0 for e in np.eye(chain.dof)]
    column = chain.jacobian(q_singular, frame="world")[:, int(np.argmax(rise))]
    servo = Servo(chain, q_singular, ServoConfig(position_margin_rad=0.0))
    for sign in (1.0, -1.0):
        away = sign * 0.3 * column / np.linalg.norm(column)
        servo.reset(q_singular)
        trace = run(servo, _twist(tuple(away[:3]), tuple(away[3:]), chain.base_link), 1.0)
        assert limit_violations(servo.limits, trace) == []
        moved = _moved(chain, q_singular, trace.q[-1])
        assert moved @ away > 0.99 * np.linalg.norm(moved) * np.linalg.norm(away)
        assert np.linalg.norm(moved) > 0.8 * np.linalg.norm(away)  # 1 s, less the ramp's delay
        assert _sigma_min(chain, trace.q[-1]) > 1e-3


@pytest.mark.parametrize("name", ["ur5e", "iiwa14"])
def test_a_straight_elbow_is_left_by_pulling_the_tool_in(name):
    """The lost direction itself: inward from a straight elbow, reached only at second order
    (bending the elbow either way pulls the tool in). It starts at once, not after drifting."""
    q_singular = SINGULAR[1][1] if name == "ur5e" else SINGULAR[3][1]
    chain = robot(name)
    servo = Servo(chain, q_singular, ServoConfig(position_margin_rad=0.0))
    U = np.linalg.svd(chain.jacobian(q_singular, frame="world"))[0]
    lost = U[:, -1]
    p = chain.fk(q_singular)[:3, 3]
    inward = 0.05 * lost * np.sign(lost[3:] @ -p)  # the sign that points at the base
    trace = run(servo, _twist(tuple(inward[:3]), tuple(inward[3:]), chain.base_link), 1.0)
    assert limit_violations(servo.limits, trace) == []
    k_left = int(np.argmax([_sigma_min(chain, q) > 0.05 for q in trace.q]))
    assert 0 < k_left * trace.dt < 0.5
    moved = _moved(chain, q_singular, trace.q[-1])
    assert moved @ inward > 0.5 * np.linalg.norm(moved) * np.linalg.norm(inward)


# ---------------------------------------------------------------------- drift and tracking
def _reversing_rotation(chain, speed=0.5, half_period_s=2.0, axis=(1.0, 1.0, 1.0)):
    """A pure rotation at `speed` about a fixed axis of the tool frame, through the tool point,
    reversing every `half_period_s` (the first time after half of it, so it swings about the
    start); ω is given in the tool frame."""
    w = speed * np.asarray(axis) / np.linalg.norm(axis)

    def script(k, t):
        tt = k * 0.01 if script.dt is None else k * script.dt
        sign = 1.0 if ((tt + half_period_s / 2) // half_period_s) % 2 == 0 else -1.0
        return [TwistCommand(tuple(sign * w), (0.0, 0.0, 0.0), chain.tip_link, t)]

    script.dt = None
    return script


@pytest.mark.parametrize("name", ["ur5e", "panda", "iiwa14"])
def test_ten_seconds_of_pure_rotation_do_not_move_the_tool_point(name):
    chain = robot(name)
    servo = _servo(name)
    script = _reversing_rotation(chain)
    script.dt = servo.config.period_s
    p0 = chain.fk(HOMES[name])[:3, 3]
    trace = run(servo, script, 10.0)
    rest = run(servo, lambda k, t: [], 1.0, t0=trace.t[-1] + trace.dt)  # timeout, stop, rest
    assert limit_violations(servo.limits, joined(trace, rest)) == []
    assert rest.codes[-1] == StatusCode.TIMEOUT_STOP.name and not np.any(rest.v[-1])
    T = chain.fk(trace.q)
    assert rotation_angle(chain.fk(HOMES[name])[:3, :3][None], T[:, :3, :3]).max() > 0.45
    drift = np.linalg.norm(chain.fk(rest.q[-1])[:3, 3] - p0)
    assert drift < 1e-4  # issue 23: < 0.1 mm after 10 s at 0.5 rad/s
    excursion = np.linalg.norm(T[:, :3, 3] - p0, axis=1).max()
    assert excursion < 1e-3  # and never more than 1 mm on the way, reversals included


_NEAR_WRIST = np.array([0.3, -1.3, 1.6, -1.9, 0.05, 0.4])  # the UR5e's home, q5 2.9° from 0


_TILTED = (1.0, 1.0, 1.0)


@pytest.mark.parametrize(
    ("q0", "axis", "sign"),
    [
        pytest.param(HOMES["ur5e"], _TILTED, 1.0, id="home+"),
        pytest.param(HOMES["ur5e"], _TILTED, -1.0, id="home-"),
        pytest.param(_NEAR_WRIST, _TILTED, 1.0, id="near_wrist+"),
        pytest.param(_NEAR_WRIST, _TILTED, -1.0, id="near_wrist-"),
        # the joints' velocity limits slow these spins (the ramp restarts from what the arm does)
        pytest.param(HOMES["ur5e"], (0.0, 1.0, 0.0), 1.0, id="home_y+"),
        pytest.param(HOMES["ur5e"], (0.0, 1.0, 0.0), -1.0, id="home_y-"),
        pytest.param(_NEAR_WRIST, (1.0, 0.0, 0.0), -1.0, id="near_wrist_x-"),
    ],
)
def test_ten_seconds_of_rotation_one_way_leave_the_tool_point_where_it_was(q0, axis, sign):
    """Issue 23's drift bound on a spin that never reverses, from a well-conditioned start and from
    2.9° beside the wrist singularity (which the spin passes): after 10 s at 0.5 rad/s about a
    tool axis, the timeout's stop and rest, the tool point is within 0.1 mm of where it began
    (14-25 mm off while falling more than the kept error behind pulled the commanded pose toward
    the arm)."""
    chain = robot("ur5e")
    servo = Servo(chain, q0)
    w = sign * 0.5 * np.array(axis) / np.linalg.norm(axis)
    trace = run(servo, _twist(tuple(w), (0.0, 0.0, 0.0), chain.tip_link), 10.0)
    rest = run(servo, lambda k, t: [], 2.0, t0=trace.t[-1] + trace.dt)  # timeout, stop, rest
    assert limit_violations(servo.limits, joined(trace, rest)) == []
    assert rest.codes[-1] == StatusCode.TIMEOUT_STOP.name and not np.any(rest.v[-1])
    R0 = chain.fk(q0)[:3, :3]
    assert rotation_angle(R0[None], chain.fk(trace.q)[:, :3, :3]).max() > 1.0  # it did turn
    drift = np.linalg.norm(chain.fk(rest.q[-1])[:3, 3] - chain.fk(q0)[:3, 3])
    assert drift < 1e-4


@pytest.mark.parametrize("stop", ["timeout", "zero_twist"])
def test_a_fast_spin_ramped_to_zero_stops_with_the_joints_in_proportion(stop):
    """After 10 s of rotation one way from the UR5e's home, the joints turn at up to 2.8 rad/s:
    the twist's ramp to zero (the timeout's, or a zero twist sent) is slowed to what every joint
    can follow, so the joints decelerate in proportion and the tool point stays within 2 mm of
    where it began all through the stop (6 mm when the joints' smoothing limited them one by
    one); the joints' velocities stay near the line of their velocity as the stop began."""
    chain = robot("ur5e")
    q0 = HOMES["ur5e"]
    servo = Servo(chain, q0)
    w = -0.5 * np.ones(3) / np.sqrt(3.0)
    trace = run(servo, _twist(tuple(w), (0.0, 0.0, 0.0), chain.tip_link), 10.0)
    script = (
        (lambda k, t: []) if stop == "timeout" else _twist((0, 0, 0), (0, 0, 0), chain.base_link)
    )
    rest = run(servo, script, 3.0, t0=trace.t[-1] + trace.dt)
    assert limit_violations(servo.limits, joined(trace, rest)) == []
    assert np.abs(rest.v[-1]).max() < 1e-9  # stopped (a zero twist keeps the loop closed)
    p0 = chain.fk(q0)[:3, 3]
    assert np.linalg.norm(chain.fk(rest.q)[:, :3, 3] - p0, axis=1).max() < 2e-3
    v0 = trace.v[-1]
    u = v0 / np.linalg.norm(v0)
    across = np.linalg.norm(rest.v - np.outer(rest.v @ u, u), axis=1)
    assert across.max() < 0.1 * np.linalg.norm(v0)  # 0.14-0.16 one by one, 0.04-0.07 now


@pytest.mark.parametrize("name", ["ur5e", "panda", "iiwa14"])
def test_out_to_the_edge_of_the_workspace_and_back_stays_on_the_line(name):
    """0.2 m/s radially outward for 3 s, past the edge, then back for 3 s. The commanded pose
    stays on the line and the arm within the kept error of it (`max_kept_error_m`), so the tool
    is never farther than that from the line (braked at the edge, `Servo._brake`: 4-6 mm); and
    it comes back inward."""
    chain = robot(name)
    servo = _servo(name)
    p0 = chain.fk(HOMES[name])[:3, 3]
    radial = np.r_[p0[:2], 0.0] / np.linalg.norm(p0[:2])
    trace = run(
        servo,
        lambda k, t: [
            TwistCommand((0, 0, 0), tuple((0.2 if k < 300 else -0.2) * radial), chain.base_link, t)
        ],
        6.0,
    )
    assert limit_violations(servo.limits, trace) == []
    rel = chain.fk(trace.q)[:, :3, 3] - p0
    along = rel @ radial
    cross = np.linalg.norm(rel - np.outer(along, radial), axis=1)
    assert cross.max() < servo.config.max_kept_error_m
    assert along[-1] < along.max() - 0.2  # back inward


def test_an_arm_held_off_its_path_reports_its_whole_error():
    """A spin about a tilted axis through the tool point, from 2.9° beside the UR5e's wrist
    singularity, which the spin passes: damped least squares gives up some accuracy there, and
    the tool point leaves its place by more than the kept error bound (the benchmark's
    wrist_spin+). The twist has no linear part, so the commanded position stays at the start's
    (the kept error is pulled back only along the commanded motion), and the status reports the
    whole distance of the tool point from it, not the bound."""
    chain = robot("ur5e")
    q0 = HOMES["ur5e"].copy()
    q0[4] = 0.05
    servo = _servo("ur5e", q0)
    bound_m = servo.config.max_kept_error_m
    T0 = chain.fk(q0)
    axis = np.ones(3) / np.sqrt(3.0)
    trace = run(servo, _twist(tuple(0.5 * axis), (0.0, 0.0, 0.0), chain.tip_link), 4.0)
    assert limit_violations(servo.limits, trace) == []
    # a step's error is that of the pose its step started from: the previous command
    T = chain.fk(np.vstack([trace.q_start[None], trace.q[:-1]]))
    off_point = np.linalg.norm(T[:, :3, 3] - T0[:3, 3], axis=1)
    position = np.array([s.position_error_m for s in trace.statuses])
    assert off_point.max() > bound_m  # the arm is held off its path
    np.testing.assert_allclose(position, off_point, rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", ARMS)
def test_a_well_conditioned_line_is_followed_within_a_millimetre(name):
    chain = robot(name)
    servo = _servo(name)
    d = np.array(LINES[name])
    trace = run(servo, _twist((0, 0, 0), tuple(0.1 * d), chain.base_link), 2.0)
    assert limit_violations(servo.limits, trace) == []
    T0 = chain.fk(HOMES[name])
    T = chain.fk(trace.q)
    rel = T[:, :3, 3] - T0[:3, 3]
    along = rel @ d
    cross = np.linalg.norm(rel - np.outer(along, d), axis=1)
    assert cross.max() < 1e-3
    assert rotation_angle(T0[:3, :3][None], T[:, :3, :3]).max() < 1e-3
    # it moves at the commanded speed once ramped up (≈ 0.2 m in 2 s, less the ramp's delay)
    assert along[-1] > 0.18
    assert np.diff(along[100:]).min() / trace.dt > 0.099


def test_a_line_at_one_kilohertz_is_followed_too():
    servo = _servo("panda", period_s=0.001)
    chain = servo.chain
    d = np.array(LINES["panda"])
    trace = run(servo, _twist((0, 0, 0), tuple(0.1 * d), chain.base_link), 1.0)
    assert limit_violations(servo.limits, trace) == []
    rel = chain.fk(trace.q)[:, :3, 3] - chain.fk(HOMES["panda"])[:3, 3]
    assert np.linalg.norm(rel - np.outer(rel @ d, d), axis=1).max() < 1e-3
    assert (rel @ d)[-1] > 0.08


@pytest.mark.parametrize("name", ARMS)
def test_pose_targets_are_reached_without_overshoot(name):
    chain = robot(name)
    servo = _servo(name)
    T0 = chain.fk(HOMES[name])
    rng = np.random.default_rng(17)
    for _ in range(2):
        servo.reset(HOMES[name])
        step = rng.normal(size=3)
        step *= 0.12 / np.linalg.norm(step)
        turn = rng.normal(size=3)
        turn *= 0.4 / np.linalg.norm(turn)
        if name == "scara":  # it can only turn about z
            turn = np.array([0.0, 0.0, 0.4])
        goal = T0.copy()
        goal[:3, 3] += step
        goal[:3, :3] = so3.exp(turn) @ T0[:3, :3]
        trace = run(servo, lambda k, t, g=goal: [PoseCommand(g, chain.base_link, t)], 6.0)
        assert limit_violations(servo.limits, trace) == []
        T = chain.fk(trace.q)
        err = np.linalg.norm(T[:, :3, 3] - goal[:3, 3], axis=1)
        ang = rotation_angle(goal[:3, :3][None], T[:, :3, :3])
        assert err[-1] < 1e-4 and ang[-1] < 1e-3
        overshoot = ((T[:, :3, 3] - goal[:3, 3]) @ (step / np.linalg.norm(step))).max()
        assert overshoot < 1e-3
        assert trace.statuses[-1].target_reached
        assert trace.statuses[-1].position_error_m == pytest.approx(err[-1], abs=1e-6)


# ---------------------------------------------------------------------- limits
def _near_upper(name: str, joint: int) -> tuple[np.ndarray, float]:
    servo = _servo(name)
    return HOMES[name].copy(), float(servo.limits.upper[joint])


@pytest.mark.parametrize("name", ARMS)
def test_jogging_into_a_joint_limit_and_out_stays_within_every_limit(name):
    chain = robot(name)
    servo = _servo(name)
    joint = 1 if name != "scara" else 2  # the SCARA's prismatic joint
    jname = chain.joint_names[joint]
    v = float(servo.limits.velocity[joint])

    def script(k, t):
        speed = v if t - 100.0 < 3.0 else -v  # full speed into the limit, then back out
        return [JointJogCommand([jname], [speed], t)]

    trace = run(servo, script, 4.0)
    assert limit_violations(servo.limits, trace) == []
    upper = servo.limits.upper[joint]
    top = trace.q[:, joint].max()
    assert upper - 1e-3 < top <= upper + 1e-12  # it got to the bound (with margin), not past it
    held = [s for s in trace.statuses if s.code == StatusCode.AT_JOINT_LIMIT]
    assert held and all(s.joints_at_limit == (jname,) for s in held)
    assert trace.q[-1, joint] < top - 0.05  # and came back out


def test_a_continuous_joint_goes_on_while_another_joint_meets_its_limit():
    # planar3r's joint1 is continuous (no position limit): the velocity planning near joint2's
    # limit must leave it its full speed (an infinite distance to its bound once gave NaN)
    chain = robot("planar3r")
    assert chain.joint_types[0] == "continuous"
    servo = Servo(chain, [0.0, 2.0, 0.3])
    jog = JointJogCommand(["joint1", "joint2"], [0.5, 0.8], 0.0)

    def script(k, t):
        return [JointJogCommand(jog.joint_names, jog.velocities, t)]

    trace = run(servo, script, 3.0)
    assert limit_violations(servo.limits, trace) == []
    assert trace.q[-1, 1] == pytest.approx(servo.limits.upper[1], abs=1e-3)  # held at its bound
    assert "joint2" in trace.statuses[-1].joints_at_limit
    assert trace.v[-1, 0] == pytest.approx(0.5)  # joint1 keeps its commanded speed
    assert trace.q[-1, 0] > 1.2


@pytest.mark.parametrize("name", ["ur5e", "panda", "iiwa14"])
def test_a_twist_into_a_joint_limit_stops_there_without_winding_up(name):
    chain = robot(name)
    q0 = HOMES[name].copy()
    if name == "ur5e":  # its joints turn ±2π: start the last one near its limit
        q0[5] = 5.9
    # turn the tool about its axis until the last joint (and then others) meet their limits
    w, v = np.array([0.0, 0.0, 0.6]), np.zeros(3)
    servo = Servo(chain, q0)
    trace = run(servo, _twist(tuple(w), tuple(v), chain.tip_link), 6.0)
    assert limit_violations(servo.limits, trace) == []
    assert StatusCode.AT_JOINT_LIMIT.name in trace.codes
    cfg = servo.config
    assert max(s.position_error_m for s in trace.statuses) <= cfg.max_kept_error_m + 1e-12
    assert max(s.orientation_error_rad for s in trace.statuses) <= cfg.max_kept_error_rad + 1e-12
    # no wind-up: after 6 s of pushing, reversing the command leaves the limit within the time
    # the bounded kept error and the twist's ramp take (0.4 s), and the arm comes back
    back = run(servo, _twist(tuple(-w), tuple(-v), chain.tip_link), 0.6, t0=trace.t[-1] + 0.01)
    assert limit_violations(servo.limits, joined(trace, back)) == []
    assert StatusCode.AT_JOINT_LIMIT.name not in back.codes[40:]
    assert np.abs(back.q[-1] - trace.q[-1]).max() > 0.05


@pytest.mark.parametrize("name", ARMS)
def test_step_commands_never_break_a_limit(name):
    chain = robot(name)
    servo = _servo(name)
    rng = np.random.default_rng(23)
    steps = [(rng.normal(size=3) * 0.6, rng.normal(size=3) * 0.15) for _ in range(8)]

    def script(k, t):
        w, v = steps[(k // 50) % len(steps)]  # a new twist every 0.5 s, a step each time
        return [TwistCommand(tuple(w), tuple(v), chain.base_link, t)]

    trace = run(servo, script, 4.0)
    assert limit_violations(servo.limits, trace) == []
    assert np.abs(trace.v).max() > 0.1  # it did move


@pytest.mark.parametrize("name", ARMS)
def test_random_scripts_of_any_command_never_break_a_limit(name):
    chain = robot(name)
    servo = _servo(name)
    script, periods = random_script(chain, servo, 1000 + len(name))
    trace = run(servo, script, periods * servo.config.period_s)
    assert limit_violations(servo.limits, trace) == []


# ---------------------------------------------------------------------- timeout
@pytest.mark.parametrize("name", ["ur5e", "iiwa14"])
def test_a_timeout_begins_a_smooth_stop_within_one_period(name):
    chain = robot(name)
    servo = _servo(name)
    last = 100.0 + 1.0  # commands stop arriving after 1 s of steady jogging

    def script(k, t):
        return (
            [JointJogCommand(list(chain.joint_names[:3]), [0.5, -0.4, 0.3], t)] if t <= last else []
        )

    trace = run(servo, script, 2.0)
    assert limit_violations(servo.limits, trace) == []
    deadline = last + servo.config.command_timeout_s
    k_first = int(np.flatnonzero(trace.t > deadline + 1e-9)[0])
    # before the deadline it was still at full speed; on the first step after it, it stops
    assert trace.codes[k_first - 1] == "OK"
    assert trace.codes[k_first] == StatusCode.TIMEOUT_STOP.name
    assert trace.t[k_first] - deadline <= servo.config.period_s + 1e-9
    speed = np.linalg.norm(trace.v, axis=1)
    assert speed[k_first] < speed[k_first - 1]
    stopping = speed[k_first:]
    assert np.all(np.diff(stopping) <= 1e-12)  # monotonically down to rest
    assert stopping[-1] == 0.0
    assert trace.statuses[-1].message.startswith("stopped")


def test_periods_of_a_held_up_caller_leave_the_timeout_to_the_next_one():
    """A caller held up (its process off the CPU) makes up the periods it missed before it takes
    the commands sent meanwhile: those periods do not time out the command; the next does."""
    chain = robot("ur5e")
    twist = _twist((0, 0, 0), (0.05, 0.0, 0.0), chain.base_link)
    hold = 0.2  # [s], twice the timeout, with no command taken
    for fresh in (True, False):  # a fresh twist was queued meanwhile, or the sender stopped
        servo = _servo("ur5e")

        def tool_speed(trace):  # [m/s], of the commanded positions, cycle to cycle
            p = np.array([chain.fk(q)[:3, 3] for q in trace.q])
            return np.linalg.norm(np.diff(p, axis=0), axis=1) / trace.dt

        before = run(servo, twist, 1.0)
        assert tool_speed(before)[-1] == pytest.approx(0.05, rel=1e-3)
        made_up = run(servo, lambda k, t: [], hold, t0=before.t[-1] + before.dt, held_up=True)
        assert set(made_up.codes) == {"OK"}
        assert tool_speed(made_up) == pytest.approx(0.05, rel=1e-3)
        after = run(
            servo, twist if fresh else (lambda k, t: []), 1.0, t0=made_up.t[-1] + made_up.dt
        )
        if fresh:  # taken now: the motion goes on without a stop
            assert set(after.codes) == {"OK"}
            assert tool_speed(after) == pytest.approx(0.05, rel=1e-3)
        else:  # the first period not held up stops it
            assert after.codes[0] == "TIMEOUT_STOP" and not after.v[-1].any()
        whole = joined(joined(before, made_up), after)
        assert limit_violations(servo.limits, whole) == []


# ---------------------------------------------------------------------- redundancy, fewer joints
@pytest.mark.parametrize(
    ("name", "q0"),
    [
        ("panda", np.array([2.7, -0.4, 0.0, -2.2, 0.0, 1.9, 0.8])),  # joint 1 near its +2.897
        ("iiwa14", np.array([2.8, 0.5, 0.0, -1.2, 0.0, 0.8, 0.0])),  # joint 1 near its +2.967
    ],
)
def test_null_space_motion_moves_joints_away_from_limits_without_moving_the_tool(name, q0):
    chain = robot(name)
    servo = Servo(chain, q0)
    lim = servo.limits
    trace = run(servo, _twist((0, 0, 0), (0, 0, 0), chain.base_link), 3.0)
    assert limit_violations(lim, trace) == []

    def worst_margin(q):
        return np.minimum(q - lim.lower, lim.upper - q).min()

    assert worst_margin(trace.q[-1]) > worst_margin(q0) + 0.1
    T0 = chain.fk(q0)
    T = chain.fk(trace.q)
    assert np.linalg.norm(T[:, :3, 3] - T0[:3, 3], axis=1).max() < 1e-4
    assert rotation_angle(T0[:3, :3][None], T[:, :3, :3]).max() < 1e-3


def test_without_null_space_gain_a_redundant_arm_holds_still():
    q0 = np.array([0.0, -0.4, 0.0, -2.2, 2.7, 1.9, 0.8])
    servo = Servo(robot("panda"), q0, ServoConfig(nullspace_gain_1_per_s=0.0))
    trace = run(servo, _twist((0, 0, 0), (0, 0, 0), "panda_link0"), 1.0)
    assert np.abs(trace.q - q0).max() < 1e-9


def test_an_arm_with_four_joints_follows_the_chosen_directions_and_says_what_it_drops():
    chain = robot("scara")
    servo = _servo("scara")
    w, v = (0.4, 0.0, 0.5), (0.0, -0.05, -0.02)  # wx cannot be followed by a SCARA
    trace = run(servo, _twist(w, v, "base_link"), 1.0)
    assert limit_violations(servo.limits, trace) == []
    status = trace.statuses[-1]
    assert status.dropped_axes == ("wx", "wy")
    assert "drops wx, wy" in status.message
    T0, T1 = chain.fk(HOMES["scara"]), chain.fk(trace.q[-1])
    turned = so3.log(T1[:3, :3] @ T0[:3, :3].T)
    moved = T1[:3, 3] - T0[:3, 3]
    # followed: z rotation and the translation, at the commanded rates (less the ramp's delay)
    ramp_delay = 0.1
    assert turned[2] == pytest.approx(0.5 * (1.0 - ramp_delay), abs=0.02)
    np.testing.assert_allclose(moved, np.array(v) * (1.0 - ramp_delay), atol=2e-3)
    assert abs(turned[0]) < 1e-9 and abs(turned[1]) < 1e-9  # dropped, not approximated


def test_a_chosen_subset_of_axes_is_followed_on_a_six_joint_arm():
    chain = robot("ur5e")
    servo = _servo("ur5e", task_axes=("vx", "vy", "vz"))
    trace = run(servo, _twist((0.5, 0.0, 0.0), (0.0, 0.05, 0.0), "base_link"), 1.0)
    T0, T1 = chain.fk(HOMES["ur5e"]), chain.fk(trace.q[-1])
    np.testing.assert_allclose(T1[:3, 3] - T0[:3, 3], [0.0, 0.045, 0.0], atol=2e-3)
    assert trace.statuses[-1].dropped_axes == ("wx", "wy", "wz")


# ---------------------------------------------------------------------- arms that do not follow
def test_a_lagging_arm_still_gets_a_clean_path():
    chain = robot("ur5e")
    servo = _servo("ur5e")
    d = np.array(LINES["ur5e"])
    trace = run(servo, _twist((0, 0, 0), tuple(0.1 * d), "base_link"), 2.0, lag_s=0.05)
    assert limit_violations(servo.limits, trace) == []
    assert StatusCode.NOT_FOLLOWING.name not in trace.codes
    rel = chain.fk(trace.measured)[:, :3, 3] - chain.fk(HOMES["ur5e"])[:3, 3]
    assert np.linalg.norm(rel - np.outer(rel @ d, d), axis=1).max() < 1e-3


def test_a_blocked_arm_is_noticed_and_the_command_stops():
    servo = _servo("ur5e")
    script = _twist((0, 0, 0), (0.2, 0, 0), "base_link")
    # commands for 0.6 s (a later one would start again from where the arm is), then none
    trace = run(servo, lambda k, t: script(k, t) if k < 60 else [], 2.0, blocked=True)
    assert limit_violations(servo.limits, trace) == []
    assert StatusCode.NOT_FOLLOWING.name in trace.codes
    k = trace.codes.index(StatusCode.NOT_FOLLOWING.name)
    gap = np.abs(trace.q[: k + 1] - HOMES["ur5e"]).max(axis=1)
    # noticed on the first step that finds the last command that far from the arm
    assert gap[k - 2] <= servo.config.max_following_error < gap[k - 1]
    assert "not following" in trace.statuses[k].message
    assert not np.any(trace.v[-1])  # it stopped


def test_after_a_stop_a_new_command_starts_from_where_the_arm_was_moved():
    servo = _servo("ur5e")
    moved = HOMES["ur5e"] + 0.3  # someone moved the arm while the servo was idle
    servo.step(100.0, moved)
    servo.submit(TwistCommand((0, 0, 0), (0.05, 0, 0), "base_link", 100.01), 100.01)
    out = servo.step(100.01, moved)
    assert np.abs(out.positions - moved).max() < 1e-3


@pytest.mark.parametrize(("name", "seconds"), [("panda", 12.0), ("iiwa14", 9.0)])
def test_a_pure_rotation_through_a_joint_limit_keeps_the_tool_point(name, seconds):
    """Issue 32 item 10: a pure rotation about the tool's z axis until the last joint meets its
    limit. The other joints take over only what they carry exactly, at velocities the smoothing
    reaches within the period (`JerkLimitedIntegrator.follow`), and the rest slows: the tool
    point stays put (5.0 mm on the Panda, 14.5 mm on the iiwa14 before task scaling, 1.2 and
    0.8 mm with it and the smoothing lagging; 0.13 and 0.008 mm at the exact share; 0.017 and
    0.008 mm with it braked ahead), no joint passes a bound."""
    chain = robot(name)
    servo = _servo(name)
    trace = run(servo, _twist((0.0, 0.0, 0.5), (0.0, 0.0, 0.0), chain.tip_link), seconds)
    assert limit_violations(servo.limits, trace) == []
    last = chain.joint_names[-1]
    assert any(last in s.joints_at_limit for s in trace.statuses)  # the limit was met
    p0 = chain.fk(HOMES[name])[:3, 3]
    moved = np.linalg.norm(chain.fk(trace.q)[:, :3, 3] - p0, axis=1)
    assert moved.max() < (0.2e-3 if name == "panda" else 1e-4)


@pytest.mark.parametrize("period", [0.01, 0.002, 0.001], ids=["100Hz", "500Hz", "1kHz"])
@pytest.mark.parametrize("name", ["panda", "iiwa14"])
def test_a_pure_rotation_through_a_joint_limit_keeps_the_tool_point_within_0_1_mm(name, period):
    """Issue 32 item 10's goal, with Ruckig at the rates users run: the tool point stays within
    0.1 mm while the last joint meets its limit, the others take over, and they in turn slow
    to a stop before a singularity of their own and a position bound. Started 1 rad before
    the limit (the other joints do not move before it: the 9 s run from HOMES, cut short; the
    rotation is at full speed 2 s before the limit). Before the take-over's share was braked (`Servo._share_brake`) and a held joint kept
    from speeding up toward its bound again: up to 0.82 mm on the Panda at 1 kHz."""
    chain = robot(name)
    servo = _servo(name, period_s=period)
    q0 = HOMES[name].copy()
    q0[-1] = servo.limits.upper[-1] - 1.0
    servo.reset(q0)
    trace = run(servo, _twist((0.0, 0.0, 0.5), (0.0, 0.0, 0.0), chain.tip_link), 5.2)
    assert limit_violations(servo.limits, trace) == []
    assert any(chain.joint_names[-1] in s.joints_at_limit for s in trace.statuses)
    assert trace.q[:, -1].max() > servo.limits.upper[-1] - 1e-3  # it went to the limit
    p0 = chain.fk(q0)[:3, 3]
    moved = np.linalg.norm(chain.fk(trace.q)[:, :3, 3] - p0, axis=1)
    assert moved.max() < 1e-4, moved.max()


@pytest.mark.parametrize(
    ("name", "period", "before"),
    [
        ("panda", 0.002, 0.4),
        ("panda", 0.001, 0.2),
        ("iiwa14", 0.001, 0.2),
        ("iiwa14", 0.002, 0.7),
        ("panda", 0.01, 0.3),
    ],
    ids=[
        "panda-500Hz-0.4rad",
        "panda-1kHz-0.2rad",
        "iiwa14-1kHz-0.2rad",
        "iiwa14-500Hz-0.7rad",
        "panda-100Hz-0.3rad",
    ],
)
def test_a_pure_rotation_reaching_the_limit_sooner_keeps_the_tool_point_within_0_1_mm(
    name, period, before
):
    """The same rotation arriving at the limit at other phases of the take-over (`before` rad
    before it: the other joints still in the null-space motion of the start, or the share
    reaching 1 where the joints taking over bend fastest). Before the share was kept within the
    take-over path's bend (`Servo._curvature_cap`) and a lagged take-over was followed with its
    targets' rate: 0.55 mm (Panda, 500 Hz, 0.4 rad), 0.46 mm (Panda, 1 kHz, 0.2 rad), 0.64 mm
    (iiwa14, 1 kHz, 0.2 rad); the last two cases were within 0.1 mm already."""
    chain = robot(name)
    servo = _servo(name, period_s=period)
    q0 = HOMES[name].copy()
    q0[-1] = servo.limits.upper[-1] - before
    servo.reset(q0)
    trace = run(servo, _twist((0.0, 0.0, 0.5), (0.0, 0.0, 0.0), chain.tip_link), before / 0.5 + 3.2)
    assert limit_violations(servo.limits, trace) == []
    assert any(chain.joint_names[-1] in s.joints_at_limit for s in trace.statuses)
    p0 = chain.fk(q0)[:3, 3]
    moved = np.linalg.norm(chain.fk(trace.q)[:, :3, 3] - p0, axis=1)
    assert moved.max() < 1e-4, moved.max()


@pytest.mark.parametrize("name", ["panda", "iiwa14"])
def test_without_ruckig_a_pure_rotation_through_a_joint_limit_keeps_the_tool_point(name):
    """The same take-over with the acceleration-limited smoothing (no Ruckig): its `reachable`
    and `follow` are what the exact share needs, with no jerk limit to respect."""
    chain = robot(name)
    servo = _servo(name, smoothing="acceleration")
    assert not servo.smoothing.jerk_limited
    trace = run(servo, _twist((0.0, 0.0, 0.5), (0.0, 0.0, 0.0), chain.tip_link), 9.0)
    assert limit_violations(servo.limits, trace, jerk=False) == []
    assert any(chain.joint_names[-1] in s.joints_at_limit for s in trace.statuses)
    p0 = chain.fk(HOMES[name])[:3, 3]
    moved = np.linalg.norm(chain.fk(trace.q)[:, :3, 3] - p0, axis=1)
    assert moved.max() < 0.2e-3, moved.max()


def _stop_after_rotation(name: str, start: np.ndarray, period: float) -> tuple[float, float]:
    """(during, stop): the tool point's largest distance [m] from where it started while a pure
    rotation about the tool z comes for 2 s, and over the 0.6 s after it stops coming."""
    chain = robot(name)
    servo = _servo(name, q0=start, period_s=period)

    def script(k, t):
        return [TwistCommand((0.0, 0.0, 0.5), (0.0, 0.0, 0.0), chain.tip_link, t)] * (
            k * period < 2.0
        )

    trace = run(servo, script, 2.6)
    assert limit_violations(servo.limits, trace) == []
    moved = np.linalg.norm(chain.fk(trace.q)[:, :3, 3] - chain.fk(start)[:3, 3], axis=1)
    n = int(2.0 / period)
    return moved[:n].max(), moved[n:].max()


#: The live test's Panda: joint 7 0.5 rad before its limit less the margin.
LIVE_START = np.array([0.0, -0.4, 0.0, -2.2, 0.0, 1.9, 2.8973 - 0.1 - 0.5])


@pytest.mark.parametrize("period", [0.002, 0.001])
def test_the_stop_after_a_rotation_through_a_joint_limit_keeps_the_tool_point(period):
    """The twists stop while the other joints carry joint 7's share: the ramp to zero asks them
    for a tenth of their acceleration and jerk (`_STOP_SHARE_TAKING_OVER`), where half left the
    point by 0.47 mm (Panda, 500 Hz and 1 kHz)."""
    during, stop = _stop_after_rotation("panda", LIVE_START, period)
    assert during < 1e-4 and stop < 1e-4, (during, stop)


@pytest.mark.xfail(
    strict=True,
    reason="issue 32 item 10, the stop: from other starts the end of the stop along the path "
    "still leaves the tool point (Panda 0.3 rad before the limit, 500 Hz: 0.87 mm; iiwa14 0.5 "
    "rad before: 0.2-0.26 mm): the ramp of the twist reaches zero with the take-over joints "
    "still moving, and their joint-space stop bends the path",
)
def test_the_stop_after_a_rotation_from_nearer_the_limit_keeps_the_tool_point():
    chain = robot("panda")
    start = HOMES["panda"].copy()
    start[-1] = chain.upper[-1] - 0.1 - 0.3
    during, stop = _stop_after_rotation("panda", start, 0.002)
    assert during < 1e-4 and stop < 1e-4, (during, stop)
