"""`kinematics`: forward kinematics, Jacobians and IK from the command line, without ROS.

    kinematics info --urdf arm.urdf [--base B] [--tip T] [--json]
    kinematics fk --robot ur5e --q 0,0.5,-1,0,0,0 [--json]
    kinematics fk --robot ur5e --q-file poses.txt --json      # one configuration per line; - = stdin
    kinematics jacobian --dh scara.json --q 0.1,0.2,0.05,0 --frame body [--json]
    kinematics ik --robot ur5e --target 0.4,0.1,0.5,0,1,0,0 --all [--seed ...] [--json]

Joint values are comma-separated, in rad (m for prismatic joints), in the order `info` lists.
Errors print one line on stderr and exit with status 1 (2 for command-line usage errors).
`--json` output is strict JSON (RFC 8259): an unbounded limit or an infinite value is `null`.

Start-up matters for scripts: this module imports numpy and the FK core only. yourdfpy is needed
only the first time a URDF file is seen (see `chain_cache`), scipy only for `ik`.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import re
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from typing import Any, TextIO

import numpy as np

from ..core import KinematicsError, SerialChain
from ..core.exceptions import RobotDescriptionError, UnknownNameError
from ..core.ik.options import IKOptions
from ..core.model import mimic_rule
from . import bag, place, reach, ros_commands

_MAX_SHOWN = 40  # characters of user input echoed in an error message
_MAX_STEPS = 1_000_000  # demo: joint states simulated at most


class CliError(Exception):
    """A user error reported as one line on stderr (exit status 1)."""


def _shown(text: str) -> str:
    """User input for an error message: repr'd, at most _MAX_SHOWN characters."""
    text = str(text)
    return repr(text if len(text) <= _MAX_SHOWN else text[: _MAX_SHOWN - 1] + "…")


def parse_floats(text: str, name: str, allow_inf: bool = False) -> np.ndarray:
    """'0.1, -2, 3e-3' → array; a clear error names the option and the bad item (by position,
    never echoing a long input). NaN is always refused, ±inf unless `allow_inf`."""
    items = [s for s in re.split(r"[,;\s]+", text) if s]
    if not items:
        raise CliError(f"{name}: no values given (expected comma-separated numbers)")
    values = np.empty(len(items))
    for i, item in enumerate(items):
        try:
            v = float(item)
        except ValueError:
            raise CliError(
                f"{name}: value {i + 1} is {_shown(item)}, not a number (expected "
                "comma-separated numbers)"
            ) from None
        if math.isnan(v) or (not allow_inf and math.isinf(v)):
            raise CliError(
                f"{name}: value {i + 1} is {_shown(item)}; values must be "
                f"{'numbers (inf allowed)' if allow_inf else 'finite numbers'}"
            )
        values[i] = v
    return values


def _number_type(
    what: str, *, positive: bool = True, finite: bool = True
) -> Callable[[str], float]:
    """An argparse `type` for a float option: finite, and > 0 if `positive`."""

    def convert(text: str) -> float:
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{_shown(text)} is not a number") from None
        if math.isnan(v) or (finite and math.isinf(v)) or (positive and not v > 0):
            raise argparse.ArgumentTypeError(f"must be {what}, got {_shown(text)}")
        return v

    convert.__name__ = what  # argparse names the type in some messages
    return convert


# ---------------------------------------------------------------------- robots
def load_chain(args: argparse.Namespace) -> SerialChain:
    """The chain the robot options name; the library's errors about the base and tip links in
    this command line's words (`--base`, `--tip`), with the library's reason kept."""
    try:
        return _load_chain(args)
    except UnknownNameError as exc:
        given = [f for f, v in (("--base", args.base), ("--tip", args.tip)) if v == exc.name]
        if exc.kind != "link" or not given:
            raise
        raise CliError(f"{given[0]}: {exc}") from None  # (the library checks the base first)
    except RobotDescriptionError as exc:
        # the library's parameters (from_urdf's base_link, tip_link) are this command's --base,
        # --tip; a link *named* base_link is quoted in these messages, so it stays as it is
        text = _NOT_BELOW.sub(r"--tip \1 is not below --base \2", cli_words(str(exc)))
        raise CliError(_LIBRARY_LINK_ARGUMENT.sub(_link_flag, text)) from None


_LIBRARY_LINK_ARGUMENT = re.compile(r"(?<![\w'\"])(base_link|tip_link)(?![\w'\"])")
_NOT_BELOW = re.compile(r"\btip link ('[^']*') is not below base link ('[^']*')")


def _link_flag(match: re.Match[str]) -> str:
    return "--base" if match.group(1) == "base_link" else "--tip"


