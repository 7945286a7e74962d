"""SIGINT at any moment of a node process's life is a clean stop: the built `servo` and `sim_arm`,
started side by side, each sent SIGINT at a moment of its own (while Python imports numpy and
rclpy, while the node is built, once it runs: twice in a row there), exit with status 0 within
`spin.STOP_DEADLINE_S`, with no traceback in their logs.

The moments are random within their phases (printed on failure), so that runs cover different
ones. The only other outcome accepted is a signal that came while the interpreter itself was
starting, before any code of ours ran (`_before_python`), which no code of ours can change.
"""

from __future__ import annotations

import random
import signal
import tempfile
import time
from pathlib import Path

from live_node import DOMAIN_ID, UR5E

from kinematics_node.ros.env import local_ros_env
from kinematics_node.ros.processes import log_tail, start_node
from kinematics_node.ros.spin import STOP_DEADLINE_S

READY = [0.0, -1.57, 1.57, -1.57, -1.57, 0.0]


def _ready(directory: Path, name: str) -> bool:
    said = "servo ready" if name == "servo" else "simulating"
    return any(said in line for line in log_tail(directory, name, 200))


def test_sigint_at_any_moment_stops_each_node_with_status_0():
    rng = random.Random()
    env = local_ros_env(DOMAIN_ID)
    # (name, when: "start" + s, "ready" + s or "last" (after the others) + s, a second SIGINT)
    plans = [
        ("servo", "start", rng.uniform(0.15, 0.4), None),  # Python importing numpy, scipy
        ("servo", "start", rng.uniform(0.4, 1.2), None),  # importing rclpy, building the node
        ("servo", "ready", rng.uniform(0.0, 0.5), 0.05),  # running; Ctrl-C pressed twice
        # (the servos' joint_states: stopped once they are)
        ("sim_arm", "last", rng.uniform(0.0, 0.5), None),
    ]
    params = {
        "servo": {
            "robot_description_file": str(UR5E),
            "base_link": "base_link",
            "tip_link": "tool0",
            "period_s": 0.01,
        },
        "sim_arm": {"robot": "ur5e", "command_mode": "position", "initial_positions": READY},
    }
    with tempfile.TemporaryDirectory(prefix="kinematics_stop_") as tmp:
        runs = []
        due_at: dict[int, float] = {}  # when a SIGINT after "ready" is due
        for i, (name, *_) in enumerate(plans):
            directory = Path(tmp) / str(i)
            directory.mkdir()
            runs.append((start_node(name, params[name], directory, env), directory))
        started = time.monotonic()
        sent: dict[int, float] = {}  # when each one's SIGINT went
        ended: dict[int, tuple[int | None, float]] = {}  # status, seconds after the SIGINT
        try:
            while len(ended) < len(plans) and time.monotonic() - started < 60.0:
                now = time.monotonic()
                for i, (name, phase, delay, again) in enumerate(plans):
                    proc, directory = runs[i]
                    if i in sent:
                        if i not in ended and proc.poll() is not None:
                            ended[i] = (proc.returncode, now - sent[i])
                        elif i not in ended and now - sent[i] > STOP_DEADLINE_S + 1.0:
                            ended[i] = (None, now - sent[i])  # (killed below)
                        continue
                    if proc.poll() is not None:  # ended before its SIGINT: a failure
                        sent[i], ended[i] = now, (proc.returncode, -1.0)
                        continue
                    if phase == "start":
                        due = started + delay
                    elif not _ready(directory, name) or (
                        phase == "last" and len(sent) < len(plans) - 1
                    ):
                        continue
                    else:
                        due = due_at.setdefault(i, now + delay)
                    if now < due:
                        continue
                    proc.send_signal(signal.SIGINT)
                    sent[i] = time.monotonic()
                    if again is not None:
                        time.sleep(again)
                        proc.send_signal(signal.SIGINT)
                time.sleep(0.005)
        finally:
            for proc, _ in runs:
                if proc.poll() is None:
                    proc.kill()
                    proc.wait()
        logs = [
            "\n".join(log_tail(directory, plans[i][0], 500))
            for i, (_, directory) in enumerate(runs)
        ]
    outcomes = [ended.get(i, (None, float("nan"))) for i in range(len(plans))]
    told = "\n".join(
        f"--- {plan} -> status {code} {took:.2f} s after the SIGINT\n{log[-3000:]}"
        for plan, (code, took), log in zip(plans, outcomes, logs, strict=True)
    )
    for (code, took), log in zip(outcomes, logs, strict=True):
        assert took >= 0 and (
            (code == 0 and "Traceback" not in log) or _before_python(code, log)
        ), told


def _before_python(code: int | None, log: str) -> bool:
    """The signal came while the interpreter itself started, before any code of ours ran: killed
    by it with nothing said (Python's handler not yet installed), or Python's own fatal error
    in its `site` import (a venv's .pth files: an editable install's finder imports pathlib)."""
    if code == -signal.SIGINT:
        return not log.strip()
    return code == 1 and "init_import_site" in log and "KeyboardInterrupt" in log
