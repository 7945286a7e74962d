"""The launch files' node parameters, without ROS 2 launch (not on PyPI): each launch file runs
against small stand-ins of `launch`, `launch_ros` and `ament_index_python` that record the nodes it
starts, and the kinematics node's parameters are checked against the parameters it declares.
(Where ROS 2 launch is installed, test/launch/ runs the real thing.)"""

from __future__ import annotations

import importlib.util
import os
import sys
import types
from pathlib import Path
from typing import Any

import pytest

from kinematics_node.service.parameters import SPECS, validate_parameters

ROOT = Path(__file__).resolve().parents[2]
SHARE = "/opt/ros/share/kinematics_service"


class _Substitution:
    def __init__(self, *parts: Any, **kwargs: Any) -> None:
        self.parts, self.kwargs = parts, kwargs


class _LaunchConfiguration(_Substitution):
    def perform(self, context: dict[str, str]) -> str:
        return context[self.parts[0]]


class _PathJoin(_Substitution):
    def perform(self, context: dict[str, str]) -> str:
        return os.path.join(
            *(p if isinstance(p, str) else p.perform(context) for p in self.parts[0])
        )


class _FindPackageShare(_Substitution):
    def perform(self, context: dict[str, str]) -> str:
        return SHARE


class _Action(_Substitution):
    """DeclareLaunchArgument, OpaqueFunction, Node, LaunchDescription, IfCondition, ..."""


def _stand_ins() -> dict[str, types.ModuleType]:
    modules: dict[str, types.ModuleType] = {}
    content = {
        "launch": {"LaunchDescription": _Action},
        "launch.actions": {"DeclareLaunchArgument": _Action, "OpaqueFunction": _Action},
        "launch.conditions": {"IfCondition": _Action},
        "launch.substitutions": {
            "LaunchConfiguration": _LaunchConfiguration,
            "PathJoinSubstitution": _PathJoin,
        },
        "launch_ros": {},
        "launch_ros.actions": {"Node": _Action},
        "launch_ros.parameter_descriptions": {"ParameterValue": _Substitution},
        "launch_ros.substitutions": {"FindPackageShare": _FindPackageShare},
        "ament_index_python": {},
        "ament_index_python.packages": {"get_package_share_directory": lambda package: SHARE},
    }
    for name, attributes in content.items():
        module = types.ModuleType(name)
        module.__dict__.update(attributes)
        modules[name] = module
    return modules


