"""`JointStateTracker`: required joints reject bad samples, other tracked joints never block them."""

from __future__ import annotations

import math

import numpy as np
import pytest
from kin_testing import PinocchioOracle
from service_testing import check_message, js

import msg_adapters as ma
from kinematics_node.core.exceptions import InvalidInputError
from kinematics_node.service.ee_state import (
    ARRIVAL_SPAN,
    FROM_ARRIVAL_REPEATED,
    FROM_ARRIVAL_UNSTAMPED,
    FROM_MESSAGE,
    FROM_STAMPS,
    JUMP_BACK,
    NO_VELOCITY_YET,
    SOURCE_HOLD,
    JointStateTracker,
)
from kinematics_node.service.kinematics import Severity

ARM = ("a", "b")


def tracker() -> JointStateTracker:
    return JointStateTracker(ARM + ("gripper",), continuous=(False, True, False), required=ARM)


def test_a_bad_value_of_an_optional_joint_is_skipped_and_the_rest_merged():
    t = tracker()
    assert t.update(["a", "b", "gripper"], [0.1, 0.2, math.nan], [], 1.0)
    assert t.positions([0, 1]) == [0.1, 0.2]
    assert math.isnan(t.positions([2])[0])  # never received a valid gripper value
    assert t.update(["gripper"], [0.04], [], 1.1)
    assert t.positions([2]) == [0.04]


@pytest.mark.parametrize(
    ("names", "positions", "velocities", "needle"),
    [
        (["a", "b"], [0.1, math.nan], [], "position of 'b' is nan"),
        (["a", "b"], [math.inf, 0.0], [], "position of 'a' is inf"),
        (["a", "b"], [0.1, 0.2], [0.0, -math.inf], "velocity of 'b' is -inf"),
        (["a", "b", "a"], [0.1, 0.2, 0.3], [], "'a' more than once"),
        (["a", "b"], [0.1], [], "2 names but 1 positions"),
        (["a", "b"], [0.1, 0.2], [0.0], "2 names but 1 velocities"),
    ],
)
def test_bad_samples_of_required_joints_are_refused_whole(names, positions, velocities, needle):
    t = tracker()
    assert t.update(["a", "b"], [1.0, 2.0], [], 0.5)
    with pytest.raises(InvalidInputError, match=needle):
        t.update(names, positions, velocities, 1.0)
    assert t.positions([0, 1]) == [1.0, 2.0]  # nothing merged


def test_velocity_estimated_across_the_wrap_of_a_continuous_joint():
    t = tracker()
    t.update(["a", "b"], [0.0, math.pi - 0.01], [], 0.0)
    t.update(["a", "b"], [0.02, -math.pi + 0.01], [], 0.01)
    np.testing.assert_allclose(t.velocities([0, 1]), [2.0, 2.0], atol=1e-9)


def test_nan_velocity_means_unknown_and_is_estimated():
    t = tracker()
    t.update(["a", "b"], [0.0, 0.0], [math.nan, math.nan], 0.0)
    assert t.velocities([0, 1]) is None
    t.update(["a", "b"], [0.1, -0.1], [math.nan, 0.5], 0.1)
    np.testing.assert_allclose(t.velocities([0, 1]), [1.0, 0.5])


def test_a_jump_back_starts_a_new_timeline_and_a_small_one_is_stale():
    t = JointStateTracker(["a", "b"])
    assert t.update(["a", "b"], [0.0, 0.0], None, 10.0)
    assert t.update(["a", "b"], [0.1, 0.2], None, 10.1)  # velocities estimated: 1 and 2 rad/s
    np.testing.assert_allclose(t.qdot, [1.0, 2.0])
    # reordered in transit (older by less than JUMP_BACK): ignored
    assert not t.update(["a", "b"], [5.0, 5.0], None, 10.1 - 0.5 * JUMP_BACK)
    assert t.stale_samples == 2 and t.jumps_back == 0
    # a bag or simulation restarted: taken, with no velocity estimated across the jump
    assert t.update(["a", "b"], [0.3, 0.4], None, 10.1 - 2 * JUMP_BACK)
    assert t.jumps_back == 1 and t.qdot is None
    np.testing.assert_array_equal(t.q, [0.3, 0.4])
    assert t.update(["a", "b"], [0.4, 0.6], None, 10.2 - 2 * JUMP_BACK)  # estimated again
    np.testing.assert_allclose(t.qdot, [1.0, 2.0])
    assert t.latest_stamp == pytest.approx(10.2 - 2 * JUMP_BACK)


