"""The package's executables as child processes, for the live demos and the benchmarks (no rclpy
import here: the parent imports rclpy itself, after `env.keep_discovery_local`).

`start_node` runs one executable (`env.executable`: the built one) with its parameters in a
parameter file, its output in a log file of the run's directory; `stop_nodes` stops them the way
a supervisor does (SIGINT, then SIGKILL for one that has not exited after its grace), so each
node's exit status says whether it stopped cleanly (`spin.spin_until_shutdown`: 0); `log_tail`
is the end of a node's log, to say why one did not, before the run's directory is removed.
"""

from __future__ import annotations

import json
import signal
import subprocess
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from .env import executable


def start_node(
    name: str, params: Mapping[str, Any], directory: Path, env: Mapping[str, str]
) -> subprocess.Popen[bytes]:
    """Start the package's executable `name` (its node has the same name) with `params`, in the
    environment `env`; its parameter file and its output (stdout and stderr) go to
    `directory`/<name>.yaml and <name>.log.

    Raises:
        RuntimeError: the executable is not built here (saying how to build it).
    """
    argv = executable(name)
    if argv is None:
        raise RuntimeError(
            f"the {name} executable is not found: run `make ros`, then . build/ros/env.sh"
        )
    path = directory / f"{name}.yaml"
    # JSON is YAML too: a --params-file without a YAML writer
    path.write_text(json.dumps({name: {"ros__parameters": dict(params)}}), encoding="utf-8")
    with (directory / f"{name}.log").open("wb") as log:  # the child keeps its own descriptor
        return subprocess.Popen(
            [*argv, "--ros-args", "--params-file", str(path)],
            env=dict(env),
            stdout=log,
            stderr=subprocess.STDOUT,
        )


def stop_nodes(processes: Iterable[subprocess.Popen[Any]], grace_s: float = 10.0) -> list[int]:
    """SIGINT to every process (all at once, so they stop side by side), then wait up to
    `grace_s` [s] for each and kill the ones still running; returns their exit statuses (a
    killed one's is -9)."""
    processes = list(processes)
    for p in processes:
        if p.poll() is None:
            p.send_signal(signal.SIGINT)
    for p in processes:
        try:
            p.wait(grace_s)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()
    return [int(p.returncode) for p in processes]


def log_tail(directory: Path, name: str, lines: int = 15) -> list[str]:
    """The last `lines` lines of `start_node`'s log of `name` in `directory` ([] if none)."""
    path = directory / f"{name}.log"
    if not path.is_file():
        return []
    return path.read_text(errors="replace").splitlines()[-lines:]