def _load_chain(args: argparse.Namespace) -> SerialChain:
    if args.urdf:
        from .chain_cache import chain_from_urdf_file

        return chain_from_urdf_file(args.urdf, args.base, args.tip)
    if args.dh:
        from ..core.urdf import shorten

        try:
            with open(args.dh, "rb") as fh:
                table = json.loads(fh.read())  # bytes: UTF-8/16/32 detected as RFC 8259 says
        except OSError as exc:
            raise CliError(f"cannot read DH table {_shown(args.dh)}: {exc.strerror}") from None
        except (ValueError, RecursionError) as exc:  # JSONDecodeError, UnicodeDecodeError
            raise CliError(f"DH table {_shown(args.dh)} is not JSON: {shorten(str(exc))}") from None
        return SerialChain.from_dh(table)
    from ..sim.robots import default_chain_links, robot_path
    from .chain_cache import chain_from_urdf_file

    path = robot_path(args.robot)
    default_base, default_tip = default_chain_links(args.robot)
    return chain_from_urdf_file(
        path,
        default_base if args.base is None else args.base,
        default_tip if args.tip is None else args.tip,
    )


# ---------------------------------------------------------------------- output helpers
def strict_json(value: Any) -> Any:
    """`value` with every non-finite float replaced by None (JSON null), recursively."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: strict_json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [strict_json(v) for v in value]
    return value


def dump_json(value: Any, indent: int | None = 2) -> str:
    return json.dumps(strict_json(value), indent=indent, allow_nan=False, ensure_ascii=False)


def _for_people(A: np.ndarray) -> np.ndarray:
    """`A` to print: entries below 1e-10 (round-off, e.g. of printed URDF angles) as 0, never -0."""
    return np.where(np.abs(A) < 1e-10, 0.0, A)


def _fmt_matrix(A: np.ndarray, indent: str = "  ") -> str:
    """Rows of a matrix for people (`_for_people`)."""
    return "\n".join(indent + " ".join(f"{x:10.6g}" for x in row) for row in _for_people(A))


def _pose_dict(T: np.ndarray) -> dict[str, Any]:
    from ..core.rotations import quaternion_from_matrix, rpy_from_matrix

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


def _require_finite(values: np.ndarray, what: str) -> None:
    if not np.all(np.isfinite(values)):
        raise CliError(f"the {what} is not finite (joint values too large for this chain?)")


# ---------------------------------------------------------------------- joint values
def _check_q(chain: SerialChain, q: np.ndarray, name: str) -> np.ndarray:
    if q.size != chain.dof:
        raise CliError(
            f"{name}: expected {chain.dof} values ({', '.join(chain.joint_names)}), got {q.size}"
        )
    return q


def get_q(chain: SerialChain, text: str | None, name: str = "--q") -> np.ndarray:
    if text is None:
        raise CliError(f"{name} is required: {chain.dof} values for {', '.join(chain.joint_names)}")
    return _check_q(chain, parse_floats(text, name), name)


def read_configurations(chain: SerialChain, source: str, stdin: TextIO | None) -> np.ndarray:
    """(N, n) joint values from a file (or stdin for '-'): one configuration per line, numbers
    separated by commas or spaces; blank lines and lines starting with '#' are skipped."""
    name = "--q-file"
    try:
        if source == "-":
            if stdin is None:  # (started with standard input closed)
                raise CliError(f"{name}: standard input is closed")
            lines = stdin.read().splitlines()
        else:
            with open(source, encoding="utf-8") as fh:
                lines = fh.read().splitlines()
    except OSError as exc:
        raise CliError(f"{name}: cannot read {_shown(source)}: {exc.strerror}") from None
    except UnicodeDecodeError as exc:
        raise CliError(f"{name}: {_shown(source)} is not UTF-8 text (byte {exc.start})") from None
    rows = []
    for number, line in enumerate(lines, start=1):
        stripped = line.strip()
        if not stripped or stripped.startswith("#"):
            continue
        where = f"{name} line {number}"
        rows.append(_check_q(chain, parse_floats(stripped, where), where))
    if not rows:
        raise CliError(f"{name}: {_shown(source)} holds no configuration")
    return np.array(rows)


def _configurations(args: argparse.Namespace, chain: SerialChain) -> tuple[np.ndarray, bool]:
    """(Q (N, n), many): from --q (N = 1) or --q-file."""
    if getattr(args, "q_file", None) is not None:
        return read_configurations(chain, args.q_file, sys.stdin), True
    return get_q(chain, args.q)[None, :], False


# ---------------------------------------------------------------------- commands
Output = Iterable[dict[str, Any] | str]


def _description_notes(args: argparse.Namespace) -> list[str]:
    """What the whole description (not only the chain) has that was adjusted or ignored
    (`RobotDescription.notes`: normalised axes, mimic joints, a <mimic> on a fixed joint); [] for
    a DH table. Reads the XML only (no yourdfpy): a few ms."""
    if args.dh:
        return []
    from ..core.urdf import RobotDescription

    if args.urdf:
        return list(RobotDescription(args.urdf).notes)
    from ..sim.robots import robot_path

    return list(RobotDescription(robot_path(args.robot)).notes)


_NOTE_JOINT = re.compile(r"^joint '([^']*)'")


def cmd_info(args: argparse.Namespace, chain: SerialChain) -> Output:
    moving = list(chain.moving_joint_names)
    description_notes = _description_notes(args)
    data = {
        "base_link": chain.base_link,
        "tip_link": chain.tip_link,
        "dof": chain.dof,
        # the actuated joints: lower/upper are the limits IK keeps, own_lower/own_upper the
        # joint's own (they differ where a mimic follower's own limits narrow its leader's)
        "joints": [
            {
                "name": n, "type": t, "lower": lo, "upper": up, "velocity": v,
                "own_lower": own_lo, "own_upper": own_up,
            }
            for n, t, lo, up, v, own_lo, own_up in zip(
                chain.joint_names, chain.joint_types, chain.lower.tolist(),
                chain.upper.tolist(), chain.velocity_limit.tolist(), chain.own_lower.tolist(),
                chain.own_upper.tolist(), strict=True,
            )
        ],
        # followers: value = multiplier · leader + offset; lower/upper are their own limits
        "mimic_joints": [
            {
                "name": m.name, "leader": m.leader, "multiplier": m.multiplier,
                "offset": m.offset, "lower": float(chain.moving_lower[moving.index(m.name)]),
                "upper": float(chain.moving_upper[moving.index(m.name)]),
            }
            for m in chain.mimic_joints
        ],
        "moving_joint_names": moving,  # the columns of S and B
        "links": list(chain.link_names),
        "S": chain.S.tolist(),
        "B": chain.B.tolist(),
        "M": chain.M.tolist(),
        "G": chain.G.tolist(),  # θ = G q + offset: the moving joints' values from q
        "offset": chain.offset.tolist(),
        "notes": list(chain.notes),  # what building this chain adjusted, accepted or ignored
        "description_notes": description_notes,  # the same for the whole description
    }  # fmt: skip
    if args.json:
        return [data]
    rows = [f"chain {chain.base_link} → {chain.tip_link}, {chain.dof} joints"]
    rows.append(f"  {'#':>2} {'joint':<28}{'type':<12}{'lower':>10}{'upper':>10}{'velocity':>10}")
    narrowed = False
    for i, j in enumerate(data["joints"], 1):
        mark = ""
        if (j["lower"], j["upper"]) != (j["own_lower"], j["own_upper"]):
            mark, narrowed = "*", True
        rows.append(
            f"  {i:>2} {j['name']:<28}{j['type']:<12}{j['lower']:>10.4g}{j['upper']:>10.4g}"
            f"{j['velocity']:>10.4g}{mark}"
        )
    if narrowed:
        rows.append("  * limits narrowed so that the joint's mimic followers stay within theirs")
    if chain.mimic_joints:
        rows.append("mimic joints on the chain (no variable of their own; value from the leader):")
        rows.append(f"     {'joint':<28}{'value':<40}{'lower':>10}{'upper':>10}")
        for m in data["mimic_joints"]:
            rule = mimic_rule(m["leader"], m["multiplier"], m["offset"])
            rows.append(f"     {m['name']:<28}{rule:<40}{m['lower']:>10.4g}{m['upper']:>10.4g}")
    if moving == list(chain.joint_names):
        columns = "columns S1..Sn"
    else:  # mimic followers have their own columns
        columns = f"columns: {', '.join(moving)}"
    rows.append(f"screw axes in the space frame, S ({columns}; rows ω then v):")
    rows.append(_fmt_matrix(chain.S))
    rows.append("screw axes in the body frame, B:")
    rows.append(_fmt_matrix(chain.B))
    rows.append("home pose of the tip, M:")
    rows.append(_fmt_matrix(chain.M))
    # the chain's notes, then the description's about joints off the chain (the chain's notes
    # already speak of its own joints, and repeat those on the whole robot, e.g. a missing name)
    elsewhere = [
        note
        for note in description_notes
        if note not in chain.notes
        and ((found := _NOTE_JOINT.match(note)) is None or found.group(1) not in moving)
    ]
    if chain.notes:
        rows.append("notes on this chain:")
        rows += [f"  - {note}" for note in chain.notes]
    if elsewhere:
        rows.append("notes on the rest of the description:")
        rows += [f"  - {note}" for note in elsewhere]
    return ["\n".join(rows)]


def cmd_fk(args: argparse.Namespace, chain: SerialChain) -> Output:
    Q, many = _configurations(args, chain)
    T_all = chain.fk(Q)
    _require_finite(T_all, "pose")
    for q, T in zip(Q, T_all, strict=True):
        if args.json:
            yield {"joint_names": list(chain.joint_names), "q": q.tolist(), **_pose_dict(T)}
        else:
            head = f"q = {' '.join(f'{x:.6g}' for x in q)}\n" if many else ""
            yield f"{head}pose of {chain.tip_link} in {chain.base_link}:\n{_pose_text(T)}"


def manipulability_unit(chain: SerialChain) -> str:
    """Unit of Yoshikawa's linear manipulability: the product of min(3, n) singular values of
    the linear rows, each [m/rad] for revolute and [m/m] for prismatic joints."""
    k = min(3, chain.dof)
    power = {1: "", 2: "²", 3: "³"}[k]
    if all(t == "prismatic" for t in chain.joint_types):
        return "(dimensionless: m/m per joint)"
    if any(t == "prismatic" for t in chain.joint_types):
        return "(mixed units: m/rad for revolute, m/m for prismatic joints)"
    return f"m{power}/rad{power}"


def cmd_jacobian(args: argparse.Namespace, chain: SerialChain) -> Output:
    from ..core import condition_number, manipulability

    Q, many = _configurations(args, chain)
    T_all, Jw_all = chain.fk_jacobian(Q, "world")
    J_all = Jw_all if args.frame == "world" else chain.jacobian(Q, args.frame)
    _require_finite(J_all, "Jacobian")
    w_all = manipulability(Jw_all, "linear")
    c_all = condition_number(Jw_all, "full")
    unit = manipulability_unit(chain)
    rows_labels = ["wx", "wy", "wz", "vx", "vy", "vz"]
    for q, J, w, c in zip(Q, J_all, w_all, c_all, strict=True):
        if args.json:
            yield {
                "frame": args.frame,
                "q": q.tolist(),
                "rows": rows_labels,
                "columns": list(chain.joint_names),
                "J": J.tolist(),
                "manipulability_linear": float(w),
                "manipulability_linear_unit": unit,
                "condition_number": float(c),  # null when infinite (exact singularity)
            }
            continue
        head = f"q = {' '.join(f'{x:.6g}' for x in q)}\n" if many else ""
        head += f"{args.frame} Jacobian (rows ω then v; columns {', '.join(chain.joint_names)}):"
        body = "\n".join(
            f"  {label:<3}" + " ".join(f"{x:10.6g}" for x in row)
            for label, row in zip(rows_labels, _for_people(J), strict=True)
        )
        cond = f"{c:.6g}" if math.isfinite(c) else "inf (singular)"
        yield (
            f"{head}\n{body}\nmanipulability (linear) {w:.6g} {unit}\n"
            f"condition number {cond} (of the full 6×n world Jacobian; it mixes rad and m, so it "
            "depends on the length unit)"
        )


_IK_OPTION_NAMES = {  # IKOptions field → the option that sets it (library names stay inside)
    "IKOptions.position_tolerance": "--position-tolerance",
    "IKOptions.orientation_tolerance": "--orientation-tolerance",
    "IKOptions.timeout": "--timeout",
    "IKOptions.axis_tolerances": "--axis-tolerances",
    "IKOptions.mode": "--mode",
    "IKOptions.method='closed_form'": "--method closed_form",
    "IKOptions.position_only": "--position-only",
    "IKOptions": "IK options",
}
# The library's words in its messages (and what in them names an API) → this command line's:
# the reason stays, the names become the options that set them.
_CLI_WORDS: tuple[tuple[re.Pattern[str], str], ...] = (
    *((re.compile(re.escape(k)), v) for k, v in _IK_OPTION_NAMES.items()),
    (re.compile(r"; use chain\.ik \(numeric\) instead"), "; without --all, ik searches numerically"),
    (re.compile(r"\(?chain\.ik_all sweeps the held joint for sets\)?"), "(--all sweeps the held "
     "joint and gives sets)"),
    (re.compile(r"in mode '(speed|distance)'"), r"with --mode \1"),
    (re.compile(r"\bposition_only\b"), "--position-only"),
    (re.compile(r"a freed pose component"), "an axis freed by --axis-tolerances (inf)"),
    (re.compile(r"the ([0-9.e+-]+ m?s) timeout ran out"), r"the --timeout of \1 ran out"),
    (re.compile(r"max_restarts=(\d+) reached"), r"gave up after \1 restarts"),
    (re.compile(r"(?<![\w'\"])q_seed(?![\w'\"])"), "--seed"),
    (re.compile(r"(?<![\w'\"])T_target(?![\w'\"])"), "--target"),
)  # fmt: skip


def cli_words(text: str) -> str:
    """A library message with its parameter and API names replaced by this command line's
    options (`--tip`, `--method numeric`, `--timeout` ...): the reason is kept."""
    for pattern, words in _CLI_WORDS:
        text = pattern.sub(words, text)
    return text


def _failure_text(message: str) -> str:
    """The library's IK failure message (why, how long, best residual) as this command's."""
    text = cli_words(" ".join(message.split()))
    # "closed form: <why>; numeric search: no solution: <why>": "no solution" said once, first
    text = text.replace("; numeric search: no solution: ", "; numeric search: ")
    return text if text.startswith("no solution") else f"no solution: {text}"


def cmd_ik(args: argparse.Namespace, chain: SerialChain) -> Output:

    from ..core.rotations import matrix_from_quaternion

    v = parse_floats(args.target, "--target")
    if v.size != 7:
        raise CliError(f"--target: expected 7 values x,y,z,qx,qy,qz,qw, got {v.size}")
    T = np.eye(4)
    try:
        T[:3, :3] = matrix_from_quaternion(v[3:])  # any non-zero quaternion is normalised
    except KinematicsError:
        raise CliError(
            "--target: the quaternion qx,qy,qz,qw is zero; give any non-zero quaternion "
            "(it is normalised)"
        ) from None
    T[:3, 3] = v[:3]
    seed = None if args.seed is None else get_q(chain, args.seed, "--seed")
    if args.all:
        return _ik_all(args, chain, T, seed)
    axis_tolerances = None
    if args.axis_tolerances is not None:
        bounds = parse_floats(args.axis_tolerances, "--axis-tolerances", allow_inf=True)
        if bounds.size != 6 or not np.all(bounds > 0) or np.all(np.isinf(bounds)):
            raise CliError(
                "--axis-tolerances: expected 6 values > 0 (wx,wy,wz,x,y,z; inf frees an axis, "
                f"not all inf), got {bounds.size} values"
                + ("" if bounds.size != 6 else f" {bounds.tolist()}")
            )
        axis_tolerances = tuple(bounds)
    try:
        options = IKOptions(
            position_tolerance=args.position_tolerance,
            orientation_tolerance=args.orientation_tolerance,
            timeout=args.timeout,
            position_only=args.position_only,
            axis_tolerances=axis_tolerances,
            mode=args.mode,
            method=args.method,
            rng_seed=0,
        )
    except KinematicsError as exc:
        raise CliError(cli_words(str(exc))) from None
    # The solvers' imports (~0.2 s, SciPy's) and the detection of the arm's closed form (a UR5e
    # 4 ms, a Panda ~50 ms) happen now, before the clock starts: the time reported is the
    # solve's, as in a program that calls ik more than once.
    from ..core.ik.solver import duration_text
    from .chain_cache import detect_family

    detect_family(chain)  # (kept in the chain's cache entry: the next run skips it)
    t0 = time.perf_counter()
    res = chain.ik(T, q_seed=seed, options=options)
    ms = (time.perf_counter() - t0) * 1e3
    q = np.asarray(res.q, dtype=float)
    _require_finite(q, "IK solution")
    # orientation free: position-only, or every rotation axis unbounded (the solver then reports 0)
    free = bool(args.position_only) or (
        axis_tolerances is not None and all(math.isinf(b) for b in axis_tolerances[:3])
    )
    data = {
        "success": bool(res.success),
        "joint_names": list(chain.joint_names),
        "q": q.tolist(),
        "position_error": float(res.position_error),
        "orientation_error": None if free else float(res.orientation_error),
        "iterations": int(res.iterations),
        "restarts": int(getattr(res, "restarts", 0)),
        "time_ms": ms,
    }
    if axis_tolerances is not None:
        wanted = f"per-axis bounds {','.join(f'{b:g}' for b in axis_tolerances)}"
    elif free:
        wanted = f"{options.position_tolerance:g} m (orientation free)"
    else:
        wanted = f"{options.position_tolerance:g} m / {options.orientation_tolerance:g} rad"
    if res.success:
        data["message"] = f"solved within {wanted} in {duration_text(ms / 1e3)}"  # "0.31 ms"
    else:  # the library's reason: out of reach (how far), out of time, no closed form ...
        data["message"] = _failure_text(res.message)
    if not res.success:
        # Still report the best configuration found, but exit non-zero.
        print(dump_json(data) if args.json else _ik_text(data), file=sys.stdout)
        raise CliError(str(data["message"]))
    return [data if args.json else _ik_text(data)]


def _ik_all(
    args: argparse.Namespace, chain: SerialChain, T: np.ndarray, seed: np.ndarray | None
) -> Output:
    """`ik --all`: every closed-form solution, nearest the seed first (7R arms: held joint swept)."""
    from .chain_cache import detect_family

    detect_family(chain)
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
        from ..core.ik.solver import beyond_reach

        far = beyond_reach(chain, T, IKOptions())  # how far, where the position alone says so
        data["message"] = _failure_text(res.message + (f" ({far})" if far else ""))
        print(dump_json(data) if args.json else str(data["message"]))
        raise CliError(str(data["message"]))
    if args.json:
        return [data]
    rows = [res.message, f"columns [rad]: {', '.join(chain.joint_names)}"]
    rows += [
        f"{i:>4}  " + " ".join(f"{x:10.6f}" for x in _for_people(np.asarray(sol)))
        for i, sol in enumerate(res.solutions, 1)
    ]
    return ["\n".join(rows)]


def _ik_text(d: dict[str, Any]) -> str:
    rows = [str(d["message"])]
    rows += [f"  {n:<28}{x: .6f}" for n, x in zip(d["joint_names"], d["q"], strict=True)]
    orientation = (
        "orientation free"
        if d["orientation_error"] is None
        else f"orientation error {d['orientation_error']:.2e} rad"
    )
    rows.append(
        f"position error {d['position_error']:.2e} m, {orientation}, {d['iterations']} iterations"
    )
    return "\n".join(rows)


COMMANDS: dict[str, tuple[str, Callable[[argparse.Namespace, SerialChain], Output]]] = {
    "info": ("print the chain, joint table and S, B, M", cmd_info),
    "fk": ("forward kinematics: pose of the tip in the base", cmd_fk),
    "jacobian": ("Jacobian in the space, body or world frame", cmd_jacobian),
    "ik": ("inverse kinematics: joint values reaching a tip pose", cmd_ik),
}

EXAMPLES = {
    "info": """examples:
  kinematics info --robot panda
  kinematics info --urdf arm.urdf --base base_link --tip tool0 --json""",
    "fk": """examples:
  kinematics fk --robot ur5e --q 0,-1.2,1.4,0,0.5,0
  kinematics fk --robot ur5e --q-file poses.txt --json    # JSON Lines, one pose per line
  printf '0 0 0 0 0 0\\n0.1 0 0 0 0 0\\n' | kinematics fk --robot ur5e --q-file -""",
    "jacobian": """examples:
  kinematics jacobian --robot ur5e --q 0,-1.2,1.4,0,0.5,0 --frame body
  kinematics jacobian --dh config/robots/scara_dh.json --q 0.1,0.2,0.05,0 --json

