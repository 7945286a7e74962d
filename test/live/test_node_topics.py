"""The live node's topics: ee_pose / ee_twist from joint_states, malformed input, descriptions,
parameters and shutdown. See conftest.py for how the node is started and driven."""

from __future__ import annotations

import math
import re
import signal
import time

import numpy as np
import pytest
from geometry_msgs.msg import PoseStamped, TwistStamped
from live_node import ROBOTS, UR5E_JOINTS, ur5e_description, wait_until
from sensor_msgs.msg import JointState
from std_msgs.msg import String

from kinematics_node.core import SerialChain
from msg_adapters import matrix_from_pose

CHAIN = SerialChain.from_urdf(ROBOTS / "ur5e.urdf")
RNG = np.random.default_rng(7)


def joint_state(names, positions, velocities=(), stamp_ns=0):
    msg = JointState()
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(int(stamp_ns), 1_000_000_000)
    msg.name = list(names)
    msg.position = [float(v) for v in positions]
    msg.velocity = [float(v) for v in velocities]
    return msg


def stamp_ns(msg) -> int:
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


def twist_core(msg) -> np.ndarray:
    t = msg.twist
    return np.array([t.angular.x, t.angular.y, t.angular.z, t.linear.x, t.linear.y, t.linear.z])


def all_finite_pose(msg) -> bool:
    p, o = msg.pose.position, msg.pose.orientation
    return all(math.isfinite(v) for v in (p.x, p.y, p.z, o.x, o.y, o.z, o.w))


def all_finite_twist(msg) -> bool:
    return bool(np.all(np.isfinite(twist_core(msg))))


class Stream:
    """A client publishing joint_states to the node and collecting what comes back."""

    def __init__(self, client) -> None:
        self.pub = client.publisher(JointState, "joint_states")
        self.poses = client.collect(PoseStamped, "ee_pose")
        self.twists = client.collect(TwistStamped, "ee_twist")
        self.client = client

    def connected(self, node) -> None:
        wait_until(lambda: self.pub.get_subscription_count() > 0, 20, "the node's subscription")
        q0 = np.zeros(6)
        wait_until(
            lambda: self.pub.publish(joint_state(UR5E_JOINTS, q0, stamp_ns=1)) or self.poses,
            20,
            f"a first ee_pose; node log:\n{node.log()}",
        )
        time.sleep(0.1)
        self.poses.clear()
        self.twists.clear()

    def by_stamp(self, messages) -> dict[int, object]:
        return {stamp_ns(m): m for m in list(messages)}


@pytest.fixture
def ur5e(start_node):
    return start_node(robot_description=ur5e_description())


@pytest.fixture
def stream(client):
    return Stream(client)


def test_moving_stream_matches_fk_and_finite_difference_twist(ur5e, stream):
    stream.connected(ur5e)
    dt = 0.002
    t = np.arange(200) * dt
    w = np.array([1.0, 1.3, 0.7, 2.0, 1.1, 1.7])  # joint frequencies [rad/s]

    def q_of(tt):
        return 0.4 * np.sin(np.outer(tt, w) + 0.3)

    def qdot_of(tt):
        return 0.4 * w * np.cos(np.outer(tt, w) + 0.3)

    base_ns = 1_000_000_000_000
    sent = {}
    for k, tk in enumerate(t):
        ns = base_ns + int(round(tk * 1e9))
        sent[ns] = k
        stream.pub.publish(joint_state(UR5E_JOINTS, q_of([tk])[0], qdot_of([tk])[0], ns))
        time.sleep(0.004)  # correctness, not throughput (that is benchmarks/node_benchmark.py)
    wait_until(lambda: len(stream.twists) >= 190, 10, "the twists of 200 joint states")
    poses, twists = stream.by_stamp(stream.poses), stream.by_stamp(stream.twists)
    assert len(poses) >= 190, f"{len(poses)} of 200 poses arrived"
    for ns, pose in poses.items():
        k = sent[ns]  # every pose carries the stamp of a joint state we sent
        assert pose.header.frame_id == "base_link"
        np.testing.assert_allclose(
            matrix_from_pose(pose.pose), CHAIN.fk(q_of([t[k]])[0]), atol=1e-12
        )
    for ns, tw in twists.items():
        k = sent[ns]
        assert tw.header.frame_id == "base_link"
        # the published twist is d/dt of the published pose: central finite differences of FK
        h = 1e-6
        Tp, Tm = CHAIN.fk(q_of([t[k] + h])[0]), CHAIN.fk(q_of([t[k] - h])[0])
        dT = (Tp - Tm) / (2 * h)
        R = CHAIN.fk(q_of([t[k]])[0])[:3, :3]
        W = dT[:3, :3] @ R.T
        expected = np.r_[W[2, 1], W[0, 2], W[1, 0], dT[:3, 3]]
        np.testing.assert_allclose(twist_core(tw), expected, atol=1e-7)


