"""URDF / xacro → `ChainSpec`, using yourdfpy for parsing and the `xacro` package for macros.

Joint origins are T_parent_joint = Trans(xyz) · R_Z(yaw) R_Y(pitch) R_X(roll) (URDF rpy = fixed
XYZ). A moving joint then applies a rotation about (or translation along) its `axis`, given in
the joint frame and normalised to a unit vector, as Pinocchio does ("0.707 0 0.707" and "0 0 2"
are accepted; a zero or non-finite axis is refused). Fixed joints are folded into the constant
transforms. A mimic joint (value = multiplier · leader + offset) stays a moving joint of the chain
whose value follows its leader, which becomes the chain's actuated variable (see
`SerialChain`). Floating and planar joints on the chain, kinematic loops, missing links and
zero axes are refused with an error that names the joint or link. What is accepted and adjusted
(normalised axes), taken as given (mimic joints) or missing but harmless for kinematics (a <robot>
without a name) is listed in `RobotDescription.notes` and, for one chain, in `ChainSpec.notes`.

Only what kinematics reads is checked (`check_kinematic_elements`: link names; each joint's name,
type, parent, child, origin, axis, limit and mimic) and handed to yourdfpy. Visual, collision,
inertial, material, calibration, safety and transmission elements are not read, so a malformed one
is neither refused nor noted (robot_state_publisher and other urdfdom-based tools refuse such a
description).
"""

from __future__ import annotations

import codecs
import contextlib
import dataclasses
import io
import logging
import math
import os
import re
import xml.etree.ElementTree as ET
from os import PathLike
from typing import Any

import numpy as np

from .exceptions import RobotDescriptionError, UnknownNameError
from .model import MOVING_JOINT_TYPES, ChainSpec, JointModel, frame_aligned_with, mimic_rule

#: An axis whose norm differs from 1 by more than this is noted as normalised (less is the
#: rounding of an axis printed to six or more digits, e.g. "0 0.7071068 0.7071068").
_AXIS_NOTED = 1e-6


_XACRO_NAMESPACE_MARK = "xacro"  # every xacro namespace URI in use ends in /xacro
_ENCODING_DECLARATION = re.compile(
    rb"""^\s*<\?xml[^>]*?\sencoding\s*=\s*["']([A-Za-z0-9._:-]+)["']"""
)
_BOMS = (
    (codecs.BOM_UTF32_LE, "utf-32"),  # before UTF-16: its BOM starts with UTF-16 LE's
    (codecs.BOM_UTF32_BE, "utf-32"),
    (codecs.BOM_UTF8, "utf-8-sig"),
    (codecs.BOM_UTF16_LE, "utf-16"),
    (codecs.BOM_UTF16_BE, "utf-16"),
)


def shorten(text: str, limit: int = 60) -> str:
    """`text` for an error message: one line, at most `limit` characters."""
    text = " ".join(str(text).split())
    return text if len(text) <= limit else text[: limit - 1] + "…"


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__


def decode_xml(data: bytes, where: str = "robot description") -> str:
    """Decode XML bytes as the XML spec says: a byte-order mark, else the `encoding` of the XML
    declaration, else UTF-8. The declaration's encoding is removed from the returned text, which
    is a str (already decoded) from then on.

    Raises:
        RobotDescriptionError: unknown encoding, or bytes that are not text in that encoding.
    """
    encoding = "utf-8"
    for bom, name in _BOMS:
        if data.startswith(bom):
            encoding = name
            break
    else:
        declared = _ENCODING_DECLARATION.match(data[:400])
        if declared:
            encoding = declared.group(1).decode("ascii")
            try:
                codecs.lookup(encoding)
            except LookupError:
                raise RobotDescriptionError(
                    f"{where} declares an unknown encoding {shorten(encoding)!r}"
                ) from None
    try:
        text = data.decode(encoding)
    except UnicodeDecodeError as exc:
        byte = f"byte 0x{data[exc.start]:02x} at position {exc.start}"
        if b"\0" in data[:4096]:
            raise RobotDescriptionError(
                f"{where} is a binary file, not XML text ({byte})"
            ) from None
        raise RobotDescriptionError(
            f"{where} is not {encoding} text ({byte}); if it is in another encoding, declare it: "
            "<?xml version='1.0' encoding='...'?>"
        ) from None
    return _drop_encoding_declaration(text)


