"""`kinematics ros`: the running nodes from a shell, where ros2cli is not at hand (it is not on
PyPI): print one `ee_pose`, `ee_twist` or `/diagnostics` message, call `compute_fk`,
`compute_jacobian` or `compute_ik` and print the answer, jog the arm through the servo from the
keyboard (teleop_twist_keyboard is not on PyPI either), or list, get and set a node's parameters
at run time (as `ros2 param` does: the tip of a description with a gripper).

    kinematics ros pose [--topic ee_pose] [--wait 10] [--json]
    kinematics ros twist [--topic ee_twist] [--wait 10] [--json]
    kinematics ros diagnostics [--node kinematics_node] [--topic /diagnostics] [--wait 10] [--json]
    kinematics ros fk [--q Q] [--tip LINK] [--links L1,L2] [--service compute_fk] [--wait 10]
                      [--json]
    kinematics ros jacobian [--q Q] [--tip LINK] [--frame world|space|body]
                            [--service compute_jacobian] [--wait 10] [--json]
    kinematics ros ik --target X,Y,Z,QX,QY,QZ,QW [--frame F] [--tip LINK] [--position-only]
                      [--timeout S] [--service compute_ik] [--wait 10] [--json]
    kinematics ros jog [--topic /servo/delta_twist_cmds] [--frame F] [--speed 0.05] [--turn 0.3]
                       [--rate 50] [--status /servo/status] [--keys-from-stdin] [--wait 10]
    kinematics ros param list|get|set NODE [NAME [VALUE]] [--wait 10]
    kinematics ros reach-markers MAP [--topic /reachability_map] [--frame BASE] [--once]

This module holds the arguments and imports no ROS: main.py adds the `ros` command with
`add_parser` and runs it with `run`; ROS is imported by `run`, through `ros.client`, only when the
command runs. The topic readers are in `ros_topics`, the service calls in `ros_services`. DDS settings come from the caller's environment (`ros.client` says why).
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import select
import sys
import time
from collections.abc import Callable, Iterator
from typing import Any

from ..ros.client import RosClient, RosClientError, missing_ros
from . import ros_markers, ros_services, ros_topics
from .jog import HELP, Jog

_EXAMPLES = """examples:
  kinematics ros pose                               # one ee_pose message of the running node
  kinematics ros pose --topic /arm/ee_pose --json
  kinematics ros twist                              # one ee_twist message
  kinematics ros diagnostics                        # the node's /diagnostics status
  kinematics ros fk --q 0,-1.2,1.4,0,0.5,0          # values in the order of the node's chain
  kinematics ros fk --q elbow_joint=0.5 --links wrist_1_link,tool0   # the rest: joint_states
  kinematics ros jacobian --q 0,-1.2,1.4,0,0.5,0 --frame body --json
  kinematics ros ik --target 0.4,0.1,0.4,1,0,0,0    # x,y,z [m], quaternion qx,qy,qz,qw
  kinematics ros ik --target 0.4,0.1,0.4,0,0,0,1 --position-only --tip tool0
  kinematics ros jog                                # keys w/s a/d r/f move, Shift turns, q quits
  kinematics ros jog --frame tool0 --speed 0.02     # along the tool's own axes
  kinematics ros param set kinematics_node tip_link tool0   # as `ros2 param set` (YAML values)
  kinematics ros param list kinematics_node
  kinematics ros reach-markers ur5e.h5              # the map's cubes for RViz, until Ctrl-C

Start the node first (kinematics_node --help; for jog, the servo: servo --help). The commands wait
up to --wait seconds for it and use this shell's ROS_DOMAIN_ID and ROS_AUTOMATIC_DISCOVERY_RANGE,
as every ROS 2 tool does."""


def _pose7(text: str) -> tuple[float, ...]:
    """argparse type of --target: 7 finite numbers, the quaternion not zero."""
    items = [item.strip() for item in text.split(",")]
    try:
        values = tuple(float(item) for item in items)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected 7 numbers x,y,z,qx,qy,qz,qw, got {text!r}"
        ) from None
    if len(values) != 7:
        raise argparse.ArgumentTypeError(
            f"expected 7 values x,y,z,qx,qy,qz,qw, got {len(values)}: {text!r}"
        )
    if not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"every value must be finite, got {text!r}")
    if not any(values[3:]):
        raise argparse.ArgumentTypeError(
            "the quaternion qx,qy,qz,qw is zero; give any non-zero quaternion (it is normalised)"
        )
    return values


def _positive(text: str, what: str = "number") -> float:
    """argparse type of --speed, --turn and --rate: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"expected a finite {what} > 0, got {text!r}")
    return value


