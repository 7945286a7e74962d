"""`kinematics demo` end to end, headless, as a newcomer runs it."""

import io

import numpy as np
import pytest

from kinematics_node.cli.main import main
from kinematics_node.sim.demo import run_demo


def test_demo_writes_the_picture_and_exits_0(tmp_path, capsys, monkeypatch):
    pytest.importorskip("matplotlib", reason="the demo picture needs the [demo] extra")
    monkeypatch.chdir(tmp_path)
    code = main(["demo", "--duration", "2", "--no-ros"])
    out = capsys.readouterr().out
    assert code == 0
    png = tmp_path / "kinematics_demo.png"
    assert png.stat().st_size > 10_000
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "robot ur5e" in out and "solved" in out and "FAILED" not in out


def test_demo_out_option_and_other_robot(tmp_path, capsys):
    pytest.importorskip("matplotlib", reason="the demo picture needs the [demo] extra")
    target = tmp_path / "sub.png"
    assert (
        main(["demo", "--robot", "panda", "--duration", "1", "--out", str(target), "--no-ros"]) == 0
    )
    assert target.exists()
    assert "robot panda: 7 joints" in capsys.readouterr().out


def test_demo_numbers_are_the_chain_s_numbers():
    run = run_demo("planar3r", duration=1.0, rate=50.0, n_ik=3, stream=io.StringIO())
    assert len(run.t) == 50
    np.testing.assert_allclose(run.p_tip, run.chain.fk(run.q)[:, :3, 3], atol=1e-12)
    assert np.all(run.chain.within_limits(run.q))
    assert all(ok for _, ok, *_ in run.ik_rows)
    # speed from alternating message/estimated velocities stays close to the finite difference
    v_fd = np.linalg.norm(np.diff(run.p_tip, axis=0), axis=1) * 50.0
    assert np.nanmax(np.abs(run.speed_tip[2:] - v_fd[1:])) < 0.05


def test_demo_unknown_robot_is_one_clear_error(capsys):
    assert main(["demo", "--robot", "r2d2"]) == 1
    err = capsys.readouterr().err
    assert "unknown robot 'r2d2'" in err and "ur5e" in err


def test_progress_bar_only_on_a_terminal():
    from kinematics_node.sim.demo import Progress

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    for stream, drawn in ((io.StringIO(), False), (Terminal(), True)):
        bar = Progress(10, stream, "simulating")
        bar.start -= 10.0  # long enough to be drawn
        bar.update(10)
        bar.close()
        assert ("\r" in stream.getvalue()) is drawn


def test_planar_arm_manipulability_is_not_a_flat_zero():
    run = run_demo("planar3r", duration=1.0, rate=50.0, n_ik=2, stream=io.StringIO())
    assert run.manipulability_rank == 2 and run.manipulability.max() > 1e-2  # starts stretched
    assert run.ik_targets.shape == (2, 3)


def test_demo_without_ros_says_so_and_runs_in_process(tmp_path):
    """Where the node is not built (no kinematics_service interfaces on the path), the demo falls
    back to the in-process run and says why, in one line."""
    import os
    import subprocess
    import sys

    pytest.importorskip("matplotlib", reason="the demo picture needs the [demo] extra")
    env = {
        k: v
        for k, v in os.environ.items()
        if not k.startswith("KINEMATICS_") and k not in ("PYTHONPATH", "AMENT_PREFIX_PATH")
    }
    out = tmp_path / "demo.png"
    proc = subprocess.run(
        [sys.executable, "-m", "kinematics_node.cli", "demo", "--duration", "1", "--out", str(out)],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    assert "ROS 2 is not available" in proc.stderr and "in this process instead" in proc.stderr
    assert "robot ur5e" in proc.stdout and out.exists()