def test_subsets_any_order_foreign_joints_and_no_velocities(ur5e, stream):
    stream.connected(ur5e)
    q = RNG.uniform(-1, 1, 6)
    order = [3, 0, 5]
    rest = [1, 2, 4]
    stream.pub.publish(
        joint_state(
            [UR5E_JOINTS[i] for i in order] + ["gripper_joint"],
            list(q[order]) + [0.02],
            stamp_ns=10_000_000_000,
        )
    )
    stream.pub.publish(
        joint_state(
            ["other_arm_joint"] + [UR5E_JOINTS[i] for i in rest],
            [9.0] + list(q[rest]),
            stamp_ns=10_000_000_000,
        )
    )

    # the first half alone may already give a pose (with joints from earlier tests): wait for
    # the pose after both halves, which is the last one with their stamp
    def both_halves_taken() -> bool:
        with_stamp = [p for p in stream.poses if stamp_ns(p) == 10_000_000_000]
        return len(with_stamp) >= 2 or (
            len(with_stamp) == 1 and np.allclose(matrix_from_pose(with_stamp[0].pose), CHAIN.fk(q))
        )

    wait_until(both_halves_taken, 5, "the pose of both halves")
    last = [p for p in stream.poses if stamp_ns(p) == 10_000_000_000][-1]
    np.testing.assert_allclose(matrix_from_pose(last.pose), CHAIN.fk(q), atol=1e-12)
    # no velocities given: the twist is estimated from the next sample's positions and stamps
    q2 = q + 0.001 * np.arange(1, 7)
    stream.pub.publish(joint_state(UR5E_JOINTS[::-1], q2[::-1], stamp_ns=10_010_000_000))
    wait_until(lambda: any(stamp_ns(t) == 10_010_000_000 for t in stream.twists), 5, "a twist")
    tw = [t for t in stream.twists if stamp_ns(t) == 10_010_000_000][-1]
    expected = CHAIN.jacobian(q2, "world") @ ((q2 - q) / 0.01)
    np.testing.assert_allclose(twist_core(tw), expected, atol=1e-9)


MALFORMED = {
    "NaN position": (UR5E_JOINTS, [0.1, math.nan, 0, 0, 0, 0], []),
    "inf position": (UR5E_JOINTS, [0.1, math.inf, 0, 0, 0, 0], []),
    "inf velocity": (UR5E_JOINTS, [0.1] * 6, [0, 0, -math.inf, 0, 0, 0]),
    "positions length mismatch": (UR5E_JOINTS, [0.1] * 5, []),
    "velocities length mismatch": (UR5E_JOINTS, [0.1] * 6, [0.0] * 3),
    "duplicate name": (UR5E_JOINTS + ("elbow_joint",), [0.1] * 7, []),
    "10,000 names": (tuple(f"j{i}" for i in range(10_000)) + UR5E_JOINTS, [0.1] * 9_000, []),
    "empty": ((), [], []),
}


