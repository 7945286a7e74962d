"""KinematicsService's /tf, /tf_static (publish_tf) and manipulability markers, on real message
classes (rosbags) and read back after CDR: the links chained from /tf and /tf_static equal
Pinocchio's FK of every link of the Panda with its fingers; a joint_states message gives the /tf
of the joints it names (mimic followers with their leader), at most tf_rate by the stamps, as
robot_state_publisher does; the markers show the SVD of J at the last joint_states."""

from __future__ import annotations

import math

import numpy as np
import pytest
from kin_testing import PinocchioOracle
from service_testing import js

from kinematics_node.core import SerialChain
from kinematics_node.core.exceptions import InvalidInputError
from kinematics_node.service.kinematics import KinematicsService
from msg_adapters.markers import MARKER_ARRAY_TYPE, MarkerTypes
from msg_adapters.transforms import TFTypes

ARM = [f"panda_joint{i}" for i in range(1, 8)]


def _service(ros, panda_path, **params) -> KinematicsService:
    given = {"robot_description": panda_path.read_text(), "tip_link": "panda_hand"} | params
    return KinematicsService(ros.types, given, tf_types=TFTypes.from_typestore(ros.store))


def _read(ros, msg) -> dict[str, tuple[str, np.ndarray]]:
    """{child: (parent, T_parent_child)} of a TFMessage, after CDR."""
    name = "tf2_msgs/msg/TFMessage"
    msg = ros.store.deserialize_cdr(ros.store.serialize_cdr(msg, name), name)
    out = {}
    for t in msg.transforms:
        T = np.eye(4)
        r, p = t.transform.rotation, t.transform.translation
        from scipy.spatial.transform import Rotation

        T[:3, :3] = Rotation.from_quat([r.x, r.y, r.z, r.w]).as_matrix()
        T[:3, 3] = (p.x, p.y, p.z)
        out[t.child_frame_id] = (t.header.frame_id, T, (t.header.stamp.sec, t.header.stamp.nanosec))
    return out


def test_tf_of_every_link_equals_pinocchio(ros, panda_path):
    svc = _service(ros, panda_path, publish_tf=True)
    static = _read(ros, svc.static_tf(ros.new("builtin_interfaces/msg/Time", sec=1, nanosec=0)))
    assert set(static) == {"panda_link8", "panda_hand", "panda_hand_tcp"}
    pin = PinocchioOracle.from_urdf(
        panda_path, ARM + ["panda_finger_joint1", "panda_finger_joint2"]
    )
    rng = np.random.default_rng(4)
    chain = SerialChain.from_urdf(panda_path, tip_link="panda_hand")
    for k in range(5):
        q = rng.uniform(chain.lower, chain.upper)
        finger = rng.uniform(0, 0.04)
        arm = svc.on_joint_state(js(ros, ARM, q, t=(10 + k, 5)))
        moved = _read(ros, arm.tf)
        assert set(moved) == {f"panda_link{i}" for i in range(1, 8)}  # only the joints named
        assert all(stamp == (10 + k, 5) for _, _, stamp in moved.values())
        fingers = _read(
            ros, svc.on_joint_state(js(ros, ["panda_finger_joint1"], [finger], t=(10 + k, 6))).tf
        )
        assert set(fingers) == {"panda_leftfinger", "panda_rightfinger"}  # the mimic follows
        tree = {c: (p, T) for c, (p, T, _) in (static | moved | fingers).items()}

        expected = np.concatenate((q, [finger, finger]))
        for link in tree:
            np.testing.assert_allclose(_pose(tree, link), pin.pose(expected, link), atol=1e-12)


def _pose(tree: dict[str, tuple[str, np.ndarray]], link: str) -> np.ndarray:
    """T_base_link chained from {child: (parent, T_parent_child)} up to panda_link0."""
    if link == "panda_link0":
        return np.eye(4)
    parent, T = tree[link]
    return _pose(tree, parent) @ T


def test_no_tf_without_publish_tf_or_tf_types(ros, panda_path):
    q = np.zeros(7)
    assert _service(ros, panda_path).on_joint_state(js(ros, ARM, q, t=1.0)).tf is None
    plain = KinematicsService(
        ros.types,
        {"robot_description": panda_path.read_text(), "tip_link": "panda_hand", "publish_tf": True},
    )
    out = plain.on_joint_state(js(ros, ARM, q, t=1.0))
    assert out.pose is not None and out.tf is None