# =========================================================================== timing of samples
# joint_states as drivers send them: unstamped, stamps that repeat, bursts, duplicates. The
# positions below move at a steady speed V, so every estimate has one right answer.
V = np.array([0.8, -1.5])  # [rad/s]
Q0 = np.array([0.2, 3.0])


def feed(t: JointStateTracker, times, stamps, arrivals, names=("a", "b")):
    """Feed samples taken at `times` (positions Q0 + V·time), stamped `stamps`, arriving at
    `arrivals`; the velocity after each ([nan, nan] while unknown)."""
    out = []
    for time_, stamp, received in zip(times, stamps, arrivals, strict=True):
        t.update(list(names), list(Q0 + V * time_), [], stamp, received)
        v = t.velocities([0, 1])
        out.append([math.nan, math.nan] if v is None else v)
    return np.array(out)


def steady(rate: float, seconds: float, start: float = 0.0) -> np.ndarray:
    return start + np.arange(int(rate * seconds)) / rate


def test_unstamped_samples_are_estimated_over_their_arrival_times():
    t = JointStateTracker(["a", "b"])
    times = steady(500.0, 0.4)
    jitter = np.random.default_rng(3).uniform(0.0, 2e-4, times.size)  # 0–0.2 ms late
    v = feed(t, times, [0.0] * times.size, 1000.0 + times + jitter)
    assert t.velocity_source == FROM_ARRIVAL_UNSTAMPED and t.from_arrival_times
    assert t.arrival_episodes == 1
    known = ~np.isnan(v[:, 0])
    # unknown until ARRIVAL_SPAN of history, known from then on
    assert not known[: int(500 * ARRIVAL_SPAN)].any() and known[int(500 * ARRIVAL_SPAN) + 1 :].all()
    # 0.2 ms of jitter over at least ARRIVAL_SPAN: within 0.4 %
    np.testing.assert_allclose(
        v[known], np.broadcast_to(V, v[known].shape), rtol=2e-4 / ARRIVAL_SPAN
    )


def test_a_burst_of_unstamped_samples_gives_no_huge_velocity():
    """Samples that waited in a queue arrive within microseconds: over single intervals they
    would read as 1000× the speed; over ARRIVAL_SPAN the error is at most the burst's length
    over the span."""
    t = JointStateTracker(["a", "b"])
    times = steady(500.0, 0.5)
    arrivals = times.copy()
    burst = slice(150, 160)  # 20 ms of samples delivered at once, 1 µs apart
    arrivals[burst] = arrivals[burst.stop - 1] + 1e-6 * np.arange(10)
    v = feed(t, times, [0.0] * times.size, arrivals)
    assert np.isfinite(v[100:]).all()
    # 20 ms of samples arriving as one, over ARRIVAL_SPAN = 50 ms: off by at most 40 %
    worst = np.max(np.abs(v[100:] / V - 1.0))
    assert worst <= 0.4 + 1e-9, worst
    np.testing.assert_allclose(v[-1], V, rtol=1e-9)  # and exact again once the burst is past


def test_stamps_that_advance_every_fifth_sample_give_the_speed_at_every_sample():
    t = JointStateTracker(["a", "b"])
    times = steady(500.0, 0.4, start=50.0)
    stamps = 50.0 + np.floor((times - 50.0) * 100.0 + 1e-9) / 100.0  # a 10 ms stamp clock
    arrivals = times + np.random.default_rng(5).uniform(0.0, 1e-4, times.size)
    v = feed(t, times, stamps, arrivals)
    assert t.velocity_source == FROM_ARRIVAL_REPEATED
    known = ~np.isnan(v[:, 0])
    assert known[int(500 * 2 * ARRIVAL_SPAN) :].all()
    np.testing.assert_allclose(v[known], np.broadcast_to(V, v[known].shape), rtol=3e-3)
    # where the stamp advances, the estimate is over the stamps, from the first sample with the
    # previous stamp: exact, whatever the arrival times
    advancing = np.flatnonzero(np.diff(stamps) > 0) + 1
    np.testing.assert_allclose(v[advancing[1:]], np.broadcast_to(V, (advancing.size - 1, 2)))