def _drop_encoding_declaration(text: str) -> str:
    """The text without the `encoding` of its XML declaration (it is decoded already; parsers
    handed the text as UTF-8 bytes must not decode it again with the declared encoding)."""
    text = text.lstrip("\ufeff")
    if text.lstrip().startswith("<?xml"):
        end = text.find("?>")
        if end > 0:
            head = re.sub(r"""\sencoding\s*=\s*["'][^"']*["']""", "", text[:end])
            text = head + text[end:]
    return text


def read_description(path_or_xml: str | bytes | PathLike[str]) -> str:
    """URDF XML text of a description; see `RobotDescription` (which also keeps the parse)."""
    return _read(path_or_xml)[0]


def _read(path_or_xml: str | bytes | PathLike[str]) -> tuple[str, ET.Element]:
    """(URDF XML text, its parsed root) from a path, XML text or XML bytes, expanding xacro when needed.

    Returns URDF XML text from a path, XML text or XML bytes, expanding xacro when needed.

    Bytes and files are decoded as XML says (byte-order mark, else the declared encoding, else
    UTF-8). Xacro is run for `.xacro` files and for descriptions with xacro content (elements or
    attributes in the xacro namespace, or ``${…}``/``$(…)`` substitutions); merely declaring
    ``xmlns:xacro``, as most generated URDFs do, does not need xacro.

    Raises:
        RobotDescriptionError: unreadable file, not text, malformed XML, a root other than
            <robot>, or xacro needed but not installed or failing.
    """
    text: str
    filename: str | None = None
    if isinstance(path_or_xml, (bytes, bytearray)):
        text = decode_xml(bytes(path_or_xml))
    elif isinstance(path_or_xml, PathLike) or not str(path_or_xml).lstrip(
        " \t\r\n\ufeff"
    ).startswith("<"):
        filename = os.fspath(path_or_xml)
        try:
            with open(filename, "rb") as fh:
                data = fh.read()
        except (OSError, ValueError) as exc:  # ValueError: a NUL character in the path
            raise RobotDescriptionError(
                f"cannot read robot description {shorten(filename)!r}: "
                f"{_one_line(getattr(exc, 'strerror', None) or exc)}"
            ) from None
        text = decode_xml(data, f"robot description {shorten(filename)!r}")
    else:
        text = _drop_encoding_declaration(str(path_or_xml))
    root = _parse(text, filename)
    if (filename is not None and filename.endswith(".xacro")) or _uses_xacro(root):
        text = _expand_xacro(text, filename)
        root = _parse(text, filename)
    if root.tag != "robot":
        raise RobotDescriptionError(
            f"expected a <robot> root element, got <{shorten(str(root.tag), 40)}>"
        )
    return text, root


def _parse(text: str, filename: str | None) -> ET.Element:
    try:
        return ET.fromstring(text)
    except ET.ParseError as exc:
        where = f" in {shorten(filename)!r}" if filename else ""
        raise RobotDescriptionError(f"malformed XML{where}: {_one_line(exc)}") from None
    except (ValueError, RecursionError) as exc:  # e.g. nesting deeper than the parser allows
        raise RobotDescriptionError(f"unusable XML: {_one_line(exc)}") from None


def _uses_xacro(root: ET.Element) -> bool:
    """True if the document has xacro content: an element or attribute in a xacro namespace, or a
    ``${…}``/``$(…)`` substitution in an attribute or text."""
    for el in root.iter():
        tag = el.tag if isinstance(el.tag, str) else ""
        if tag.startswith("{") and _XACRO_NAMESPACE_MARK in tag.split("}")[0]:
            return True
        for key, value in el.attrib.items():
            if key.startswith("{") and _XACRO_NAMESPACE_MARK in key.split("}")[0]:
                return True
            if "${" in value or "$(" in value:
                return True
        if el.text and ("${" in el.text or "$(" in el.text):
            return True
    return False


