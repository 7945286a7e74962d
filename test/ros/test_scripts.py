"""The executables `kinematics_node`, `sim_arm` and `kinematics` as a user starts them.

From the source tree (no ROS needed): `--help` prints the usage without importing rclpy; an
argument outside --ros-args is refused in one line; without ROS, one line says what is needed.
Installed by colcon (where `make ros` built the package; skipped elsewhere, failed where
KINEMATICS_REQUIRE_ROS=1 says the build must be there): they run under the build's Python whatever
`python3` comes first on PATH, and build/ros/env.sh puts them on PATH.
"""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from kinematics_node.ros import executables
from kinematics_node.ros.env import executable, local_ros_env
from kinematics_node.ros.executables import SIM_ARM_PARAMETERS, usage
from kinematics_node.service.parameters import PARAMETERS
from kinematics_node.service.servo_parameters import SERVO_PARAMETERS

ROOT = Path(__file__).resolve().parents[2]
SCRIPTS = ROOT / "scripts"
#: The env.sh of the build this run uses (build/ros-<distro>/env.sh for a second distribution, as
#: in CI), which names itself; else build/ros/env.sh
ENV_SH = Path(os.environ.get("KINEMATICS_ROS_ENV") or ROOT / "build" / "ros" / "env.sh")
SPECS = {
    "kinematics_node": PARAMETERS,
    "sim_arm": SIM_ARM_PARAMETERS,
    "servo": SERVO_PARAMETERS,
}


def _run_script(script: str, *args: str) -> subprocess.CompletedProcess[str]:
    """The script from the source tree, with rclpy hidden (as on a machine without ROS)."""
    code = (
        f"import runpy, sys; sys.modules['rclpy'] = None; sys.argv = [{script!r}, *{list(args)!r}]; "
        f"runpy.run_path({str(SCRIPTS / script)!r}, run_name='__main__')"
    )
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=ROOT
    )


@pytest.mark.parametrize(
    ("script", "uses_our_interfaces"),
    [("kinematics_node", True), ("sim_arm", False), ("servo", False)],
)
def test_without_rclpy_the_executable_says_what_is_needed(script, uses_our_interfaces):
    out = _run_script(script)
    assert out.returncode == 1
    assert out.stderr.count("\n") == 1 and "Traceback" not in out.stderr
    # the first ROS package the import misses: the node's first is our built interfaces, which
    # are missing too when the workspace is not sourced (`. build/ros/env.sh`)
    built = importlib.util.find_spec("kinematics_service") is not None
    missing = "kinematics_service" if uses_our_interfaces and not built else "rclpy"
    assert out.stderr.startswith(f"{script}: needs ROS 2 (module {missing!r} not found)")
    assert "build/ros/env.sh" in out.stderr and "install/setup.bash" in out.stderr


@pytest.mark.parametrize("script", ["kinematics_node", "sim_arm", "servo"])
@pytest.mark.parametrize("flag", ["--help", "-h"])
def test_help_prints_the_usage_and_starts_nothing(script, flag):
    """rclpy is hidden: a node or the sim arm could not even start, yet help works."""
    out = _run_script(script, flag)
    assert out.returncode == 0, out.stderr
    assert out.stderr == ""
    text = out.stdout
    assert text.startswith(f"usage: {script} [-h] [--ros-args")
    for spec in SPECS[script]:  # every declared parameter, with its default
        assert f"  {spec.name} (" in text, spec.name
    assert "-p robot_description_file:=" in text  # how to give a robot description
    assert "joint_states" in text
    if script == "kinematics_node":
        assert all(topic in text for topic in ("ee_pose", "ee_twist", "compute_ik"))


@pytest.mark.parametrize("script", ["kinematics_node", "sim_arm", "servo"])
def test_help_into_a_closed_pipe_ends_quietly(script):
    """`kinematics_node --help | head -3`: the reader goes away first; no traceback."""
    code = (
        "import os, runpy, sys; sys.modules['rclpy'] = None; "
        "r, w = os.pipe(); os.close(r); os.dup2(w, 1); "
        f"sys.argv = [{script!r}, '--help']; "
        f"runpy.run_path({str(SCRIPTS / script)!r}, run_name='__main__')"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=ROOT
    )
    assert (out.returncode, out.stderr) == (141, "")


def test_the_usage_lists_exactly_the_declared_parameters():
    for script, specs in SPECS.items():
        listed = re.findall(
            r"^  (\S+) \((?:bool|integer|double|string|double\[\]), default ",
            usage(script),
            re.MULTILINE,
        )
        assert listed == [spec.name for spec in specs], script


def test_every_parameter_the_usage_text_names_is_declared():
    """The prose and examples name parameters as `-p name:=`; each must be a declared one."""
    for script, specs in SPECS.items():
        named = set(re.findall(r"-p ([a-z_.]+):=", usage(script)))
        assert "robot_description_file" in named
        assert named <= {spec.name for spec in specs}, (script, named)


@pytest.mark.parametrize(
    ("argv", "own"),
    [
        (["--help"], ["--help"]),
        (["--ros-args", "-p", "a:=1"], []),
        (["--ros-args", "--help"], []),  # ROS's (rcl's), not ours
        (["--ros-args", "-p", "a:=1", "--", "-h"], ["-h"]),  # `--` ends the ROS arguments
        (["x", "--ros-args", "-r", "a:=b", "--", "y", "--ros-args", "--", "z"], ["x", "y", "z"]),
    ],
)
def test_only_arguments_outside_ros_args_are_ours(argv, own):
    assert executables._own_arguments(argv) == own


