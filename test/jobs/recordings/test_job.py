"""`process_recording` end to end, on recordings written with rosbags in both storages: what it
adds equals what the node's logic publishes for the same joint_states and Pinocchio's FK, every
message decodes with mcap-ros2-support's decoder (an implementation independent of rosbags),
every input message is copied byte for byte, and each refusal is one line with nothing left
behind."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from kin_testing import PinocchioOracle
from recording_testing import STORE, rosbag2, write_recording

from kinematics_node.jobs.recordings.job import BagOptions, RecordingError, process_recording
from kinematics_node.sim.robots import robot_path

TIP = "panda_hand_tcp"
OPTIONS = BagOptions(tip_link=TIP)


def _messages(path: Path) -> list[tuple[str, int, bytes]]:
    with rosbag2.Reader(path) as reader:
        return [(c.topic, t, bytes(d)) for c, t, d in reader.messages()]


def _decoded(path: Path) -> dict[str, list[tuple[int, object]]]:
    """Every message of the output's MCAP file, decoded by mcap-ros2-support."""
    reader_mod = pytest.importorskip("mcap.reader", reason="pip install mcap-ros2-support")
    decoder = pytest.importorskip("mcap_ros2.decoder", reason="pip install mcap-ros2-support")
    (mcap_file,) = path.glob("*.mcap")
    out: dict[str, list[tuple[int, object]]] = {}
    with mcap_file.open("rb") as f:
        reader = reader_mod.make_reader(f, decoder_factories=[decoder.DecoderFactory()])
        for _, channel, message, decoded in reader.iter_decoded_messages(log_time_order=True):
            out.setdefault(channel.topic, []).append((message.log_time, decoded))
    return out


@pytest.fixture(scope="module", params=["mcap", "sqlite3"])
def recording(request, tmp_path_factory) -> tuple[Path, Path]:
    base = tmp_path_factory.mktemp(request.param)
    src = write_recording(base / "in", storage=request.param, count=300)
    out = base / "out"
    process_recording(src, out, OPTIONS)
    return src, out


def test_every_input_message_is_copied_byte_for_byte(recording):
    src, out = recording
    copied = [
        m for m in _messages(out) if m[0] in {"/joint_states", "/chatter", "/robot_description"}
    ]
    assert sorted(copied) == sorted(_messages(src))


def test_pose_and_twist_are_the_nodes_and_decode_independently(recording, ros):
    from kinematics_node.service.kinematics import KinematicsService

    src, out = recording
    service = KinematicsService(
        ros.types,
        {"robot_description": robot_path("panda").read_text(), "tip_link": TIP},
        clock=lambda: 0.0,
    )
    published = []
    for topic, t, raw in _messages(src):
        if topic != "/joint_states":
            continue
        msg = STORE.deserialize_cdr(raw, "sensor_msgs/msg/JointState")
        result = service.on_joint_state(msg, received=t * 1e-9)
        published.append((t, result.pose, result.twist))
    decoded = _decoded(out)
    poses, twists = decoded["/ee_pose"], decoded["/ee_twist"]
    assert len(poses) == len(twists) == len(published) == 300
    for (t, pose, twist), (tp, p), (tt, w) in zip(published, poses, twists, strict=True):
        assert t == tp == tt
        assert p.header.frame_id == pose.header.frame_id == "panda_link0"
        assert (p.header.stamp.sec, p.header.stamp.nanosec) == (
            pose.header.stamp.sec,
            pose.header.stamp.nanosec,
        )
        for field in ("x", "y", "z"):
            assert getattr(p.pose.position, field) == pytest.approx(
                getattr(pose.pose.position, field), abs=1e-12
            )
            assert getattr(w.twist.linear, field) == pytest.approx(
                getattr(twist.twist.linear, field), abs=1e-12
            )
            assert getattr(w.twist.angular, field) == pytest.approx(
                getattr(twist.twist.angular, field), abs=1e-12
            )
        for field in ("x", "y", "z", "w"):
            assert getattr(p.pose.orientation, field) == pytest.approx(
                getattr(pose.pose.orientation, field), abs=1e-12
            )


def _matrix(translation, rotation) -> np.ndarray:
    from kinematics_node.core.rotations import matrix_from_quaternion

    T = np.eye(4)
    T[:3, :3] = matrix_from_quaternion([rotation.x, rotation.y, rotation.z, rotation.w])
    T[:3, 3] = [translation.x, translation.y, translation.z]
    return T