def _seconds(text: str) -> float:
    """argparse type of --wait and --timeout: a finite number of seconds > 0."""
    return _positive(text, "number of seconds")


def add_parser(commands: Any) -> None:
    """Add the `ros` command (with `pose`, `ik`, `jog` and `param`) to main.py's subcommands."""
    ros = commands.add_parser(
        "ros",
        help="the running nodes over ROS 2: pose, twist, FK, Jacobian, IK, diagnostics, "
        "jogging, parameters",
        description="Talk to a running kinematics node or servo over ROS 2 (needs rclpy: a\n"
        "sourced ROS 2 workspace, or `. build/ros/env.sh` after `make ros`).",
        epilog=_EXAMPLES,
    )
    which = ros.add_subparsers(dest="ros_command", required=True, metavar="COMMAND")
    pose = which.add_parser(
        "pose",
        help="print one ee_pose message and exit",
        description="Print the next message on the node's ee_pose topic (geometry_msgs/"
        "PoseStamped) and exit;\nexit status 1 with what was seen when none comes in time.",
        epilog=_EXAMPLES,
    )
    pose.add_argument("--topic", default="ee_pose", help="topic to read (default: %(default)s)")
    twist = which.add_parser(
        "twist",
        help="print one ee_twist message and exit",
        description="Print the next message on the node's ee_twist topic (geometry_msgs/"
        "TwistStamped: the tip\norigin's velocity) and exit; exit status 1 with what was seen "
        "when none comes in time.",
        epilog=_EXAMPLES,
    )
    twist.add_argument("--topic", default="ee_twist", help="topic to read (default: %(default)s)")
    fk = which.add_parser(
        "fk",
        help="call compute_fk and print the pose(s)",
        description="Call the node's compute_fk service and print the tip's pose (and those of "
        "--links) in the\nnode's base_link; exit status 1 with the node's reason when it "
        "refuses.",
        epilog=_EXAMPLES,
    )
    jacobian = which.add_parser(
        "jacobian",
        help="call compute_jacobian and print the matrix",
        description="Call the node's compute_jacobian service and print the 6 x n Jacobian, rows "
        "in ROS order:\nlinear x, y, z, then angular x, y, z (as geometry_msgs/Twist); exit "
        "status 1 with the\nnode's reason when it refuses.",
        epilog=_EXAMPLES,
    )
    for command in (fk, jacobian):
        command.add_argument(
            "--q",
            metavar="Q",
            type=ros_services.joint_values,
            help="joint values [rad or m]: NAME=VALUE,... (the chain's other joints take the "
            "node's current joint_states) or VALUE,... in the order of the node's chain (named "
            "as compute_jacobian names them); default: the node's current joint_states",
        )
        command.add_argument("--tip", help="link (default: the node's tip_link)")
    fk.add_argument(
        "--links",
        type=lambda text: [link.strip() for link in text.split(",") if link.strip()],
        metavar="L1,L2",
        help="more links whose poses to print (compute_fk's link_names)",
    )
    jacobian.add_argument(
        "--frame",
        choices=("world", "space", "body"),
        default="world",
        help="world: base axes, tip origin; body: tip axes, tip origin; space: base axes, the "
        "body-fixed point at the base origin (default: %(default)s)",
    )
    fk.add_argument("--service", default="compute_fk", help="service (default: %(default)s)")
    jacobian.add_argument(
        "--service", default="compute_jacobian", help="service (default: %(default)s)"
    )
    ik = which.add_parser(
        "ik",
        help="call compute_ik and print the answer",
        description="Call the node's compute_ik service for a tip pose and print the joint\n"
        "values; exit status 1 when it finds no solution (its best is still printed).",
        epilog=_EXAMPLES,
    )
    ik.add_argument(
        "--target",
        metavar="X,Y,Z,QX,QY,QZ,QW",
        type=_pose7,
        required=True,
        help="tip pose: position [m], quaternion (normalised if not unit)",
    )
    ik.add_argument("--frame", help="frame of the target (default: the node's base_link)")
    ik.add_argument("--tip", help="link to place (default: the node's tip_link)")
    ik.add_argument("--position-only", action="store_true", help="ignore the target's orientation")
    ik.add_argument(
        "--timeout",
        type=_seconds,
        help="IK time budget [s] (default: the node's ik.timeout parameter)",
    )
    ik.add_argument("--service", default="compute_ik", help="service (default: %(default)s)")
    diagnostics = which.add_parser(
        "diagnostics",
        help="print the node's /diagnostics status and exit",
        description="Print the statuses of a node (its name, level, message and values) in the "
        "next /diagnostics\nmessage that has any, and exit; exit status 1 with what was seen "
        "when none comes in time.",
        epilog=_EXAMPLES,
    )
    diagnostics.add_argument(
        "--node",
        default="kinematics_node",
        help="the node: its name, in any namespace, or its full name /ns/name (default: "
        "%(default)s)",
    )
    diagnostics.add_argument(
        "--topic", default="/diagnostics", help="topic to read (default: %(default)s)"
    )
    jog = which.add_parser(
        "jog",
        help="jog the arm through the servo from the keyboard",
        description="Publish TwistStamped to the servo from the keyboard: " + HELP + ".\n"
        "A key's twist is sent at --rate for 0.6 s after its last press or repeat, so a held key\n"
        "moves the arm without a pause and a released one lets the servo stop it smoothly.\n"
        "It needs a terminal: without one (standard input a pipe, a file or /dev/null) it exits\n"
        "with status 1, unless --keys-from-stdin. The servo's status is shown as it changes.",
        epilog=_EXAMPLES,
    )
    jog.add_argument(
        "--topic",
        default="/servo/delta_twist_cmds",
        help="the servo's twist topic (default: %(default)s)",
    )
    jog.add_argument(
        "--frame", default="", help="frame_id of the twists: its axes (default: the servo's base)"
    )
    jog.add_argument(
        "--speed", type=_positive, default=0.05, help="linear speed [m/s] (default: %(default)s)"
    )
    jog.add_argument(
        "--turn", type=_positive, default=0.3, help="angular speed [rad/s] (default: %(default)s)"
    )
    jog.add_argument(
        "--rate", type=_positive, default=50.0, help="twists per second (default: %(default)s)"
    )
    jog.add_argument(
        "--status", default="/servo/status", help="the servo's status topic (default: %(default)s)"
    )
    jog.add_argument(
        "--keys-from-stdin",
        action="store_true",
        help="read keys from standard input even when it is not a terminal (a script's pipe): "
        "each character a key; at the end of input the last key's twist lapses, then it exits",
    )
    param = which.add_parser(
        "param",
        help="list, get or set a running node's parameters",
        description="A node's parameters at run time, as `ros2 param list|get|set` (ros2cli is "
        "not on PyPI).",
        epilog=_EXAMPLES,
    )
    actions = param.add_subparsers(dest="param_action", required=True, metavar="ACTION")
    listing = actions.add_parser("list", help="every parameter with its value")
    getting = actions.add_parser("get", help="one parameter's value")
    setting = actions.add_parser(
        "set",
        help="set one parameter",
        description="Set a parameter of a running node. VALUE is read as YAML, as ros2 param "
        "reads it:\ntrue, 3, 0.5, [1, 2], text. A value the node refuses: exit status 1 with "
        "its reason.",
    )
    markers = which.add_parser(
        "reach-markers",
        help="publish a reachability map's cubes (MarkerArray), transient local, for RViz",
        description="Publish a reachability map (kinematics reach --out) as a visualization_msgs/"
        "MarkerArray:\none cube per voxel with D > 0, coloured by D, offered transient local so "
        "that RViz\nstarted later gets it too. Stays up until Ctrl-C, or with --once until a "
        "subscriber has it.",
        epilog=_EXAMPLES,
    )
    markers.add_argument("map", metavar="MAP", help="the map file")
    markers.add_argument(
        "--topic", default="/reachability_map", help="topic (default: %(default)s)"
    )
    markers.add_argument("--frame", metavar="FRAME", help="frame_id (default: the map's base link)")
    markers.add_argument(
        "--once", action="store_true", help="exit once a subscriber has the map (waits --wait)"
    )
    for action in (listing, getting, setting):
        action.add_argument("node", metavar="NODE", help="the node's name, e.g. kinematics_node")
    for action in (getting, setting):
        action.add_argument("name", metavar="NAME", help="the parameter")
    setting.add_argument("value", metavar="VALUE", help="its new value (YAML)")
    for command in (
        pose,
        twist,
        fk,
        jacobian,
        ik,
        diagnostics,
        jog,
        listing,
        getting,
        setting,
        markers,
    ):
        command.add_argument(
            "--wait",
            type=_seconds,
            default=10.0,
            help="how long to wait for the node [s] (default: %(default)s)",
        )
    for command in (pose, twist, fk, jacobian, ik, diagnostics):
        command.add_argument("--json", action="store_true", help="JSON output")