def test_an_argument_outside_ros_args_is_refused_in_one_line(capsys):
    status = executables.run("kinematics_node", "no.such.module", ["my_robot.urdf"])
    assert status == executables.USAGE_ERROR
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "unexpected argument 'my_robot.urdf'" in err
    assert "--ros-args -p robot_description_file:=my_robot.urdf" in err


def test_help_after_ros_args_is_not_ours_and_the_node_module_is_run(capsys):
    """`--ros-args --help` goes on to the node (here a module that does not exist: the import is
    the proof that run() went past its own arguments)."""
    with pytest.raises(ModuleNotFoundError, match="no_such_module"):
        executables.run("kinematics_node", "no_such_module", ["--ros-args", "--help"])


# ----------------------------------------------------------------------------- installed


def _installed(name: str) -> Path:
    argv = executable(name)
    if argv is None:
        reason = f"{name} is not built here (make ros, then . build/ros/env.sh)"
        if os.environ.get("KINEMATICS_REQUIRE_ROS") == "1":
            pytest.fail(reason)
        pytest.skip(reason)
    return Path(argv[1])


def _installed_paths() -> dict[str, Path]:
    node = _installed("kinematics_node")
    prefix = node.parents[2]  # <prefix>/lib/kinematics_service/kinematics_node
    return {
        "kinematics_node": node,
        "sim_arm": _installed("sim_arm"),
        "servo": _installed("servo"),
        "kinematics": prefix / "bin" / "kinematics",
    }


@pytest.fixture
def foreign_python3(tmp_path: Path) -> str:
    """A PATH whose first `python3` is not the build's: it fails loudly if anything runs it."""
    fake = tmp_path / "bin" / "python3"
    fake.parent.mkdir()
    fake.write_text("#!/bin/sh\necho 'the python3 on PATH ran' >&2\nexit 97\n")
    fake.chmod(0o755)
    return f"{fake.parent}:/usr/bin:/bin"


@pytest.mark.parametrize("name", ["kinematics_node", "sim_arm", "servo", "kinematics"])
def test_the_installed_executable_runs_under_the_build_python_whatever_the_path(
    name, foreign_python3
):
    path = _installed_paths()[name]
    shebang = path.read_text(encoding="utf-8").splitlines()[0]
    interpreter = shebang.removeprefix("#!")
    assert Path(interpreter).is_absolute() and os.access(interpreter, os.X_OK), shebang
    if os.environ.get("KINEMATICS_ROS_PYTHON"):  # our PyPI build names the venv's Python
        assert Path(interpreter) == Path(os.environ["KINEMATICS_ROS_PYTHON"])
    out = subprocess.run(
        [str(path), "--help"],
        env={**os.environ, "PATH": foreign_python3},
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith(f"usage: {name} "), out.stdout[:200]


def test_the_installed_node_starts_ros_whatever_the_path(foreign_python3):
    """Beyond --help: rclpy starts and the node reads its parameters under that PATH (a refused
    parameter ends it at once, status 2, one line naming it)."""
    path = _installed_paths()["kinematics_node"]
    env = local_ros_env(base={**os.environ, "PATH": foreign_python3})
    out = subprocess.run(
        [str(path), "--ros-args", "-p", "twist_frame:=sideways"],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert out.returncode == 2, out.stderr
    assert "twist_frame" in out.stderr and "sideways" in out.stderr
    assert "Traceback" not in out.stderr


def _env_sh(variables: dict[str, str]) -> dict[str, str]:
    if not ENV_SH.is_file():
        reason = f"{ENV_SH} missing (make ros writes it)"
        if os.environ.get("KINEMATICS_REQUIRE_ROS") == "1":
            pytest.fail(reason)
        pytest.skip(reason)
    script = (
        f". {ENV_SH} && for c in kinematics_node sim_arm kinematics; do command -v $c; done "
        "&& echo range=$ROS_AUTOMATIC_DISCOVERY_RANGE domain=${ROS_DOMAIN_ID:-unset}"
    )
    out = subprocess.run(
        ["bash", "-c", script],
        env={"PATH": "/usr/bin:/bin", "HOME": "/nonexistent", **variables},
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert out.returncode == 0, out.stderr
    *found, settings = out.stdout.splitlines()
    return {"found": found, "settings": settings}


def test_env_sh_puts_the_executables_on_path_and_keeps_discovery_on_this_machine():
    paths = _installed_paths()
    got = _env_sh({})
    assert got["found"] == [str(paths[n]) for n in ("kinematics_node", "sim_arm", "kinematics")]
    assert got["settings"] == "range=LOCALHOST domain=unset"  # the user's domain: ROS's default


def test_env_sh_keeps_the_users_discovery_settings():
    got = _env_sh({"ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET", "ROS_DOMAIN_ID": "42"})
    assert got["settings"] == "range=SUBNET domain=42"


def test_the_installed_sim_arm_refuses_a_missing_description_file_in_one_line(tmp_path):
    path = _installed_paths()["sim_arm"]
    missing = tmp_path / "my_robot.urdf"
    out = subprocess.run(
        [str(path), "--ros-args", "-p", f"robot_description_file:={missing}"],
        env=local_ros_env(),
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert out.returncode == 2, out.stderr
    assert out.stderr == f"sim_arm: robot_description_file {str(missing)!r}: no such file\n"
