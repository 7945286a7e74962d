"""msg_adapters.markers with real ROS 2 message definitions (rosbags' Jazzy store): the
manipulability markers' fields, read back after CDR (what DDS and a recording carry), against
numpy's SVD of the Jacobian and SciPy's rotations."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from kinematics_node.core import SerialChain
from kinematics_node.core.analysis import condition_colour, translational_ellipsoid
from msg_adapters.markers import (
    MARKER_ARRAY_TYPE,
    MARKER_MESSAGE_NAMES,
    MIN_SCALE,
    NAMESPACE,
    MarkerTypes,
    manipulability_markers,
)

typesys = pytest.importorskip("rosbags.typesys", reason="rosbags not installed")


@pytest.fixture(scope="module")
def store():
    return typesys.get_typestore(typesys.Stores.ROS2_JAZZY)


@pytest.fixture(scope="module")
def types(store) -> MarkerTypes:
    return MarkerTypes.from_typestore(store)


def test_every_type_name_is_a_real_interface(store):
    for full in MARKER_MESSAGE_NAMES.values():
        assert full in store.types


def _round_trip(store, msg):
    return store.deserialize_cdr(store.serialize_cdr(msg, MARKER_ARRAY_TYPE), MARKER_ARRAY_TYPE)


def test_markers_show_the_svd_of_the_linear_rows(store, types, panda_path):
    chain = SerialChain.from_urdf(panda_path, tip_link="panda_hand")
    rng = np.random.default_rng(5)
    for q in rng.uniform(chain.lower, chain.upper, size=(10, chain.dof)):
        T, J = chain.fk_jacobian(q, "world")
        e = translational_ellipsoid(J, T[:3, 3])
        msg = _round_trip(
            store, manipulability_markers(types, e, chain.base_link, 12, 345, red_at=50.0)
        )
        sphere, arrow = msg.markers
        U, s, _ = np.linalg.svd(J[3:])
        for m, kind, marker_id in ((sphere, "SPHERE", 0), (arrow, "ARROW", 1)):
            assert m.type == getattr(types.Marker, kind) and m.id == marker_id
            assert m.ns == NAMESPACE and m.action == types.Marker.ADD
            assert m.header.frame_id == "panda_link0"
            assert (m.header.stamp.sec, m.header.stamp.nanosec) == (12, 345)
        p = sphere.pose.position
        np.testing.assert_allclose([p.x, p.y, p.z], T[:3, 3], atol=1e-15)
        o = sphere.pose.orientation
        R = Rotation.from_quat([o.x, o.y, o.z, o.w]).as_matrix()
        np.testing.assert_allclose(R @ np.diag(s**2) @ R.T, J[3:] @ J[3:].T, atol=1e-12)
        for k in range(3):  # each axis of the marker is a left singular vector, in order
            assert abs(R[:, k] @ U[:, k]) == pytest.approx(1.0, abs=1e-9)
        scale = sphere.scale
        np.testing.assert_allclose([scale.x, scale.y, scale.z], 2 * s, rtol=1e-12)
        rgb = condition_colour(s[0] / s[2], 50.0)
        c = sphere.color
        np.testing.assert_allclose([c.r, c.g, c.b], rgb, atol=1e-6)  # float32 in the message
        assert 0 < c.a < 1 and arrow.color.a == 1
        start, end = ([pt.x, pt.y, pt.z] for pt in arrow.points)
        np.testing.assert_allclose(start, T[:3, 3], atol=1e-15)
        direction = np.subtract(end, start)
        assert np.linalg.norm(direction) == pytest.approx(s[0], rel=1e-12)
        assert abs(direction @ U[:, 2]) / s[0] == pytest.approx(1.0, abs=1e-9)


def test_a_flat_ellipsoid_is_drawn_thin_and_red(store, types):
    J = np.zeros((6, 2))
    J[3:5] = np.eye(2)  # the tool moves in x and y only
    msg = _round_trip(
        store, manipulability_markers(types, translational_ellipsoid(J, np.zeros(3)), "b", 0, 0)
    )
    sphere, arrow = msg.markers
    assert (sphere.scale.x, sphere.scale.y, sphere.scale.z) == (2.0, 2.0, MIN_SCALE)
    assert (sphere.color.r, sphere.color.g) == (1.0, 0.0)
    assert abs(arrow.points[1].z) == pytest.approx(1.0)


def test_batched_markers_are_rosbags_bytes_of_the_message_builder():
    """`manipulability_markers_cdr` writes, byte for byte, what rosbags' serialiser writes for
    `manipulability_markers` of the same ellipsoids (singular and flat ones included)."""
    from kinematics_node.core.analysis import translational_ellipsoid
    from msg_adapters.markers import manipulability_markers, manipulability_markers_cdr

    rng = np.random.default_rng(21)
    Js = [rng.normal(size=(6, 7)) for _ in range(6)]
    Js[1][3:] = 0.0  # no linear motion at all
    Js[2][5] = 0.0  # a flat ellipsoid
    ellipsoids = [translational_ellipsoid(J, rng.normal(size=3)) for J in Js]
    stamp = rng.integers(0, 2**31 - 1, size=6) * 10**9 + rng.integers(0, 10**9, size=6)
    rows = manipulability_markers_cdr(ellipsoids, "panda_link0", stamp)
    store = typesys.get_typestore(typesys.Stores.ROS2_JAZZY)
    types = MarkerTypes.from_typestore(store)
    for k, e in enumerate(ellipsoids):
        msg = manipulability_markers(
            types, e, "panda_link0", int(stamp[k] // 10**9), int(stamp[k] % 10**9)
        )
        want = store.serialize_cdr(msg, "visualization_msgs/msg/MarkerArray")
        assert rows[k].tobytes() == bytes(want), k
