"""`kinematics ros`: the running nodes from a shell, where ros2cli is not at hand (it is not on
PyPI): print one `ee_pose` message, call `compute_ik` and print the answer, jog the arm through
the servo from the keyboard (teleop_twist_keyboard is not on PyPI either), or list, get and set a
node's parameters at run time (as `ros2 param` does: the tip of a description with a gripper).

    kinematics ros pose [--topic ee_pose] [--wait 10] [--json]
    kinematics ros ik --target X,Y,Z,QX,QY,QZ,QW [--frame F] [--tip LINK] [--position-only]
                      [--timeout S] [--service compute_ik] [--wait 10] [--json]
    kinematics ros jog [--topic /servo/delta_twist_cmds] [--frame F] [--speed 0.05] [--turn 0.3]
                       [--rate 50] [--status /servo/status] [--keys-from-stdin] [--wait 10]
    kinematics ros param list|get|set NODE [NAME [VALUE]] [--wait 10]

This module holds the arguments and the words and imports no ROS: main.py adds the `ros` command
with `add_parser` and runs it with `run`; ROS is imported by `run`, through `ros.client`, only
when the command runs. DDS settings come from the caller's environment (`ros.client` says why).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import select
import sys
import time
from collections.abc import Callable, Iterator
from typing import Any

from ..ros.client import RosClient, RosClientError, missing_ros
from .jog import HELP, Jog

_EXAMPLES = """examples:
  kinematics ros pose                               # one ee_pose message of the running node
  kinematics ros pose --topic /arm/ee_pose --json
  kinematics ros ik --target 0.4,0.1,0.4,1,0,0,0    # x,y,z [m], quaternion qx,qy,qz,qw
  kinematics ros ik --target 0.4,0.1,0.4,0,0,0,1 --position-only --tip tool0
  kinematics ros jog                                # keys w/s a/d r/f move, Shift turns, q quits
  kinematics ros jog --frame tool0 --speed 0.02     # along the tool's own axes
  kinematics ros param set kinematics_node tip_link tool0   # as `ros2 param set` (YAML values)
  kinematics ros param list kinematics_node

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
        help="the running nodes over ROS 2: the pose, an IK call, jogging, parameters",
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
    for action in (listing, getting, setting):
        action.add_argument("node", metavar="NODE", help="the node's name, e.g. kinematics_node")
    for action in (getting, setting):
        action.add_argument("name", metavar="NAME", help="the parameter")
    setting.add_argument("value", metavar="VALUE", help="its new value (YAML)")
    for command in (pose, ik, jog, listing, getting, setting):
        command.add_argument(
            "--wait",
            type=_seconds,
            default=10.0,
            help="how long to wait for the node [s] (default: %(default)s)",
        )
    for command in (pose, ik):
        command.add_argument("--json", action="store_true", help="JSON output")


def run(args: argparse.Namespace, emit: Callable[[str], None] = print) -> int:
    """Run `kinematics ros <args.ros_command>`; the exit status.

    Raises:
        RosClientError: ROS 2 is missing, or the node did not answer (the message says what was
            seen and what to do); main.py prints it as one line, status 1.
    """
    command, needs = {
        "pose": (_pose, ("geometry_msgs.msg",)),
        "ik": (_ik, ("kinematics_service.srv",)),
        "jog": (_jog, ("geometry_msgs.msg", "diagnostic_msgs.msg")),
        "param": (_param, ("rcl_interfaces.srv",)),
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


def _stamp(header: Any) -> str:
    return f"{header.stamp.sec}.{header.stamp.nanosec:09d}"


def _pose(client: RosClient, args: argparse.Namespace, emit: Callable[[str], None]) -> int:
    from geometry_msgs.msg import PoseStamped

    msg = client.first_message(PoseStamped, args.topic, args.wait)
    topic = client.resolve(args.topic)
    if msg is None:
        publishers = client.publishers(args.topic)
        if publishers == 0:
            why = (
                f"nothing publishes it. Is kinematics_node running, started with the same "
                f"ROS_DOMAIN_ID and discovery range as this shell? {client.graph_seen()}"
            )
        else:
            joint_states = client.publishers("joint_states")
            why = (
                f"{publishers} node(s) offer it but sent nothing: the node publishes a pose for "
                "each joint_states message that names every joint of its chain, once it has a "
                f"robot description and a tip link ({joint_states} publisher(s) of "
                f"{client.resolve('joint_states')}); its log says what it waits for"
            )
        raise RosClientError(f"no message on {topic} within {args.wait:g} s: {why}")
    p, q = msg.pose.position, msg.pose.orientation
    if args.json:
        emit(
            json.dumps(
                {
                    "topic": topic,
                    "frame_id": msg.header.frame_id,
                    "stamp": {"sec": msg.header.stamp.sec, "nanosec": msg.header.stamp.nanosec},
                    "position": [p.x, p.y, p.z],
                    "quaternion_xyzw": [q.x, q.y, q.z, q.w],
                }
            )
        )
        return 0
    emit(
        f"{topic}: pose in {msg.header.frame_id!r} at stamp {_stamp(msg.header)}\n"
        f"position [m]         {p.x: .6f} {p.y: .6f} {p.z: .6f}\n"
        f"quaternion (x,y,z,w) {q.x: .6f} {q.y: .6f} {q.z: .6f} {q.w: .6f}"
    )
    return 0


def _ik(client: RosClient, args: argparse.Namespace, emit: Callable[[str], None]) -> int:
    from kinematics_service.srv import ComputeIK

    request = ComputeIK.Request()
    request.target.header.frame_id = args.frame or ""
    x, y, z, qx, qy, qz, qw = args.target
    position, orientation = request.target.pose.position, request.target.pose.orientation
    position.x, position.y, position.z = x, y, z
    orientation.x, orientation.y, orientation.z, orientation.w = qx, qy, qz, qw
    request.tip_link = args.tip or ""
    request.position_only = bool(args.position_only)
    request.timeout = 0.0 if args.timeout is None else args.timeout
    # the node answers by the request's deadline; a few seconds more for the trip and start-up
    answer = args.wait + (0.0 if args.timeout is None else args.timeout)
    response = client.call(ComputeIK, args.service, request, args.wait, answer)
    names = list(response.solution.name)
    values = [float(v) for v in response.solution.position]
    if args.json:
        emit(
            json.dumps(
                {
                    "success": bool(response.success),
                    "message": response.message,
                    "joint_names": names,
                    "q": values,
                    "position_error": response.position_error,
                    "orientation_error": None if args.position_only else response.orientation_error,
                    "iterations": response.iterations,
                }
            )
        )
    elif response.success or (names and response.position_error >= 0):
        # a failure's reason goes to stderr once (below); stdout shows a best effort, if any
        head = (
            f"solved by {client.resolve(args.service)}"
            if response.success
            else "best effort (not a solution):"
        )
        rows = [head] + [f"  {n:<28}{v: .6f}" for n, v in zip(names, values, strict=True)]
        if response.position_error >= 0:
            orientation = (
                "orientation free"
                if args.position_only
                else f"orientation error {response.orientation_error:.2e} rad"
            )
            rows.append(
                f"position error {response.position_error:.2e} m, {orientation}, "
                f"{response.iterations} iterations"
            )
        emit("\n".join(rows))
    if not response.success:
        raise RosClientError(f"{client.resolve(args.service)}: {response.message}")
    return 0


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
