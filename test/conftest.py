"""Shared fixtures (helpers live in kin_testing.py, ros_testing.py and service_testing.py,
importable because pythonpath includes test/: unique names, so no test imports the wrong file)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from kin_testing import REAL_ARMS, erd_path
from ros_testing import RosTypes

# The fixtures of the KinematicsService tests (ur5, clock, q_ur5), next to their helpers.
pytest_plugins = ["service_testing"]

if os.environ.get("KINEMATICS_LAUNCH_TEST_SEPARATE"):  # CMake runs it through add_launch_test
    collect_ignore = ["launch/test_launch_integration.py"]

#: The tests that start or import ROS 2 (rclpy, the built node, launch), relative to test/: a
#: folder (ending in /) or a module. They carry the marker `ros`, and they are all that a run with
#: KINEMATICS_TESTS=ros keeps: CI runs the whole suite on its first ROS distribution and only these
#: on the others, since the rest never touches ROS and gives the same answers on every one.
#: test_suite_split.py checks that every module that imports rclpy or starts the node is here.
ROS_TESTS = ("live/", "launch/", "ros/", "cli/test_ros_commands.py")
_HERE = Path(__file__).resolve().parent


def touches_ros(path: Path) -> bool:
    """Whether the test module at `path` is one of `ROS_TESTS`."""
    rel = path.resolve().relative_to(_HERE).as_posix()
    return any(
        rel.startswith(entry) if entry.endswith("/") else rel == entry for entry in ROS_TESTS
    )


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "ros: starts or imports ROS 2 (conftest.ROS_TESTS)")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    for item in items:
        if touches_ros(item.path):
            item.add_marker(pytest.mark.ros)
    only = os.environ.get("KINEMATICS_TESTS", "all")
    if only not in ("all", "ros"):
        raise pytest.UsageError(f"KINEMATICS_TESTS={only!r}: expected 'all' or 'ros'")
    if only == "ros":
        kept = [item for item in items if item.get_closest_marker("ros")]
        config.hook.pytest_deselected(items=[item for item in items if item not in kept])
        items[:] = kept


@pytest.fixture(params=REAL_ARMS, ids=[a[0] for a in REAL_ARMS])
def real_arm(request):
    """(SerialChain, path) for each real arm description."""
    from kinematics_node.core import SerialChain

    name, rel, base, tip = request.param
    path = erd_path(rel)
    return SerialChain.from_urdf(path, base, tip), path


@pytest.fixture(params=["vectorised", "per-target"])
def batch_path(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    """Run a batch test through both implementations of `ik_batch`, whatever the batch size."""
    from kinematics_node.core.ik import solver as ik_module

    monkeypatch.setattr(
        ik_module, "SCALAR_BATCH_BELOW", 0 if request.param == "vectorised" else 10**9
    )
    return str(request.param)


@pytest.fixture(autouse=True)
def _private_chain_cache(tmp_path_factory, monkeypatch):
    """The CLI caches parsed URDFs in the user's cache directory; tests use their own."""
    monkeypatch.setenv("KINEMATICS_CACHE_DIR", str(tmp_path_factory.mktemp("chain_cache")))


@pytest.fixture(scope="session")
def ros() -> RosTypes:
    """Real ROS 2 message classes (rosbags) with our srv types; skips without rosbags."""
    return RosTypes()


@pytest.fixture(scope="session")
def ur5_path() -> Path:
    return erd_path("ur_description/urdf/ur5_robot.urdf")


@pytest.fixture(scope="session")
def panda_path() -> Path:
    return erd_path("panda_description/urdf/panda.urdf")
