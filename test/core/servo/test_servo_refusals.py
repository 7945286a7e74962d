"""Bad input to the servo: refused with a status that names the problem, never an exception, never
a non-finite output, and the arm holds or stops smoothly within its limits."""

from __future__ import annotations

import math

import numpy as np
import pytest
from servo_testing import joined, limit_violations, robot, run

from kinematics_node.core.exceptions import InvalidInputError
from kinematics_node.core.servo import (
    JointJogCommand,
    PoseCommand,
    Servo,
    ServoConfig,
    StatusCode,
    TwistCommand,
)

Q0 = np.array([0.3, -1.3, 1.6, -1.9, 1.2, 0.4])
NOW = 100.0


def _moving_servo() -> tuple[Servo, object]:
    """A UR5e servo moving its tool at 0.1 m/s (a good twist streamed for 0.5 s)."""
    servo = Servo(robot("ur5e"), Q0)
    trace = run(servo, lambda k, t: [TwistCommand((0, 0, 0.3), (0.1, 0, 0), "base_link", t)], 0.5)
    assert np.abs(trace.v[-1]).max() > 0.05
    return servo, trace


T_GOOD = robot("ur5e").fk(Q0)
T_SCALED = T_GOOD.copy()
T_SCALED[:3, :3] *= 2.0
T_NAN = T_GOOD.copy()
T_NAN[0, 3] = math.nan
T_FAR = T_GOOD.copy()
T_FAR[:3, 3] = (5.0, 0.0, 0.0)

BAD = [  # (command made at time t, expected code, words the message must contain)
    (lambda t: TwistCommand((math.nan, 0, 0), (0, 0, 0), "base_link", t), "REFUSED", "angular"),
    (lambda t: TwistCommand((0, 0, 0), (math.inf, 0, 0), "base_link", t), "REFUSED", "linear"),
    (lambda t: TwistCommand((0, 0, 0), (0, 0), "base_link", t), "REFUSED", "3 finite"),
    (lambda t: TwistCommand((0, 0, 0), "abc", "base_link", t), "REFUSED", "linear"),
    (lambda t: TwistCommand((0, 0, 0), (1e300, 0, 0), "base_link", t), "REFUSED", "unit error"),
    (lambda t: TwistCommand((0, 0, 40.0), (0, 0, 0), "base_link", t), "REFUSED", "unit error"),
    (lambda t: TwistCommand((0, 0, 0), (0.1, 0, 0), "world", t), "REFUSED", "'world'"),
    (lambda t: TwistCommand((0, 0, 0), (0.1, 0, 0), None, t), "REFUSED", "frame"),
    (lambda t: JointJogCommand(["elbow"], [0.1], t), "REFUSED", "'elbow'"),
    (lambda t: JointJogCommand(["elbow_joint", "elbow_joint"], [0.1, 0.1], t), "REFUSED", "twice"),
    (lambda t: JointJogCommand(["elbow_joint"], [0.1, 0.2], t), "REFUSED", "1 finite"),
    (lambda t: JointJogCommand("elbow_joint", [0.1], t), "REFUSED", "sequence"),
    (lambda t: JointJogCommand(["elbow_joint"], [math.nan], t), "REFUSED", "finite"),
    (lambda t: JointJogCommand(["elbow_joint"], [1e9], t), "REFUSED", "unit error"),
    (lambda t: PoseCommand(T_SCALED, "base_link", t), "REFUSED", "rotation"),
    (lambda t: PoseCommand(T_NAN, "base_link", t), "REFUSED", "non-finite"),
    (lambda t: PoseCommand(np.eye(3), "base_link", t), "REFUSED", "shape"),
    (lambda t: PoseCommand(T_FAR, "base_link", t), "REFUSED", "reach"),
    (lambda t: PoseCommand(T_GOOD, "map", t), "REFUSED", "'map'"),
    (lambda t: TwistCommand((0, 0, 0), (0.1, 0, 0), "base_link", math.nan), "REFUSED", "stamp"),
    (lambda t: "go left", "REFUSED", "unknown command type"),
]


@pytest.mark.parametrize(("make", "code", "words"), BAD)
def test_a_bad_command_is_refused_and_the_arm_stops_smoothly(make, code, words):
    servo, before = _moving_servo()
    t = float(before.t[-1]) + before.dt
    status = servo.submit(make(t), t)
    assert status.refused
    assert status.code == StatusCode[f"COMMAND_{code}"]
    assert words in status.message
    after = run(servo, lambda k, t: [], 1.0, t0=t)
    assert after.codes[0] == status.code.name and after.statuses[0].message == status.message
    assert limit_violations(servo.limits, joined(before, after)) == []
    speed = np.linalg.norm(after.v, axis=1)
    assert np.all(np.diff(speed) <= 1e-12) and speed[-1] == 0.0  # decelerates to a stop


@pytest.mark.parametrize(
    ("offset", "words"), [(-0.5, "stamped 0.500 s ago"), (0.5, "in the future")]
)
def test_a_stale_command_is_refused_and_the_active_one_runs_to_its_own_timeout(offset, words):
    """A stale command says nothing about now (commands queued while the receiver was held up
    arrive so, fresh ones behind them): refused, it leaves the active twist to its timeout."""
    servo, before = _moving_servo()
    t = float(before.t[-1]) + before.dt
    last_good = float(before.t[-1])
    stale = TwistCommand((0, 0, 0), (-0.1, 0, 0), "base_link", t + offset)
    status = servo.submit(stale, t)
    assert status.code == StatusCode.COMMAND_STALE and words in status.message
    after = run(servo, lambda k, t: [], 1.5, t0=t)
    timed_out = after.t - last_good > servo.config.command_timeout_s  # (the servo's arithmetic)
    assert set(np.array(after.codes)[~timed_out]) == {"OK"}  # still following the good twist
    assert after.codes[int(np.flatnonzero(timed_out)[0])] == "TIMEOUT_STOP"
    assert limit_violations(servo.limits, joined(before, after)) == []
    assert not np.any(after.v[-1])
    # and the stale twist (the other way) was never followed: the tool never went back along x
    # by more than the stop's own corrections (µm; one period of the stale twist is 1 mm)
    x = np.array([servo.chain.fk(q)[0, 3] for q in joined(before, after).q])
    assert np.diff(x).min() > -1e-5


