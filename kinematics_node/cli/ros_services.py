"""`kinematics ros fk|jacobian|ik`: one call of a running node's compute_fk, compute_jacobian or
compute_ik service, its answer printed as text or JSON (`ros_commands` holds their arguments; ROS
is imported inside the functions only).

A refusal (`success = false`) is one line with the node's reason, status 1; IK prints its best
effort first, when the solver ran.

Joint values (`--q`) are given by name (`elbow_joint=0.5,wrist_1_joint=-1`: a subset, the rest
from the node's current joint state, as the services take them) or positionally, in the order of
the node's chain (`0,-1.2,1.4,0,0.5,0`). The services take names only, so positional values are
named with the joint names that compute_jacobian answers at the node's current state: the node
says them, and nothing here reads the robot description again.
"""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Callable, Sequence
from typing import Any

from ..ros.client import RosClient, RosClientError

#: --q: (name, value) pairs, or values in chain order (names None).
JointValues = tuple[tuple[str | None, float], ...]


def joint_values(text: str) -> JointValues:
    """argparse type of --q: `NAME=VALUE,...` or `VALUE,...`, finite numbers, not both forms."""
    items = [item.strip() for item in text.split(",")]
    pairs: list[tuple[str | None, float]] = []
    for item in items:
        name, has_name, value = item.rpartition("=")
        name = name.strip()
        if has_name and not name:
            raise argparse.ArgumentTypeError(f"a joint name is missing before '=' in {text!r}")
        try:
            number = float(value)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected numbers (VALUE,... in chain order, or NAME=VALUE,...), got {item!r}"
            ) from None
        if not math.isfinite(number):
            raise argparse.ArgumentTypeError(f"every value must be finite, got {item!r}")
        pairs.append((name if has_name else None, number))
    if len({name is None for name, _ in pairs}) > 1:
        raise argparse.ArgumentTypeError(
            f"give every value a joint name (NAME=VALUE,...) or none (values in chain order), "
            f"not some: {text!r}"
        )
    return tuple(pairs)


def _named(
    client: RosClient, args: argparse.Namespace, q: JointValues | None
) -> tuple[list[str], list[float]]:
    """(names, positions) of the request's joint_state: empty for no --q (the node's current
    state); positional values named after the node's chain (`_chain_joint_names`)."""
    if not q:
        return [], []
    values = [v for _, v in q]
    if q[0][0] is not None:
        return [str(name) for name, _ in q], values
    names, chain = _chain_joint_names(client, args)
    if len(names) != len(values):
        raise RosClientError(
            f"--q has {len(values)} value(s) but the chain {chain} has {len(names)} joint(s): "
            f"{', '.join(names)}"
        )
    return names, values


def _chain_joint_names(client: RosClient, args: argparse.Namespace) -> tuple[list[str], str]:
    """The joint names of the chain to args.tip (or the node's tip_link), base to tip, as the
    node's compute_jacobian names them at its current state, and 'base -> tip'."""
    from kinematics_service.srv import ComputeJacobian

    request = ComputeJacobian.Request()
    request.tip_link = args.tip or ""
    service = client.resolve(
        args.service
        if args.ros_command == "jacobian"
        else _sibling(args.service, "compute_jacobian")
    )
    response = client.call(ComputeJacobian, service, request, args.wait, args.wait)
    if not response.success:
        raise RosClientError(
            f"values in chain order need the chain's joint names, which {service} gives only "
            f"for the node's current joint state, and it answered: {response.message}. Name "
            "each joint instead: --q NAME=VALUE,..."
        )
    return list(response.joint_names), f"{response.base_link} -> {response.tip_link}"


def _sibling(given: str, service: str) -> str:
    """`service` in the namespace of the service `given` ('/arm/compute_fk' -> '/arm/<service>')."""
    head, slash, _ = given.rpartition("/")
    return f"{head}{slash}{service}"


def _check(client: RosClient, args: argparse.Namespace, response: Any) -> None:
    if not response.success:
        raise RosClientError(f"{client.resolve(args.service)}: {response.message}")


def fk(client: RosClient, args: argparse.Namespace, emit: Callable[[str], None]) -> int:
    """`kinematics ros fk`: the pose of the tip (and of --links) for --q."""
    from kinematics_service.srv import ComputeFK

    request = ComputeFK.Request()
    request.joint_state.name, request.joint_state.position = _named(client, args, args.q)
    request.tip_link = args.tip or ""
    request.link_names = list(args.links or [])
    response = client.call(ComputeFK, args.service, request, args.wait, args.wait)
    _check(client, args, response)
    tip = args.tip or "the node's tip_link"
    poses = [(args.tip or "", response.pose)] + list(
        zip(request.link_names, response.poses, strict=True)
    )
    if args.json:
        emit(
            json.dumps(
                {
                    "service": client.resolve(args.service),
                    "frame_id": response.pose.header.frame_id,
                    "tip_link": args.tip or "",
                    **_pose_json(response.pose),
                    "links": [{"link": link, **_pose_json(p)} for link, p in poses[1:]],
                }
            )
        )
        return 0
    blocks = [f"{link or tip}: pose in {p.header.frame_id!r}\n{_pose_rows(p)}" for link, p in poses]
    emit(f"answered by {client.resolve(args.service)}\n" + "\n".join(blocks))
    return 0