def run(args: argparse.Namespace, emit: Callable[[str], None] = print) -> int:
    """Run `kinematics ros <args.ros_command>`; the exit status.

    Raises:
        RosClientError: ROS 2 is missing, or the node did not answer (the message says what was
            seen and what to do); main.py prints it as one line, status 1.
    """
    command, needs = {
        "pose": (ros_topics.pose, ("geometry_msgs.msg",)),
        "twist": (ros_topics.twist, ("geometry_msgs.msg",)),
        "diagnostics": (ros_topics.diagnostics, ("diagnostic_msgs.msg",)),
        "fk": (ros_services.fk, ("kinematics_service.srv",)),
        "jacobian": (ros_services.jacobian, ("kinematics_service.srv",)),
        "ik": (ros_services.ik, ("kinematics_service.srv",)),
        "jog": (_jog, ("geometry_msgs.msg", "diagnostic_msgs.msg")),
        "param": (_param, ("rcl_interfaces.srv",)),
        "reach-markers": (ros_markers.reach_markers, ("visualization_msgs.msg",)),
    }[args.ros_command]
    if args.ros_command == "jog" and not (args.keys_from_stdin or _stdin_is_a_terminal()):
        # before ROS starts and before the banner: without a terminal there are no keys to jog
        # with (`< /dev/null` ended at once, status 0, as if the user had quit)
        raise RosClientError(
            "kinematics ros jog reads keys from a terminal, and standard input is not one (a "
            "pipe, a file or /dev/null): run it in a terminal, or give --keys-from-stdin to take "
            "keys from standard input as they come"
        )
    reason = missing_ros(needs)
    if reason is not None:
        raise RosClientError(f"kinematics ros {args.ros_command} {reason}")
    with RosClient() as client:
        return command(client, args, emit)