def _expand_xacro(text: str, filename: str | None) -> str:
    try:
        import xacro
    except ImportError:
        raise RobotDescriptionError(
            "this description uses xacro, but the 'xacro' package is not installed "
            "(pip install xacro, or pip install 'kinematics_service[xacro]')"
        ) from None
    try:
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            if filename is not None:
                return str(xacro.process_file(filename).toxml())
            doc = xacro.parse(text)
            xacro.process_doc(doc)
            return str(doc.toxml())
    except Exception as exc:  # xacro raises its own XacroException and plain Python errors
        raise RobotDescriptionError(f"xacro processing failed: {_one_line(exc)}") from None


_JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")


def _numbers(el: ET.Element, attr: str, what: str, count: int | None = 3) -> list[float] | None:
    """The numbers of attribute `attr` of `el` (None if absent), all finite, `count` of them."""
    raw = el.get(attr)
    if raw is None:
        return None
    shown = f'<{el.tag} {attr}="{shorten(raw, 40)}">'
    try:
        values = [float(v) for v in raw.split()]
    except ValueError:
        raise RobotDescriptionError(f"{what}: {shown} must hold numbers") from None
    if count is not None and len(values) != count:
        raise RobotDescriptionError(f"{what}: {shown} must hold {count} numbers, got {len(values)}")
    if not all(math.isfinite(v) for v in values):
        raise RobotDescriptionError(f"{what}: {shown} must be finite")
    return values


def check_kinematic_elements(root: ET.Element) -> None:
    """Validate what kinematics reads, before any parser does: unique link and joint names, joint
    types, parent/child links, and the numbers of <origin>, <axis>, <limit> and <mimic>.

    Raises:
        RobotDescriptionError: naming the joint or link and showing the attribute received.
    """
    link_names: set[str] = set()
    for k, link in enumerate(root.findall("link"), start=1):
        name = link.get("name")
        if not name:
            raise RobotDescriptionError(f"<link> number {k} has no name attribute")
        if name in link_names:
            raise RobotDescriptionError(f"link {shorten(name)!r} is defined twice")
        link_names.add(name)
    joint_names: set[str] = set()
    for k, j in enumerate(root.findall("joint"), start=1):
        name = j.get("name")
        if not name:
            raise RobotDescriptionError(f"<joint> number {k} has no name attribute")
        what = f"joint {shorten(name)!r}"
        if name in joint_names:
            raise RobotDescriptionError(f"{what} is defined twice")
        joint_names.add(name)
        jtype = j.get("type")
        if jtype is None:
            raise RobotDescriptionError(
                f"{what} has no type attribute; expected one of {', '.join(_JOINT_TYPES)}"
            )
        if jtype not in _JOINT_TYPES:
            raise RobotDescriptionError(
                f"{what} has type {shorten(str(jtype), 40)!r}; expected one of {', '.join(_JOINT_TYPES)}"
            )
        for role in ("parent", "child"):
            el = j.find(role)
            if el is None or not el.get("link"):
                raise RobotDescriptionError(f'{what} needs a <{role} link="..."/> element')
        for tag in ("origin", "axis", "limit", "mimic", "parent", "child"):
            if len(j.findall(tag)) > 1:
                raise RobotDescriptionError(f"{what} has more than one <{tag}>")
        origin = j.find("origin")
        if origin is not None:
            _numbers(origin, "xyz", what)
            _numbers(origin, "rpy", what)
        axis = j.find("axis")
        if axis is not None:
            _numbers(axis, "xyz", what)
        limit = j.find("limit")
        if limit is not None:
            for attr in ("lower", "upper", "velocity", "effort"):
                raw = limit.get(attr)
                if raw is None:
                    continue
                try:
                    value = float(raw)
                except ValueError:
                    raise RobotDescriptionError(
                        f'{what}: <limit {attr}="{shorten(raw, 40)}"> must be a number'
                    ) from None
                if math.isnan(value) or (attr in ("velocity", "effort") and value < 0):
                    raise RobotDescriptionError(
                        f'{what}: <limit {attr}="{shorten(raw, 40)}"> must be '
                        + ("a number" if math.isnan(value) else "≥ 0")
                    )
        mimic = j.find("mimic")
        if mimic is not None:
            if not mimic.get("joint"):
                raise RobotDescriptionError(f'{what}: <mimic> needs a joint="..." attribute')
            for attr in ("multiplier", "offset"):
                _numbers(mimic, attr, what, count=1)


