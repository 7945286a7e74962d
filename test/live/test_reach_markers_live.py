"""`kinematics ros reach-markers MAP` run as a user runs it (a process) over DDS: a subscriber with
transient-local QoS that starts AFTER the map was published still receives the MarkerArray, and
its cubes and colours are the map's voxels with D > 0; Ctrl-C ends it with status 0; --once exits
once a subscriber has it."""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from live_node import DOMAIN_ID, Client, wait_until
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "jobs" / "maps"))
from map_testing import save_npz, small_map  # noqa: E402

from kinematics_node.ros.env import local_ros_env  # noqa: E402
from msg_adapters.reach_markers import index_colours  # noqa: E402

MarkerArray = pytest.importorskip("visualization_msgs.msg").MarkerArray
LATCHED = QoSProfile(
    depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE
)


@pytest.fixture
def map_file(tmp_path: Path) -> Path:
    path = tmp_path / "ur5e.npz"
    save_npz(small_map(), path)
    return path


def _start(*args: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "kinematics_node.cli", "ros", "reach-markers", *args],
        env=local_ros_env(DOMAIN_ID),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _check_cubes(array) -> None:
    m = small_map()
    (marker,) = array.markers
    drawn = np.asarray(m.index) > 0
    assert marker.header.frame_id == "base_link" and marker.type == 6
    points = np.array([[p.x, p.y, p.z] for p in marker.points])
    np.testing.assert_array_equal(points, np.asarray(m.centres)[drawn])
    colours = np.array([[c.r, c.g, c.b, c.a] for c in marker.colors])
    np.testing.assert_allclose(colours, index_colours(np.asarray(m.index)[drawn]), rtol=1e-6)


def test_a_late_subscriber_gets_the_map(map_file: Path) -> None:
    process = _start(str(map_file), "--topic", "/live_reach_map")
    try:
        line = process.stdout.readline()  # printed once published
        assert "Ctrl-C ends" in line, process.stderr.read() if process.poll() is not None else line
        client = Client()
        try:
            received: list = []
            client.node.create_subscription(
                MarkerArray, "/live_reach_map", received.append, LATCHED
            )
            wait_until(lambda: bool(received), 20.0, "the map's MarkerArray")
            _check_cubes(received[0])
        finally:
            client.close()
        process.send_signal(signal.SIGINT)
        assert process.wait(timeout=20) == 0
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()


def test_once_exits_when_a_subscriber_has_it(map_file: Path) -> None:
    client = Client()
    try:
        received: list = []
        client.node.create_subscription(MarkerArray, "/live_reach_once", received.append, LATCHED)
        process = _start(str(map_file), "--topic", "/live_reach_once", "--once", "--wait", "30")
        out, err = process.communicate(timeout=60)
        assert process.returncode == 0, err
        assert "delivered" in out
        wait_until(lambda: bool(received), 10.0, "the map's MarkerArray")
        _check_cubes(received[0])
    finally:
        client.close()