def test_markers_show_the_last_joint_states(ros, panda_path):
    typesys = pytest.importorskip("rosbags.typesys")
    jazzy = typesys.get_typestore(typesys.Stores.ROS2_JAZZY)
    types = MarkerTypes.from_typestore(jazzy)
    svc = _service(ros, panda_path)
    assert svc.markers(types) is None and svc.markers_published == 0
    chain = SerialChain.from_urdf(panda_path, tip_link="panda_hand")
    q = np.random.default_rng(8).uniform(chain.lower, chain.upper)
    svc.on_joint_state(js(ros, ARM, q, t=(7, 250)))
    raw = jazzy.serialize_cdr(svc.markers(types), MARKER_ARRAY_TYPE)
    sphere, arrow = jazzy.deserialize_cdr(raw, MARKER_ARRAY_TYPE).markers
    T, J = chain.fk_jacobian(q, "world")
    s = np.linalg.svd(J[3:], compute_uv=False)
    np.testing.assert_allclose([sphere.scale.x, sphere.scale.y, sphere.scale.z], 2 * s, rtol=1e-12)
    p = sphere.pose.position
    np.testing.assert_allclose([p.x, p.y, p.z], T[:3, 3], atol=1e-14)
    assert (sphere.header.stamp.sec, sphere.header.stamp.nanosec) == (7, 250)
    assert sphere.header.frame_id == "panda_link0"
    assert svc.markers_published == 1
    values = {kv.key: kv.value for kv in svc.diagnostics().status[0].values}
    assert values["markers_published"] == "1"


@pytest.mark.parametrize("bad", [-1.0, 101.0, float("nan")])
def test_markers_rate_is_validated(ros, bad):
    with pytest.raises(InvalidInputError, match="markers_rate"):
        KinematicsService(ros.types, {"markers_rate": bad})


def _stream(svc, ros, q, seconds_ms: int, start=(10, 0)):
    """1 kHz joint_states of the arm for `seconds_ms` ms; the stamps [ms after start] of those
    that got a /tf."""
    sec, nanosec = start
    out = []
    for k in range(seconds_ms):
        stamp = (sec + (nanosec + k * 10**6) // 10**9, (nanosec + k * 10**6) % 10**9)
        if svc.on_joint_state(js(ros, ARM, q + 1e-4 * k, t=stamp)).tf is not None:
            out.append(k)
    return out


@pytest.mark.parametrize(("rate", "expected"), [(None, 20), (100.0, 100), (7.0, 7), (0.0, 1000)])
def test_tf_at_most_tf_rate_by_the_stamps_as_robot_state_publisher(ros, panda_path, rate, expected):
    """1 s of 1 kHz joint_states: /tf for the first and then each one stamped at least
    1/tf_rate after the last that got one (robot_state_publisher's publish_frequency, 20 Hz by
    default); tf_rate 0: every one."""
    params = {"publish_tf": True} | ({} if rate is None else {"tf_rate": rate})
    svc = _service(ros, panda_path, **params)
    published = _stream(svc, ros, np.zeros(7), 1000)
    assert len(published) == expected
    assert published[0] == 0
    gap = 1000 / (rate or 20.0) if rate != 0.0 else 1
    assert all(b - a == math.ceil(gap) for a, b in zip(published, published[1:], strict=False))


def test_tf_rate_counts_per_joint_and_starts_afresh_when_the_stamps_jump_back(ros, panda_path):
    """The fingers, named by joint_states of their own, get their /tf although the arm's was
    just published (the rule is per joint, as robot_state_publisher's); a stream whose stamps
    jump back (a bag restarted) gets its /tf at once."""
    svc = _service(ros, panda_path, publish_tf=True)
    assert _stream(svc, ros, np.zeros(7), 10, start=(20, 0)) == [0]
    finger = js(ros, ["panda_finger_joint1"], [0.01], t=(20, 10**7))
    assert svc.on_joint_state(finger).tf is not None  # its own joint: due
    finger = js(ros, ["panda_finger_joint1"], [0.02], t=(20, 2 * 10**7))
    assert svc.on_joint_state(finger).tf is None  # 10 ms later: not yet
    assert _stream(svc, ros, np.zeros(7), 10, start=(5, 0)) == [0]  # 15 s back: anew


@pytest.mark.parametrize(
    ("bad", "why"),
    [(-1.0, "must be >= 0"), (float("nan"), "must be finite"), (float("inf"), "must be finite")],
)
def test_tf_rate_is_validated(ros, bad, why):
    with pytest.raises(InvalidInputError, match=f"'tf_rate' {why}"):
        KinematicsService(ros.types, {"tf_rate": bad})