#: What `_kinematic_copy` keeps of a <joint>: its children and their attributes.
_JOINT_PARTS = {
    "parent": ("link",),
    "child": ("link",),
    "origin": ("xyz", "rpy"),
    "axis": ("xyz",),
    "limit": ("lower", "upper", "effort", "velocity"),
    "mimic": ("joint", "multiplier", "offset"),
}

#: The <robot name> given to yourdfpy for a description without one (yourdfpy needs a name).
_NAMELESS = "unnamed_robot"


def _kinematic_copy(root: ET.Element) -> bytes:
    """The part of a description that kinematics reads, as URDF bytes for yourdfpy: <robot name>,
    each <link name>, and each <joint name type> with the attributes of its <parent>, <child>,
    <origin>, <axis>, <limit> and <mimic>, all validated by `check_kinematic_elements`.

    yourdfpy parses every element it knows and indexes attributes directly, so a <cylinder>
    without a radius or a <robot> without a name would reach the user as a bare KeyError
    ('radius', 'name'); what is not handed to it cannot fail there.
    """
    robot = ET.Element("robot", name=root.get("name") or _NAMELESS)
    for link in root.findall("link"):
        ET.SubElement(robot, "link", name=str(link.get("name")))
    for joint in root.findall("joint"):
        copy = ET.SubElement(
            robot, "joint", name=str(joint.get("name")), type=str(joint.get("type"))
        )
        for tag, attrs in _JOINT_PARTS.items():
            part = joint.find(tag)
            if part is not None:
                kept = {a: value for a in attrs if (value := part.get(a)) is not None}
                ET.SubElement(copy, tag, kept)
    return ET.tostring(robot, encoding="utf-8")


def _load_robot(root: ET.Element) -> Any:
    """yourdfpy's model of `_kinematic_copy(root)`; `root` has passed `check_kinematic_elements`."""
    import yourdfpy

    log = logging.getLogger("yourdfpy")
    level = log.level
    log.setLevel(logging.CRITICAL)  # we report problems ourselves, with the culprit's name
    try:
        urdf = yourdfpy.URDF.load(
            io.BytesIO(_kinematic_copy(root)),
            build_scene_graph=False,
            load_meshes=False,
            load_collision_meshes=False,
        )
    except Exception as exc:  # not expected after check_kinematic_elements: say what it was
        raise RobotDescriptionError(
            f"URDF could not be parsed: yourdfpy raised {type(exc).__name__}: {_one_line(exc)}"
        ) from None
    finally:
        log.setLevel(level)
    return urdf.robot


def _robot_notes(root: ET.Element) -> tuple[str, ...]:
    """Notes on the <robot> element itself: a missing or empty name (URDF requires one; urdfdom
    and Pinocchio refuse the description without it, but no kinematic quantity depends on it)."""
    name = root.get("name")
    if name:
        return ()
    what = "no name attribute" if name is None else "an empty name"
    return (
        f"the <robot> element has {what}, which URDF requires; loaded anyway, as kinematics does not use the name",
    )