def test_a_velocity_never_stays_stale_while_positions_change_under_a_repeated_stamp():
    t = JointStateTracker(["a"])
    for k in range(100):  # stamped at 1 kHz, moving at 1 rad/s
        t.update(["a"], [0.001 * k], [], 10.0 + 0.001 * k, 500.0 + 0.001 * k)
    assert t.velocities([0]) == pytest.approx([1.0])
    assert t.velocity_source == FROM_STAMPS
    estimates = []
    for k in range(1, 200):  # the stamp sticks; the joint moves at 3 rad/s
        t.update(["a"], [0.099 + 0.003 * k], [], 10.099, 500.099 + 0.001 * k)
        estimates.append(t.velocities([0])[0])
    # every sample gets an estimate of its own (none keeps the last one), rising to 3 rad/s
    assert all(
        b > a for a, b in zip(estimates, estimates[1 : int(1000 * ARRIVAL_SPAN)], strict=False)
    )
    np.testing.assert_allclose(estimates[int(2000 * ARRIVAL_SPAN) :], 3.0, rtol=1e-9)
    assert t.velocity_source == FROM_ARRIVAL_REPEATED and t.duplicates == 0


def test_a_duplicate_keeps_its_velocity_and_a_robot_at_rest_reaches_zero():
    t = JointStateTracker(["a"])
    t.update(["a"], [0.0], [], 1.0, 100.0)
    t.update(["a"], [0.01], [], 1.01, 100.01)
    assert t.velocities([0]) == pytest.approx([1.0])
    # the same sample again, 1 ms later: a duplicate, still taken (the pose is answered)
    assert t.update(["a"], [0.01], [], 1.01, 100.011)
    assert t.duplicates == 1 and t.velocities([0]) == pytest.approx([1.0])
    # the joint stopped, and its driver repeats the last stamp: estimated over the arrival
    # times once the repeats outlast ARRIVAL_SPAN, down to exactly 0
    for k in range(1, 200):
        t.update(["a"], [0.01], [], 1.01, 100.011 + 0.001 * k)
    assert t.velocities([0]) == [0.0]
    # unstamped at rest: 0 as well, never a duplicate
    u = JointStateTracker(["a"])
    for k in range(200):
        u.update(["a"], [min(0.001 * k, 0.05)], [], 0.0, 7.0 + 0.001 * k)
    assert u.velocities([0]) == [0.0] and u.duplicates == 0


def test_reordered_samples_in_a_burst_are_dropped_and_the_stamps_still_give_the_speed():
    t = JointStateTracker(["a", "b"])
    times = steady(1000.0, 0.1, start=20.0)
    order = np.arange(times.size)
    order[[40, 41]] = order[[41, 40]]  # two samples swapped in transit
    order[[70, 71]] = order[[71, 70]]
    arrival = 900.0 + np.repeat(times[::10], 10)  # and delivered ten at a time
    v = feed(t, times[order], times[order], arrival)
    assert t.stale_samples == 2 * 2  # the late one of each swap, for each joint
    np.testing.assert_allclose(v[2:], np.broadcast_to(V, v[2:].shape))  # from the stamps alone
    assert t.velocity_source == FROM_STAMPS and t.arrival_episodes == 0


def test_arrival_estimates_wrap_continuous_joints():
    t = JointStateTracker(["c"], continuous=[True])
    for k in range(100):
        angle = math.remainder(math.pi - 0.2 + 2.0 * 0.001 * k, 2 * math.pi)
        t.update(["c"], [angle], [], 0.0, 3.0 + 0.001 * k)
    assert t.velocities([0]) == pytest.approx([2.0], rel=1e-9)


def test_where_the_velocities_come_from_is_reported_and_held():
    t = JointStateTracker(["a", "b", "gripper"], required=["a", "b"])
    assert t.velocity_source == NO_VELOCITY_YET
    t.update(["a", "b"], [0.0, 0.0], [0.1, 0.2], 1.0, 10.0)
    assert t.velocity_source == FROM_MESSAGE
    t.update(["a", "b"], [0.1, 0.2], [], 1.1, 10.1)
    assert t.velocity_source == FROM_STAMPS
    t.update(["a", "b"], [0.2, 0.3], [], 1.1, 10.2)  # the stamp repeats, positions move
    assert t.velocity_source == FROM_ARRIVAL_REPEATED and t.arrival_episodes == 1
    # advancing stamps within SOURCE_HOLD do not hide it (a stream that advances only now and
    # then reads as one source) ...
    t.update(["a", "b"], [0.3, 0.4], [], 1.2, 10.2 + 0.5 * SOURCE_HOLD)
    assert t.velocity_source == FROM_ARRIVAL_REPEATED
    # ... nor do other joints' samples: only the required joints' count
    t.update(["gripper"], [0.01], [], 1.2, 10.2 + 2 * SOURCE_HOLD)
    t.update(["gripper"], [0.02], [], 0.0, 10.3 + 2 * SOURCE_HOLD)
    assert t.velocity_source == FROM_ARRIVAL_REPEATED and t.arrival_episodes == 1
    t.update(["a", "b"], [0.4, 0.5], [], 1.3, 10.4 + 2 * SOURCE_HOLD)
    assert t.velocity_source == FROM_STAMPS and not t.from_arrival_times


