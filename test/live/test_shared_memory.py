"""Fast DDS as `kinematics_node.ros.env` meets it, on real participants, with Fast DDS 2 (Jazzy) and
3 (Kilted) alike: `clean_dead_shared_memory` removes what a killed rclpy process left in /dev/shm
and keeps what a running one uses; the profile goes in the one variable that this Fast DDS reads,
and no process warns about it."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from live_node import DOMAIN_ID  # (importing it skips where rclpy or the build is missing)

from kinematics_node.ros.env import (
    FASTDDS_PROFILE_VARIABLES,
    FASTDDS_VERSIONS,
    clean_dead_shared_memory,
    fastdds_major,
    fastdds_profile_env,
    fastdds_tool,
    local_ros_env,
)

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

needs_shm = pytest.mark.skipif(
    not SHM.is_dir() or fastdds_tool() is None,
    reason="needs /dev/shm and Fast DDS's `fastdds` tool (the ros-<distro>-fastdds wheel)",
)


def _fastdds_files() -> set[str]:
    """This Fast DDS's files in /dev/shm (Fast DDS 2: fastrtps_*, 3: fastdds_*, and sem.*)."""
    major = fastdds_major()
    assert major is not None, "the Fast DDS that rclpy loads here is found"
    prefix = FASTDDS_VERSIONS[major][2]
    return {name for name in os.listdir(SHM) if prefix in name}


def _start() -> subprocess.Popen[str]:
    env = local_ros_env(DOMAIN_ID)
    process = subprocess.Popen(
        [sys.executable, "-c", PARTICIPANT], env=env, stdout=subprocess.PIPE, text=True
    )
    assert process.stdout is not None and process.stdout.readline().strip() == "up"
    time.sleep(1.0)  # discovery: each participant opens the other's ports
    return process


def _own_files(pid: int) -> set[str]:
    """The files in /dev/shm that process `pid` owns: each port or segment X whose lock X_el it
    holds open, with X_el and X's semaphore (sem.X_mutex). Exact where other processes on the
    machine (other test runs) make and drop such files meanwhile."""
    locks = set()
    for fd in os.listdir(f"/proc/{pid}/fd"):
        try:
            target = os.readlink(f"/proc/{pid}/fd/{fd}")
        except OSError:  # closed meanwhile
            continue
        if target.startswith(f"{SHM}/") and target.endswith("_el"):
            locks.add(target[len(f"{SHM}/") : -len("_el")])
    return {name for x in locks for name in (x, f"{x}_el", f"sem.{x}_mutex")} & _fastdds_files()


@needs_shm
def test_clean_removes_a_killed_participants_files_and_keeps_a_running_ones() -> None:
    running = _start()
    try:
        killed = _start()
        running_files, killed_files = _own_files(running.pid), _own_files(killed.pid)
        assert killed_files and running_files, "a participant makes files in /dev/shm"
        assert not killed_files & running_files
        killed.send_signal(signal.SIGKILL)  # no chance to close its ports: as after a crash
        killed.wait(timeout=10.0)
        assert killed_files <= _fastdds_files(), "a killed participant leaves its files behind"

        line = clean_dead_shared_memory()
        after = _fastdds_files()
        assert "segments of dead processes removed" in line, line
        assert not killed_files & after, line
        assert running_files <= after, "the running participant's files stay"
        assert running.poll() is None
    finally:
        running.send_signal(signal.SIGINT)
        running.wait(timeout=10.0)
    assert running.returncode == 0
    # closed cleanly, it let go of its ports and segments: nothing of it is left for a clean
    assert not {f for f in running_files if f.endswith("_el")} & _fastdds_files()


def _loaded_fastdds_major() -> int:
    """The Fast DDS major version loaded in this process (rclpy is up: live_node started it),
    from the libraries mapped into it: what `fastdds_major` must find without loading any."""
    maps = Path("/proc/self/maps").read_text()
    found = {m for m, (library, _, _) in FASTDDS_VERSIONS.items() if f"/{library}" in maps}
    assert len(found) == 1, found
    return found.pop()


def _participant_says(env: dict[str, str]) -> str:
    """What a participant started with `env` prints while it comes up (Fast DDS 2 logs its
    errors on stdout, 3 on stderr; ROS 2's warnings go to stderr)."""
    done = subprocess.run(
        [sys.executable, "-c", "import rclpy; rclpy.init(); rclpy.create_node('profile_probe')"],
        env=env,
        capture_output=True,
        text=True,
        timeout=60.0,
        check=True,
    )
    return done.stdout + done.stderr


@pytest.mark.skipif(not Path("/proc/self/maps").is_file(), reason="needs /proc")
def test_the_profile_goes_in_the_variable_this_fast_dds_reads_and_nothing_warns(
    tmp_path: Path,
) -> None:
    """Fast DDS 3 warns in every process where FASTRTPS_DEFAULT_PROFILES_FILE is set; Fast DDS 2
    reads only that one. The variable `local_ros_env` sets is read: a broken profile given
    there makes Fast DDS say so."""
    assert fastdds_major() == _loaded_fastdds_major()
    env = local_ros_env(
        DOMAIN_ID, base={k: v for k, v in os.environ.items() if "PROFILES" not in k}
    )
    (variable,) = [v for v in FASTDDS_PROFILE_VARIABLES if v in env]
    assert "DEFAULT_PROFILES_FILE" not in _participant_says(env)

    broken = tmp_path / "broken_profile.xml"
    broken.write_text("<dds><profiles><participant")
    del env[variable]
    assert fastdds_profile_env(broken, env) == {variable: str(broken)}
    said = _participant_says({**env, variable: str(broken)})
    assert str(broken) in said and "deprecated" not in said, said
