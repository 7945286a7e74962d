"""The live node's ~/markers and /tf.

~/markers: nothing is published while nobody subscribes (its diagnostics count the markers it
built), and once a client subscribes, the ellipsoid arrives at markers_rate and is the SVD of the
core's J at the joint_states it is stamped with.

/tf with publish_tf: every link of the Panda, its fingers too, chained from the node's /tf and
/tf_static (received transient local, by a subscriber that came after the node published it) equals
Pinocchio's FK and the core's FK to each link. The messages are decoded with rosbags from the bytes
on the wire, and the node announces tf2_msgs/msg/TFMessage under ROS 2's own type hash: with ROS 2
from PyPI that is tools/interfaces/tf2_msgs (no wheel), which must be the real definition.
"""

from __future__ import annotations

import os
import time

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from live_node import UR5E_JOINTS, ur5e_description, wait_until
from scipy.spatial.transform import Rotation
from sensor_msgs.msg import JointState

from kinematics_node.core import SerialChain
from kinematics_node.sim.robots import robot_path

CHAIN = SerialChain.from_urdf(robot_path("ur5e"))
visualization = pytest.importorskip(
    "visualization_msgs.msg",
    reason="visualization_msgs is not installed (ros-jazzy-visualization-msgs)",
)


def _joint_state(q, stamp_ns: int) -> JointState:
    msg = JointState()
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
    msg.name = list(UR5E_JOINTS)
    msg.position = [float(v) for v in q]
    return msg


def _published(diagnostics) -> int | None:
    for array in reversed(list(diagnostics)):
        for status in array.status:
            for kv in status.values:
                if kv.key == "markers_published":
                    return int(kv.value)
    return None


def test_markers_only_while_subscribed_and_they_are_the_svd_of_j(start_node, client):
    diagnostics = client.collect(DiagnosticArray, "/diagnostics")
    node = start_node(
        robot_description=ur5e_description(), markers_rate=20.0, diagnostics_period=0.1
    )
    pub = client.publisher(JointState, "joint_states")
    wait_until(lambda: pub.get_subscription_count() > 0, 20, "the node's joint_states subscription")
    rng = np.random.default_rng(12)
    sent: dict[int, np.ndarray] = {}
    k = 0

    def send(seconds: float) -> None:
        nonlocal k
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            k += 1
            q = rng.uniform(-2, 2, CHAIN.dof)
            sent[10**12 + k * 10**6] = q
            pub.publish(_joint_state(q, 10**12 + k * 10**6))
            time.sleep(0.005)

    send(1.0)  # 1 s of joint_states, 20 marker periods, and nobody subscribes to ~/markers
    diagnostics.clear()
    wait_until(lambda: _published(diagnostics) is not None, 5, f"diagnostics; log:\n{node.log()}")
    assert _published(diagnostics) == 0
    markers = client.collect(visualization.MarkerArray, "/kinematics_node/markers")
    send(1.0)
    wait_until(lambda: len(markers) >= 3, 10, f"markers once subscribed; log:\n{node.log()}")
    send(0.3)
    assert _published(diagnostics) and _published(diagnostics) > 0
    for msg in list(markers):
        sphere, arrow = msg.markers
        stamp = sphere.header.stamp.sec * 10**9 + sphere.header.stamp.nanosec
        q = sent[stamp]  # stamped like a joint_states message we sent
        T, J = CHAIN.fk_jacobian(q, "world")
        U, s, _ = np.linalg.svd(J[3:])
        assert sphere.header.frame_id == CHAIN.base_link
        assert sphere.type == visualization.Marker.SPHERE
        p, o = sphere.pose.position, sphere.pose.orientation
        np.testing.assert_allclose([p.x, p.y, p.z], T[:3, 3], atol=1e-12)
        R = Rotation.from_quat([o.x, o.y, o.z, o.w]).as_matrix()
        assert np.linalg.det(R) == pytest.approx(1.0)
        np.testing.assert_allclose(R @ np.diag(s**2) @ R.T, J[3:] @ J[3:].T, atol=1e-9)
        np.testing.assert_allclose([sphere.scale.x, sphere.scale.y, sphere.scale.z], 2 * s)
        a, b = (np.array([pt.x, pt.y, pt.z]) for pt in arrow.points)
        assert abs((b - a) @ U[:, 2]) == pytest.approx(max(s[0], 0.05), rel=1e-9)


