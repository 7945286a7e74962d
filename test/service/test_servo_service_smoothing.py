"""ServoService without Ruckig (issue 32 item 7): the servo runs with its acceleration-limited
smoothing, says once (log and ~/status) that jerk limits need Ruckig and how to install it, and
names the smoother on every status; with Ruckig, the status names Ruckig and says nothing more.
Real UR5 description (example-robot-data), real message classes (rosbags), no rclpy."""

from __future__ import annotations

import numpy as np
import pytest
from servo_node_testing import Q_UR5, Loop, make_service, twist_msg, values

from kinematics_node.core.exceptions import InvalidInputError
from kinematics_node.core.servo import smoothing as ruckig_smoothing

UR5 = {"base_link": "base_link", "tip_link": "tool0"}


@pytest.fixture
def no_ruckig(monkeypatch):
    """Ruckig as where it is not installed (`smoothing`'s handle is None then)."""
    monkeypatch.setattr(ruckig_smoothing, "_ruckig", None)


def _twist_run(ros, ur5_path, **params):
    service = make_service(ros, ur5_path.read_text(encoding="utf-8"), **UR5, **params)
    loop = Loop(ros, service)
    v = np.array([0.03, -0.04, 0.02])
    loop.run(1.5, lambda now: service.on_twist(twist_msg(ros, linear=v), now))
    loop.run(1.0)  # the timeout and the stop
    return service, loop, v


def test_without_ruckig_the_servo_follows_a_twist_and_says_once_what_is_missing(
    ros, ur5_path, no_ruckig
):
    service, loop, v = _twist_run(ros, ur5_path)
    assert service.servo is not None and service.servo.smoothing.name == "acceleration"
    log = service.take_log()
    told = [(level, text) for level, text in log if "Ruckig" in text]
    assert len(told) == 1, log
    level, text = told[0]
    assert level == "warn"
    assert "jerk" in text and "pip install ruckig" in text
    assert "python3 -m pip install --user --break-system-packages ruckig" in text  # rosdep users
    assert not any("settings do not fit" in t for _, t in log), log
    statuses = loop.statuses()
    assert len(statuses) > 10
    assert all(values(s)["smoother"] == "acceleration-limited (no Ruckig)" for s in statuses)
    notes = [values(s)["smoother_note"] for s in statuses if "smoother_note" in values(s)]
    assert notes == [text]  # once, the log's words
    # the tool followed the twist (the last 0.5 s of it: the ramp is over)
    chain = service.chain
    p = chain.fk(loop.positions())[:, :3, 3]
    period = service.period_s
    assert np.linalg.norm(p[-1] - chain.fk(Q_UR5)[:3, 3]) > 0.05
    i = round(1.5 / period) - 1  # the last period of the commands
    velocity = (p[i] - p[i - 50]) / (50 * period)
    assert np.allclose(velocity, v, atol=1e-3), velocity
    assert np.array_equal(p[-1], p[-2])  # then it stopped (the holding commands)
    # a second servo (new settings at rest) does not say it again
    service.configure({"max_linear_speed_m_s": 0.4})
    loop.run(0.3)
    assert not [t for _, t in service.take_log() if "Ruckig" in t]
    assert not any("smoother_note" in values(s) for s in loop.statuses()[len(statuses) :])


def test_with_ruckig_the_status_names_it_and_says_nothing_more(ros, ur5_path):
    pytest.importorskip("ruckig")
    service, loop, _ = _twist_run(ros, ur5_path)
    assert service.servo is not None and service.servo.smoothing.name == "ruckig"
    assert not [t for _, t in service.take_log() if "Ruckig" in t]
    statuses = loop.statuses()
    assert all(values(s)["smoother"] == "ruckig (jerk-limited)" for s in statuses)
    assert not any("smoother_note" in values(s) for s in statuses)


def test_smoothing_ruckig_without_ruckig_is_refused_naming_the_parameter(ros, no_ruckig):
    with pytest.raises(InvalidInputError) as refused:
        make_service(ros, "", smoothing="ruckig")
    assert "parameter 'smoothing'" in str(refused.value)
    assert "pip install ruckig" in str(refused.value)
    with pytest.raises(InvalidInputError, match="smoothing"):
        make_service(ros, "", smoothing="jerky")
    make_service(ros, "", smoothing="acceleration")  # accepted