def test_tf_and_ee_pose_equal_pinocchios_fk(recording):
    from kinematics_node.core import SerialChain

    src, out = recording
    chain = SerialChain.from_urdf(robot_path("panda"), None, TIP)
    pin = PinocchioOracle.from_urdf(robot_path("panda"), chain.joint_names)
    decoded = _decoded(out)
    joint_states = [
        STORE.deserialize_cdr(raw, "sensor_msgs/msg/JointState")
        for topic, _, raw in _messages(src)
        if topic == "/joint_states"
    ]
    (static,) = decoded["/tf_static"]
    fixed = {t.child_frame_id: t for t in static[1].transforms}
    assert set(fixed) == {"panda_link8", "panda_hand", TIP}
    for k in range(0, 300, 37):
        q = np.array(joint_states[k].position)
        tf = {t.child_frame_id: t for t in decoded["/tf"][k][1].transforms} | fixed
        T = pin.pose(q, "panda_link0")
        for link in chain.link_names[1:]:
            t = tf[link]
            assert t.header.frame_id == chain.link_names[chain.link_names.index(link) - 1]
            T = T @ _matrix(t.transform.translation, t.transform.rotation)
            np.testing.assert_allclose(T, pin.pose(q, link), atol=1e-12)
        pose = decoded["/ee_pose"][k][1].pose
        np.testing.assert_allclose(
            _matrix(pose.position, pose.orientation), pin.pose(q, TIP), atol=1e-12
        )


def test_markers_are_the_nodes_at_10_hz_and_show_the_svd_of_j(recording):
    """The node's manipulability markers, decoded by mcap-ros2-support: one per 100 ms of log
    time, stamped like the joint_states they come from, the ellipsoid the SVD of J_v there."""
    from scipy.spatial.transform import Rotation

    from kinematics_node.core import SerialChain

    src, out = recording
    chain = SerialChain.from_urdf(robot_path("panda"), None, TIP)
    states = {
        t: STORE.deserialize_cdr(raw, "sensor_msgs/msg/JointState")
        for topic, t, raw in _messages(src)
        if topic == "/joint_states"
    }
    markers = _decoded(out)["/kinematics_node/markers"]
    first = min(states)
    assert [t for t, _ in markers] == [
        min(s for s in states if s // 10**8 == b) for b in sorted({s // 10**8 for s in states})
    ]
    assert len(markers) >= 3 and markers[0][0] == first
    for log_time, msg in markers:
        state = states[log_time]
        T, J = chain.fk_jacobian(np.array(state.position), "world")
        sphere, arrow = msg.markers
        assert sphere.header.frame_id == chain.base_link
        assert (sphere.header.stamp.sec, sphere.header.stamp.nanosec) == (
            state.header.stamp.sec,
            state.header.stamp.nanosec,
        )
        U, s, _ = np.linalg.svd(J[3:])
        p, o = sphere.pose.position, sphere.pose.orientation
        np.testing.assert_allclose([p.x, p.y, p.z], T[:3, 3], atol=1e-12)
        R = Rotation.from_quat([o.x, o.y, o.z, o.w]).as_matrix()
        np.testing.assert_allclose(R @ np.diag(s**2) @ R.T, J[3:] @ J[3:].T, atol=1e-12)
        np.testing.assert_allclose(
            [sphere.scale.x, sphere.scale.y, sphere.scale.z], 2 * s, rtol=1e-12
        )
        a, b = ([pt.x, pt.y, pt.z] for pt in arrow.points)
        assert abs(np.subtract(b, a) @ U[:, 2]) == pytest.approx(s[0], rel=1e-9)


def test_tf_static_is_latched_and_the_added_topics_are_typed(recording):
    _, out = recording
    with rosbag2.Reader(out) as reader:
        kinds = {c.topic: c for c in reader.connections}
    assert kinds["/ee_pose"].msgtype == "geometry_msgs/msg/PoseStamped"
    assert kinds["/ee_twist"].msgtype == "geometry_msgs/msg/TwistStamped"
    assert kinds["/tf"].msgtype == kinds["/tf_static"].msgtype == "tf2_msgs/msg/TFMessage"
    assert kinds["/kinematics_node/markers"].msgtype == "visualization_msgs/msg/MarkerArray"
    (qos,) = kinds["/tf_static"].ext.offered_qos_profiles
    assert qos.durability.name == "TRANSIENT_LOCAL"
    (copied,) = kinds["/robot_description"].ext.offered_qos_profiles
    assert copied.durability.name == "TRANSIENT_LOCAL"


def test_the_same_recording_in_batches_of_any_size_gives_the_same_output(tmp_path, monkeypatch):
    from kinematics_node.jobs.recordings import job

    src = write_recording(tmp_path / "in", count=250)
    process_recording(src, tmp_path / "whole", OPTIONS)
    monkeypatch.setattr(job, "BATCH", 7)
    process_recording(src, tmp_path / "pieces", OPTIONS)
    whole, pieces = sorted(_messages(tmp_path / "whole")), sorted(_messages(tmp_path / "pieces"))
    assert [m[:2] for m in whole] == [m[:2] for m in pieces]
    for (topic, _, a), (_, _, b) in zip(whole, pieces, strict=True):
        if topic in ("/ee_pose", "/ee_twist"):  # FK of 7 or 250 rows may differ in the last bit
            assert a[:-56] == b[:-56]
            np.testing.assert_allclose(
                np.frombuffer(a[-48:], "<f8"), np.frombuffer(b[-48:], "<f8"), atol=1e-14
            )
        elif topic != "/tf":
            assert a == b, topic


def _refused(tmp_path: Path, src: Path, match: str, **options) -> None:
    out = tmp_path / "refused"
    with pytest.raises(RecordingError, match=match) as err:
        process_recording(src, out, BagOptions(**({"tip_link": TIP} | options)))
    assert "\n" not in str(err.value)
    assert not out.exists()
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".refused")] == []


