"""`kinematics ros pose|twist|diagnostics`: one message of a running node's topic, printed as text
or JSON (`ros_commands` holds their arguments; ROS is imported inside the functions only).

Each waits up to --wait seconds for a message; when none comes it says what it saw instead (the
topic carries another type, nothing publishes it, or its publishers sent nothing, and why a
kinematics node would not), and the status is 1.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from typing import Any

from ..ros.client import RosClient, RosClientError, type_name

#: The verb that prints each type these commands read (a topic of another type names it).
VERB_OF_TYPE = {
    "geometry_msgs/msg/PoseStamped": "pose",
    "geometry_msgs/msg/TwistStamped": "twist",
    "diagnostic_msgs/msg/DiagnosticArray": "diagnostics",
}

#: DiagnosticStatus.level -> its name.
LEVELS = {0: "OK", 1: "WARN", 2: "ERROR", 3: "STALE"}


def _stamp(header: Any) -> str:
    return f"{header.stamp.sec}.{header.stamp.nanosec:09d}"


def _stamp_json(header: Any) -> dict[str, int]:
    return {"sec": int(header.stamp.sec), "nanosec": int(header.stamp.nanosec)}


def _read_one(
    client: RosClient,
    msg_type: Any,
    args: argparse.Namespace,
    silent: Callable[[], str],
    accept: Callable[[Any], bool] | None = None,
) -> Any:
    """The first message on args.topic within args.wait (one `accept` takes, if given).

    Raises:
        RosClientError: none came: the topic carries another type (naming the verb that reads
            it), nothing publishes it, or `silent()` says why its publishers sent nothing.
    """
    msg = client.first_message(msg_type, args.topic, args.wait, accept)
    if msg is not None:
        return msg
    topic = client.resolve(args.topic)
    others = client.other_types(args.topic, msg_type)
    if others:
        verbs = [VERB_OF_TYPE[t] for t in others if t in VERB_OF_TYPE]
        hint = f": try kinematics ros {verbs[0]}" if len(verbs) == 1 else ""
        raise RosClientError(
            f"{topic} carries {' and '.join(others)}, not {type_name(msg_type)}{hint}"
        )
    publishers = client.publishers(args.topic)
    if publishers == 0:
        why = (
            f"nothing publishes it. Is kinematics_node running, started with the same "
            f"ROS_DOMAIN_ID and discovery range as this shell? {client.graph_seen()}"
        )
    else:
        why = f"{publishers} node(s) offer it but {silent()}"
    raise RosClientError(f"no message on {topic} within {args.wait:g} s: {why}")


def _waits_for_joint_states(client: RosClient, first: str) -> Callable[[], str]:
    """Why a kinematics node publishes no end-effector message (`first` says when it would)."""

    def why() -> str:
        joint_states = client.publishers("joint_states")
        return (
            f"sent nothing: the node publishes {first} each joint_states message that names "
            "every joint of its chain, once it has a robot description and a tip link "
            f"({joint_states} publisher(s) of {client.resolve('joint_states')}); its log says "
            "what it waits for"
        )

    return why


def pose(client: RosClient, args: argparse.Namespace, emit: Callable[[str], None]) -> int:
    """`kinematics ros pose`: one geometry_msgs/PoseStamped."""
    from geometry_msgs.msg import PoseStamped

    msg = _read_one(client, PoseStamped, args, _waits_for_joint_states(client, "a pose for"))
    topic = client.resolve(args.topic)
    p, q = msg.pose.position, msg.pose.orientation
    if args.json:
        emit(
            json.dumps(
                {
                    "topic": topic,
                    "frame_id": msg.header.frame_id,
                    "stamp": _stamp_json(msg.header),
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


def twist(client: RosClient, args: argparse.Namespace, emit: Callable[[str], None]) -> int:
    """`kinematics ros twist`: one geometry_msgs/TwistStamped (the tip origin's velocity)."""
    from geometry_msgs.msg import TwistStamped

    when = "a twist for the second of two successive (the first, if it carries velocities)"
    msg = _read_one(client, TwistStamped, args, _waits_for_joint_states(client, when))
    topic = client.resolve(args.topic)
    v, w = msg.twist.linear, msg.twist.angular
    if args.json:
        emit(
            json.dumps(
                {
                    "topic": topic,
                    "frame_id": msg.header.frame_id,
                    "stamp": _stamp_json(msg.header),
                    "linear": [v.x, v.y, v.z],
                    "angular": [w.x, w.y, w.z],
                }
            )
        )
        return 0
    emit(
        f"{topic}: twist in {msg.header.frame_id!r} axes at stamp {_stamp(msg.header)}\n"
        f"linear [m/s]    {v.x: .6f} {v.y: .6f} {v.z: .6f}\n"
        f"angular [rad/s] {w.x: .6f} {w.y: .6f} {w.z: .6f}"
    )
    return 0


def status_of_node(status_name: str, node: str) -> bool:
    """Whether a DiagnosticStatus named `status_name` ('/ns/kinematics_node: end effector', or
    'kinematics_node: end effector' without the namespace) comes from the node `node`: its name
    ('kinematics_node': in any namespace) or its full name ('/ns/kinematics_node')."""
    source = status_name.split(": ", 1)[0].strip("/")
    wanted = node.strip("/")
    return bool(wanted) and (source == wanted or source.endswith("/" + wanted))


def diagnostics(client: RosClient, args: argparse.Namespace, emit: Callable[[str], None]) -> int:
    """`kinematics ros diagnostics`: the statuses of args.node in the first DiagnosticArray on
    args.topic that has any."""
    from diagnostic_msgs.msg import DiagnosticArray

    seen: set[str] = set()  # statuses of other nodes, for the message when none matches

    def ours(msg: Any) -> bool:
        names = [s.name for s in msg.status]
        seen.update(names)
        return any(status_of_node(n, args.node) for n in names)

    def silent() -> str:
        others = f"sent statuses of {', '.join(sorted(seen))} only" if seen else "sent nothing"
        return (
            f"{others}. Is {args.node} running, with publish_diagnostics true? (one status every "
            "diagnostics_period, 1 s by default)"
        )

    msg = _read_one(client, DiagnosticArray, args, silent, ours)
    topic = client.resolve(args.topic)
    statuses = [s for s in msg.status if status_of_node(s.name, args.node)]
    if args.json:
        emit(
            json.dumps(
                {
                    "topic": topic,
                    "stamp": _stamp_json(msg.header),
                    "status": [
                        {
                            "name": s.name,
                            "level": LEVELS.get(_level(s), str(_level(s))),
                            "message": s.message,
                            "hardware_id": s.hardware_id,
                            "values": {kv.key: kv.value for kv in s.values},
                        }
                        for s in statuses
                    ],
                }
            )
        )
        return 0
    blocks = []
    for s in statuses:
        width = max((len(kv.key) for kv in s.values), default=0) + 2
        level = LEVELS.get(_level(s), str(_level(s)))
        hardware = f" (hardware_id {s.hardware_id!r})" if s.hardware_id else ""
        rows = [f"{s.name}: {level}: {s.message}{hardware}"]
        rows += [f"  {kv.key:<{width}}{kv.value}" for kv in s.values]
        blocks.append("\n".join(rows))
    emit(f"{topic} at stamp {_stamp(msg.header)}\n" + "\n".join(blocks))
    return 0


def _level(status: Any) -> int:
    """DiagnosticStatus.level: a byte (rclpy gives bytes of length 1) as an int."""
    level = status.level
    return level[0] if isinstance(level, bytes) else int(level)
