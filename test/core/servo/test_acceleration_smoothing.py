"""The servo's smoothing without Ruckig (`acceleration_smoothing`) and the choice of smoothing
(`smoothers`), issue 32 item 7.

Oracles: Ruckig's own velocity interface with an infinite jerk limit (a library nobody here
wrote: its time-optimal, phase-synchronised acceleration-limited motion) for the free motion, where
Ruckig is installed; the constant-deceleration stop v²/(2A) of elementary kinematics for the
stopping distance; and, on every step of random scripts, the limits themselves (positions less the
margin, velocity, acceleration, on the reported values and on the commanded positions' finite
differences). The servo runs with Ruckig hidden (the module's handle set to None, as where
`import ruckig` fails) on the scripts the Ruckig path is tested on.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from servo_testing import limit_violations, random_script, robot, run

from kinematics_node.core.exceptions import InvalidInputError
from kinematics_node.core.servo import (
    NO_RUCKIG_NOTE,
    JointJogCommand,
    MissingDependencyError,
    Servo,
    ServoConfig,
    ServoLimits,
    TwistCommand,
    choose_smoothing,
)
from kinematics_node.core.servo import smoothing as ruckig_smoothing
from kinematics_node.core.servo.acceleration_smoothing import (
    AccelerationLimitedIntegrator,
    AccelerationRamp,
    stopping_distance,
)

DT = 0.01
HOMES = {
    "ur5e": np.array([0.3, -1.3, 1.6, -1.9, 1.2, 0.4]),
    "panda": np.array([0.0, -0.4, 0.0, -2.2, 0.0, 1.9, 0.8]),
    "iiwa14": np.array([0.0, 0.5, 0.0, -1.2, 0.0, 0.8, 0.0]),
    "scara": np.array([0.3, 1.2, -0.1, 0.2]),
}


@pytest.fixture
def no_ruckig(monkeypatch):
    """Ruckig as where it is not installed (`smoothing`'s handle is None then)."""
    monkeypatch.setattr(ruckig_smoothing, "_ruckig", None)


def _limits(n: int = 3, lower=-1.0, upper=1.0, rng=None) -> ServoLimits:
    rng = np.random.default_rng(0) if rng is None else rng
    velocity = rng.uniform(0.5, 3.0, n)
    acceleration = velocity / rng.uniform(0.1, 0.5, n)
    return ServoLimits(
        tuple(f"j{k}" for k in range(n)),
        np.full(n, lower),
        np.full(n, upper),
        velocity,
        acceleration,
        acceleration / 0.1,
    )


def _check_step(lim, integ, q0, v0, q_start, dt=DT):
    """Every limit on one step (q0, v0: the state before it)."""
    v, a, q = np.array(integ.v_list), np.array(integ.a_list), np.array(integ.q_list)
    assert np.all(np.abs(v) <= lim.velocity * (1 + 1e-12))
    assert np.all(np.abs(a) <= lim.acceleration * (1 + 1e-9))
    assert np.all(np.abs(q - q0) / dt <= lim.velocity * (1 + 1e-12))  # mean velocity
    assert np.allclose(a, (v - v0) / dt, rtol=0, atol=1e-9)
    assert np.allclose(q, q0 + 0.5 * dt * (v0 + v), rtol=0, atol=1e-15)  # exact integration
    # never past a bound (a joint that started outside: never further out than it started)
    assert np.all(q <= np.maximum(lim.upper, q_start) + 1e-9)
    assert np.all(q >= np.minimum(lim.lower, q_start) - 1e-9)
    assert np.array_equal(integ.q, q) and np.array_equal(integ.v, v)


def test_random_scripts_never_break_a_limit_nor_cross_a_bound():
    rng = np.random.default_rng(32)
    for _ in range(40):
        lim = _limits(4, rng=rng)
        # starts anywhere, a few joints outside their bounds (the margin moved inward)
        q_start = rng.uniform(-1.1, 1.1, 4)
        integ = AccelerationLimitedIntegrator(lim, DT, q_start)
        braked = 0
        for _ in range(25):  # 25 targets, each held for a random number of steps
            target = rng.normal(size=4) * lim.velocity * rng.choice([0.3, 1.0, 3.0])
            for _ in range(int(rng.integers(1, 60))):
                q0, v0 = np.array(integ.q_list), np.array(integ.v_list)
                braking = integ.step(target.tolist())
                braked += braking is not None
                _check_step(lim, integ, q0, v0, q_start)
        assert braked > 0, "the position guard never acted: the scripts test nothing"


def test_a_joint_driven_into_its_bound_stops_just_inside_it():
    lim = _limits(1, lower=-1.0, upper=1.0)
    vmax, A = float(lim.velocity[0]), float(lim.acceleration[0])
    integ = AccelerationLimitedIntegrator(lim, DT, np.array([-0.9]))
    for _ in range(2000):
        q0, v0 = np.array(integ.q_list), np.array(integ.v_list)
        integ.step([10.0 * vmax])  # far beyond the limit: clipped to it
        _check_step(lim, integ, q0, v0, np.array([-0.9]))
    assert integ.at_rest
    # at rest near the bound: within what one period at the braking speed covers
    assert 1.0 - 1.5 * A * DT * DT - 1e-9 <= integ.q_list[0] <= 1.0 + 1e-9


def test_it_reaches_the_target_velocity_on_a_straight_line_in_the_fewest_periods():
    lim = _limits(3, lower=-100.0, upper=100.0)
    integ = AccelerationLimitedIntegrator(lim, DT, np.zeros(3))
    target = np.array([0.8, -0.4, 0.3]) * lim.velocity
    # the slowest joint needs ceil(|Δv| / (A dt)) periods; the others are synchronised with it
    needed = math.ceil(float(np.max(np.abs(target) / (lim.acceleration * DT))) - 1e-12)
    for k in range(1, needed + 1):
        integ.step(target.tolist())
        v = np.array(integ.v_list)
        # on the line from 0 to the target (phase synchronisation: the path is not bent)
        share = float(v @ target / (target @ target))
        assert np.allclose(v, share * target, rtol=0, atol=1e-12)
        # each period the slowest joint gains A dt: share k A dt / |Δv| of the way, then 1
        expected = min(1.0, k * float(np.min(lim.acceleration * DT / np.abs(target))))
        assert share == pytest.approx(expected, rel=1e-12)
    assert integ.v_list == target.tolist()  # exactly there
    integ.step(target.tolist())
    assert integ.v_list == target.tolist() and not any(integ.a_list)


def test_it_stops_smoothly_within_the_constant_deceleration_distance():
    lim = _limits(3, lower=-100.0, upper=100.0)
    integ = AccelerationLimitedIntegrator(lim, DT, np.zeros(3))
    v_run = (np.array([1.0, -0.7, 0.4]) * lim.velocity).tolist()
    for _ in range(300):
        integ.step(v_run)
    assert integ.v_list == v_run
    q_stop = np.array(integ.q_list)
    speeds = [np.abs(integ.v_list)]
    for _ in range(300):
        q0, v0 = np.array(integ.q_list), np.array(integ.v_list)
        integ.step([0.0, 0.0, 0.0])
        _check_step(lim, integ, q0, v0, q_stop)
        speeds.append(np.abs(integ.v_list))
    speeds_a = np.array(speeds)
    assert np.all(np.diff(speeds_a, axis=0) <= 0.0)  # the speed only falls, every joint
    assert integ.at_rest and integ.v_list == [0.0] * 3 and integ.a_list == [0.0] * 3
    travelled = np.abs(np.array(integ.q_list) - q_stop)
    # the slowest-stopping joint brakes at full deceleration: v²/(2A) of elementary kinematics,
    # plus at most A dt²/8 for its last, shorter period; the others are synchronised with it
    v = np.abs(v_run)
    slowest = int(np.argmax(v / lim.acceleration))
    continuous = v[slowest] ** 2 / (2 * lim.acceleration[slowest])
    assert continuous - 1e-12 <= travelled[slowest]
    assert travelled[slowest] <= continuous + lim.acceleration[slowest] * DT**2 / 8 + 1e-12
    assert travelled[slowest] == pytest.approx(
        stopping_distance(v[slowest], lim.acceleration[slowest], DT), abs=1e-12
    )
    # every joint stops in proportion: the same share of its speed at each period
    ratio = speeds_a[:, 1:] / speeds_a[:, :1].clip(min=1e-300)
    moving = speeds_a[:, 0] > 0
    assert np.allclose(ratio[moving], (v[1:] / v[0])[None], rtol=1e-9)


def test_free_motion_is_rucKigs_velocity_interface_without_a_jerk_limit():
    # each step is what a fresh Ruckig plan from the same state, with an infinite jerk limit,
    # gives for one period: the same velocities; the same positions, except on the period it
    # arrives at the target, where Ruckig reaches it within the period and goes on at it, and
    # this smoothing spreads the change over the period (at most A dt²/8 apart)
    ruckig = pytest.importorskip("ruckig")
    lim = _limits(4, lower=-100.0, upper=100.0)
    integ = AccelerationLimitedIntegrator(lim, DT, np.zeros(4))
    rng = np.random.default_rng(7)
    arrivals = 0
    for _ in range(6):
        target = (rng.normal(size=4) * lim.velocity).tolist()
        for _ in range(80):
            otg, out = ruckig.Ruckig(4, DT), ruckig.OutputParameter(4)
            inp = ruckig.InputParameter(4)
            inp.control_interface = ruckig.ControlInterface.Velocity
            inp.synchronization = ruckig.Synchronization.Phase
            inp.max_velocity = lim.velocity.tolist()
            inp.max_acceleration = lim.acceleration.tolist()
            inp.max_jerk = [math.inf] * 4
            inp.current_position, inp.current_velocity = integ.q_list, integ.v_list
            inp.current_acceleration = [0.0] * 4
            inp.target_velocity = np.clip(target, -lim.velocity, lim.velocity).tolist()
            result = otg.update(inp, out)
            integ.step(target)
            assert np.allclose(integ.v_list, out.new_velocity, rtol=0, atol=1e-12)
            gap = np.abs(np.array(integ.q_list) - out.new_position)
            if result == ruckig.Result.Finished and gap.max() > 1e-12:  # it arrived
                arrivals += 1
                assert np.all(gap <= lim.acceleration * DT**2 / 8 + 1e-12)
            else:
                assert gap.max() <= 1e-12
    assert arrivals >= 3


def test_the_ramp_keeps_its_direction_and_its_acceleration_limits():
    acc = np.array([3.0, 3.0, 3.0, 1.0, 1.0, 1.0])
    ramp = AccelerationRamp(acc, acc / 0.1, DT)
    rng = np.random.default_rng(5)
    for target in [rng.normal(size=6).tolist() for _ in range(4)] + [[0.0] * 6]:
        start = list(ramp.v)
        for _ in range(400):
            before = np.array(ramp.v)
            v = np.array(ramp.step(list(target)))
            assert np.all(np.abs(v - before) <= acc * DT * (1 + 1e-12))
            assert np.allclose(ramp.a, (v - before) / DT, rtol=0, atol=1e-9)
            # on the line from where it started toward the target
            d = np.array(target) - np.array(start)
            moved = v - np.array(start)
            assert np.allclose(moved, (moved @ d) / (d @ d) * d, rtol=0, atol=1e-12)
        assert ramp.v == target and not any(ramp.a)
    # slowed: half the acceleration, in proportion; restored: the full one again
    ramp.slow(0.5, 0.5)
    v = np.array(ramp.step([1.0] * 6))
    assert np.abs(v).max() == pytest.approx(0.5 * acc.min() * DT)
    ramp.restore()
    before = np.array(ramp.v)
    v = np.array(ramp.step([1.0] * 6))
    assert np.abs(v - before).max() == pytest.approx(acc.min() * DT)


# ---------------------------------------------------------------------------- the choice
def test_with_ruckig_installed_the_servo_uses_it():
    pytest.importorskip("ruckig")
    choice = choose_smoothing()
    assert choice.name == "ruckig" and choice.jerk_limited and choice.note is None
    servo = Servo(robot("ur5e"), HOMES["ur5e"])
    assert servo.smoothing == choice
    assert type(servo._integrator) is ruckig_smoothing.JerkLimitedIntegrator
    assert type(servo._ramp) is ruckig_smoothing.VelocityRamp
    chosen = Servo(robot("ur5e"), HOMES["ur5e"], ServoConfig(smoothing="acceleration"))
    assert chosen.smoothing.name == "acceleration" and chosen.smoothing.note is None


def test_without_ruckig_the_servo_runs_and_says_what_is_missing(no_ruckig):
    servo = Servo(robot("ur5e"), HOMES["ur5e"])
    assert servo.smoothing.name == "acceleration" and not servo.smoothing.jerk_limited
    assert type(servo._integrator) is AccelerationLimitedIntegrator
    note = servo.smoothing.note
    assert note == NO_RUCKIG_NOTE
    assert "jerk" in note and "pip install ruckig" in note and "--break-system-packages" in note
    assert "setting" not in note and "chain" not in note  # it blames neither


def test_smoothing_ruckig_without_ruckig_is_refused_saying_how_to_install_it(no_ruckig):
    with pytest.raises(MissingDependencyError, match="pip install ruckig"):
        Servo(robot("ur5e"), HOMES["ur5e"], ServoConfig(smoothing="ruckig"))
    with pytest.raises(InvalidInputError, match="smoothing"):
        ServoConfig(smoothing="jerk")  # type: ignore[arg-type]


# ---------------------------------------------------------------------------- the servo
@pytest.mark.parametrize("name", list(HOMES))
def test_without_ruckig_random_scripts_never_break_a_limit(no_ruckig, name):
    chain = robot(name)
    servo = Servo(chain, HOMES[name])
    assert servo.smoothing.name == "acceleration"
    script, steps = random_script(chain, servo, 1000 + len(name))
    trace = run(servo, script, steps * servo.config.period_s)
    assert limit_violations(servo.limits, trace, jerk=False) == []
    assert np.abs(trace.v).max() > 0.1  # it did move


@pytest.mark.parametrize("name", ["ur5e", "panda", "iiwa14"])
def test_without_ruckig_a_joint_jogged_into_its_limit_stops_inside_it(no_ruckig, name):
    chain = robot(name)
    servo = Servo(chain, HOMES[name])
    lim = servo.limits
    k = 1
    jog = [0.0] * chain.dof
    jog[k] = float(lim.velocity[k])
    trace = run(servo, lambda i, t: [JointJogCommand(list(chain.joint_names), jog, t)], 6.0)
    assert limit_violations(lim, trace, jerk=False) == []
    assert trace.q[-1, k] == pytest.approx(lim.upper[k], abs=2e-3)  # it got there
    assert abs(trace.v[-1, k]) < 1e-9


@pytest.mark.parametrize("name", ["ur5e", "panda", "iiwa14"])
def test_without_ruckig_a_line_is_followed_as_closely_as_with_it(no_ruckig, name):
    chain = robot(name)
    servo = Servo(chain, HOMES[name])
    v = np.array([0.0, 0.0, 0.05])
    trace = run(servo, lambda k, t: [TwistCommand((0, 0, 0), tuple(v), chain.base_link, t)], 2.0)
    assert limit_violations(servo.limits, trace, jerk=False) == []
    p = chain.fk(trace.q)[:, :3, 3]
    p0 = chain.fk(HOMES[name])[:3, 3]
    off_line = np.linalg.norm(np.cross(p - p0, v / np.linalg.norm(v)), axis=1)
    assert off_line.max() < 1e-3
    speed = (p[-1, 2] - p[-51, 2]) / (50 * servo.config.period_s)
    assert speed == pytest.approx(0.05, rel=1e-3)  # after the ramp, at the commanded speed