def _load(monkeypatch: pytest.MonkeyPatch, filename: str) -> Any:
    for name, module in _stand_ins().items():
        monkeypatch.setitem(sys.modules, name, module)
    spec = importlib.util.spec_from_file_location(
        filename.replace(".", "_"), ROOT / "launch" / filename
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _kinematics_parameters(nodes: list[_Action]) -> dict[str, Any]:
    """The parameter overrides (dicts, after the parameter file) of the one kinematics node."""
    (node,) = [n for n in nodes if n.kwargs.get("executable") == "kinematics_node"]
    assert node.kwargs["package"] == "kinematics_service"
    merged: dict[str, Any] = {}
    for entry in node.kwargs["parameters"]:
        if isinstance(entry, dict):
            merged.update(entry)
    return merged


def _check_declared(params: dict[str, Any]) -> None:
    assert set(params) <= set(SPECS), set(params) - set(SPECS)
    assert validate_parameters(params) is None


def _arguments(module: Any) -> dict[str, str]:
    """The launch file's declared arguments with their defaults."""
    description = module.generate_launch_description()
    (entities,) = description.parts
    return {
        a.parts[0]: a.kwargs.get("default_value", "")
        for a in entities
        if a.parts and isinstance(a.parts[0], str)
    }


def test_kinematics_launch_passes_the_file_and_xacro_args_as_parameters(monkeypatch, tmp_path):
    module = _load(monkeypatch, "kinematics.launch.py")
    arguments = _arguments(module)
    assert {"description_file", "xacro_args", "base_link", "tip_link"} <= set(arguments)
    monkeypatch.chdir(tmp_path)
    context = {
        **arguments,
        "description_file": "robots/arm.urdf.xacro",  # relative to where `ros2 launch` runs
        "xacro_args": "prefix:=left_ name:=arm",
        "tip_link": "tool0",
        "params_file": "params.yaml",
        "namespace": "",
    }
    params = _kinematics_parameters(module._kinematics_node(context))
    assert params == {
        "robot_description_file": str(tmp_path / "robots" / "arm.urdf.xacro"),
        "xacro_args": "prefix:=left_ name:=arm",
        "tip_link": "tool0",
    }
    _check_declared(params)
    # nothing given: the parameter file decides (the topic, by default)
    context |= {"description_file": "", "xacro_args": "", "tip_link": ""}
    assert _kinematics_parameters(module._kinematics_node(context)) == {}


@pytest.mark.parametrize("robot", ["ur5e", "panda"])
def test_sim_arm_launch_gives_the_node_the_bundled_file(monkeypatch, robot):
    module = _load(monkeypatch, "sim_arm.launch.py")
    monkeypatch.setattr(module, "get_package_share_directory", lambda package: str(ROOT))
    arguments = _arguments(module)
    nodes = module._nodes({**arguments, "robot": robot})
    params = _kinematics_parameters(nodes)
    _check_declared(params)
    assert params["robot_description_file"] == str(ROOT / "config" / "robots" / f"{robot}.urdf")
    assert "robot_description" not in params  # the file, not its text (one source)
    sim, _ = _node_parameters(nodes, "sim_arm")
    assert sim == {"robot": robot, "rate": float(arguments["rate"])}  # every joint, demo motion
    (rsp,) = [n for n in nodes if n.kwargs.get("executable") == "robot_state_publisher"]
    (rsp_params,) = rsp.kwargs["parameters"]
    text = rsp_params["robot_description"].parts[0]  # robot_state_publisher takes the XML
    assert text == (ROOT / "config" / "robots" / f"{robot}.urdf").read_text(encoding="utf-8")


def _node_parameters(nodes: list[_Action], executable: str) -> tuple[dict[str, Any], list[str]]:
    """(the merged parameter dicts, the parameter files) of the one node running `executable`."""
    (node,) = [n for n in nodes if n.kwargs.get("executable") == executable]
    merged: dict[str, Any] = {}
    files = []
    for entry in node.kwargs["parameters"]:
        if isinstance(entry, dict):
            merged.update(entry)
        else:
            files.append(entry)
    return merged, files


@pytest.mark.parametrize("robot", ["ur5e", "panda", "iiwa14", "scara", "planar3r"])
@pytest.mark.parametrize("out_type", ["position", "trajectory"])
def test_servo_launch_drives_one_chain_with_sim_arm_kinematics_node_and_servo(
    monkeypatch, robot, out_type
):
    """servo.launch.py: the sim arm simulates every joint robot_state_publisher needs (a Panda's
    finger too) and takes what the servo sends for the chain's joints (same form, the chain's
    joints in chain order: a Float64MultiArray fits), every parameter is declared and valid, and
    the arm starts well-conditioned at its `READY` positions."""
    import numpy as np

    from kinematics_node.ros.executables import SIM_ARM_PARAMETERS
    from kinematics_node.service.servo_parameters import SERVO_SPECS, validate_servo_parameters
    from kinematics_node.sim.arm import urdf_actuated_joints
    from kinematics_node.sim.robots import load_robot

    module = _load(monkeypatch, "servo.launch.py")
    monkeypatch.setattr(module, "get_package_share_directory", lambda package: str(ROOT))
    arguments = _arguments(module)
    assert {"robot", "base_link", "tip_link", "command_out_type", "period", "rviz"} <= set(
        arguments
    )
    nodes = module._nodes({**arguments, "robot": robot, "command_out_type": out_type})
    kinematics = _kinematics_parameters(nodes)
    _check_declared(kinematics)
    servo, files = _node_parameters(nodes, "servo")
    assert set(servo) <= set(SERVO_SPECS) and validate_servo_parameters(servo) is None
    assert files == [os.path.join(str(ROOT), "config", "servo.yaml")] and os.path.isfile(files[0])
    assert servo["period_s"] == float(arguments["period"]) <= 0.001  # 1 kHz by default
    sim, _ = _node_parameters(nodes, "sim_arm")
    assert servo["thread_priority"] == sim["thread_priority"] == 0  # the default scheduling
    assert set(sim) <= {spec.name for spec in SIM_ARM_PARAMETERS}
    assert sim["command_mode"] == servo["command_out_type"] == out_type
    for key in ("robot_description_file", "base_link", "tip_link"):
        assert kinematics[key] == servo[key]
    # sim_arm: every moving joint without <mimic>, as robot_state_publisher needs them
    assert "tip_link" not in sim and sim["robot"] == robot
    names, lower, upper, _ = urdf_actuated_joints(servo["robot_description_file"])
    chain = load_robot(robot, servo["base_link"], servo["tip_link"])
    assert sim["command_joints"].split() == list(chain.joint_names)
    assert len(names) == chain.dof + (robot == "panda")  # the Panda's finger_joint1
    q = np.array(sim["initial_positions"])
    assert q.shape == (len(names),) and np.all((lower <= q) & (q <= upper))
    q_chain = q[[names.index(n) for n in chain.joint_names]]
    np.testing.assert_array_equal(q_chain, module.READY[robot])
    assert chain.within_limits(q_chain, tolerance=-0.1)


@pytest.mark.parametrize(
    ("given", "servo_priority", "sim_priority"),
    [("40", 40, 50), ("1", 1, 11), ("95", 95, 99), ("99", 99, 99)],
)
def test_servo_launch_thread_priority_raises_the_servo_and_the_sim_arm_above_it(
    monkeypatch, given, servo_priority, sim_priority
):
    """thread_priority:=N: the servo's thread SCHED_FIFO at N, sim_arm's (controller_manager's
    stand-in) 10 above it within 99, both values the nodes accept."""
    from kinematics_node.ros.executables import SIM_ARM_PARAMETERS
    from kinematics_node.service.servo_parameters import validate_servo_parameters

    module = _load(monkeypatch, "servo.launch.py")
    monkeypatch.setattr(module, "get_package_share_directory", lambda package: str(ROOT))
    arguments = _arguments(module)
    assert arguments["thread_priority"] == "0"
    nodes = module._nodes({**arguments, "thread_priority": given})
    servo, _ = _node_parameters(nodes, "servo")
    sim, _ = _node_parameters(nodes, "sim_arm")
    assert (servo["thread_priority"], sim["thread_priority"]) == (servo_priority, sim_priority)
    assert validate_servo_parameters(servo) is None
    (spec,) = [s for s in SIM_ARM_PARAMETERS if s.name == "thread_priority"]
    assert spec.minimum <= sim["thread_priority"] <= spec.maximum
    kinematics = _kinematics_parameters(nodes)
    assert "thread_priority" not in kinematics  # the kinematics node keeps the default


@pytest.mark.parametrize("given", ["-1", "100", "forty", "4.5", ""])
def test_servo_launch_refuses_a_bad_thread_priority_naming_it(monkeypatch, given):
    module = _load(monkeypatch, "servo.launch.py")
    monkeypatch.setattr(module, "get_package_share_directory", lambda package: str(ROOT))
    with pytest.raises(RuntimeError, match="thread_priority must be an integer 0-99"):
        module._nodes({**_arguments(module), "thread_priority": given})


def test_servo_launch_on_another_chain_commands_that_chain(monkeypatch):
    """A chain of the user's (the Panda to its flange): the servo's joints are the ones commanded,
    and the arm starts in the middle of its limits (`READY` is for the default chain)."""
    module = _load(monkeypatch, "servo.launch.py")
    monkeypatch.setattr(module, "get_package_share_directory", lambda package: str(ROOT))
    context = {**_arguments(module), "robot": "panda", "tip_link": "panda_link8"}
    nodes = module._nodes(context)
    sim, _ = _node_parameters(nodes, "sim_arm")
    servo, _ = _node_parameters(nodes, "servo")
    assert servo["tip_link"] == "panda_link8" and servo["base_link"] == "panda_link0"
    assert sim["command_joints"].split() == [f"panda_joint{k}" for k in range(1, 8)]
    assert "initial_positions" not in sim


def test_launch_files_find_their_helper_beside_them_wherever_installed(monkeypatch, tmp_path):
    """`ros2 launch` runs a launch file from share/kinematics_service/launch, which is not on
    sys.path (nor the working directory): the helper bundled_robot.py is loaded from beside the
    launch file, not from the repository."""
    import shutil

    share = tmp_path / "share" / "kinematics_service"
    shutil.copytree(ROOT / "launch", share / "launch")
    shutil.copytree(ROOT / "config", share / "config")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "path", [p for p in sys.path if Path(p or ".").resolve() != ROOT])
    for filename in ("sim_arm.launch.py", "servo.launch.py"):
        for name, stand_in in _stand_ins().items():
            monkeypatch.setitem(sys.modules, name, stand_in)
        spec = importlib.util.spec_from_file_location("launch_file", share / "launch" / filename)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        assert Path(module.bundled_robot.__file__) == share / "launch" / "bundled_robot.py"
        monkeypatch.setattr(module, "get_package_share_directory", lambda package: str(share))
        nodes = module._nodes({**_arguments(module), "robot": "panda"})
        params = _kinematics_parameters(nodes)
        assert params["robot_description_file"] == str(share / "config" / "robots" / "panda.urdf")


