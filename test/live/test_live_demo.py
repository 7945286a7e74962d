"""`kinematics demo` with ROS 2, run as a user runs it (`make demo` runs the same command): the
simulated arm and the node as real processes, the services over DDS, a picture of what arrived."""

from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path

import pytest


def test_live_demo_runs_both_processes_calls_the_services_and_draws(tmp_path):
    pytest.importorskip("matplotlib", reason="the demo picture needs the [demo] extra")
    kinematics = Path(os.environ.get("KINEMATICS_ROS_PYTHON", "python")).parent / "kinematics"
    out = tmp_path / "live.png"
    proc = subprocess.run(
        [str(kinematics), "demo", "--duration", "2", "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=180,
        cwd=tmp_path,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    text = proc.stdout
    assert "ROS 2 is not available" not in proc.stderr
    received = re.search(r"received over DDS in 2 s: (\d+) ee_pose, (\d+) ee_twist", text)
    assert received, text
    assert int(received[1]) >= 150 and int(received[2]) >= 150, text  # 100 Hz for 2 s
    fk_match = re.search(r"equals the core's FK of its joint_states to (\S+) m", text)
    assert fk_match and float(fk_match[1]) < 1e-9, text
    for service in ("compute_fk: ok", "compute_jacobian: ok", "compute_ik (the last pose"):
        assert service in text, text
    assert "FAILED" not in text and "solved in" in text, text
    assert "exit codes [0, 0]" in text, text
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and out.stat().st_size > 10_000