frames (rows ω then v, as in Modern Robotics):
  world  angular velocity and velocity of the tip origin, both in base axes (geometric Jacobian)
  space  J_s: twist in the base frame; v = velocity of the point at the base origin
  body   J_b: twist in the tip frame""",
    "ik": """examples:
  kinematics ik --robot ur5e --target -0.5756,-0.3902,0.3512,0,0,0,1 --position-only
  kinematics ik --robot panda --target 0.4,0.1,0.5,1,0,0,0 --axis-tolerances 1e-4,1e-4,inf,1e-5,1e-5,1e-5
  kinematics ik --robot ur5e --target 0.3,0.2,0.4,1,0,0,0 --all    # every closed-form solution

modes:
  speed     return the first solution found (default)
  distance  search until the timeout and return the solution closest to the seed

The quaternion is (x, y, z, w); any non-zero quaternion is normalised. Exit status 1 when no
solution is found (the best configuration is still printed).""",
    "demo": """examples:
  kinematics demo
  kinematics demo --robot panda --duration 5 --out panda.svg""",
    "servo-demo": """examples:
  kinematics servo-demo
  kinematics servo-demo --rate 500 --out servo.svg --no-ros""",
}


class _Formatter(argparse.RawDescriptionHelpFormatter):
    """Keeps the examples' layout and shows each option's default (when it has a real one)."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        if (
            action.default not in (None, False, argparse.SUPPRESS)
            and "%(default)" not in text
            and action.option_strings
        ):
            text += " (default: %(default)s)"
        return text


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors, and `--q -0.5,1` taken as a value, not an option."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("formatter_class", _Formatter)
        super().__init__(*args, **kwargs)
        # argparse takes '-0.5,1' for an option unless it matches this (private, but stable since
        # Python 3.2; 3.13 widened its own pattern the same way). Our options never look like it.
        self._negative_number_matcher = re.compile(r"^-(\d|\.\d|inf|nan)", re.IGNORECASE)

    def error(self, message: str) -> Any:  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