def _transforms(raw: bytes, store) -> dict[str, tuple[str, np.ndarray, int]]:
    """{child: (parent, T_parent_child, stamp [ns])} of a TFMessage's CDR bytes, decoded by
    rosbags (a decoder independent of the node's rclpy classes)."""
    msg = store.deserialize_cdr(raw, "tf2_msgs/msg/TFMessage")
    out = {}
    for t in msg.transforms:
        T = np.eye(4)
        r, p = t.transform.rotation, t.transform.translation
        T[:3, :3] = Rotation.from_quat([r.x, r.y, r.z, r.w]).as_matrix()
        T[:3, 3] = (p.x, p.y, p.z)
        stamp = t.header.stamp.sec * 10**9 + t.header.stamp.nanosec
        out[t.child_frame_id] = (t.header.frame_id, T, stamp)
    return out


def _chained(tree: dict[str, tuple[str, np.ndarray]], root: str, link: str) -> np.ndarray:
    """T_root_link, chained through {child: (parent, T_parent_child)}."""
    T = np.eye(4)
    while link != root:
        link, T_parent_link = tree[link]
        T = T_parent_link @ T
    return T


def test_tf_from_the_node_is_every_link_at_the_joint_states(start_node, client):
    try:
        import tf2_msgs.msg as tf2
    except ImportError:
        why = "tf2_msgs is not installed (make ros builds it where the venv lacks it)"
        if os.environ.get("KINEMATICS_REQUIRE_ROS") == "1":
            pytest.fail(why)
        pytest.skip(why)
    rosbags = pytest.importorskip("rosbags.typesys", reason="rosbags decodes the bytes (.[test])")
    import yourdfpy
    from kin_testing import PinocchioOracle, erd_path
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    store = rosbags.get_typestore(rosbags.Stores.ROS2_JAZZY)
    panda = erd_path("panda_description/urdf/panda.urdf")
    urdf = yourdfpy.URDF.load(str(panda), load_meshes=False, build_scene_graph=False)
    links = {link.name for link in urdf.robot.links}
    (root,) = links - {joint.child for joint in urdf.robot.joints}
    arm = [f"panda_joint{i}" for i in range(1, 8)]
    node = start_node(robot_description=panda.read_text(), tip_link="panda_hand", publish_tf=True)
    # Subscribed only now, after the node published /tf_static: transient local brings it.
    static: list[bytes] = []
    latched = QoSProfile(
        depth=100,
        durability=DurabilityPolicy.TRANSIENT_LOCAL,
        reliability=ReliabilityPolicy.RELIABLE,
    )
    client.node.create_subscription(tf2.TFMessage, "/tf_static", static.append, latched, raw=True)
    moving: list[bytes] = []
    client.node.create_subscription(tf2.TFMessage, "/tf", moving.append, 1000, raw=True)
    wait_until(lambda: static, 10, f"/tf_static (transient local); log:\n{node.log()}")
    (info,) = client.node.get_publishers_info_by_topic("/tf")
    assert str(info.topic_type_hash) == store.hash_rihs01("tf2_msgs/msg/TFMessage")

    pub = client.publisher(JointState, "joint_states")
    wait_until(lambda: pub.get_subscription_count() > 0, 20, "the node's joint_states subscription")
    rng = np.random.default_rng(33)
    pin = PinocchioOracle.from_urdf(panda, arm + ["panda_finger_joint1", "panda_finger_joint2"])
    for k in range(3):
        q = rng.uniform(-1.5, 1.5, 7)
        finger = float(rng.uniform(0.0, 0.04))
        stamp = 2 * 10**12 + k * 10**9  # 1 s apart: each gets its /tf at the default tf_rate
        msg = JointState()
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp, 10**9)
        msg.name = [*arm, "panda_finger_joint1"]
        msg.position = [*map(float, q), finger]
        moving.clear()
        sent = [0.0]

        def answered(msg=msg, sent=sent) -> bool:
            # joint_states is best effort: a sample sent just after matching may be lost, so it
            # goes again every 0.2 s (the same stamp: /tf is due once, at tf_rate by the stamps)
            if time.monotonic() - sent[0] > 0.2:
                pub.publish(msg)
                sent[0] = time.monotonic()
            return bool(moving)

        wait_until(answered, 10, f"/tf of joint_states {k}; log:\n{node.log()}")
        (raw,) = moving
        tf = _transforms(raw, store)
        assert {t for _, _, t in tf.values()} == {stamp}  # stamped like the joint_states
        fixed = _transforms(static[-1], store)
        assert not set(tf) & set(fixed)
        tree = {child: (parent, T) for child, (parent, T, _) in (fixed | tf).items()}
        assert set(tree) == links - {root}  # the whole tree: the hand and both fingers too
        assert {"panda_leftfinger", "panda_rightfinger"} <= set(tf)  # the mimic with its leader
        for link in links:
            T = _chained(tree, root, link)
            np.testing.assert_allclose(T, pin.pose([*q, finger, finger], link), atol=1e-12)
            chain = SerialChain.from_urdf(panda, tip_link=link) if link != root else None
            if chain is not None:
                given = dict(zip(msg.name, msg.position, strict=True))
                core = chain.fk(np.array([given[name] for name in chain.joint_names]))
                np.testing.assert_allclose(T, core, atol=1e-12)