class RobotDescription:
    """A robot description, read and parsed once (xacro expanded), and the chains between its
    links. The yourdfpy model behind `chain_spec` is loaded on its first call.

    Attributes:
        xml: the URDF text. root: its parsed <robot> element. robot_name: `<robot name>`.
        joint_names: every joint (any type). link_names: every link.
        moving_joint_names: joints of a type in `MOVING_JOINT_TYPES` (mimic followers included),
            in document order.
        notes: what the description has that is accepted and adjusted or ignored, as sentences
            for users, in document order: a <robot> without a name, moving joints whose axis is
            normalised or whose <limit> lacks effort or velocity, mimic joints (and whom they
            follow), <mimic> on joints that cannot move. () when nothing.

    Raises:
        RobotDescriptionError: as `read_description`.
    """

    def __init__(self, path_or_xml: str | bytes | PathLike[str]) -> None:
        self.xml, self.root = _read(path_or_xml)
        self.robot_name = self.root.get("name", "")
        joints = self.root.findall("joint")
        self.joint_names = frozenset(str(j.get("name")) for j in joints)
        self.moving_joint_names = tuple(
            str(j.get("name")) for j in joints if j.get("type") in MOVING_JOINT_TYPES
        )
        self.link_names = frozenset(str(link.get("name")) for link in self.root.findall("link"))
        self._robot_notes = _robot_notes(self.root)
        self.notes = self._robot_notes + _description_notes(joints)
        self._robot: Any = None  # yourdfpy's model; loading it twice in a race is harmless

    def chain_spec(self, base_link: str | None = None, tip_link: str | None = None) -> ChainSpec:
        """The chain `base_link` → `tip_link` (see the module docstring and `spec_from_urdf`).

        Raises:
            RobotDescriptionError: malformed or unsupported description, naming the culprit.
            UnknownNameError: `base_link` or `tip_link` is not a link of the robot.
        """
        robot = self._robot
        if robot is None:
            check_kinematic_elements(self.root)
            robot = self._robot = _load_robot(self.root)
        spec = _chain_spec(robot, base_link, tip_link)
        if self._robot_notes:
            spec = dataclasses.replace(spec, notes=self._robot_notes + spec.notes)
        return spec

    def actuated_joints(self) -> tuple[list[str], np.ndarray, np.ndarray, np.ndarray]:
        """(names, lower, upper, velocity) of every moving joint without <mimic>, in document
        order: the joints robot_state_publisher needs in ``joint_states``. Continuous joints get
        ±inf limits; a missing limit is 0, a missing velocity inf.

        Raises:
            RobotDescriptionError: a nameless joint, a malformed <limit>, or no such joint.
        """
        names: list[str] = []
        lower: list[float] = []
        upper: list[float] = []
        vel: list[float] = []
        for joint in self.root.iter("joint"):
            kind = joint.get("type")
            if kind not in MOVING_JOINT_TYPES or joint.find("mimic") is not None:
                continue
            name = joint.get("name")
            if not name:
                raise RobotDescriptionError("a <joint> has no name attribute")
            limit = joint.find("limit")
            attrs = {} if limit is None else limit.attrib
            try:
                v = float(attrs.get("velocity", "inf"))
                lo = -math.inf if kind == "continuous" else float(attrs.get("lower", 0.0))
                up = math.inf if kind == "continuous" else float(attrs.get("upper", 0.0))
            except ValueError as exc:
                raise RobotDescriptionError(
                    f"joint {name!r} has a malformed <limit>: {exc}"
                ) from None
            names.append(name)
            lower.append(lo)
            upper.append(up)
            vel.append(v)
        if not names:
            raise RobotDescriptionError("the robot description has no moving, non-mimic joint")
        return names, np.array(lower), np.array(upper), np.array(vel)


def _axis_note(name: str, xyz: Any, norm: float) -> str:
    shown = " ".join(f"{float(v):g}" for v in xyz)
    return f"joint {name!r}: axis ({shown}) has norm {norm:.6g}; normalised to a unit vector"


def _limit_note(name: str, has_effort: bool, has_velocity: bool) -> str | None:
    """A note on a moving joint's <limit> without effort or velocity, which URDF requires (urdfdom
    refuses the description); loaded anyway: a missing velocity limit is taken as unlimited, and
    kinematics does not use the effort."""
    missing = [
        attr for attr, has in (("effort", has_effort), ("velocity", has_velocity)) if not has
    ]
    if not missing:
        return None
    what = " and no ".join(missing)
    taken = "" if has_velocity else "; its velocity is taken as unlimited"
    return f"joint {name!r}: <limit> has no {what} attribute, which URDF requires{taken}"