class _Version(argparse.Action):
    """--version, looked up only when asked (importlib.metadata costs start-up time)."""

    def __init__(self, option_strings: Sequence[str], dest: str = argparse.SUPPRESS, **kw: Any):
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, **kw)

    def __call__(self, parser: argparse.ArgumentParser, *_: Any) -> None:
        from importlib.metadata import PackageNotFoundError, version

        try:
            v = version("kinematics_service")
        except PackageNotFoundError:
            v = "unknown (not installed)"
        print(f"kinematics {v}")
        parser.exit(0)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="kinematics",
        description="Product-of-exponentials kinematics of a URDF, xacro or DH robot, without ROS.\n"
        "Joint values are in rad (m for prismatic joints), lengths in m, quaternions (x, y, z, w).",
        epilog="Run 'kinematics COMMAND --help' for a command's options and examples. Errors are\n"
        "one line on stderr; exit status 1 for bad input, 2 for command-line usage.",
    )
    parser.add_argument("--version", action=_Version, help="print the version and exit")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    positive = _number_type("a finite number > 0")
    for name, (helptext, _) in COMMANDS.items():
        p = sub.add_parser(name, help=helptext, description=helptext, epilog=EXAMPLES[name])
        src = p.add_argument_group("robot (exactly one is required)")
        one = src.add_mutually_exclusive_group(required=True)
        one.add_argument("--urdf", metavar="FILE", help="URDF or xacro file")
        one.add_argument(
            "--dh",
            metavar="FILE",
            help="JSON DH table: {'joints': [{a, alpha, d, theta, type}, ...]} (standard DH)",
        )
        one.add_argument(
            "--robot",
            metavar="NAME",
            help="a bundled robot: ur5e, panda, iiwa14, scara, planar3r",
        )
        p.add_argument("--base", metavar="LINK", help="base link (default: the root link)")
        p.add_argument("--tip", metavar="LINK", help="tip link (default: the single leaf)")
        p.add_argument("--json", action="store_true", help="strict JSON output (inf → null)")
        if name in ("fk", "jacobian"):
            qs = p.add_argument_group("joint values (exactly one is required)")
            qgroup = qs.add_mutually_exclusive_group(required=True)
            qgroup.add_argument("--q", metavar="Q1,Q2,...", help="one configuration [rad or m]")
            qgroup.add_argument(
                "--q-file",
                metavar="FILE",
                help="many configurations, one per line ('-' = stdin); with --json, "
                "the output is JSON Lines",
            )
        if name == "jacobian":
            p.add_argument(
                "--frame",
                choices=("world", "space", "body"),
                default="world",
                help="reference frame of the twist (see the frames below)",
            )
        if name == "ik":
            p.add_argument(
                "--target",
                metavar="X,Y,Z,QX,QY,QZ,QW",
                required=True,
                help="tip pose in the base: position [m], quaternion (normalised if not unit)",
            )
            p.add_argument(
                "--seed", metavar="Q1,Q2,...", help="start configuration (default: mid-limits)"
            )
            p.add_argument(
                "--all",
                action="store_true",
                help="every solution, in closed form (arms with a closed-form family only)",
            )
            p.add_argument(
                "--mode",
                choices=("speed", "distance"),
                default="speed",
                help="speed: first solution; distance: closest to the seed within the timeout",
            )
            p.add_argument(
                "--method",
                choices=("auto", "closed_form", "numeric"),
                default="auto",
                help="auto: the closed form where the arm has one (see --all), else the numeric "
                "search; closed_form or numeric: only that one",
            )
            ik_defaults = IKOptions()  # one source of the IK defaults: the library's
            p.add_argument(
                "--timeout", type=positive, default=ik_defaults.timeout, help="time budget [s]"
            )
            p.add_argument(
                "--position-tolerance",
                type=positive,
                default=ik_defaults.position_tolerance,
                help="position error [m]",
            )
            p.add_argument(
                "--orientation-tolerance",
                type=positive,
                default=ik_defaults.orientation_tolerance,
                help="orientation error (rotation angle) [rad]",
            )
            how = p.add_mutually_exclusive_group()
            how.add_argument(
                "--position-only", action="store_true", help="ignore the target orientation"
            )
            how.add_argument(
                "--axis-tolerances",
                metavar="WX,WY,WZ,X,Y,Z",
                help="per-axis bounds in the tip frame [rad, m]; inf frees an axis "
                "(replaces the two tolerances above)",
            )
    demo = sub.add_parser(
        "demo",
        help="run a simulated arm and the node, call the services, draw a picture",
        description="With ROS 2 (make demo builds it from PyPI): start the simulated arm and the\n"
        "kinematics node as processes, listen to ee_pose/ee_twist, call compute_fk,\n"
        "compute_jacobian and compute_ik over DDS, print a live summary and draw a picture of\n"
        "what arrived. Without ROS 2 (or with --no-ros): the same arm and joint-state logic in\n"
        "this process. Needs matplotlib.",
        epilog=EXAMPLES["demo"],
    )
    demo.add_argument("--robot", default="ur5e", help="bundled robot")
    demo.add_argument(
        "--out", default="kinematics_demo.png", help="picture file (.png, .svg, .pdf, ...)"
    )
    demo.add_argument("--duration", type=positive, default=10.0, help="simulated time [s]")
    demo.add_argument("--rate", type=positive, default=100.0, help="joint_states rate [Hz]")
    demo.add_argument(
        "--no-ros", action="store_true", help="run in this process even where ROS 2 is available"
    )
    servo_demo = sub.add_parser(
        "servo-demo",
        help="the servo drives the UR5e's tool around a square through a wrist singularity",
        description="The servo drives the UR5e's tool around a 0.2 m square through a wrist\n"
        "singularity, then spins it in place; prints the tracking error, the time stopped, the\n"
        "peak joint velocity, acceleration and jerk against their limits, and draws a picture.\n"
        "With ROS 2 (make demo builds it from PyPI): the simulated arm, the kinematics node and\n"
        "the servo node as processes, the twists sent over DDS. Without ROS 2 (or with\n"
        "--no-ros): the core servo and the simulated arm in this process. Needs matplotlib;\n"
        "without ruckig the servo runs without its jerk limits.",
        epilog=EXAMPLES["servo-demo"],
    )
    servo_demo.add_argument(
        "--out", default="servo_demo.png", help="picture file (.png, .svg, .pdf, ...)"
    )
    servo_demo.add_argument(
        "--rate", type=positive, default=100.0, help="servo and simulated arm rate [Hz], 10 to 2000"
    )
    servo_demo.add_argument(
        "--no-ros", action="store_true", help="run in this process even where ROS 2 is available"
    )
    bag.add_parser(sub)  # `kinematics bag`: rosbags is imported only when it runs
    bag.add_record_demo_parser(sub)
    reach.add_parser(sub)  # `kinematics reach`: the map job is imported only when it runs
    place.add_parser(sub)  # `kinematics place`: base placement from a reachability map
    ros_commands.add_parser(sub)  # `kinematics ros ...`: ROS is imported only when it runs
    return parser