def test_the_output_is_named_after_out_and_the_same_input_gives_the_same_bytes(tmp_path):
    src = write_recording(tmp_path / "in", count=50)
    for name in ("one", "two"):
        process_recording(src, tmp_path / name, OPTIONS)
    assert sorted(p.name for p in (tmp_path / "one").iterdir()) == ["metadata.yaml", "one.mcap"]
    one = (tmp_path / "one" / "one.mcap").read_bytes()
    two = (tmp_path / "two" / "two.mcap").read_bytes()
    assert one.replace(b"one.mcap", b"two.mcap") == two
    with pytest.raises(RecordingError, match="its folder .* does not exist"):
        process_recording(src, tmp_path / "no" / "out", OPTIONS)
    assert not (tmp_path / "no").exists()


def test_not_a_recording_is_refused(tmp_path):
    (tmp_path / "empty").mkdir()
    _refused(tmp_path, tmp_path / "empty", "is not a readable rosbag2 recording")
    (tmp_path / "file.txt").write_text("hello")
    _refused(tmp_path, tmp_path / "file.txt", "is a file")
    _refused(tmp_path, tmp_path / "missing", "no such file")


def test_a_truncated_recording_is_refused_with_nothing_left(tmp_path):
    src = write_recording(tmp_path / "in", count=3000)
    (mcap,) = src.glob("*.mcap")
    data = mcap.read_bytes()
    mcap.write_bytes(data[: len(data) // 2])
    _refused(tmp_path, src, "rosbag2 recording|could not be read")


def test_no_joint_states_lists_the_topics(tmp_path):
    src = write_recording(tmp_path / "in", count=10)
    _refused(
        tmp_path,
        src,
        r"no /arm/joint_states of type sensor_msgs/msg/JointState; its topics: /chatter "
        r"\(std_msgs/msg/String\), /joint_states \(sensor_msgs/msg/JointState\)",
        joint_states="arm/joint_states",
    )


def test_chain_joints_never_present_are_named(tmp_path):
    src = write_recording(tmp_path / "in", count=10, joint_names=[f"j{i}" for i in range(7)])
    _refused(tmp_path, src, r"never names the chain's joints \['panda_joint1', ")


def test_a_description_that_does_not_parse_is_refused(tmp_path):
    src = write_recording(tmp_path / "in", count=10)
    _refused(tmp_path, src, "robot description .* was refused", description="<robot name='x'>")
    _refused(tmp_path, src, "was refused: .*leaf links", tip_link=None)


def test_an_existing_output_needs_force_and_the_input_is_untouched(tmp_path):
    src = write_recording(tmp_path / "in", count=20)
    before = {p.name: p.read_bytes() for p in src.iterdir()}
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep").write_text("mine")
    with pytest.raises(RecordingError, match="exists: give --force"):
        process_recording(src, out, OPTIONS)
    assert (out / "keep").read_text() == "mine"
    process_recording(src, out, BagOptions(tip_link=TIP, force=True))
    assert not (out / "keep").exists() and list(out.glob("*.mcap"))
    assert {p.name: p.read_bytes() for p in src.iterdir()} == before


def test_nan_rows_other_robots_and_unset_stamps_are_handled_and_reported(tmp_path):
    def edit(i, msg):
        if i in (10, 11):
            msg.position[3] = math.nan
        if i == 20:
            msg.name = ["other_joint"]
            msg.position = np.array([1.0])
            msg.velocity = np.zeros(0)
        if i in (30, 31):
            msg.header.stamp.sec, msg.header.stamp.nanosec = 0, 0
        return msg

    src = write_recording(tmp_path / "in", count=100, edit=edit)
    result = process_recording(src, tmp_path / "out", OPTIONS)
    counts = result.counts
    assert (counts.rejected, counts.foreign, counts.unset_stamps) == (2, 1, 2)
    assert result.written["/ee_pose"] == 97
    text = result.report()
    assert "2 skipped (NaN" in text and "1 naming no joint of the chain" in text
    assert "2 stamped 0" in text