def test_valid_frames_are_listed_when_a_frame_is_unknown():
    servo = Servo(robot("ur5e"), Q0)
    status = servo.submit(TwistCommand((0, 0, 0), (0.1, 0, 0), "tool", NOW), NOW)
    assert "'tool0'" in status.message and "'wrist_3_link'" in status.message


def test_while_paused_commands_are_refused_and_the_arm_stops():
    servo, before = _moving_servo()
    t = float(before.t[-1]) + before.dt
    servo.pause()
    assert servo.paused
    status = servo.submit(TwistCommand((0, 0, 0), (0.1, 0, 0), "base_link", t), t)
    assert status.code == StatusCode.COMMAND_REFUSED and "paused" in status.message
    after = run(
        servo, lambda k, t: [TwistCommand((0, 0, 0), (0.1, 0, 0), "base_link", t)], 1.0, t0=t
    )
    assert set(after.codes) == {StatusCode.PAUSED.name}
    assert limit_violations(servo.limits, joined(before, after)) == []
    assert not np.any(after.v[-1])
    servo.resume()
    t = float(after.t[-1]) + after.dt
    assert servo.step(t, after.q[-1]).status.code == StatusCode.IDLE
    assert (
        servo.submit(TwistCommand((0, 0, 0), (0.1, 0, 0), "base_link", t), t).code == StatusCode.OK
    )


@pytest.mark.parametrize(
    "measured",
    [
        [0.0] * 5,
        [0.0] * 7,
        [math.nan, 0, 0, 0, 0, 0],
        [math.inf, 0, 0, 0, 0, 0],
        "abc",
        [[0.0] * 6],
    ],
)
def test_unusable_measured_positions_are_refused_and_the_arm_stops(measured):
    servo, before = _moving_servo()
    t = float(before.t[-1]) + before.dt
    after = run(servo, lambda k, t: [], 1.0, t0=t, corrupt=lambda k, m: measured if k == 0 else m)
    assert after.statuses[0].code == StatusCode.STATE_REFUSED
    assert "measured_positions" in after.statuses[0].message
    assert limit_violations(servo.limits, joined(before, after)) == []
    assert not np.any(after.v[-1])


def test_a_non_finite_clock_is_refused_without_output_going_bad():
    servo, _ = _moving_servo()
    out = servo.step(math.nan, Q0)
    assert out.status.code == StatusCode.STATE_REFUSED and "now_s" in out.status.message
    assert np.all(np.isfinite(out.positions)) and math.isfinite(out.time_s)
    assert servo.submit(TwistCommand((0, 0, 0), (0.1, 0, 0), "base_link", 1.0), math.inf).refused


def test_without_commands_the_servo_idles_and_holds():
    servo = Servo(robot("ur5e"), Q0)
    trace = run(servo, lambda k, t: [], 0.5)
    assert set(trace.codes) == {StatusCode.IDLE.name}
    assert np.array_equal(trace.q, np.repeat(Q0[None], len(trace.q), axis=0))


def test_a_refusal_does_not_end_a_later_good_command():
    servo, _ = _moving_servo()
    t = NOW + 0.6
    assert servo.submit(TwistCommand((math.nan,) * 3, (0, 0, 0), "base_link", t), t).refused
    assert (
        servo.submit(TwistCommand((0, 0, 0), (0.1, 0, 0), "base_link", t), t).code == StatusCode.OK
    )
    assert servo.step(t, servo.positions).status.code == StatusCode.OK


def test_outputs_are_read_only():
    servo = Servo(robot("ur5e"), Q0)
    out = servo.step(NOW, Q0)
    with pytest.raises(ValueError):
        out.positions[0] = 1.0
    with pytest.raises(ValueError):
        servo.positions[0] = 1.0


@pytest.mark.parametrize(
    ("args", "match"),
    [
        ((robot("ur5e"), [0.0] * 5), "initial_positions"),
        ((robot("ur5e"), [math.nan] * 6), "initial_positions"),
        (("ur5e", Q0), "SerialChain"),
        ((robot("ur5e"), Q0, {"period_s": 0.01}), "ServoConfig"),
    ],
)
def test_a_servo_cannot_be_built_from_bad_arguments(args, match):
    with pytest.raises(InvalidInputError, match=match):
        Servo(*args)


def test_commands_faster_than_the_maximum_are_slowed_and_say_so():
    servo = Servo(robot("ur5e"), Q0, ServoConfig(max_linear_speed_m_s=0.05))
    trace = run(servo, lambda k, t: [TwistCommand((0, 0, 0), (0.2, 0, 0), "base_link", t)], 1.5)
    assert trace.statuses[-1].velocity_scaled
    p = robot("ur5e").fk(trace.q)[:, :3, 3]
    assert np.linalg.norm(p[-1] - p[-11]) / (10 * trace.dt) == pytest.approx(0.05, rel=1e-3)