def _description_notes(joints: list[ET.Element]) -> tuple[str, ...]:
    """`RobotDescription.notes`: one pass over the <joint> elements, reading attributes only
    (malformed numbers are left to `check_kinematic_elements`, which names them)."""
    notes: list[str] = []
    for j in joints:
        name, kind = j.get("name"), j.get("type")
        axis = j.find("axis")
        if kind in MOVING_JOINT_TYPES and axis is not None:
            try:
                xyz = [float(v) for v in str(axis.get("xyz", "")).split()]
            except ValueError:
                xyz = []
            norm = math.sqrt(sum(v * v for v in xyz)) if len(xyz) == 3 else math.nan
            if math.isfinite(norm) and norm > 0.0 and abs(norm - 1.0) > _AXIS_NOTED:
                notes.append(_axis_note(str(name), xyz, norm))
        limit = j.find("limit")
        if kind in MOVING_JOINT_TYPES and limit is not None:
            note = _limit_note(str(name), "effort" in limit.attrib, "velocity" in limit.attrib)
            if note is not None:
                notes.append(note)
        mimic = j.find("mimic")
        if mimic is None:
            continue
        leader = mimic.get("joint")
        if kind not in MOVING_JOINT_TYPES:
            notes.append(f"joint {name!r} is {kind!r}: its <mimic> of {leader!r} is ignored")
            continue
        try:
            rule = mimic_rule(
                str(leader),
                float(mimic.get("multiplier", "1")),
                float(mimic.get("offset", "0")),
            )
        except ValueError:  # refused by check_kinematic_elements when a chain is built
            rule = f"{mimic.get('multiplier', '1')}·{leader} + {mimic.get('offset', '0')}"
        notes.append(
            f"joint {name!r} mimics {leader!r}: its value is {rule}, not a variable of its own"
        )
    return tuple(notes)


def spec_from_urdf(
    path_or_xml: str | bytes | PathLike[str],
    base_link: str | None = None,
    tip_link: str | None = None,
) -> ChainSpec:
    """Parse a description and extract the chain `base_link` → `tip_link` (see module docstring)."""
    return RobotDescription(path_or_xml).chain_spec(base_link, tip_link)


def _chain_spec(robot: Any, base_link: str | None, tip_link: str | None) -> ChainSpec:
    base_link, tip_link = base_link or None, tip_link or None  # "" = the default, as in the node
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
        if not leaves:
            raise RobotDescriptionError(
                f"no link below {base!r}: "
                + (
                    "the robot has a single link and no joint"
                    if len(links) == 1
                    else "it has no child links; choose another base_link"
                )
            )
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


def _unit_axis(j: Any) -> tuple[np.ndarray, float]:
    """(the joint's axis normalised, its norm as written); URDF's default axis is (1, 0, 0)."""
    axis = np.array([1.0, 0.0, 0.0]) if j.axis is None else np.asarray(j.axis, dtype=np.float64)
    with np.errstate(over="ignore"):  # a norm beyond 1e308 is refused below as non-finite
        norm = float(np.linalg.norm(axis))
    if not (np.all(np.isfinite(axis)) and math.isfinite(norm)) or norm < 1e-12:
        raise RobotDescriptionError(
            f"joint {j.name!r} has a zero or invalid axis {axis.tolist()}; a moving joint needs "
            "a non-zero direction"
        )
    return axis / norm, norm


def _own_limits(j: Any, notes: list[str]) -> tuple[float, float]:
    """A mimic follower's own position limits [rad or m]; ±inf where it gives none (noted)."""
    lim = j.limit
    if j.type == "continuous":
        return -math.inf, math.inf
    if lim is None or (lim.lower is None and lim.upper is None):
        notes.append(
            f"mimic joint {j.name!r} gives no lower/upper limits: only its leader's limits apply"
        )
        return -math.inf, math.inf
    lower = 0.0 if lim.lower is None else float(lim.lower)  # URDF's defaults
    upper = 0.0 if lim.upper is None else float(lim.upper)
    if not lower <= upper:
        raise RobotDescriptionError(
            f"joint {j.name!r} has lower limit {lower} > upper limit {upper}"
        )
    return lower, upper


