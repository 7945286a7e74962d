"""URDF / xacro → `ChainSpec`, using yourdfpy for parsing and the `xacro` package for macros.

Joint origins are T_parent_joint = Trans(xyz) · R_Z(yaw) R_Y(pitch) R_X(roll) (URDF rpy = fixed
XYZ). A moving joint then applies a rotation about (or translation along) its unit `axis`, given in
the joint frame. Fixed joints are folded into the constant transforms; mimic joints (value =
multiplier · leader + offset) are folded into the leader's column. Floating and planar joints on
the chain, kinematic loops, missing links and zero or non-unit axes are refused with an error that
names the joint or link.
"""

from __future__ import annotations

import io
import logging
import os
import xml.etree.ElementTree as ET
from os import PathLike
from typing import Any

import numpy as np

from .chain import ChainSpec, JointModel, frame_aligned_with
from .exceptions import RobotDescriptionError, UnknownNameError

_MOVING = ("revolute", "continuous", "prismatic")
_AXIS_TOLERANCE = 1e-4  # URDFs often print axes with 4–6 digits, e.g. "0 0.7071 0.7071"


def read_description(path_or_xml: str | PathLike[str]) -> str:
    """Return URDF XML text from a path or XML string, expanding xacro when needed.

    Raises:
        RobotDescriptionError: unreadable file, malformed XML, or xacro not installed/failing.
    """
    text: str
    filename: str | None = None
    if isinstance(path_or_xml, PathLike) or not str(path_or_xml).lstrip().startswith("<"):
        filename = os.fspath(path_or_xml)
        try:
            with open(filename, encoding="utf-8") as fh:
                text = fh.read()
        except OSError as exc:
            raise RobotDescriptionError(
                f"cannot read robot description {filename!r}: {exc}"
            ) from None
    else:
        text = str(path_or_xml)
    if (filename is not None and filename.endswith(".xacro")) or "xmlns:xacro" in text:
        text = _expand_xacro(text, filename)
    try:
        ET.fromstring(text)
    except ET.ParseError as exc:
        where = f" in {filename!r}" if filename else ""
        raise RobotDescriptionError(f"malformed XML{where}: {exc}") from None
    return text


def _expand_xacro(text: str, filename: str | None) -> str:
    try:
        import xacro
    except ImportError:
        raise RobotDescriptionError(
            "this description uses xacro, but the 'xacro' package is not installed "
            "(pip install xacro, or pip install 'kinematics_service[xacro]')"
        ) from None
    try:
        if filename is not None:
            return str(xacro.process_file(filename).toxml())
        doc = xacro.parse(text)
        xacro.process_doc(doc)
        return str(doc.toxml())
    except Exception as exc:  # xacro raises its own XacroException and plain Python errors
        raise RobotDescriptionError(f"xacro processing failed: {exc}") from None


def _load_robot(text: str) -> Any:
    import yourdfpy

    log = logging.getLogger("yourdfpy")
    level = log.level
    log.setLevel(logging.CRITICAL)  # we report problems ourselves, with the culprit's name
    try:
        urdf = yourdfpy.URDF.load(
            io.BytesIO(text.encode("utf-8")),
            build_scene_graph=False,
            load_meshes=False,
            load_collision_meshes=False,
        )
    except Exception as exc:
        raise RobotDescriptionError(f"URDF could not be parsed: {exc}") from None
    finally:
        log.setLevel(level)
    return urdf.robot


def spec_from_urdf(
    path_or_xml: str | PathLike[str], base_link: str | None = None, tip_link: str | None = None
) -> ChainSpec:
    """Parse a description and extract the chain `base_link` → `tip_link` (see module docstring)."""
    robot = _load_robot(read_description(path_or_xml))
    links = [link.name for link in robot.links]
    if not links:
        raise RobotDescriptionError("the robot description has no <link>")
    joints = {j.name: j for j in robot.joints}
    link_set = set(links)

    parent_joint: dict[str, Any] = {}
    children: dict[str, list[str]] = {name: [] for name in links}
    for j in robot.joints:
        for role, link in (("parent", j.parent), ("child", j.child)):
            if link not in link_set:
                raise RobotDescriptionError(
                    f"joint {j.name!r} refers to {role} link {link!r}, which is not defined"
                )
        if j.child in parent_joint:
            raise RobotDescriptionError(
                f"link {j.child!r} is the child of two joints ({parent_joint[j.child].name!r} and "
                f"{j.name!r}): kinematic loops are not supported"
            )
        parent_joint[j.child] = j
        children[j.parent].append(j.child)
    roots = [name for name in links if name not in parent_joint]
    if len(roots) != 1:
        if not roots:
            raise RobotDescriptionError("the description has no root link: its joints form a loop")
        raise RobotDescriptionError(
            f"the description has several root links {roots}; expected one tree"
        )

    base = roots[0] if base_link is None else base_link
    if base not in link_set:
        raise UnknownNameError("link", base, links)
    if tip_link is None:
        leaves = _leaves_below(base, children)
        if len(leaves) != 1:
            raise RobotDescriptionError(
                f"several leaf links below {base!r}: {leaves}; choose one with tip_link"
            )
        tip = leaves[0]
    else:
        tip = tip_link
        if tip not in link_set:
            raise UnknownNameError("link", tip, links)

    path = _path(base, tip, parent_joint)  # joints base → tip
    return _build_spec(base, tip, path, joints)


def _leaves_below(base: str, children: dict[str, list[str]]) -> list[str]:
    leaves, stack = [], [base]
    while stack:
        link = stack.pop()
        if children[link]:
            stack.extend(reversed(children[link]))
        elif link != base:
            leaves.append(link)
    return leaves


