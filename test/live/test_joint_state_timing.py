"""joint_states as real drivers send them, against the live node over DDS: unstamped (stamp 0, as
`ros2 topic pub` sends them) and stamps that advance only every 5th sample. The twist must match
the core's J(q) q̇ at steady speed, and /diagnostics and the log must say where the velocity came
from.

The positions are taken from this process's clock at each publish, as a driver samples its
encoders. The node takes a sample's arrival time from DDS (its source timestamp: when it was
sent), so what its estimate has to absorb is only the time between reading the clock and sending.
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped, TwistStamped
from live_node import ROBOTS, UR5E_JOINTS, ur5e_description, wait_until
from sensor_msgs.msg import JointState

from kinematics_node.core import SerialChain
from kinematics_node.service.ee_state import (
    ARRIVAL_SPAN,
    FROM_ARRIVAL_REPEATED,
    FROM_ARRIVAL_UNSTAMPED,
)

CHAIN = SerialChain.from_urdf(ROBOTS / "ur5e.urdf")
Q0 = np.array([0.3, -1.2, 1.5, -0.8, 0.9, 0.2])
QDOT = np.array([0.25, -0.2, 0.3, 0.4, -0.3, 0.5])  # steady joint speeds [rad/s]
RATE = 400.0  # [Hz]
SECONDS = 1.2
#: Twists within this long of the start are not at steady speed yet: the estimate over arrival
#: times needs ARRIVAL_SPAN of history, and spans up to two of them [s].
SETTLE = 2 * ARRIVAL_SPAN + 0.05


def _twist(msg) -> np.ndarray:
    t = msg.twist
    return np.array([t.angular.x, t.angular.y, t.angular.z, t.linear.x, t.linear.y, t.linear.z])


def _position(msg) -> np.ndarray:
    p = msg.pose.position
    return np.array([p.x, p.y, p.z])


def _stream(client, every: int) -> tuple[np.ndarray, list, list]:
    """Publish RATE Hz of joint_states for SECONDS, moving at QDOT; stamped 0 (`every` = 0) or
    with a stamp that advances every `every`-th sample (to that sample's time). Returns the
    times of the samples (from the first) and the poses and twists received."""
    pub = client.publisher(JointState, "joint_states")
    poses = client.collect(PoseStamped, "ee_pose")
    twists = client.collect(TwistStamped, "ee_twist")
    wait_until(lambda: pub.get_subscription_count() > 0, 20, "the node's joint_states subscription")
    warm_up = JointState(name=list(UR5E_JOINTS), position=[float(v) for v in Q0])
    warm_up.header.stamp.sec = 999 if every else 0
    wait_until(lambda: pub.publish(warm_up) or poses, 20, "a first pose")  # all connected
    time.sleep(0.1)
    poses.clear()
    twists.clear()
    times = []
    start = time.monotonic()
    stamp = 0.0
    for k in range(int(RATE * SECONDS)):
        next_at = start + k / RATE
        while (now := time.monotonic()) < next_at:
            time.sleep(min(next_at - now, 0.001))
        msg = JointState(name=list(UR5E_JOINTS))
        t = time.monotonic() - start  # the sampling instant
        if every and k % every == 0:
            stamp = 1000.0 + t  # the stamp clock ticks: this sample's time
        msg.header.stamp.sec = int(stamp)
        msg.header.stamp.nanosec = int(round((stamp - int(stamp)) * 1e9))
        msg.position = [float(v) for v in Q0 + QDOT * t]
        pub.publish(msg)
        times.append(t)
    n = len(times)
    wait_until(lambda: len(poses) >= n, 10, f"{n} poses")
    return np.array(times), poses, twists


def _errors(times: np.ndarray, poses: list, twists: list) -> np.ndarray:
    """Relative error |V − J(q) q̇| / |J(q) q̇| of each twist at steady speed, with q the sample
    whose pose was published with it (the node answers each sample with a pose and, once the
    velocity is known, a twist: the last len(twists) poses go with the twists)."""
    assert 0 < len(twists) <= len(poses) == len(times)
    qs = Q0 + np.outer(times, QDOT)
    tips = CHAIN.fk(qs)[:, :3, 3]
    errors = []
    for pose, twist in zip(poses[-len(twists) :], twists, strict=True):
        gaps = np.linalg.norm(tips - _position(pose), axis=1)
        k = int(np.argmin(gaps))
        assert gaps[k] < 1e-9, "a pose that matches no sample sent"
        if times[k] < SETTLE:
            continue
        expected = CHAIN.jacobian(qs[k], "world") @ QDOT
        errors.append(np.linalg.norm(_twist(twist) - expected) / np.linalg.norm(expected))
    return np.array(errors)


@pytest.mark.parametrize(
    ("every", "source"),
    [(0, FROM_ARRIVAL_UNSTAMPED), (5, FROM_ARRIVAL_REPEATED)],
    ids=["unstamped", "stamp-every-5th"],
)
def test_twist_at_steady_speed_matches_the_core(start_node, client, every, source):
    diagnostics = client.collect(DiagnosticArray, "/diagnostics")
    node = start_node(robot_description=ur5e_description(), diagnostics_period=0.2)
    times, poses, twists = _stream(client, every)
    errors = _errors(times, poses, twists)
    within = float(np.mean(errors < 0.01))
    figures = (
        f"{len(errors)} twists at steady speed: {within:.1%} within 1 %, relative error median "
        f"{np.median(errors):.1e}, 98th percentile {np.percentile(errors, 98):.1e}, "
        f"max {errors.max():.1e}"
    )
    assert len(errors) >= 0.8 * RATE * (SECONDS - SETTLE), figures
    # Within 1 %, but for the samples that this Python publisher sent some ms after it read its
    # clock: the node cannot tell (it is the error that stamps remove), and a sample sent 1 ms late
    # over ARRIVAL_SPAN is 2 % off. On a quiet machine that is one sample in a few hundred; on a
    # loaded one (a full CI run beside other work: 98th percentile 9 %, max 13 %) a few in a
    # hundred. So: the bulk within 1 %, and never garbage (a 20 ms stall would be 40 %).
    assert np.median(errors) < 0.002 and within >= 0.9 and errors.max() < 0.4, figures
    wait_until(
        lambda: any(
            kv.key == "velocity_source" and kv.value == source
            for array in diagnostics[-3:]
            for status in array.status
            for kv in status.values
        ),
        3,
        f"diagnostics saying {source!r}",
    )
    status = diagnostics[-1].status[0]
    assert status.level == status.WARN and "arrival times" in status.message
    latency = {kv.key: kv.value for kv in status.values}["joint_states_latency_s"]
    if every:  # stamped (on a clock of their own, from 1000 s): a latency, though a large one
        assert math.isfinite(float(latency)), latency
    else:  # now − 0 would be ~1.7e9 s
        assert latency == "unknown (unstamped joint_states)", latency
    log = node.log()
    assert log.count("estimated from the arrival times") == 1, log
