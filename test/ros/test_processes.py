"""kinematics_node.ros.processes: the package's executables as child processes (no ROS needed: a
small Python script stands in for the executable, as `env.executable` would give it)."""

from __future__ import annotations

import json
import signal
import sys
import time
from pathlib import Path

import pytest

from kinematics_node.ros import processes

#: Stands in for a node: prints its arguments and the parameter file, stops on SIGINT with
#: status 0 (as `spin.spin_until_shutdown` does), or ignores it when told to.
NODE = """
import signal, sys, time
args = sys.argv[1:]
print("args", args, flush=True)
print("params", open(args[args.index("--params-file") + 1]).read(), flush=True)
if "{name}" == "stubborn":
    signal.signal(signal.SIGINT, signal.SIG_IGN)
print("ready", flush=True)
try:
    time.sleep(60)
except KeyboardInterrupt:
    print("stopped", flush=True)
"""


@pytest.fixture
def stand_in(monkeypatch, tmp_path):
    def executable(name: str) -> list[str] | None:
        if name == "not_built":
            return None
        script = tmp_path / f"{name}_stand_in.py"
        script.write_text(NODE.replace("{name}", name), encoding="utf-8")
        return [sys.executable, str(script)]

    monkeypatch.setattr(processes, "executable", executable)
    run = tmp_path / "run"
    run.mkdir()
    return run


def _wait_for(path: Path, text: str, timeout: float = 20.0) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if path.is_file() and text in path.read_text(errors="replace"):
            return
        time.sleep(0.02)
    raise AssertionError(f"{text!r} never appeared in {path}")


def test_a_node_gets_its_parameters_and_stops_cleanly_on_sigint(stand_in):
    params = {"robot": "ur5e", "rate": 250.0, "initial_positions": [0.0, -1.5]}
    p = processes.start_node("sim_arm", params, stand_in, {"PATH": "/usr/bin:/bin"})
    _wait_for(stand_in / "sim_arm.log", "ready")
    written = json.loads((stand_in / "sim_arm.yaml").read_text(encoding="utf-8"))
    assert written == {"sim_arm": {"ros__parameters": params}}
    assert processes.stop_nodes([p]) == [0]
    tail = processes.log_tail(stand_in, "sim_arm")
    assert tail[-1] == "stopped"
    assert f"'--ros-args', '--params-file', '{stand_in / 'sim_arm.yaml'}'" in tail[0]


def test_a_node_that_ignores_sigint_is_killed_after_its_grace(stand_in):
    polite = processes.start_node("kinematics_node", {}, stand_in, {})
    stubborn = processes.start_node("stubborn", {}, stand_in, {})
    for name in ("kinematics_node", "stubborn"):
        _wait_for(stand_in / f"{name}.log", "ready")
    t0 = time.monotonic()
    codes = processes.stop_nodes([stubborn, polite], grace_s=0.5)
    assert codes == [-signal.SIGKILL, 0]
    assert time.monotonic() - t0 < 10.0
    assert processes.stop_nodes([polite]) == [0]  # stopping again: nothing to signal


def test_an_executable_not_built_is_named_with_how_to_build_it(stand_in):
    with pytest.raises(RuntimeError, match="the not_built executable is not found: run `make ros`"):
        processes.start_node("not_built", {}, stand_in, {})
    assert processes.log_tail(stand_in, "not_built") == []