def test_malformed_joint_states_are_refused_and_warned_about_with_throttling(ur5e, stream, client):
    from diagnostic_msgs.msg import DiagnosticArray

    diagnostics = client.collect(DiagnosticArray, "/diagnostics")
    stream.connected(ur5e)
    good = RNG.uniform(-1, 1, 6)
    stream.pub.publish(joint_state(UR5E_JOINTS, good, np.zeros(6), stamp_ns=20_000_000_000))
    wait_until(lambda: len(stream.twists) > 0, 5, "the good sample's twist")
    for round_ in range(3):  # many bad samples: the warning must be throttled, not repeated
        for k, (names, positions, velocities) in enumerate(MALFORMED.values()):
            ns = 20_000_000_000 + 1_000_000 * (1 + 10 * round_ + k)
            stream.pub.publish(joint_state(names, positions, velocities, stamp_ns=ns))
            time.sleep(0.02)
    time.sleep(0.5)
    assert ur5e.alive(), ur5e.log()
    # nothing published for a malformed sample, and nothing non-finite at all
    assert all(stamp_ns(p) == 20_000_000_000 for p in stream.poses)
    assert all(all_finite_pose(p) for p in stream.poses)
    assert all(all_finite_twist(t) for t in stream.twists)
    log = ur5e.log()
    warnings = [line for line in log.splitlines() if "joint_states sample rejected" in line]
    assert warnings, f"no warning for malformed joint_states:\n{log}"
    assert len(warnings) <= 2 * len(MALFORMED), f"warnings are not throttled: {len(warnings)}"
    assert max(len(line) for line in warnings) < 400, "a warning echoes the whole sample"
    for needle in (
        "is nan",
        "is inf",
        "names but 5 positions",
        "names but 3 velocities",
        "'elbow_joint' more than once",
    ):
        assert any(needle in line for line in warnings), f"no warning says {needle!r}:\n{log}"
    # the node still works, and its diagnostics carry finite numbers only
    stream.pub.publish(joint_state(UR5E_JOINTS, good, stamp_ns=21_000_000_000))
    wait_until(lambda: any(stamp_ns(p) == 21_000_000_000 for p in stream.poses), 5, "a pose")
    wait_until(lambda: len(diagnostics) > 0, 5, "diagnostics")
    # named after the node's full name (`service.kinematics.diagnostics_name`)
    assert {s.name for a in diagnostics for s in a.status} == {"/kinematics_node: end effector"}
    for array in diagnostics:
        for status in array.status:
            for kv in status.values:
                if re.fullmatch(r"[-+0-9.e]+|nan|inf|-inf", kv.value):
                    assert kv.value not in ("nan", "-inf") and "nan" not in kv.value, kv


def test_parameters_change_at_run_time_and_bad_values_are_refused(ur5e, stream, client):
    stream.connected(ur5e)
    results = client.set_parameters("kinematics_node", twist_frame="body")
    assert results[0].successful, results[0].reason
    q = RNG.uniform(-1, 1, 6)
    qdot = RNG.uniform(-1, 1, 6)
    stream.pub.publish(joint_state(UR5E_JOINTS, q, qdot, stamp_ns=30_000_000_000))
    wait_until(lambda: any(stamp_ns(t) == 30_000_000_000 for t in stream.twists), 5, "a twist")
    tw = [t for t in stream.twists if stamp_ns(t) == 30_000_000_000][-1]
    assert tw.header.frame_id == CHAIN.tip_link
    np.testing.assert_allclose(twist_core(tw), CHAIN.jacobian(q, "body") @ qdot, atol=1e-9)

    for name, value, needle in (
        ("ik__timeout", -1.0, "ik.timeout"),
        ("twist_frame", "sideways", "twist_frame"),
        ("ik__workers", 3, "start-up"),
        ("tip_link", "no_such_link", "no_such_link"),
    ):
        (result,) = client.set_parameters("kinematics_node", **{name: value})
        assert not result.successful, name
        assert needle in result.reason, result.reason
    # the refused tip_link left the model as it was
    stream.pub.publish(joint_state(UR5E_JOINTS, q, qdot, stamp_ns=31_000_000_000))
    wait_until(lambda: any(stamp_ns(p) == 31_000_000_000 for p in stream.poses), 5, "a pose")
    pose = [p for p in stream.poses if stamp_ns(p) == 31_000_000_000][-1]
    np.testing.assert_allclose(matrix_from_pose(pose.pose), CHAIN.fk(q), atol=1e-12)