def _own_robot(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> str:
    """A user's description (the Panda's file under a name of the user's, with its gripper's
    several leaves), given relative to where `ros2 launch` runs."""
    (tmp_path / "robots").mkdir()
    (tmp_path / "robots" / "my_arm.urdf").write_text(
        (ROOT / "config" / "robots" / "panda.urdf").read_text(encoding="utf-8"), encoding="utf-8"
    )
    monkeypatch.chdir(tmp_path)
    return "robots/my_arm.urdf"


def test_sim_arm_launch_runs_the_users_own_description(monkeypatch, tmp_path):
    """description_file: every node reads the user's file (absolute, from where the launch ran),
    sim_arm simulates it (no bundled `robot`), robot_state_publisher gets its XML, and the
    chain is left to the nodes (empty base and tip, as without launch)."""
    from kinematics_node.ros.executables import SIM_ARM_PARAMETERS

    module = _load(monkeypatch, "sim_arm.launch.py")
    monkeypatch.setattr(module, "get_package_share_directory", lambda package: str(ROOT))
    own = _own_robot(tmp_path, monkeypatch)
    arguments = _arguments(module)
    assert arguments["description_file"] == "" and arguments["xacro_args"] == ""
    nodes = module._nodes({**arguments, "description_file": own})
    path = str(tmp_path / "robots" / "my_arm.urdf")
    kinematics = _kinematics_parameters(nodes)
    _check_declared(kinematics)
    assert kinematics == {"robot_description_file": path, "base_link": "", "tip_link": ""}
    sim, _ = _node_parameters(nodes, "sim_arm")
    assert sim == {"robot_description_file": path, "rate": float(arguments["rate"])}
    assert set(sim) <= {spec.name for spec in SIM_ARM_PARAMETERS}
    (rsp,) = [n for n in nodes if n.kwargs.get("executable") == "robot_state_publisher"]
    (rsp_params,) = rsp.kwargs["parameters"]
    assert rsp_params["robot_description"].parts[0] == Path(path).read_text(encoding="utf-8")
    (rviz,) = [n for n in nodes if n.kwargs.get("executable") == "rviz2"]
    assert rviz.kwargs["arguments"][-1] == "panda_link0"  # the description's root


def test_a_missing_own_description_is_refused_naming_it(monkeypatch, tmp_path):
    module = _load(monkeypatch, "sim_arm.launch.py")
    monkeypatch.setattr(module, "get_package_share_directory", lambda package: str(ROOT))
    monkeypatch.chdir(tmp_path)
    with pytest.raises(RuntimeError, match="description_file: .*nowhere.urdf.*no such file"):
        module._nodes({**_arguments(module), "description_file": "nowhere.urdf"})


def test_servo_launch_on_the_users_own_description_needs_its_tip_and_then_drives_it(
    monkeypatch, tmp_path
):
    """With several tips the launch stops naming them (the nodes would wait for one); with
    tip_link, the servo drives that chain, and sim_arm takes its joints' commands and simulates
    the rest too (the finger), starting in the middle of the limits."""
    from kinematics_node.service.servo_parameters import validate_servo_parameters

    module = _load(monkeypatch, "servo.launch.py")
    monkeypatch.setattr(module, "get_package_share_directory", lambda package: str(ROOT))
    own = _own_robot(tmp_path, monkeypatch)
    context = {**_arguments(module), "description_file": own}
    with pytest.raises(RuntimeError, match="tip_link.*panda_hand_tcp"):
        module._nodes(context)
    nodes = module._nodes({**context, "tip_link": "panda_hand_tcp"})
    servo, _ = _node_parameters(nodes, "servo")
    sim, _ = _node_parameters(nodes, "sim_arm")
    path = str(tmp_path / "robots" / "my_arm.urdf")
    assert servo["robot_description_file"] == sim["robot_description_file"] == path
    assert servo["tip_link"] == "panda_hand_tcp" and validate_servo_parameters(servo) is None
    assert sim["command_joints"].split() == [f"panda_joint{k}" for k in range(1, 8)]
    assert "initial_positions" not in sim and "robot" not in sim


def test_own_xacro_description_and_its_arguments_reach_every_node(monkeypatch, tmp_path):
    pytest.importorskip("xacro", reason="xacro descriptions need the xacro extra")
    module = _load(monkeypatch, "sim_arm.launch.py")
    monkeypatch.setattr(module, "get_package_share_directory", lambda package: str(ROOT))
    monkeypatch.chdir(tmp_path)
    text = (ROOT / "config" / "robots" / "ur5e.urdf").read_text(encoding="utf-8")
    xacro_robot = '<robot xmlns:xacro="http://www.ros.org/wiki/xacro" name="$(arg name)">'
    xacro_robot += '<xacro:arg name="name" default="arm"/>'
    assert '<robot name="ur5e">' in text
    (tmp_path / "arm.urdf.xacro").write_text(
        text.replace('<robot name="ur5e">', xacro_robot, 1), encoding="utf-8"
    )
    nodes = module._nodes(
        {**_arguments(module), "description_file": "arm.urdf.xacro", "xacro_args": "name:=mine"}
    )
    sim, _ = _node_parameters(nodes, "sim_arm")
    assert sim["xacro_args"] == "name:=mine"
    assert _kinematics_parameters(nodes)["xacro_args"] == "name:=mine"
    (rsp,) = [n for n in nodes if n.kwargs.get("executable") == "robot_state_publisher"]
    (rsp_params,) = rsp.kwargs["parameters"]
    xml = rsp_params["robot_description"].parts[0]
    assert '<robot name="mine"' in xml and "xacro:" not in xml  # expanded for the publisher


@pytest.mark.parametrize("filename", ["sim_arm.launch.py", "servo.launch.py"])
def test_state_publisher_chooses_robot_state_publisher_or_the_kinematics_nodes_tf(
    monkeypatch, filename
):
    """state_publisher: robot_state_publisher by default (the nodes as before: no publish_tf);
    kinematics_node starts no robot_state_publisher and gives the kinematics node publish_tf,
    a parameter it declares and accepts. Nothing else changes."""
    module = _load(monkeypatch, filename)
    monkeypatch.setattr(module, "get_package_share_directory", lambda package: str(ROOT))
    arguments = _arguments(module)
    assert arguments["state_publisher"] == "robot_state_publisher"
    before = module._nodes({**arguments, "robot": "panda"})
    assert [n.kwargs["executable"] for n in before].count("robot_state_publisher") == 1
    assert "publish_tf" not in _kinematics_parameters(before)
    ours = module._nodes({**arguments, "robot": "panda", "state_publisher": "kinematics_node"})
    assert "robot_state_publisher" not in [n.kwargs["executable"] for n in ours]
    params = _kinematics_parameters(ours)
    assert params == {**_kinematics_parameters(before), "publish_tf": True}
    _check_declared(params)
    rest = [n.kwargs for n in before if n.kwargs["executable"] != "robot_state_publisher"]
    assert [n.kwargs["executable"] for n in ours] == [n["executable"] for n in rest]
    for node, kwargs in zip(ours, rest, strict=True):
        if kwargs["executable"] != "kinematics_node":  # sim_arm (the finger too), servo, RViz
            assert _comparable(node.kwargs) == _comparable(kwargs)


def _comparable(kwargs: dict[str, Any]) -> dict[str, Any]:
    """A node's arguments with its condition (IfCondition(LaunchConfiguration(name))) as the
    name it reads, so that two launches' nodes compare by value."""
    condition = kwargs.get("condition")
    if condition is None:
        return kwargs
    (configuration,) = condition.parts
    return {**kwargs, "condition": (type(condition), configuration.parts)}


@pytest.mark.parametrize("given", ["rsp", "node", "", "Kinematics_Node"])
def test_a_bad_state_publisher_is_refused_naming_the_choices(monkeypatch, given):
    module = _load(monkeypatch, "sim_arm.launch.py")
    monkeypatch.setattr(module, "get_package_share_directory", lambda package: str(ROOT))
    with pytest.raises(
        RuntimeError, match="state_publisher must be robot_state_publisher or kinematics_node"
    ):
        module._nodes({**_arguments(module), "state_publisher": given})