def _pose_json(msg: Any) -> dict[str, list[float]]:
    p, q = msg.pose.position, msg.pose.orientation
    return {"position": [p.x, p.y, p.z], "quaternion_xyzw": [q.x, q.y, q.z, q.w]}


def _pose_rows(msg: Any) -> str:
    p, q = msg.pose.position, msg.pose.orientation
    return (
        f"position [m]         {p.x: .6f} {p.y: .6f} {p.z: .6f}\n"
        f"quaternion (x,y,z,w) {q.x: .6f} {q.y: .6f} {q.z: .6f} {q.w: .6f}"
    )


#: What the rows of each convention are, for the text output (see srv/ComputeJacobian.srv).
_CONVENTION = {
    "world": "rows in {base} axes; linear rows: the velocity of the {tip} origin",
    "body": "rows in {tip} axes; linear rows: the velocity of the {tip} origin",
    "space": "rows in {base} axes; linear rows: the velocity of the body-fixed point at the "
    "{base} origin",
}


def jacobian(client: RosClient, args: argparse.Namespace, emit: Callable[[str], None]) -> int:
    """`kinematics ros jacobian`: the 6 x n Jacobian for --q, rows in the service's (ROS) order:
    linear x, y, z, then angular x, y, z."""
    from kinematics_service.srv import ComputeJacobian

    request = ComputeJacobian.Request()
    request.joint_state.name, request.joint_state.position = _named(client, args, args.q)
    request.tip_link = args.tip or ""
    request.frame = args.frame
    response = client.call(ComputeJacobian, args.service, request, args.wait, args.wait)
    _check(client, args, response)
    rows, cols = int(response.rows), int(response.cols)
    data = [float(v) for v in response.jacobian]
    matrix = [data[r * cols : (r + 1) * cols] for r in range(rows)]
    labels = list(response.row_labels)
    names = list(response.joint_names)
    condition = float(response.condition_number)
    if args.json:
        emit(
            json.dumps(
                {
                    "service": client.resolve(args.service),
                    "frame": response.frame,
                    "reference_frame": response.reference_frame,
                    "reference_point_frame": response.reference_point_frame,
                    "base_link": response.base_link,
                    "tip_link": response.tip_link,
                    "row_labels": labels,
                    "joint_names": names,
                    "jacobian": matrix,
                    "manipulability": response.manipulability,
                    "condition_number": None if condition < 0 else condition,
                    "min_singular_value": response.min_singular_value,
                }
            )
        )
        return 0
    convention = _CONVENTION.get(response.frame, "{base} -> {tip}").format(
        base=response.base_link, tip=response.tip_link
    )
    emit(
        "\n".join(
            [
                f"{response.frame} Jacobian of {response.base_link} -> {response.tip_link} "
                f"from {client.resolve(args.service)}: {convention}",
                "rows in ROS order (as geometry_msgs/Twist): linear x, y, z [m/s], then angular "
                "x, y, z [rad/s], per unit velocity of each joint [rad/s or m/s]",
                *_matrix_rows(labels, names, matrix),
                f"manipulability {response.manipulability:.6g}, condition number "
                f"{'inf' if condition < 0 else f'{condition:.6g}'}, smallest singular value "
                f"{response.min_singular_value:.6g}",
            ]
        )
    )
    return 0


def _matrix_rows(
    labels: Sequence[str], names: Sequence[str], matrix: Sequence[Sequence[float]]
) -> list[str]:
    """The matrix under numbered columns, each column's joint named first (names are long)."""
    width = max(len(label) for label in labels) + 1
    lines = [f"{'column':<{width}} joint"]
    lines += [f"{c + 1:<{width}} {name}" for c, name in enumerate(names)]
    lines.append(" " * width + "".join(f"{c + 1:>11}" for c in range(len(names))))
    lines += [
        f"{label:<{width}}" + "".join(f"{round(v, 6) + 0.0:>11.6f}" for v in row)  # no -0.0
        for label, row in zip(labels, matrix, strict=True)
    ]
    return lines


def ik(client: RosClient, args: argparse.Namespace, emit: Callable[[str], None]) -> int:
    """`kinematics ros ik`: the joint values placing the tip at --target."""
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
    _check(client, args, response)
    return 0
