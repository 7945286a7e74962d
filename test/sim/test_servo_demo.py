"""`kinematics servo-demo --no-ros`: the servo drives the UR5e's tool around a square through a wrist
singularity and spins it; the figures it prints are the run's, and the run does what they claim.

The run is checked against the script (not against the demo's own figures): the tool's path from
the chain's FK of the measured joint positions, the commanded square, the wrist joint and the
condition number of the Jacobian computed here.
"""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest

from kinematics_node.cli.main import main
from kinematics_node.core.analysis import condition_number

servo_demo = pytest.importorskip("kinematics_node.sim.servo_demo")
pytest.importorskip("ruckig", reason="the servo's smoothing needs ruckig (extra 'servo')")


@pytest.fixture(scope="module")
def run():
    return servo_demo.run_offline(100.0)


@pytest.fixture(scope="module")
def fig(run):
    return servo_demo.figures(run)


def _dense_square(corners, step=1e-5):
    """Points every `step` [m] along the square: a distance oracle independent of the demo's."""
    pieces = []
    for a, b in zip(corners[:-1], corners[1:], strict=True):
        n = int(np.ceil(np.linalg.norm(b - a) / step)) + 1
        pieces.append(a + np.linspace(0.0, 1.0, n)[:, None] * (b - a))
    return np.vstack(pieces)


def test_the_tool_goes_round_the_whole_square_within_a_millimetre(run):
    plan = run.plan
    p = run.chain.fk(run.q_tool)[:, :3, 3]
    np.testing.assert_allclose(p, run.p_tool, atol=1e-12)
    square = run.t_tool < plan.spin_start_s
    dense = _dense_square(plan.corners)
    dist = np.array([np.linalg.norm(dense - x, axis=1).min() for x in p[square][::5]])
    assert dist.max() < 1e-3, dist.max()
    # a tool that did not move would be on the square too: it must reach every corner, in order
    reached = [int(np.argmin(np.linalg.norm(p[square] - c, axis=1))) for c in plan.corners[:4]]
    for c, k in zip(plan.corners[:4], reached, strict=True):
        assert np.linalg.norm(p[square][k] - c) < 1e-3
    assert reached[1] < reached[2] < reached[3], reached
    # the orientation is held along the square (to the damping near the singularity)
    R = run.R_tool[square]
    cos = np.clip((np.trace(np.swapaxes(R, 1, 2) @ plan.R, axis1=1, axis2=2) - 1) / 2, -1, 1)
    assert np.arccos(cos).max() < 0.02


def test_the_square_passes_through_the_wrist_singularity_without_stopping(run, fig):
    wrist = run.q_tool[:, servo_demo.SINGULAR_JOINT]
    square = run.t_tool < run.plan.spin_start_s
    assert np.abs(wrist[square]).min() < 1e-3  # the wrist joint reaches 0 ...
    assert np.count_nonzero(np.diff(np.sign(wrist[square])) != 0) >= 1  # ... and passes it
    kappa = condition_number(run.chain.jacobian(run.q_tool), "full")
    k = int(np.argmax(kappa))
    assert kappa[k] > 1e3 and run.t_tool[k] < run.plan.spin_start_s
    # at the most singular sample the tool still moves at most of the commanded speed
    speed = np.linalg.norm(run.p_tool[k + 1] - run.p_tool[k - 1]) / (
        run.t_tool[k + 1] - run.t_tool[k - 1]
    )
    asked = np.linalg.norm(run.plan.twist(run.t_tool[k])[3:])
    assert speed > 0.8 * asked > 0.05, (speed, asked)
    assert fig.time_stopped_s == 0.0
    assert fig.time_asked_s > 0.8 * run.plan.commands_s
    assert fig.singular_crossings >= 1 and fig.condition_max == pytest.approx(kappa.max())


def test_the_spin_turns_the_tool_in_place(run, fig):
    plan = run.plan
    spin = run.t_tool >= plan.spin_start_s
    p = run.p_tool[spin]
    assert np.linalg.norm(p - plan.corners[0], axis=1).max() < 0.5e-3
    R0 = plan.R
    angles = [np.arccos(np.clip((np.trace(R.T @ R0) - 1) / 2, -1, 1)) for R in run.R_tool[spin]]
    assert max(angles) > 0.9 * plan.spin_rad  # it did turn
    assert angles[-1] < 0.01  # and back
    assert fig.spin_drift_mm == pytest.approx(
        np.linalg.norm(p - plan.corners[0], axis=1).max() * 1e3
    )