def _build_spec(base: str, tip: str, path: list[Any], joints: dict[str, Any]) -> ChainSpec:
    T = np.eye(4)  # pose of the current link in the base, at home
    moving: list[JointModel] = []
    followers: list[
        tuple[str, float, float]
    ] = []  # (leader name, multiplier, offset) per moving joint
    notes: list[str] = []
    own: list[tuple[float, float] | None] = []  # a follower's own limits; None: an actuated joint
    chain_links: list[tuple[str, np.ndarray, int]] = [(base, np.eye(4), -1)]
    for j in path:
        if j.type not in MOVING_JOINT_TYPES and j.type != "fixed":
            raise RobotDescriptionError(
                f"joint {j.name!r} on the chain {base!r} → {tip!r} is of type {j.type!r}; "
                "only revolute, continuous, prismatic and fixed joints are supported"
            )
        origin = np.eye(4) if j.origin is None else np.asarray(j.origin, dtype=np.float64)
        T_joint = T @ origin
        if j.type == "fixed":
            T = T_joint
        else:
            axis, norm = _unit_axis(j)
            if abs(norm - 1.0) > _AXIS_NOTED:
                notes.append(_axis_note(j.name, np.asarray(j.axis, dtype=np.float64), norm))
            if j.limit is not None:
                note = _limit_note(j.name, j.limit.effort is not None, j.limit.velocity is not None)
                if note is not None:
                    notes.append(note)
            R_align = frame_aligned_with(axis)
            H = T_joint.copy()
            H[:3, :3] = T_joint[:3, :3] @ R_align
            moving.append(JointModel(j.name, j.type == "prismatic", H))
            if j.mimic is not None:
                m = 1.0 if j.mimic.multiplier is None else float(j.mimic.multiplier)
                c = 0.0 if j.mimic.offset is None else float(j.mimic.offset)
                followers.append((j.mimic.joint, m, c))
                own.append(_own_limits(j, notes))
                notes.append(
                    f"joint {j.name!r} on the chain mimics {j.mimic.joint!r}: its value is "
                    f"{mimic_rule(j.mimic.joint, m, c)}, and {j.mimic.joint!r} is the chain's "
                    "variable"
                )
            else:
                followers.append((j.name, 1.0, 0.0))
                own.append(None)
            T = T_joint
        chain_links.append((j.child, T.copy(), len(moving) - 1))

    # Actuated variables: non-mimic joints, plus the leaders of mimic joints, in base → tip order.
    actuated: list[str] = []
    for leader, _, _ in followers:
        if leader not in actuated:
            actuated.append(leader)
    types, lower, upper, vel = [], [], [], []
    follower_of = {  # a follower of each leader, for the messages below
        leader: moving[k].name
        for k, (leader, _, _) in enumerate(followers)
        if leader != moving[k].name
    }
    for name in actuated:
        leader_joint = joints.get(name)
        follower = f"mimic joint {follower_of.get(name, '')!r}"
        if leader_joint is None:
            raise RobotDescriptionError(f"{follower} follows joint {name!r}, which is not defined")
        if leader_joint.type not in MOVING_JOINT_TYPES:
            raise RobotDescriptionError(
                f"{follower} follows joint {name!r} of type {leader_joint.type!r}, which cannot move"
            )
        if leader_joint.mimic is not None:
            raise RobotDescriptionError(
                f"{follower} follows {name!r}, which itself mimics {leader_joint.mimic.joint!r}: "
                "mimic joint chains are not supported"
            )
        t, lo, up, v = _joint_limits(leader_joint)
        types.append(t)
        lower.append(lo)
        upper.append(up)
        vel.append(v)
    G = np.zeros((len(moving), len(actuated)))
    offset = np.zeros(len(moving))
    leader_index = []
    for k, (leader, m, c) in enumerate(followers):
        i = actuated.index(leader)
        G[k, i] = m
        offset[k] = c
        leader_index.append(i)
        own_k = own[k]
        lo, up = (lower[i], upper[i]) if own_k is None else own_k
        moving[k] = JointModel(moving[k].name, moving[k].prismatic, moving[k].H, lo, up)
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
        leader_index=tuple(leader_index),
        notes=tuple(notes),
    )