def _stdin_is_a_terminal() -> bool:
    try:
        return sys.stdin is not None and os.isatty(sys.stdin.fileno())
    except (OSError, ValueError):  # closed, or not a file (replaced by a test harness)
        return False


def _param(client: RosClient, args: argparse.Namespace, emit: Callable[[str], None]) -> int:
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import GetParameters, ListParameters, SetParameters
    from rclpy.parameter import get_parameter_value, parameter_value_to_python

    node = args.node if args.node.startswith("/") else "/" + args.node

    def call(srv_type: Any, service: str, request: Any) -> Any:
        return client.call(srv_type, f"{node}/{service}", request, args.wait, args.wait)

    def get(names: list[str]) -> list[Any]:
        request = GetParameters.Request()
        request.names = names
        values = list(call(GetParameters, "get_parameters", request).values)
        # a node answers an undeclared name with NOT_SET, or (rclpy) with no values at all
        return values if len(values) == len(names) else [ParameterValue()] * len(names)

    if args.param_action == "set":
        value = _typed_as(get_parameter_value(args.value), get([args.name])[0], args.value)
        request = SetParameters.Request()
        request.parameters = [Parameter(name=args.name, value=value)]
        (result,) = call(SetParameters, "set_parameters", request).results
        if not result.successful:
            raise RosClientError(
                f"{node} refused {args.name} = {args.value}: {result.reason or 'no reason given'}"
            )
        emit(f"{node}: {args.name} set to {args.value}")
        return 0
    if args.param_action == "list":
        request = ListParameters.Request()
        names = sorted(call(ListParameters, "list_parameters", request).result.names)
    else:
        names = [args.name]
    rows = []
    for name, value in zip(names, get(names), strict=True):
        if value.type == ParameterType.PARAMETER_NOT_SET:
            if args.param_action == "get":
                raise RosClientError(f"{node} has no parameter {name!r}")
            continue
        rows.append(f"{name}: {_shown(parameter_value_to_python(value))}")
    emit("\n".join(rows))
    return 0