def test_description_from_the_topic_then_reloaded_mid_stream(start_node, stream, client):
    node = start_node()  # no robot_description parameter: waits for the topic
    description = client.publisher(String, "robot_description", latched=True)
    q = np.full(6, 0.3)
    stream.pub.publish(joint_state(UR5E_JOINTS, q, stamp_ns=1_000))
    time.sleep(0.5)
    assert not stream.poses, "published a pose without a model"
    description.publish(String(data=ur5e_description()))
    wait_until(
        lambda: stream.pub.publish(joint_state(UR5E_JOINTS, q, stamp_ns=2_000)) or stream.poses,
        20,
        f"a pose after the description arrived:\n{node.log()}",
    )
    np.testing.assert_allclose(matrix_from_pose(stream.poses[-1].pose), CHAIN.fk(q), atol=1e-12)

    # a malformed description is logged with its reason, and the model stays
    description.publish(String(data="<robot name='broken'><link name='a'/>"))
    wait_until(lambda: "cannot use the robot description" in node.log(), 10, "the error log")
    assert "keeping the model" in node.log()
    stream.poses.clear()
    stream.pub.publish(joint_state(UR5E_JOINTS, q, stamp_ns=3_000))
    wait_until(lambda: stream.poses, 5, "a pose with the kept model")
    np.testing.assert_allclose(matrix_from_pose(stream.poses[-1].pose), CHAIN.fk(q), atol=1e-12)

    # a new, valid description mid-stream: a robot with a longer tool replaces the model
    longer = ur5e_description().replace(
        '<origin xyz="0 0 0.0996" rpy="0 0 0"/>',
        '<origin xyz="0 0 0.1996" rpy="0 0 0"/>',
    )
    assert longer != ur5e_description(), "the test's edit did not apply"
    longer_chain = SerialChain.from_urdf(longer)
    description.publish(String(data=longer))
    k = 4_000

    def reloaded() -> bool:
        nonlocal k
        k += 1
        stream.pub.publish(joint_state(UR5E_JOINTS, q, stamp_ns=k))
        time.sleep(0.02)
        return bool(stream.poses) and np.allclose(
            matrix_from_pose(stream.poses[-1].pose), longer_chain.fk(q), atol=1e-12
        )

    wait_until(reloaded, 10, f"poses from the new description:\n{node.log()}")
    assert node.log().count("loaded 'ur5e'") >= 2 or node.log().count("loaded") >= 2


def test_sigint_ends_the_node_with_status_0_and_no_traceback(start_node, stream):
    node = start_node(robot_description=ur5e_description())
    stream.connected(node)
    assert node.stop(signal.SIGINT) == 0
    assert "Traceback" not in node.log(), node.log()


def test_invalid_start_up_parameter_gives_one_line_and_status_2(start_node):
    node = start_node(wait=False, robot_description=ur5e_description(), ik__timeout=-5.0)
    node.process.wait(30)
    assert node.process.returncode == 2, node.log()
    assert "ik.timeout" in node.log() and "Traceback" not in node.log(), node.log()


@pytest.mark.parametrize("executor", ["lean", "rclpy"])
def test_either_executor_answers_joint_states_and_stops_cleanly(start_node, stream, executor):
    node = start_node(robot_description=ur5e_description(), executor=executor)
    stream.connected(node)
    q = RNG.uniform(-1, 1, 6)
    for k in range(20):
        stream.pub.publish(joint_state(UR5E_JOINTS, q, stamp_ns=10_000 + k))
        time.sleep(0.005)
    wait_until(lambda: len(stream.poses) >= 18, 10, f"poses on the {executor} executor")
    for pose in list(stream.poses):
        np.testing.assert_allclose(matrix_from_pose(pose.pose), CHAIN.fk(q), atol=1e-12)
    assert node.stop(signal.SIGINT) == 0
    log = node.log()
    assert "Traceback" not in log and "lacks what the lean executor uses" not in log, log


def test_an_unknown_executor_is_refused_at_start_up(start_node):
    node = start_node(wait=False, robot_description=ur5e_description(), executor="events")
    node.process.wait(30)
    assert node.process.returncode == 2, node.log()
    assert "executor" in node.log() and "Traceback" not in node.log(), node.log()