def _path(base: str, tip: str, parent_joint: dict[str, Any]) -> list[Any]:
    path, link = [], tip
    while link != base:
        joint = parent_joint.get(link)
        if joint is None:
            raise RobotDescriptionError(
                f"tip link {tip!r} is not below base link {base!r}; only base → tip chains "
                "that follow the tree downwards are supported"
            )
        path.append(joint)
        link = joint.parent
    return path[::-1]


def _joint_limits(j: Any) -> tuple[str, float, float, float]:
    """(type, lower, upper, velocity) of a moving joint, validating the <limit> element."""
    lim = j.limit
    vel = float(lim.velocity) if lim is not None and lim.velocity is not None else np.inf
    if j.type == "continuous":
        return "continuous", -np.inf, np.inf, vel
    if lim is None:
        raise RobotDescriptionError(
            f"{j.type} joint {j.name!r} has no <limit>; URDF requires one "
            "(use type='continuous' for an unlimited revolute joint)"
        )
    # URDF: lower and upper default to 0 when the attributes are absent.
    lower = 0.0 if lim.lower is None else float(lim.lower)
    upper = 0.0 if lim.upper is None else float(lim.upper)
    if not lower <= upper:
        raise RobotDescriptionError(
            f"joint {j.name!r} has lower limit {lower} > upper limit {upper}"
        )
    if j.type == "revolute" and lower == upper == 0.0:
        raise RobotDescriptionError(
            f"revolute joint {j.name!r} has limits [0, 0]: it could not move "
            "(missing lower/upper attributes?)"
        )
    return j.type, lower, upper, vel


def _unit_axis(j: Any) -> np.ndarray:
    axis = np.array([1.0, 0.0, 0.0]) if j.axis is None else np.asarray(j.axis, dtype=np.float64)
    norm = float(np.linalg.norm(axis))
    if not np.all(np.isfinite(axis)) or norm < 1e-12:
        raise RobotDescriptionError(f"joint {j.name!r} has a zero or invalid axis {axis.tolist()}")
    if abs(norm - 1.0) > _AXIS_TOLERANCE:
        raise RobotDescriptionError(
            f"joint {j.name!r} has a non-unit axis {axis.tolist()} (norm {norm:.6g}); URDF axes "
            "must be unit vectors"
        )
    return axis / norm


def _build_spec(base: str, tip: str, path: list[Any], joints: dict[str, Any]) -> ChainSpec:
    T = np.eye(4)  # pose of the current link in the base, at home
    moving: list[JointModel] = []
    followers: list[
        tuple[str, float, float]
    ] = []  # (leader name, multiplier, offset) per moving joint
    chain_links: list[tuple[str, np.ndarray, int]] = [(base, np.eye(4), -1)]
    for j in path:
        if j.type not in _MOVING and j.type != "fixed":
            raise RobotDescriptionError(
                f"joint {j.name!r} on the chain {base!r} → {tip!r} is of type {j.type!r}; "
                "only revolute, continuous, prismatic and fixed joints are supported"
            )
        origin = np.eye(4) if j.origin is None else np.asarray(j.origin, dtype=np.float64)
        T_joint = T @ origin
        if j.type == "fixed":
            T = T_joint
        else:
            axis = _unit_axis(j)
            R_align = frame_aligned_with(axis)
            H = T_joint.copy()
            H[:3, :3] = T_joint[:3, :3] @ R_align
            moving.append(JointModel(j.name, j.type == "prismatic", H))
            if j.mimic is not None:
                m = 1.0 if j.mimic.multiplier is None else float(j.mimic.multiplier)
                c = 0.0 if j.mimic.offset is None else float(j.mimic.offset)
                followers.append((j.mimic.joint, m, c))
            else:
                followers.append((j.name, 1.0, 0.0))
            T = T_joint
        chain_links.append((j.child, T.copy(), len(moving) - 1))

    # Actuated variables: non-mimic joints, plus the leaders of mimic joints, in base → tip order.
    actuated: list[str] = []
    for leader, _, _ in followers:
        if leader not in actuated:
            actuated.append(leader)
    types, lower, upper, vel = [], [], [], []
    for name in actuated:
        leader_joint = joints.get(name)
        if leader_joint is None:
            raise RobotDescriptionError(
                f"a mimic joint follows joint {name!r}, which is not defined"
            )
        if leader_joint.type not in _MOVING:
            raise RobotDescriptionError(
                f"a mimic joint follows joint {name!r} of type {leader_joint.type!r}, which cannot move"
            )
        if leader_joint.mimic is not None:
            raise RobotDescriptionError(
                f"mimic joint chains are not supported: {name!r} itself mimics {leader_joint.mimic.joint!r}"
            )
        t, lo, up, v = _joint_limits(leader_joint)
        types.append(t)
        lower.append(lo)
        upper.append(up)
        vel.append(v)
    G = np.zeros((len(moving), len(actuated)))
    offset = np.zeros(len(moving))
    for k, (leader, m, c) in enumerate(followers):
        G[k, actuated.index(leader)] = m
        offset[k] = c
    if not moving:
        raise RobotDescriptionError(f"the chain {base!r} → {tip!r} has no moving joint")
    return ChainSpec(
        base_link=base,
        tip_link=tip,
        joints=moving,
        M=T,
        actuated_names=actuated,
        joint_types=types,
        lower=np.array(lower),
        upper=np.array(upper),
        velocity_limit=np.array(vel),
        G=G,
        offset=offset,
        links=chain_links,
    )
