"""Fixtures of the live suite (helpers in live_node.py, which skips the whole suite, saying why,
where the built node cannot run)."""

from __future__ import annotations

import signal
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from live_node import Client, NodeProcess


@pytest.fixture(scope="session", autouse=True)
def no_dead_shared_memory() -> str:
    """Shared-memory files of killed ROS processes (earlier runs on a developer's machine),
    removed once before the first node starts, so every session starts from the same state
    (`ros.env.clean_dead_shared_memory` says why)."""
    from kinematics_node.ros.env import clean_dead_shared_memory

    return clean_dead_shared_memory()


@pytest.fixture(scope="session")
def client() -> Iterator[Client]:
    c = Client()
    yield c
    c.close()


@pytest.fixture
def start_node(client: Client) -> Iterator[Callable[..., NodeProcess]]:
    """Start a node with the given parameters and wait until it serves compute_fk; stopped (with
    SIGINT) at the end of the test."""
    started: list[tuple[NodeProcess, tempfile.TemporaryDirectory[str]]] = []

    def start(wait: bool = True, **params: Any) -> NodeProcess:
        directory = tempfile.TemporaryDirectory(prefix="kinematics_live_")
        node = NodeProcess(
            {k.replace("__", "."): v for k, v in params.items()}, Path(directory.name)
        )
        started.append((node, directory))
        if wait:
            from kinematics_service.srv import ComputeFK

            fk = client.node.create_client(ComputeFK, "compute_fk")
            ok = fk.wait_for_service(timeout_sec=20.0)
            client.node.destroy_client(fk)
            assert ok and node.alive(), f"node did not come up:\n{node.log()}"
        return node

    yield start
    for node, directory in started:
        node.stop(signal.SIGINT)
        directory.cleanup()
