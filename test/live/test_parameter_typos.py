"""A misspelled parameter, given to each of our three executables (kinematics_node, servo,
sim_arm) started as processes: with ``-p`` on the command line and in a --params-file (the
node's own section or ``/**``), the node warns at start-up, naming the closest parameter it has;
and a run-time set of a name it does not declare, through its set_parameters service, is refused
with a reason that names the parameter and the closest one (rclpy's own reason lists none)."""

from __future__ import annotations

import subprocess
import time
from pathlib import Path

import pytest
from live_node import DOMAIN_ID, Client

from kinematics_node.ros.env import executable, local_ros_env

#: node -> (a typo on the command line, its value, the name meant; the params-file section, a
#: typo in it, its value, the name meant)
CASES = {
    "kinematics_node": ("tip_lnk", "tool0", "tip_link", "/**", "ik.timout", 0.2, "ik.timeout"),
    "servo": (
        "command_timeout",
        "0.2",
        "command_timeout_s",
        "/**",
        "period",
        0.002,
        "period_s",
    ),
    "sim_arm": ("rat", "50.0", "rate", "sim_arm", "comand_mode", "demo", "command_mode"),
}
#: A start-up's extra parameters: few IK workers, so the machine stays free for the others.
QUIET = {"kinematics_node": ["-p", "ik.workers:=1"], "servo": [], "sim_arm": []}


def _params_file(path: Path, section: str, name: str, value: object) -> Path:
    import yaml

    group, _, leaf = name.rpartition(".")
    body: dict = {leaf: value} if not group else {group: {leaf: value}}
    path.write_text(yaml.safe_dump({section: {"ros__parameters": body}}))
    return path


def _wait_for(log: Path, needles: list[str], process: subprocess.Popen, timeout: float) -> str:
    end = time.monotonic() + timeout
    while True:
        text = log.read_text(errors="replace")
        if all(n in text for n in needles):
            return text
        if process.poll() is not None or time.monotonic() > end:
            raise AssertionError(f"the log lacks {needles}:\n{text}")
        time.sleep(0.1)


@pytest.mark.parametrize("node", sorted(CASES))
def test_a_typo_is_named_at_start_up_and_refused_at_run_time(node, tmp_path, client: Client):
    typo, value, meant, section, file_typo, file_value, file_meant = CASES[node]
    argv = executable(node)
    assert argv is not None
    params = _params_file(tmp_path / "params.yaml", section, file_typo, file_value)
    log = tmp_path / "node.log"
    with log.open("wb") as out:
        process = subprocess.Popen(
            [*argv, "--ros-args", "--params-file", str(params), "-p", f"{typo}:={value}"]
            + QUIET[node],
            env=local_ros_env(DOMAIN_ID),
            stdout=out,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
    try:
        text = _wait_for(
            log,
            [
                f"unknown parameter {typo!r} (did you mean {meant!r}?): ignored",
                f"unknown parameter {file_typo!r} (did you mean {file_meant!r}?): ignored",
            ],
            process,
            60.0,
        )
        assert "use_sim_time" not in text and "qos_overrides" not in text
        # run time: the refusal names the parameter, where rclpy's lists none ("[]")
        (result,) = client.set_parameters(node, **{typo.replace(".", "__"): 1.5})
        assert not result.successful
        assert result.reason == f"unknown parameter {typo!r} (did you mean {meant!r}?): not set"
        assert process.poll() is None, log.read_text(errors="replace")
    finally:
        process.terminate()
        try:
            process.wait(15)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