def test_simulated_time_starting_at_zero_is_a_stamp_and_a_switch_to_stamps_is_not_one():
    sim = JointStateTracker(["a"])
    sim.update(["a"], [0.0], [], 0.0, 50.0)  # the first sample of a simulation, at t = 0
    sim.update(["a"], [0.002], [], 0.001, 50.9)  # (arrival times far off: not used)
    assert sim.velocities([0]) == pytest.approx([2.0]) and sim.velocity_source == FROM_STAMPS
    # unstamped samples, then a driver that starts stamping with the wall clock: no velocity
    # over the 1.7e9 s from "unset" to the first stamp
    t = JointStateTracker(["a"])
    for k in range(100):
        t.update(["a"], [0.001 * k], [], 0.0, 3.0 + 0.001 * k)
    t.update(["a"], [0.1], [], 1.7e9, 3.1)
    assert t.velocities([0]) == pytest.approx([1.0], rel=1e-9)
    assert t.velocity_source == FROM_ARRIVAL_UNSTAMPED
    t.update(["a"], [0.1 + 2.0**-10], [], 1.7e9 + 2.0**-10, 3.101)  # (exact in float64)
    assert t.velocities([0]) == pytest.approx([1.0], rel=1e-9)


def test_a_jump_back_estimates_nothing_across_it_from_arrival_times_either():
    t = JointStateTracker(["a"])
    for k in range(100):
        t.update(["a"], [0.001 * k], [], 0.0 if k < 60 else 5.0, 3.0 + 0.001 * k)
    # the positions restart (a bag replayed from its start) with stamps far back
    t.update(["a"], [5.0], [], 5.0 - 2 * JUMP_BACK, 3.1)
    assert t.jumps_back == 1 and t.velocities([0]) is None
    t.update(["a"], [5.001], [], 5.0 - 2 * JUMP_BACK, 3.101)  # repeated stamp, 1 ms later
    assert t.velocities([0]) is None  # less than ARRIVAL_SPAN since the restart


# =========================================================================== the service
def pose_matrix(msg) -> np.ndarray:
    return ma.matrix_from_pose(msg.pose)


def _stamp(msg) -> tuple[int, int]:
    return (msg.header.stamp.sec, msg.header.stamp.nanosec)


def _values(diag) -> dict[str, str]:
    return {kv.key: kv.value for kv in diag.status[0].values}


def test_unstamped_joint_states_get_a_twist_and_diagnostics_say_from_what(ros, ur5, clock):
    S = ros.cls("diagnostic_msgs/msg/DiagnosticStatus")
    chain = ur5.model.chain
    q0 = np.array([0.3, -1.1, 1.4, -0.6, 0.8, 0.2])
    qdot = np.array([0.2, -0.1, 0.3, 0.4, -0.2, 0.5])
    outs = []
    for k in range(100):  # 250 Hz, stamp 0, as `ros2 topic pub` sends them
        clock.now = 200.0 + 0.004 * k
        q = q0 + qdot * 0.004 * k
        outs.append((q, ur5.on_joint_state(js(ros, chain.joint_names, q, t=0.0), 40.0 + 0.004 * k)))
    twisted = [(q, out) for q, out in outs if out.twist is not None]
    assert len(twisted) >= 100 - 2 * ARRIVAL_SPAN / 0.004  # from ARRIVAL_SPAN of history on
    for q, out in twisted:
        expected = chain.jacobian(q, "world") @ qdot
        np.testing.assert_allclose(ma.core_from_twist(out.twist.twist), expected, atol=1e-9)
        # stamped as the joint_states were: zero (as robot_state_publisher stamps /tf)
        assert _stamp(out.twist) == _stamp(out.pose) == (0, 0)
        check_message(ros, out.twist)
    # logged once when it begins (the node logs WARN and above), a note afterwards
    warned = [out for _, out in outs if out.severity == Severity.WARN]
    assert (
        len(warned) == 1
        and "unstamped" in warned[0].problem
        and "header: auto" in warned[0].problem
    )
    assert outs[-1][1].severity == Severity.NOTE and "arrival times" in outs[-1][1].problem
    diag = ur5.diagnostics().status[0]
    assert diag.level == S.WARN and "arrival times" in diag.message and "unstamped" in diag.message
    assert _values(ur5.diagnostics())["velocity_source"] == FROM_ARRIVAL_UNSTAMPED
    # stamped samples again (the first over the arrival times: nothing to difference its stamp
    # with): the source is the stamps, and diagnostics are OK, once SOURCE_HOLD has passed
    for received in (41.0, 41.004, 41.0 + SOURCE_HOLD + 0.01):
        out = ur5.on_joint_state(js(ros, chain.joint_names, q0, t=received + 300.0), received)
    assert out.problem is None and out.twist is not None
    assert _values(ur5.diagnostics())["velocity_source"] == FROM_STAMPS
    assert ur5.diagnostics().status[0].level == S.OK