def test_joint_commands_stay_within_every_limit(run, fig):
    lim = run.limits
    q = np.vstack((run.q_command[:1],) * 3 + (run.q_command,))
    dt = run.period_s
    v = np.diff(q, axis=0) / dt
    a = np.diff(q, n=2, axis=0) / dt**2
    j = np.diff(q, n=3, axis=0) / dt**3
    for values, limit, peak in (
        (v, lim.velocity, fig.velocity),
        (a, lim.acceleration, fig.acceleration),
        (j, lim.jerk, fig.jerk),
    ):
        ratio = np.abs(values) / limit
        assert ratio.max() <= 1.0 + 1e-6
        assert peak.fraction == pytest.approx(ratio.max(), rel=1e-9)
    assert np.all(run.q_command >= lim.lower - 1e-12) and np.all(run.q_command <= lim.upper + 1e-12)
    # the arm follows the commands: measured positions are the commands one step later
    np.testing.assert_allclose(run.q_tool[1:], run.q_command, atol=1e-12)


def _frozen(r, start_s, end_s):
    """The run with the arm held where it was at `start_s` until `end_s`."""
    t = r.t_tool
    frozen = (t > start_s) & (t <= end_s)
    q, p, R = r.q_tool.copy(), r.p_tool.copy(), r.R_tool.copy()
    k0 = int(np.argmax(frozen)) - 1
    q[frozen], p[frozen], R[frozen] = q[k0], p[k0], R[k0]
    return dataclasses.replace(r, q_tool=q, p_tool=p, R_tool=R)


def test_a_stop_while_commanded_to_move_is_counted(run):
    """The stop detector finds a stop planted in the run (so the 0 s above could be false)."""
    stopped = servo_demo.figures(_frozen(run, 3.0, 3.5))  # side 2, moving at speed
    assert stopped.time_stopped_s == pytest.approx(0.5, abs=0.02)
    assert stopped.held_steps == 50


def test_one_step_without_a_new_command_is_no_stop(run, fig):
    """An arm step that found no new joint command (the loops are not synchronised over DDS) is
    counted as such, not as a stop; the undisturbed run has none."""
    assert fig.held_steps == 0 and fig.held_s == 0.0
    held = servo_demo.figures(_frozen(run, 3.0, 3.02))
    assert held.held_steps == 2 and held.held_s == pytest.approx(0.02)
    assert held.time_stopped_s == 0.0


def test_command_derivatives_of_a_cubic():
    dt = 0.01
    t = np.arange(1, 50)[:, None] * dt
    q = np.hstack((t**3, 2 * t))
    v, a, j = servo_demo.command_derivatives(q, dt)
    assert v.shape == a.shape == j.shape == q.shape
    np.testing.assert_allclose(j[3:, 0], 6.0, rtol=1e-6)  # (t³)''' = 6, after the rest start
    np.testing.assert_allclose(v[1:, 1], 2.0, rtol=1e-9)
    np.testing.assert_allclose(a[2:, 1], 0.0, atol=1e-9)


def test_distance_to_polyline():
    corners = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0]])
    pts = np.array([[0.5, -0.2, 0], [2.0, 0.5, 0], [-1, 0, 0], [0.5, 0.5, 0.3]])
    np.testing.assert_allclose(
        servo_demo.distance_to_polyline(pts, corners), [0.2, 1.0, 1.0, np.hypot(0.5, 0.3)]
    )


def _numbers(text, pattern):
    match = re.search(pattern, text)
    assert match, (pattern, text)
    return [float(x) for x in match.groups()]