def _robot_state_publisher() -> list[str] | None:
    """argv of the installed robot_state_publisher (a full ROS 2), or None."""
    try:
        from ament_index_python.packages import PackageNotFoundError, get_package_prefix
    except ImportError:
        return None
    try:
        prefix = get_package_prefix("robot_state_publisher")
    except PackageNotFoundError:
        return None
    exe = os.path.join(prefix, "lib", "robot_state_publisher", "robot_state_publisher")
    return [exe] if os.access(exe, os.X_OK) else None


def test_the_nodes_tf_is_robot_state_publishers(start_node, client, tmp_path):
    """Where robot_state_publisher is installed (a full ROS 2; not on PyPI): both are given the
    same description and joint_states, and every transform of ours equals its (its /tf and
    /tf_static remapped beside ours), to 1e-9 (its URDF parsing rounds through KDL)."""
    argv = _robot_state_publisher()
    if argv is None:
        pytest.skip("robot_state_publisher is not installed here (a full ROS 2 has it)")
    import subprocess

    import tf2_msgs.msg as tf2
    import yaml
    from kin_testing import erd_path
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    from kinematics_node.ros.env import local_ros_env

    rosbags = pytest.importorskip("rosbags.typesys", reason="rosbags decodes the bytes (.[test])")
    store = rosbags.get_typestore(rosbags.Stores.ROS2_JAZZY)
    panda = erd_path("panda_description/urdf/panda.urdf")
    params = tmp_path / "rsp.yaml"
    description = panda.read_text()
    params.write_text(
        yaml.safe_dump({"/**": {"ros__parameters": {"robot_description": description}}})
    )
    rsp = subprocess.Popen(
        [
            *argv,
            "--ros-args",
            "--params-file",
            str(params),
            "-r",
            "/tf:=/rsp/tf",
            "-r",
            "/tf_static:=/rsp/tf_static",
        ],
        env=local_ros_env(),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        start_node(robot_description=description, tip_link="panda_hand", publish_tf=True)
        latched = QoSProfile(
            depth=100,
            durability=DurabilityPolicy.TRANSIENT_LOCAL,
            reliability=ReliabilityPolicy.RELIABLE,
        )
        got: dict[str, list[bytes]] = {
            t: [] for t in ("/tf", "/tf_static", "/rsp/tf", "/rsp/tf_static")
        }
        for topic, received in got.items():
            qos = latched if topic.endswith("static") else 1000
            client.node.create_subscription(tf2.TFMessage, topic, received.append, qos, raw=True)
        wait_until(lambda: got["/tf_static"] and got["/rsp/tf_static"], 15, "both /tf_static")
        pub = client.publisher(JointState, "joint_states")
        wait_until(lambda: pub.get_subscription_count() >= 2, 20, "both joint_states subscriptions")
        msg = JointState()
        msg.header.stamp.sec = 3000
        msg.name = [*(f"panda_joint{i}" for i in range(1, 8)), "panda_finger_joint1"]
        msg.position = [0.3, -0.7, 0.2, -2.1, 0.4, 1.6, 0.5, 0.02]
        pub.publish(msg)
        wait_until(lambda: got["/tf"] and got["/rsp/tf"], 15, "both /tf")
        ours = _transforms(got["/tf"][-1], store) | _transforms(got["/tf_static"][-1], store)
        theirs = _transforms(got["/rsp/tf"][-1], store) | _transforms(
            got["/rsp/tf_static"][-1], store
        )
        assert set(ours) == set(theirs)
        for child, (parent, T, _) in ours.items():
            assert theirs[child][0] == parent
            np.testing.assert_allclose(T, theirs[child][1], atol=1e-9, err_msg=child)
    finally:
        rsp.terminate()
        rsp.wait(timeout=10)