def _demo(args: argparse.Namespace) -> int:
    steps = round(args.duration * args.rate)
    if not 2 <= steps <= _MAX_STEPS:
        raise CliError(f"--duration × --rate gives {steps} joint states; need 2 to {_MAX_STEPS:,}")
    from ..ros.env import unavailable_reason
    from ..sim import demo
    from ..sim.robots import robot_path

    # Everything the user can get wrong, before anything starts (and before saying which demo)
    robot_path(args.robot)
    try:
        demo.check_matplotlib()
        path = demo.check_picture_path(args.out)
    except ValueError as exc:
        raise CliError(str(exc)) from None
    reason = None if args.no_ros else unavailable_reason()
    if args.no_ros or reason is not None:
        if reason is not None:
            print(
                f"ROS 2 is not available ({reason}); running the demo in this process instead",
                file=sys.stderr,
            )
        return demo.main(args.robot, args.out, args.duration, args.rate)
    from ..ros import live_demo

    return live_demo.main(args.robot, path, args.duration, args.rate)


def _servo_demo(args: argparse.Namespace) -> int:
    if not 10.0 <= args.rate <= 2000.0:
        raise CliError(f"--rate {args.rate:g}: the servo runs at 10 to 2000 Hz")
    from ..core.servo import RUCKIG_INSTALL, ruckig_available
    from ..ros import servo_live_demo
    from ..sim import demo, servo_demo

    if not ruckig_available():
        print(
            "Ruckig is not installed: the servo runs within its position, velocity and "
            "acceleration limits but not its jerk limits (the jerk printed may pass them); for "
            f"jerk limits: {RUCKIG_INSTALL}",
            file=sys.stderr,
        )
    # Everything the user can get wrong, before anything starts (and before saying which demo)
    try:
        demo.check_matplotlib()
        path = demo.check_picture_path(args.out)
    except ValueError as exc:
        raise CliError(str(exc)) from None
    reason = None if args.no_ros else servo_live_demo.unavailable_reason()
    if reason is not None:
        print(
            f"ROS 2 is not available ({reason}); running the servo demo in this process instead",
            file=sys.stderr,
        )
    if args.no_ros or reason is not None:
        return servo_demo.main(path, args.rate)
    return servo_live_demo.main(path, args.rate)