def test_the_printed_figures_are_the_run_s(run, fig):
    text = servo_demo.summary(run, fig)
    (err_max, err_rms) = _numbers(text, r"tracking error .*: max (\S+) mm, rms (\S+) mm")
    assert err_max == pytest.approx(fig.path_error_max_mm, abs=0.006)
    assert err_rms == pytest.approx(fig.path_error_rms_mm, abs=0.0006)
    (stopped, asked) = _numbers(text, r"time stopped while commanded to move: (\S+) s of (\S+) s")
    assert stopped == 0.0 and asked == pytest.approx(fig.time_asked_s, abs=0.006)
    for what, peak in (("velocity", fig.velocity), ("acceleration", fig.acceleration)):
        value, percent, limit = _numbers(
            text, rf"peak joint {what}: (\S+) \S+ \({peak.joint}\), (\d+) % of its limit (\S+)"
        )
        assert value == pytest.approx(peak.value, rel=1e-2)
        assert limit == pytest.approx(peak.limit, rel=1e-2)
        assert percent == round(100 * peak.fraction) and percent <= 100
    (drift,) = _numbers(text, r"stayed within (\S+) mm of its corner")
    assert drift == pytest.approx(fig.spin_drift_mm, abs=0.006)
    total = sum(run.status_counts.values())
    assert total == len(run.q_command) and f"over {total} cycles" in text


def test_cli_runs_without_ros_and_draws(tmp_path, capsys):
    pytest.importorskip("matplotlib", reason="the demo picture needs the [demo] extra")
    out = tmp_path / "servo.png"
    assert main(["servo-demo", "--no-ros", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "the core servo in this process at 100 Hz" in text
    assert "time stopped while commanded to move: 0.00 s" in text
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and out.stat().st_size > 20_000


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["--rate", "5"], "--rate 5: the servo runs at 10 to 2000 Hz"),
        (["--rate", "4000"], "--rate 4000: the servo runs at 10 to 2000 Hz"),
        (["--out", "x.nope"], "unknown picture format .nope"),
    ],
)
def test_cli_bad_options_are_one_clear_error(argv, words, capsys, tmp_path, monkeypatch):
    pytest.importorskip("matplotlib", reason="the demo picture needs the [demo] extra")
    monkeypatch.chdir(tmp_path)
    assert main(["servo-demo", "--no-ros", *argv]) == 1
    err = capsys.readouterr().err
    assert words in err and err.count("\n") == 1, err
    assert not list(tmp_path.iterdir())  # nothing ran, nothing written


def test_other_rates_run_the_same_script():
    r = servo_demo.run_offline(250.0)
    f = servo_demo.figures(r)
    assert r.period_s == pytest.approx(0.004)
    assert f.path_error_max_mm < 1.0 and f.time_stopped_s == 0.0
    assert max(f.velocity.fraction, f.acceleration.fraction, f.jerk.fraction) <= 1.0 + 1e-6
    assert "at 250 Hz" in servo_demo.summary(r, f)


def test_derivatives_spanning_a_lost_command_are_left_out():
    dt = 0.01
    t = np.arange(1, 30)[:, None] * dt
    q = np.hstack((t**3, t))
    keep = np.r_[0:10, 11:29]  # the command of row 10 was lost
    gaps = servo_demo.command_gaps(dt, keep.astype(np.int64), None)
    v, a, j = servo_demo.command_derivatives(q[keep], dt, gaps)
    # the row after the gap: no velocity; two rows: no acceleration; three: no jerk
    assert np.isnan(v[10]).all() and not np.isnan(v[[9, 11]]).any()
    assert np.isnan(a[10:12]).all() and not np.isnan(a[[9, 12]]).any()
    assert np.isnan(j[10:13]).all() and not np.isnan(j[[9, 13]]).any()
    np.testing.assert_allclose(j[13:, 0], 6.0, rtol=1e-6)
    # without the sequence numbers the gap would be a jerk far beyond the true 6
    _, _, j_blind = servo_demo.command_derivatives(q[keep], dt)
    assert np.abs(j_blind[10:13, 1]).max() > 1e3


def test_a_command_published_late_is_a_gap_too():
    dt = 0.01
    times = np.arange(10) * dt
    times[6:] += 0.02  # command 6 came three periods after command 5
    gaps = servo_demo.command_gaps(dt, np.arange(10), times)
    assert gaps.tolist() == [i == 6 for i in range(10)]
    assert servo_demo.command_gaps(dt, None, None) is None
    gaps = servo_demo.command_gaps(dt, np.r_[0:3, 4:11], np.arange(10) * dt)
    assert gaps.tolist() == [i == 3 for i in range(10)]
