"""msg_adapters.cdr against rosbags' CDR serializer and deserializer (an implementation nobody here
wrote): the batch decoder reads what rosbags wrote, and the batch encoders write, byte for byte,
what rosbags writes for the same messages."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics_node.core.exceptions import InvalidInputError
from msg_adapters.cdr import (
    decode_joint_states,
    joint_state_cdr,
    pose_stamped_cdr,
    tf_message_cdr,
    twist_stamped_cdr,
)

typesys = pytest.importorskip("rosbags.typesys", reason="pip install rosbags")
STORE = typesys.get_typestore(typesys.Stores.ROS2_JAZZY)
T = STORE.types
ARM = tuple(f"panda_joint{i}" for i in range(1, 8))


def _time(ns: int):
    sec, nanosec = divmod(ns, 1_000_000_000)
    return T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec)


def _header(ns: int, frame: str):
    return T["std_msgs/msg/Header"](stamp=_time(ns), frame_id=frame)


def _vec(values) -> np.ndarray:
    return np.asarray(values, dtype=np.float64)


def _joint_state(ns, frame, names, pos, vel, eff, big_endian=False) -> bytes:
    msg = T["sensor_msgs/msg/JointState"](
        header=_header(ns, frame),
        name=list(names),
        position=_vec(pos),
        velocity=_vec(vel),
        effort=_vec(eff),
    )
    return bytes(
        STORE.serialize_cdr(msg, "sensor_msgs/msg/JointState", little_endian=not big_endian)
    )


def _mixed_batch(rng: np.random.Generator) -> list[tuple]:
    """Six layouts interleaved: the arm in order and reversed, a subset (big-endian), the arm and
    a finger with efforts, no velocities, and odd names with a frame id."""
    cases = []
    for k in range(60):
        kind = k % 6
        names = (ARM, ARM[::-1], ARM[:3], (*ARM, "finger"), ARM, ("ß", "x"))[kind]
        n = len(names)
        vel = rng.normal(size=n) if kind != 4 else []
        eff = rng.normal(size=n) if kind in (3, 5) else []
        frame = "odd frame" if kind == 5 else ""
        stamp = int(rng.integers(0, 2**40))
        cases.append((stamp, frame, names, rng.normal(size=n), vel, eff, kind == 2))
    return cases


def test_a_batch_of_mixed_layouts_reads_back_every_field_of_every_message():
    cases = _mixed_batch(np.random.default_rng(3))
    raw = [_joint_state(*c) for c in cases]
    groups = decode_joint_states(raw)
    assert len(groups) == 6
    rows = np.concatenate([g.rows for g in groups])
    assert sorted(rows.tolist()) == list(range(len(raw)))
    for g in groups:
        for j, row in enumerate(g.rows):
            stamp, _, names, pos, vel, eff, _ = cases[row]
            assert g.names == tuple(names)
            assert g.stamp_ns[j] == stamp
            np.testing.assert_array_equal(g.position[j], pos)
            np.testing.assert_array_equal(g.velocity[j], _vec(vel))
            np.testing.assert_array_equal(g.effort[j], _vec(eff))


def test_what_rosbags_deserialises_equals_what_the_batch_reads():
    cases = _mixed_batch(np.random.default_rng(4))
    raw = [_joint_state(*c) for c in cases]
    for g in decode_joint_states(raw):
        for j, row in enumerate(g.rows):
            msg = STORE.deserialize_cdr(raw[row], "sensor_msgs/msg/JointState")
            assert tuple(msg.name) == g.names
            assert msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec == g.stamp_ns[j]
            np.testing.assert_array_equal(msg.position, g.position[j])
            np.testing.assert_array_equal(msg.velocity, g.velocity[j])


def test_same_size_but_other_names_is_another_group():
    a = _joint_state(1, "", ("a1", "b1"), [1, 2], [], [])
    b = _joint_state(2, "", ("a2", "b2"), [3, 4], [], [])
    assert len(a) == len(b)
    groups = decode_joint_states([a, b, a])
    assert [g.names for g in groups] == [("a1", "b1"), ("a2", "b2")]
    assert groups[0].rows.tolist() == [0, 2]


@pytest.mark.parametrize(
    ("mangle", "match"),
    [
        (lambda raw: raw[:-5], "ends at byte"),
        (lambda raw: b"\x07\x07" + raw[2:], "encapsulation header"),
        (lambda raw: raw[:12] + b"\xff\xff\x00\x00" + raw[16:], "ends at byte"),
    ],
    ids=["truncated", "not CDR", "string length past the end"],
)
def test_a_broken_message_is_refused_naming_its_index(mangle, match):
    good = _joint_state(5, "", ARM, np.zeros(7), np.zeros(7), [])
    with pytest.raises(InvalidInputError, match=rf"joint_states message 1: .*{match}"):
        decode_joint_states([good, mangle(good)])


def test_pose_and_twist_rows_are_rosbags_bytes():
    rng = np.random.default_rng(5)
    n = 25
    stamp = rng.integers(0, 2**31 - 1, size=n) * 10**9 + rng.integers(0, 10**9, size=n)
    p, quat, lin, ang = (rng.normal(size=(n, k)) for k in (3, 4, 3, 3))
    for frame in ("base_link", "", "a_frame_of_7"):
        poses = pose_stamped_cdr(stamp, frame, p, quat)
        twists = twist_stamped_cdr(stamp, frame, lin, ang)
        for i in range(n):
            pose = T["geometry_msgs/msg/Pose"](
                position=T["geometry_msgs/msg/Point"](*p[i]),
                orientation=T["geometry_msgs/msg/Quaternion"](*quat[i]),
            )
            msg = T["geometry_msgs/msg/PoseStamped"](
                header=_header(int(stamp[i]), frame), pose=pose
            )
            want = STORE.serialize_cdr(msg, "geometry_msgs/msg/PoseStamped")
            assert poses[i].tobytes() == bytes(want)
            v3 = T["geometry_msgs/msg/Vector3"]
            twist = T["geometry_msgs/msg/Twist"](linear=v3(*lin[i]), angular=v3(*ang[i]))
            msg = T["geometry_msgs/msg/TwistStamped"](
                header=_header(int(stamp[i]), frame), twist=twist
            )
            assert twists[i].tobytes() == bytes(
                STORE.serialize_cdr(msg, "geometry_msgs/msg/TwistStamped")
            )


def test_tf_rows_are_rosbags_bytes():
    rng = np.random.default_rng(6)
    n, parents, children = 10, ("world", "link_1", "l2"), ("link_1", "l2", "tool0_x")
    stamp = rng.integers(0, 2**31 - 1, size=n) * 10**9 + rng.integers(0, 10**9, size=n)
    tr, rot = rng.normal(size=(n, 3, 3)), rng.normal(size=(n, 3, 4))
    rows = tf_message_cdr(stamp, parents, children, tr, rot)
    v3, quat = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Quaternion"]
    for i in range(n):
        transforms = [
            T["geometry_msgs/msg/TransformStamped"](
                header=_header(int(stamp[i]), parents[k]),
                child_frame_id=children[k],
                transform=T["geometry_msgs/msg/Transform"](
                    translation=v3(*tr[i, k]), rotation=quat(*rot[i, k])
                ),
            )
            for k in range(3)
        ]
        msg = T["tf2_msgs/msg/TFMessage"](transforms=transforms)
        assert rows[i].tobytes() == bytes(STORE.serialize_cdr(msg, "tf2_msgs/msg/TFMessage"))


def test_a_stamp_beyond_int32_seconds_is_refused():
    with pytest.raises(InvalidInputError, match="int32 seconds"):
        pose_stamped_cdr(np.array([2**31 * 10**9]), "b", np.zeros((1, 3)), np.zeros((1, 4)))


@pytest.mark.parametrize("fields", ["position", "position+velocity", "all"])
def test_joint_state_rows_are_rosbags_bytes(fields):
    rng = np.random.default_rng(7)
    n = 12
    stamp = rng.integers(0, 2**31 - 1, size=n) * 10**9 + rng.integers(0, 10**9, size=n)
    P, V, E = (rng.normal(size=(n, 7)) for _ in range(3))
    vel = V if fields != "position" else None
    eff = E if fields == "all" else None
    rows = joint_state_cdr(stamp, ARM, P, vel, eff, frame_id="arm")
    for i in range(n):
        want = _joint_state(
            int(stamp[i]),
            "arm",
            ARM,
            P[i],
            [] if vel is None else V[i],
            [] if eff is None else E[i],
        )
        assert rows[i].tobytes() == want