def _emit(results: Output, as_json: bool, many: bool) -> None:
    """Print results as they come: text blocks (blank line between), one indented JSON document,
    or JSON Lines when there are many."""
    first = True
    for result in results:
        if isinstance(result, str):
            print(result if first else f"\n{result}")
        else:
            print(dump_json(result, indent=None if many else 2))
        first = False


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(sys.argv[1:] if argv is None else list(argv))
        if args.command == "ik" and args.all:
            ignored = [
                option
                for option, given in (
                    ("--position-only", args.position_only),
                    ("--axis-tolerances", args.axis_tolerances is not None),
                    ("--method numeric", args.method == "numeric"),
                    ("--mode distance", args.mode == "distance"),
                )
                if given
            ]
            if ignored:
                parser.error(
                    f"ik: --all gives every closed-form solution of the whole pose; it does not "
                    f"combine with {', '.join(ignored)}"
                )
    except SystemExit as exc:  # --help, --version, usage errors: argparse printed them
        return exc.code if isinstance(exc.code, int) else 2
    try:
        if args.command == "demo":
            return _demo(args)
        if args.command == "servo-demo":
            return _servo_demo(args)
        if args.command == "ros":
            return ros_commands.run(args)
        if args.command == "bag":
            return bag.run(args)
        if args.command == "record-demo":
            return bag.run_record_demo(args)
        if args.command == "reach":
            return reach.run(args)
        if args.command == "place":
            return place.run(args, load_chain, dump_json)
        # overflow in extreme but finite inputs shows in the results (checked finite), not as
        # numpy's warnings on stderr
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            chain = load_chain(args)
            results = COMMANDS[args.command][1](args, chain)
            _emit(results, args.json, getattr(args, "q_file", None) is not None)
        sys.stdout.flush()
    except (CliError, KinematicsError) as exc:
        sys.stdout.flush()
        text = str(exc) if isinstance(exc, CliError) else cli_words(str(exc))
        print(f"kinematics: error: {' '.join(text.split())}", file=sys.stderr)
        return 1
    except BrokenPipeError:
        # The reader went away (`kinematics ... | head`): stop quietly, as command-line tools do.
        # Point stdout at /dev/null so that the interpreter's final flush does not fail again.
        try:
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        except (OSError, ValueError):
            pass
        return 141  # 128 + SIGPIPE, what a shell reports for a tool killed by the closed pipe
    except OSError as exc:  # e.g. output to a full disk
        print(f"kinematics: error: {exc.strerror or exc}", file=sys.stderr)
        try:
            sys.stdout.flush()
        except OSError:  # the interpreter's final flush would fail again
            with contextlib.suppress(OSError, ValueError):
                os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except KeyboardInterrupt:
        print("kinematics: interrupted", file=sys.stderr)
        return 130  # 128 + SIGINT
    return 0
