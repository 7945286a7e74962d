"""A short-lived ROS 2 client for a shell command (`kinematics ros ...`): one message from a
topic, or one service call, each with a deadline, and what it saw of the graph when nothing came.

rclpy is imported when a `RosClient` is made, not with this module: `kinematics` (cli/main.py) stays
importable, and quick, without ROS. `missing_ros` says beforehand what is missing and how to get it.

DDS: the client takes ROS_DOMAIN_ID, ROS_AUTOMATIC_DISCOVERY_RANGE and the rest from the
environment it is started in, as every ROS 2 tool does. It has to find the node that the user
started from such a shell, and a discovery setting of its own could hide that node (one on another
machine, or the user's static peers). What keeps a user's shell on this machine is the shell's
setup: build/ros/env.sh defaults the discovery range to LOCALHOST where it is unset; tests and
scripts that start these commands give them a loopback environment (`env.local_ros_env`).
"""

from __future__ import annotations

import importlib
import os
import time
from collections.abc import Callable
from typing import Any

from ..core.exceptions import KinematicsError

#: Seconds between checks of a deadline while waiting (Ctrl-C is seen within this).
_POLL = 0.05


class RosClientError(KinematicsError):
    """Nothing arrived, or ROS 2 is missing: the message says what was seen and what to do."""


def missing_ros(modules: tuple[str, ...] = ("rclpy",)) -> str | None:
    """Why `modules` (with rclpy) cannot be imported here, with how to get them; None when all can."""
    for module in ("rclpy", *modules):
        try:
            importlib.import_module(module)
        except ImportError as exc:
            # here, not at the top: executables brings the nodes' parameter tables, and with them
            # the servo's core and SciPy, which `kinematics fk` must not pay for
            from .executables import ros_setup_hint

            return f"needs ROS 2 ({module} is not importable: {exc}): {ros_setup_hint()}"
    return None


def type_name(msg_type: Any) -> str:
    """A message class's ROS type name, as the graph gives it: 'geometry_msgs/msg/PoseStamped'."""
    return f"{msg_type.__module__.split('.')[0]}/msg/{msg_type.__name__}"


def dds_settings() -> str:
    """The environment that decides whom this process finds, for messages."""
    domain = os.environ.get("ROS_DOMAIN_ID") or "0 (unset)"
    scope = os.environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE") or "unset (SUBNET)"
    return f"ROS_DOMAIN_ID={domain}, ROS_AUTOMATIC_DISCOVERY_RANGE={scope}"


class RosClient:
    """An rclpy node in a context of its own, spun by the calling thread while it waits.

    Use as a context manager; `close` shuts the context down. Ctrl-C raises KeyboardInterrupt
    (rclpy's own signal handlers are not installed), within `_POLL` seconds.
    """

    def __init__(self, name: str = "kinematics_cli") -> None:
        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.signals import SignalHandlerOptions

        self._rclpy = rclpy
        self._context = rclpy.Context()
        rclpy.init(context=self._context, signal_handler_options=SignalHandlerOptions.NO)
        try:
            self.node = rclpy.create_node(f"{name}_{os.getpid()}", context=self._context)
            self._executor = SingleThreadedExecutor(context=self._context)
            self._executor.add_node(self.node)
        except BaseException:
            rclpy.try_shutdown(context=self._context)
            raise

    def __enter__(self) -> RosClient:
        return self

    def __exit__(self, *_: object) -> None:
        self.close()

    def close(self) -> None:
        self._executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()
        self._rclpy.try_shutdown(context=self._context)

    def _spin_until(self, done: Any, deadline: float) -> bool:
        """Spin until `done()` or `deadline` (time.monotonic); whether `done()`."""
        while not done():
            left = deadline - time.monotonic()
            if left <= 0:
                return False
            self._executor.spin_once(timeout_sec=min(_POLL, left))
        return True

    def first_message(
        self,
        msg_type: Any,
        topic: str,
        wait: float,
        accept: Callable[[Any], bool] | None = None,
    ) -> Any | None:
        """The first message on `topic` within `wait` seconds (the first that `accept` takes, if
        given), or None. Subscribed best effort, which matches reliable publishers too.

        Returns None early when the topic's publishers all carry another type than `msg_type`
        (DDS never matches them with this subscription: `other_types` then says which)."""
        from rclpy.qos import qos_profile_sensor_data

        received: list[Any] = []

        def take(msg: Any) -> None:
            if accept is None or accept(msg):
                received.append(msg)

        sub = self.node.create_subscription(msg_type, topic, take, qos_profile_sensor_data)
        try:
            self._spin_until(
                lambda: bool(received) or bool(self.other_types(topic, msg_type)),
                time.monotonic() + wait,
            )
        finally:
            self.node.destroy_subscription(sub)
        return received[0] if received else None

    def other_types(self, topic: str, msg_type: Any) -> list[str]:
        """The types ('geometry_msgs/msg/TwistStamped') that `topic`'s publishers carry when none
        of them carries `msg_type`; empty when one does, or when nothing publishes it."""
        types = sorted({info.topic_type for info in self.node.get_publishers_info_by_topic(topic)})
        return [] if type_name(msg_type) in types else types

    def call(self, srv_type: Any, service: str, request: Any, wait: float, answer: float) -> Any:
        """Call `service`: wait up to `wait` seconds for it to appear, then up to `answer`
        seconds for the response.

        Raises:
            RosClientError: the service did not appear, or did not answer, in time.
        """
        client: Any = self.node.create_client(srv_type, service)
        name = self.resolve(service)
        try:
            if not self._spin_until(client.service_is_ready, time.monotonic() + wait):
                raise RosClientError(f"no {name} service within {wait:g} s: {self.graph_seen()}")
            future = client.call_async(request)
            if not self._spin_until(future.done, time.monotonic() + answer):
                raise RosClientError(f"{name} did not answer within {answer:g} s")
            return future.result()
        finally:
            self.node.destroy_client(client)

    def spin_once(self, timeout: float = 0.0) -> None:
        """Run what has arrived (callbacks of the node's subscriptions), waiting up to `timeout`."""
        self._executor.spin_once(timeout_sec=timeout)

    def resolve(self, name: str) -> str:
        """`name` as this node resolves it (a relative name gets the namespace, '/')."""
        return str(self.node.resolve_topic_name(name))

    def publishers(self, topic: str) -> int:
        return int(self.node.count_publishers(topic))

    def graph_seen(self) -> str:
        """The other nodes this one sees, and the settings that decide whom it can see."""
        own = self.node.get_name()
        names = sorted(
            f"{ns.rstrip('/')}/{n}"
            for n, ns in self.node.get_node_names_and_namespaces()
            if n != own
        )
        seen = f"nodes seen: {', '.join(names)}" if names else "no other ROS node seen"
        return f"{seen} ({dds_settings()})"