def test_repeated_stamps_get_the_twist_of_every_sample(ros, ur5, clock):
    chain = ur5.model.chain
    q0 = np.array([0.3, -1.1, 1.4, -0.6, 0.8, 0.2])
    qdot = np.array([-0.3, 0.2, 0.1, -0.4, 0.6, 0.2])
    n = 0
    for k in range(150):  # 500 Hz; the stamp advances every 5th sample
        q = q0 + qdot * 0.002 * k
        out = ur5.on_joint_state(
            js(ros, chain.joint_names, q, t=(1700000000, 10_000_000 * (k // 5))), 8.0 + 0.002 * k
        )
        assert out.pose is not None
        if k >= 2 * ARRIVAL_SPAN / 0.002:
            expected = chain.jacobian(q, "world") @ qdot
            # (float64 stamps near 1.7e9 s resolve 0.24 µs: 2e-5 of the 10 ms they advance by)
            np.testing.assert_allclose(ma.core_from_twist(out.twist.twist), expected, rtol=1e-4)
            assert _stamp(out.twist) == (1700000000, 10_000_000 * (k // 5))
            n += 1
    assert n > 90
    diag = ur5.diagnostics()
    assert "stamps do not advance" in diag.status[0].message
    assert _values(diag)["velocity_source"] == FROM_ARRIVAL_REPEATED


def test_velocities_in_the_message_are_the_source_when_given(ros, ur5):
    chain = ur5.model.chain
    q = np.array([0.3, -1.1, 1.4, -0.6, 0.8, 0.2])
    out = ur5.on_joint_state(js(ros, chain.joint_names, q, t=0.0, velocity=[0.1] * 6), 5.0)
    assert out.twist is not None and out.problem is None  # unstamped, but nothing to estimate
    assert _values(ur5.diagnostics())["velocity_source"] == FROM_MESSAGE


# =========================================================================== mimic followers
PANDA_ARM = tuple(f"panda_joint{i}" for i in range(1, 8))


@pytest.fixture
def panda_to_finger(ros, panda_path, clock):
    """The Panda's chain to its right finger, which panda_finger_joint2 moves: a mimic follower
    of panda_finger_joint1, the leader that the chain's joint vector holds."""
    from kinematics_node.service.kinematics import KinematicsService

    params = {
        "robot_description": panda_path.read_text(),
        "base_link": "panda_link0",
        "tip_link": "panda_rightfinger",
    }
    return KinematicsService(ros.types, params, clock=clock)


@pytest.mark.parametrize(
    "follower",
    [None, 0.03, 0.0, 0.04],
    ids=["absent", "consistent", "contradicting", "contradicting-at-its-limit"],
)
def test_a_mimic_followers_value_is_taken_from_its_leader(
    ros, panda_path, panda_to_finger, follower
):
    svc = panda_to_finger
    assert svc.model.chain.joint_names == PANDA_ARM + ("panda_finger_joint1",)
    q = np.array([0.1, -0.3, 0.2, -1.5, 0.1, 1.2, 0.3, 0.03])  # the fingers 3 cm open
    qdot = np.array([0.1, 0.2, -0.1, 0.3, 0.0, -0.2, 0.4, 0.01])
    names = list(svc.model.chain.joint_names)
    positions, velocities = list(q), list(qdot)
    if follower is not None:
        names.append("panda_finger_joint2")
        positions.append(follower)
        velocities.append(-0.5)
    out = svc.on_joint_state(js(ros, names, positions, t=3.0, velocity=velocities), 1.0)
    oracle = PinocchioOracle.from_urdf(panda_path, svc.model.chain.joint_names, mimic=True)
    T, J = oracle.pose_and_jacobians(q, "panda_rightfinger")
    np.testing.assert_allclose(pose_matrix(out.pose), T, atol=1e-9)
    np.testing.assert_allclose(ma.core_from_twist(out.twist.twist), J["world"] @ qdot, atol=1e-9)