def _typed_as(value: Any, current: Any, text: str) -> Any:
    """`value` (read as YAML) in the type of the parameter's `current` value where YAML read the
    text otherwise but it fits: 1 for a double is 1.0 (ros2 param set refuses it: "expected
    'Type.DOUBLE' got 'Type.INTEGER'"), so is nan or inf (then the node says why it refuses
    them, not that they are text), and 42 or true for a string is the text. Else unchanged: the
    node judges it."""
    from rcl_interfaces.msg import ParameterType as T
    from rcl_interfaces.msg import ParameterValue

    if current.type == T.PARAMETER_DOUBLE and value.type == T.PARAMETER_INTEGER:
        return ParameterValue(type=T.PARAMETER_DOUBLE, double_value=float(value.integer_value))
    if current.type == T.PARAMETER_DOUBLE and value.type == T.PARAMETER_STRING:
        try:  # nan, inf (YAML reads them as text): a double, for the node to judge
            return ParameterValue(type=T.PARAMETER_DOUBLE, double_value=float(text))
        except ValueError:
            return value
    if current.type == T.PARAMETER_DOUBLE_ARRAY and value.type == T.PARAMETER_INTEGER_ARRAY:
        doubles = [float(v) for v in value.integer_array_value]
        return ParameterValue(type=T.PARAMETER_DOUBLE_ARRAY, double_array_value=doubles)
    if current.type == T.PARAMETER_STRING and value.type != T.PARAMETER_STRING:
        return ParameterValue(type=T.PARAMETER_STRING, string_value=text)
    return value


def _shown(value: Any) -> str:
    """A parameter's value on one line: a long text (a robot description) by its length."""
    if isinstance(value, str):
        if "\n" in value or len(value) > 100:
            return f"<text of {len(value)} characters>"
        return value if value else "''"
    return repr(value.tolist() if hasattr(value, "tolist") else value)


@contextlib.contextmanager
def _keys_as_typed(fd: int) -> Iterator[None]:
    """A terminal on `fd` delivers each key as it is typed, unechoed (cbreak mode: Ctrl-C still
    interrupts), and is restored after; anything else (a pipe) is left alone."""
    if not os.isatty(fd):
        yield
        return
    import termios
    import tty

    saved = termios.tcgetattr(fd)
    try:
        tty.setcbreak(fd)
        yield
    finally:
        termios.tcsetattr(fd, termios.TCSADRAIN, saved)


def _jog(client: RosClient, args: argparse.Namespace, emit: Callable[[str], None]) -> int:
    from diagnostic_msgs.msg import DiagnosticStatus
    from geometry_msgs.msg import TwistStamped

    topic = client.resolve(args.topic)
    publisher = client.node.create_publisher(TwistStamped, args.topic, 10)
    said: list[str] = []

    def on_status(msg: Any) -> None:  # each change of its code (messages carry changing figures)
        code = {kv.key: kv.value for kv in msg.values}.get("code_name", msg.message)
        if not said or said[-1] != code:
            said.append(code)
            emit(f"servo: {msg.message}")

    client.node.create_subscription(DiagnosticStatus, args.status, on_status, 10)
    deadline = time.monotonic() + args.wait
    while publisher.get_subscription_count() == 0:
        if time.monotonic() >= deadline:
            raise RosClientError(
                f"nothing subscribes to {topic} within {args.wait:g} s: is the servo running "
                f"(servo --help), with the same ROS_DOMAIN_ID and discovery range as this "
                f"shell? {client.graph_seen()}"
            )
        client.spin_once(0.05)
    jog = Jog(speed=args.speed, turn=args.turn)
    frame = args.frame
    emit(f"jogging through {topic} in {frame or 'the servo base'}'s axes: {HELP}")
    fd = sys.stdin.fileno()
    period = 1.0 / args.rate
    due = time.monotonic()
    ended = False  # no more keys (end of input)
    with _keys_as_typed(fd):
        while not jog.quit and not (ended and jog.current(time.monotonic()) is None):
            wait = max(0.0, due - time.monotonic())
            if ended:  # no keys to wait for: only the held twist's schedule
                time.sleep(wait)
            elif select.select([fd], [], [], wait)[0]:
                data = os.read(fd, 64)
                ended = not data
                for key in data.decode(errors="replace"):
                    line = jog.press(key, time.monotonic())
                    if line:
                        emit(line)
            now = time.monotonic()
            if now >= due:
                twist = jog.current(now)
                if twist is not None:
                    publisher.publish(_twist_msg(TwistStamped, client, frame, twist))
                due = max(due + period, now)
            client.spin_once(0.0)
    return 0


def _twist_msg(kind: Any, client: RosClient, frame: str, twist: tuple[float, ...]) -> Any:
    msg = kind()
    msg.header.stamp = client.node.get_clock().now().to_msg()
    msg.header.frame_id = frame
    a, v = msg.twist.angular, msg.twist.linear
    a.x, a.y, a.z, v.x, v.y, v.z = (float(x) for x in twist)
    return msg
