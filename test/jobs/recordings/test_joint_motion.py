"""`JointMotion` reads a recording's joint_states as the node's `JointStateTracker` reads them one
at a time: the same positions and, where the stamps advance, the same velocities, to the last bit,
however the recording is cut into batches. Where stamps do not advance it uses log times."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kinematics_node.jobs.recordings.joint_motion import JointMotion
from kinematics_node.service.ee_state import JointStateTracker
from msg_adapters.cdr import decode_joint_states

typesys = pytest.importorskip("rosbags.typesys", reason="pip install rosbags")
STORE = typesys.get_typestore(typesys.Stores.ROS2_JAZZY)
T = STORE.types
JOINTS = ("j1", "j2", "j3", "j4")
CONTINUOUS = (False, True, False, False)


def _raw(stamp_ns: int, names, pos, vel) -> bytes:
    sec, nanosec = divmod(stamp_ns, 10**9)
    msg = T["sensor_msgs/msg/JointState"](
        header=T["std_msgs/msg/Header"](
            stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec), frame_id=""
        ),
        name=list(names),
        position=np.asarray(pos, dtype=np.float64),
        velocity=np.asarray(vel, dtype=np.float64),
        effort=np.zeros(0),
    )
    return bytes(STORE.serialize_cdr(msg, "sensor_msgs/msg/JointState"))


def _stream(kind: str, count: int = 400):
    """(log ns, stamp ns, names, positions, velocities) of a recording of `kind`."""
    rng = np.random.default_rng(len(kind))
    t0 = 1_733_000_000 * 10**9  # an epoch stamp: seconds are large, as in real recordings
    out = []
    for i in range(count):
        stamp = t0 + i * 1_000_000 + int(rng.integers(0, 1000))
        log = stamp + int(rng.integers(10_000, 90_000))
        q = np.sin(0.01 * i + np.arange(4)) * np.array([1.0, 3.2, 1.0, 1.0])
        names, pos = list(JOINTS), q
        vel = np.cos(0.01 * i + np.arange(4)) if kind == "velocities" else []
        if kind == "subsets":  # two drivers: j1, j2 and j3, j4 (with a gripper) in turn
            part = (0, 1) if i % 2 == 0 else (2, 3)
            names = [JOINTS[k] for k in part] + (["gripper"] if i % 2 else [])
            pos = [q[k] for k in part] + ([0.01] if i % 2 else [])
        if kind == "reordered":
            names, pos = list(JOINTS[::-1]) + ["other"], [*q[::-1], 5.0]
        out.append((log, stamp, names, pos, vel))
    return out


@pytest.mark.parametrize("kind", ["velocities", "no velocities", "subsets", "reordered"])
@pytest.mark.parametrize("batch", [1, 7, 400])
def test_positions_and_velocities_equal_the_node_trackers(kind, batch):
    stream = _stream(kind)
    tracker = JointStateTracker(JOINTS, CONTINUOUS)
    motion = JointMotion(JOINTS, CONTINUOUS)
    compared = 0
    for start in range(0, len(stream), batch):
        part = stream[start : start + batch]
        groups = decode_joint_states([_raw(s, n, p, v) for _, s, n, p, v in part])
        out = motion.advance(groups, np.array([m[0] for m in part]))
        posed = dict(zip(out.rows.tolist(), range(len(out.rows)), strict=True))
        for r, (log, stamp, names, pos, vel) in enumerate(part):
            tracker.update(names, pos, vel, int(stamp // 10**9) + int(stamp % 10**9) * 1e-9, log)
            if not tracker.complete:
                assert r not in posed
                continue
            m = posed[r]
            np.testing.assert_array_equal(out.q[m], tracker.q)
            want = tracker.qdot
            if want is None:
                assert not np.isfinite(out.qdot[m]).all()
            else:
                np.testing.assert_array_equal(out.qdot[m], want)
                compared += 1
            assert out.stamp_ns[m] == stamp and out.log_time_ns[m] == log
    assert compared > len(stream) // 2 - 5


def test_a_continuous_joint_steps_across_pi_the_short_way():
    motion = JointMotion(("j",), (True,))
    names = ("j",)
    raws = [_raw(10**9 + k * 10**7, names, [p], []) for k, p in enumerate([3.1, -3.1])]
    out = motion.advance(decode_joint_states(raws), np.array([1, 2]))
    assert out.qdot[1, 0] == pytest.approx((2 * math.pi - 6.2) / 0.01)


def test_nan_positions_are_skipped_and_counted_and_the_rest_goes_on():
    motion = JointMotion(JOINTS, CONTINUOUS)
    raws = [
        _raw(10**9 + k * 10**6, JOINTS, [math.nan if k == 2 else 0.1 * k] * 4, []) for k in range(5)
    ]
    out = motion.advance(decode_joint_states(raws), np.arange(5) * 10**6 + 10**9)
    assert out.rows.tolist() == [0, 1, 3, 4] and motion.counts.rejected == 1
    # the step over the skipped sample spans both intervals
    assert out.qdot[2, 0] == pytest.approx(0.2 / 2e-3)


def test_unset_or_repeated_stamps_take_the_log_time():
    motion = JointMotion(("j",), (False,))
    raws = [
        _raw(s, ("j",), [p], [])
        for s, p in [(0, 0.0), (0, 0.1), (5 * 10**9, 0.2), (5 * 10**9, 0.4)]
    ]
    log = np.array([10, 20, 30, 40]) * 10**6
    out = motion.advance(decode_joint_states(raws), log)
    np.testing.assert_allclose(out.qdot[1:, 0], [0.1 / 0.01, 0.1 / 0.01, 0.2 / 0.01])
    assert out.stamp_ns.tolist() == [log[0], log[1], 5 * 10**9, 5 * 10**9]
    assert motion.counts.log_time_steps == 3 and motion.counts.unset_stamps == 2


def test_joint_states_of_another_robot_are_counted_not_posed():
    motion = JointMotion(JOINTS, CONTINUOUS)
    raws = [_raw(10**9, ("x", "y"), [1, 2], []), _raw(2 * 10**9, JOINTS, [0] * 4, [])]
    out = motion.advance(decode_joint_states(raws), np.array([1, 2]))
    assert out.rows.tolist() == [1] and motion.counts.foreign == 1
