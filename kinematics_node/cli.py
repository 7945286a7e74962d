"""`kinematics`: forward kinematics, Jacobians and IK from the command line, without ROS.

    kinematics info --urdf arm.urdf [--base B] [--tip T] [--json]
    kinematics fk --urdf arm.urdf --q 0,0.5,-1,0,0,0 [--json]
    kinematics jacobian --dh scara.json --q 0.1,0.2,0.05,0 --frame body [--json]
    kinematics ik --robot ur5e --target 0.4,0.1,0.5,0,1,0,0 --all [--seed ...] [--json]

Joint values are comma-separated, in rad (m for prismatic joints), in the order `info` lists.
Errors print one line on stderr and exit with status 1 (2 for command-line usage errors).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from .core import (
    KinematicsError,
    SerialChain,
    condition_number,
    manipulability,
)
from .core.rotations import quaternion_from_matrix, rpy_from_matrix

_VECTOR_OPTIONS = ("--q", "--seed", "--target", "--qdot")


class CliError(Exception):
    """A user error reported as one line on stderr (exit status 1)."""


def parse_floats(text: str, name: str, allow_inf: bool = False) -> np.ndarray:
    """'0.1, -2, 3e-3' → array; a clear error names the option and the bad item. NaN is always
    refused, ±inf unless `allow_inf`."""
    items = [s for s in text.replace(";", ",").replace(" ", ",").split(",") if s]
    try:
        values = np.array([float(s) for s in items])
    except ValueError as exc:
        raise CliError(f"{name}: {exc} (expected comma-separated numbers)") from None
    if values.size == 0:
        raise CliError(f"{name}: no values given")
    if np.any(np.isnan(values)) or (not allow_inf and np.any(np.isinf(values))):
        raise CliError(
            f"{name}: values must be {'numbers' if allow_inf else 'finite'}, got {text!r}"
        )
    return values


def load_chain(args: argparse.Namespace) -> SerialChain:
    sources = [s for s in (args.urdf, args.dh, getattr(args, "robot", None)) if s]
    if len(sources) != 1:
        raise CliError("give exactly one robot: --urdf FILE, --dh FILE or --robot NAME")
    if args.urdf:
        return SerialChain.from_urdf(args.urdf, args.base, args.tip)
    if args.dh:
        try:
            with open(args.dh, encoding="utf-8") as fh:
                table = json.load(fh)
        except (OSError, json.JSONDecodeError) as exc:
            raise CliError(f"cannot read DH table {args.dh!r}: {exc}") from None
        return SerialChain.from_dh(table)
    from .robots import load_robot

    return load_robot(args.robot, base_link=args.base, tip_link=args.tip)


def _fmt_matrix(A: np.ndarray, indent: str = "  ") -> str:
    """Rows of a matrix for people: entries below 1e-10 (round-off of printed URDF angles) show as 0."""
    M = np.where(np.abs(A) < 1e-10, 0.0, A)
    return "\n".join(indent + " ".join(f"{x:10.6g}" for x in row) for row in M)


def _pose_dict(T: np.ndarray) -> dict[str, Any]:
    return {
        "T": T.tolist(),
        "position": T[:3, 3].tolist(),
        "quaternion_xyzw": quaternion_from_matrix(T[:3, :3]).tolist(),
        "rpy": rpy_from_matrix(T[:3, :3]).tolist(),
    }


def _pose_text(T: np.ndarray) -> str:
    d = _pose_dict(T)
    p, q, r = d["position"], d["quaternion_xyzw"], d["rpy"]
    return (
        f"position [m]         {p[0]: .6f} {p[1]: .6f} {p[2]: .6f}\n"
        f"quaternion (x,y,z,w) {q[0]: .6f} {q[1]: .6f} {q[2]: .6f} {q[3]: .6f}\n"
        f"rpy [rad]            {r[0]: .6f} {r[1]: .6f} {r[2]: .6f}\n"
        f"T =\n{_fmt_matrix(T)}"
    )


def get_q(chain: SerialChain, text: str | None, name: str = "--q") -> np.ndarray:
    if text is None:
        raise CliError(f"{name} is required: {chain.dof} values for {', '.join(chain.joint_names)}")
    q = parse_floats(text, name)
    if q.size != chain.dof:
        raise CliError(
            f"{name}: expected {chain.dof} values ({', '.join(chain.joint_names)}), got {q.size}"
        )
    return q


# ---------------------------------------------------------------------- commands
def cmd_info(args: argparse.Namespace, chain: SerialChain) -> dict[str, Any] | str:
    data = {
        "base_link": chain.base_link,
        "tip_link": chain.tip_link,
        "dof": chain.dof,
        "joints": [
            {"name": n, "type": t, "lower": lo, "upper": up, "velocity": v}
            for n, t, lo, up, v in zip(
                chain.joint_names,
                chain.joint_types,
                chain.lower.tolist(),
                chain.upper.tolist(),
                chain.velocity_limit.tolist(),
                strict=True,
            )
        ],
        "links": list(chain.link_names),
        "S": chain.S.tolist(),
        "B": chain.B.tolist(),
        "M": chain.M.tolist(),
    }
    if args.json:
        return data
    rows = [f"chain {chain.base_link} → {chain.tip_link}, {chain.dof} joints"]
    rows.append(f"  {'#':>2} {'joint':<28}{'type':<12}{'lower':>10}{'upper':>10}{'velocity':>10}")
    for i, j in enumerate(data["joints"], 1):
        rows.append(
            f"  {i:>2} {j['name']:<28}{j['type']:<12}{j['lower']:>10.4g}{j['upper']:>10.4g}"
            f"{j['velocity']:>10.4g}"
        )
    rows.append("screw axes in the space frame, S (columns S1..Sn, rows ω then v):")
    rows.append(_fmt_matrix(chain.S))
    rows.append("screw axes in the body frame, B:")
    rows.append(_fmt_matrix(chain.B))
    rows.append("home pose of the tip, M:")
    rows.append(_fmt_matrix(chain.M))
    return "\n".join(rows)


def cmd_fk(args: argparse.Namespace, chain: SerialChain) -> dict[str, Any] | str:
    q = get_q(chain, args.q)
    T = chain.fk(q)
    if args.json:
        return {"joint_names": list(chain.joint_names), "q": q.tolist(), **_pose_dict(T)}
    return f"pose of {chain.tip_link} in {chain.base_link}:\n{_pose_text(T)}"


def cmd_jacobian(args: argparse.Namespace, chain: SerialChain) -> dict[str, Any] | str:
    q = get_q(chain, args.q)
    J = chain.jacobian(q, args.frame)
    Jw = J if args.frame == "world" else chain.jacobian(q, "world")
    figures = {
        "manipulability_linear": float(manipulability(Jw, "linear")),
        "condition_number": float(condition_number(Jw, "full")),
    }
    rows_labels = ["wx", "wy", "wz", "vx", "vy", "vz"]
    if args.json:
        return {
            "frame": args.frame,
            "rows": rows_labels,
            "columns": list(chain.joint_names),
            "J": J.tolist(),
            **figures,
        }
    head = f"{args.frame} Jacobian (rows ω then v; columns {', '.join(chain.joint_names)}):"
    body = "\n".join(
        f"  {label:<3}" + " ".join(f"{x:10.6g}" for x in row)
        for label, row in zip(rows_labels, J, strict=True)
    )
    return (
        f"{head}\n{body}\nmanipulability (linear) {figures['manipulability_linear']:.6g} m, "
        f"condition number {figures['condition_number']:.6g}"
    )


def cmd_ik(args: argparse.Namespace, chain: SerialChain) -> dict[str, Any] | str:
    from .core import IKOptions
    from .core.rotations import matrix_from_quaternion

    if args.target is None:
        raise CliError("--target x,y,z,qx,qy,qz,qw is required (position [m], quaternion x,y,z,w)")
    v = parse_floats(args.target, "--target")
    if v.size != 7:
        raise CliError(f"--target: expected 7 values x,y,z,qx,qy,qz,qw, got {v.size}")
    T = np.eye(4)
    T[:3, :3] = matrix_from_quaternion(v[3:])  # refuses a zero quaternion with a clear message
    T[:3, 3] = v[:3]
    seed = None if args.seed is None else get_q(chain, args.seed, "--seed")
    if args.all:
        return _ik_all(args, chain, T, seed)
    axis_tolerances = None
    if args.axis_tolerances is not None:
        axis_tolerances = tuple(parse_floats(args.axis_tolerances, "--axis-tolerances", True))
    options = IKOptions(
        position_tolerance=args.position_tolerance,
        orientation_tolerance=args.orientation_tolerance,
        timeout=args.timeout,
        position_only=args.position_only,
        axis_tolerances=axis_tolerances,
        mode=args.mode,
        rng_seed=0,
    )
    res = chain.ik(T, q_seed=seed, options=options)
    data = {
        "success": bool(res.success),
        "joint_names": list(chain.joint_names),
        "q": np.asarray(res.q).tolist(),
        "position_error": float(res.position_error),
        "orientation_error": float(res.orientation_error),
        "iterations": int(res.iterations),
        "message": res.message,
    }
    if not res.success:
        # Still report the best configuration found, but exit non-zero.
        print(json.dumps(data, indent=2) if args.json else _ik_text(data), file=sys.stdout)
        raise CliError(f"no solution: {res.message}")
    return data if args.json else _ik_text(data)


def _ik_all(
    args: argparse.Namespace, chain: SerialChain, T: np.ndarray, seed: np.ndarray | None
) -> dict[str, Any] | str:
    """`ik --all`: every closed-form solution, nearest the seed first (7R arms: held joint swept)."""
    res = chain.ik_all(T, q_seed=seed)
    data = {
        "success": bool(res.success),
        "family": res.family,
        "singular": bool(res.singular),
        "joint_names": list(chain.joint_names),
        "solutions": [np.asarray(s).tolist() for s in res.solutions],
        "message": res.message,
    }
    if not res.success:
        print(json.dumps(data, indent=2) if args.json else f"not solved: {res.message}")
        raise CliError(f"no solution: {res.message}")
    if args.json:
        return data
    rows = [res.message, f"columns [rad]: {', '.join(chain.joint_names)}"]
    rows += [
        f"{i:>4}  " + " ".join(f"{x:10.6f}" for x in sol)
        for i, sol in enumerate(data["solutions"], 1)
    ]
    return "\n".join(rows)


def _ik_text(d: dict[str, Any]) -> str:
    rows = [f"{'solved' if d['success'] else 'not solved'}: {d['message']}"]
    rows += [f"  {n:<28}{x: .6f}" for n, x in zip(d["joint_names"], d["q"], strict=True)]
    rows.append(
        f"position error {d['position_error']:.2e} m, orientation error "
        f"{d['orientation_error']:.2e} rad, {d['iterations']} iterations"
    )
    return "\n".join(rows)


COMMANDS: dict[str, tuple[str, Callable[[argparse.Namespace, SerialChain], Any]]] = {
    "info": ("print the chain, joint table and S, B, M", cmd_info),
    "fk": ("forward kinematics: pose of the tip in the base", cmd_fk),
    "jacobian": ("Jacobian in the space, body or world frame", cmd_jacobian),
    "ik": ("inverse kinematics: joint values reaching a tip pose", cmd_ik),
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="kinematics",
        description="Product-of-exponentials kinematics of a URDF, xacro or DH robot, without ROS.",
    )
    sub = parser.add_subparsers(dest="command", required=True)
    for name, (helptext, _) in COMMANDS.items():
        p = sub.add_parser(name, help=helptext, description=helptext)
        src = p.add_argument_group("robot (exactly one)")
        src.add_argument("--urdf", metavar="FILE", help="URDF or xacro file")
        src.add_argument(
            "--dh",
            metavar="FILE",
            help="JSON DH table: {'joints': [{a, alpha, d, theta, type}, ...]}",
        )
        src.add_argument("--robot", metavar="NAME", help="a bundled robot, e.g. ur5e, panda")
        p.add_argument("--base", help="base link (default: root link)")
        p.add_argument("--tip", help="tip link (default: the single leaf)")
        p.add_argument("--json", action="store_true", help="machine-readable output")
        if name in ("fk", "jacobian"):
            p.add_argument("--q", metavar="Q1,Q2,...", help="joint values [rad or m]")
        if name == "jacobian":
            p.add_argument("--frame", choices=("space", "body", "world"), default="world")
        if name == "ik":
            p.add_argument("--target", metavar="X,Y,Z,QX,QY,QZ,QW", help="tip pose in the base")
            p.add_argument("--seed", metavar="Q1,Q2,...", help="start configuration")
            p.add_argument("--position-only", action="store_true", help="ignore orientation")
            p.add_argument(
                "--all",
                action="store_true",
                help="every solution, in closed form (arms with a closed-form family only)",
            )
            p.add_argument("--mode", choices=("speed", "distance"), default="speed")
            p.add_argument("--timeout", type=float, default=0.05, help="[s] (default 0.05)")
            p.add_argument("--position-tolerance", type=float, default=1e-5, help="[m]")
            p.add_argument("--orientation-tolerance", type=float, default=1e-4, help="[rad]")
            p.add_argument(
                "--axis-tolerances",
                metavar="WX,WY,WZ,X,Y,Z",
                help="per-axis bounds in the tip frame [rad, m]; inf frees an axis "
                "(replaces the two tolerances above)",
            )
    demo = sub.add_parser("demo", help="simulate a bundled arm, track it, solve IK, draw a picture")
    demo.add_argument("--robot", default="ur5e", help="bundled robot (default ur5e)")
    demo.add_argument("--out", default="kinematics_demo.png", help="picture file")
    demo.add_argument("--duration", type=float, default=10.0, help="simulated time [s]")
    demo.add_argument("--rate", type=float, default=100.0, help="joint_states rate [Hz]")
    return parser


def _join_vector_options(argv: Sequence[str]) -> list[str]:
    """Let `--q -0.5,1` work: argparse would take '-0.5,1' for an option."""
    out: list[str] = []
    it = iter(argv)
    for a in it:
        if a in _VECTOR_OPTIONS:
            nxt = next(it, None)
            out.append(a if nxt is None else f"{a}={nxt}")
        else:
            out.append(a)
    return out


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(_join_vector_options(sys.argv[1:] if argv is None else argv))
    try:
        if args.command == "demo":
            from . import demo

            if not (args.duration > 0 and args.rate > 0):
                raise CliError("--duration and --rate must be positive")
            return demo.main(args.robot, args.out, args.duration, args.rate)
        chain = load_chain(args)
        result = COMMANDS[args.command][1](args, chain)
    except (CliError, KinematicsError) as exc:
        print(f"kinematics: error: {exc}", file=sys.stderr)
        return 1
    if isinstance(result, str):
        print(result)
    else:
        print(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
