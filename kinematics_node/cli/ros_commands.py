"""`kinematics ros`: the running kinematics node from a shell, where ros2cli is not at hand (it is
not on PyPI): print one `ee_pose` message, or call `compute_ik` and print the answer.

    kinematics ros pose [--topic ee_pose] [--wait 10] [--json]
    kinematics ros ik --target X,Y,Z,QX,QY,QZ,QW [--frame F] [--tip LINK] [--position-only]
                      [--timeout S] [--service compute_ik] [--wait 10] [--json]

This module holds the arguments and the words and imports no ROS: main.py adds the `ros` command
with `add_parser` and runs it with `run`; ROS is imported by `run`, through `ros.client`, only
when the command runs. DDS settings come from the caller's environment (`ros.client` says why).
"""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Callable
from typing import Any

from ..ros.client import RosClient, RosClientError, missing_ros

_EXAMPLES = """examples:
  kinematics ros pose                               # one ee_pose message of the running node
  kinematics ros pose --topic /arm/ee_pose --json
  kinematics ros ik --target 0.4,0.1,0.4,1,0,0,0    # x,y,z [m], quaternion qx,qy,qz,qw
  kinematics ros ik --target 0.4,0.1,0.4,0,0,0,1 --position-only --tip tool0

Start the node first (kinematics_node --help). Both commands wait up to --wait seconds for it and
use this shell's ROS_DOMAIN_ID and ROS_AUTOMATIC_DISCOVERY_RANGE, as every ROS 2 tool does."""


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


def _seconds(text: str) -> float:
    """argparse type of --wait and --timeout: a finite number of seconds > 0."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"expected a finite number of seconds > 0, got {text!r}")
    return value


def add_parser(commands: Any) -> None:
    """Add the `ros` command (with `pose` and `ik`) to main.py's subcommands."""
    ros = commands.add_parser(
        "ros",
        help="the running kinematics node over ROS 2: its pose, an IK call",
        description="Talk to a running kinematics node over ROS 2 (needs rclpy: a sourced ROS 2\n"
        "workspace, or `. build/ros/env.sh` after `make ros`).",
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
    for command in (pose, ik):
        command.add_argument(
            "--wait",
            type=_seconds,
            default=10.0,
            help="how long to wait for the node [s] (default: %(default)s)",
        )
        command.add_argument("--json", action="store_true", help="JSON output")


def run(args: argparse.Namespace, emit: Callable[[str], None] = print) -> int:
    """Run `kinematics ros <args.ros_command>`; the exit status.

    Raises:
        RosClientError: ROS 2 is missing, or the node did not answer (the message says what was
            seen and what to do); main.py prints it as one line, status 1.
    """
    command = _pose if args.ros_command == "pose" else _ik
    needs = ("geometry_msgs.msg",) if args.ros_command == "pose" else ("kinematics_service.srv",)
    reason = missing_ros(needs)
    if reason is not None:
        raise RosClientError(f"kinematics ros {args.ros_command} {reason}")
    with RosClient() as client:
        return command(client, args, emit)


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
