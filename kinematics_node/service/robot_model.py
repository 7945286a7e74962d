"""The node's view of one robot description: its link tree (`LinkTree`: which tips there are, how
each link hangs below the base) and `RobotModel` (the description with its default chain, and
chains to other links built on first use).

Immutable after construction except for `RobotModel`'s chain cache, which is guarded by a lock so
that service threads can share one model.
"""

from __future__ import annotations

import threading
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from ..core import SerialChain
from ..core.exceptions import KinematicsError, RobotDescriptionError, UnknownNameError
from ..core.model import MOVING_JOINT_TYPES, readonly
from ..core.rotations import matrix_from_rpy
from ..core.urdf import RobotDescription, check_kinematic_elements

FloatArray = NDArray[np.float64]


class TreeJoint(NamedTuple):
    """One <joint> of the tree: its name, type, parent and child links, and T_parent_joint (4×4,
    from <origin xyz rpy>; [m], URDF rpy = fixed XYZ)."""

    name: str
    kind: str
    parent: str
    child: str
    origin: FloatArray


class LinkTree:
    """The links of a description as a tree: one root, one parent joint per other link.

    Attributes:
        robot_name: `<robot name>`.
        root_link: the link without a parent joint.
        links: every link, in document order.
        parent_joint: the joint above each link but the root.
        children: the child links of each link, in document order.

    Raises:
        RobotDescriptionError: malformed kinematic elements (`core.urdf.check_kinematic_elements`),
            a joint naming an undefined link, a link with two parent joints (a kinematic loop),
            or not exactly one root link; the message names the culprit.
    """

    def __init__(self, description: RobotDescription) -> None:
        root = description.root
        check_kinematic_elements(root)
        self.robot_name = description.robot_name
        self.links = tuple(str(link.get("name")) for link in root.findall("link"))
        if not self.links:
            raise RobotDescriptionError("the robot description has no <link>")
        known = set(self.links)
        self.parent_joint: dict[str, TreeJoint] = {}
        self.children: dict[str, list[str]] = {name: [] for name in self.links}
        for el in root.findall("joint"):
            joint = _tree_joint(el)
            for role, link in (("parent", joint.parent), ("child", joint.child)):
                if link not in known:
                    raise RobotDescriptionError(
                        f"joint {joint.name!r} refers to {role} link {link!r}, which is not defined"
                    )
            other = self.parent_joint.get(joint.child)
            if other is not None:
                raise RobotDescriptionError(
                    f"link {joint.child!r} is the child of two joints ({other.name!r} and "
                    f"{joint.name!r}): kinematic loops are not supported"
                )
            self.parent_joint[joint.child] = joint
            self.children[joint.parent].append(joint.child)
        roots = [name for name in self.links if name not in self.parent_joint]
        if len(roots) != 1:
            if not roots:
                raise RobotDescriptionError(
                    "the description has no root link: its joints form a loop"
                )
            raise RobotDescriptionError(
                f"the description has several root links {roots}; expected one tree"
            )
        self.root_link = roots[0]

    def path(self, base_link: str, link: str) -> tuple[TreeJoint, ...] | None:
        """The joints from `base_link` down to `link` (empty when they are the same link), or None
        when `link` is not below `base_link`. Both must be links of the tree."""
        joints: list[TreeJoint] = []
        while link != base_link:
            joint = self.parent_joint.get(link)
            if joint is None:
                return None
            joints.append(joint)
            link = joint.parent
        return tuple(reversed(joints))

    def leaves_below(self, base_link: str = "") -> tuple[str, ...]:
        """Every leaf of the tree below `base_link` (empty: the root link), in document order
        (depth first): the links among which an empty tip_link must find a single one."""
        base = base_link or self.root_link
        leaves: list[str] = []
        stack = [base]
        while stack:
            link = stack.pop()
            below = self.children.get(link, [])
            if below:
                stack.extend(reversed(below))
            elif link != base:
                leaves.append(link)
        return tuple(leaves)

    def tips_below(self, base_link: str = "") -> tuple[str, ...]:
        """The links a user may choose as tip below `base_link` (empty: the root link): the leaves
        of the tree below it with at least one moving joint (revolute, continuous, prismatic) and
        no floating or planar joint in between, in document order (depth first)."""
        base = base_link or self.root_link
        tips: list[str] = []
        stack: list[tuple[str, bool]] = [(base, False)]
        while stack:
            link, moves = stack.pop()
            below = self.children.get(link, [])
            if not below:
                if link != base and moves:
                    tips.append(link)
                continue
            for child in reversed(below):
                kind = self.parent_joint[child].kind
                if kind in ("floating", "planar"):
                    continue
                stack.append((child, moves or kind in MOVING_JOINT_TYPES))
        return tuple(tips)


def _tree_joint(el: ET.Element) -> TreeJoint:
    """A `TreeJoint` of a <joint> element that `check_kinematic_elements` has accepted."""
    parent, child, origin = el.find("parent"), el.find("child"), el.find("origin")
    T = np.eye(4)
    if origin is not None:
        xyz = [float(v) for v in origin.get("xyz", "0 0 0").split()]
        rpy = [float(v) for v in origin.get("rpy", "0 0 0").split()]
        T[:3, :3] = matrix_from_rpy(rpy)
        T[:3, 3] = xyz
    return TreeJoint(
        str(el.get("name")),
        str(el.get("type")),
        "" if parent is None else str(parent.get("link")),
        "" if child is None else str(child.get("link")),
        readonly(T),
    )


@dataclass(frozen=True)
class HeldDescription:
    """A robot description the node holds (in use, or waiting for its chain to be chosen), with
    its tree and where it came from (`source`, e.g. "the robot_description topic")."""

    description: RobotDescription
    tree: LinkTree
    source: str

    @classmethod
    def parse(cls, text: str, source: str) -> HeldDescription:
        """Parse URDF or xacro XML text.

        Raises:
            RobotDescriptionError: empty, malformed or unsupported, naming the culprit.
        """
        if not str(text).strip():
            raise RobotDescriptionError(f"the robot description from {source} is empty")
        return cls.of(RobotDescription(text), source)

    @classmethod
    def of(cls, description: RobotDescription, source: str) -> HeldDescription:
        """Hold a parsed description (its tree is checked here: `LinkTree`)."""
        return cls(description, LinkTree(description), source)


class RobotModel:
    """A parsed robot description with the default chain `base_link` → `tip_link`.

    Attributes:
        description: the parsed description (`core.urdf.RobotDescription`), parsed once.
        tree: its `LinkTree`.
        xml: the URDF text (xacro already expanded).
        robot_name: the `<robot name>` attribute.
        joint_names: every joint of the robot (any type): names a request may mention.
        moving_joint_names: revolute, continuous and prismatic joints (mimic followers included).
        link_names: every link of the robot.
        chain: the default chain.
    """

    def __init__(
        self,
        description: str | RobotDescription,
        base_link: str = "",
        tip_link: str = "",
        tree: LinkTree | None = None,
    ) -> None:
        """Parse `description` (URDF or xacro XML text, or a file path; or a description parsed
        already, with its `tree` when built already) and build the default chain. Empty
        `base_link` = the root link; empty `tip_link` = the single leaf below the base.

        Raises:
            RobotDescriptionError: malformed or unsupported description, naming the culprit.
            UnknownNameError: base_link or tip_link is not a link of the robot.
        """
        if isinstance(description, RobotDescription):
            self.description = description
        else:
            if not str(description).strip():
                raise RobotDescriptionError("robot description is empty")
            self.description = RobotDescription(description)  # the one parse of the description
        self.tree = tree if tree is not None else LinkTree(self.description)
        self.xml = self.description.xml
        self.robot_name = self.description.robot_name
        self.joint_names = self.description.joint_names
        self.moving_joint_names = self.description.moving_joint_names
        self.link_names = self.description.link_names
        self.chain = SerialChain.from_spec(
            self.description.chain_spec(base_link or None, tip_link or None)
        )
        self._lock = threading.Lock()
        self._chains: dict[tuple[str, str], SerialChain | KinematicsError] = {
            (self.chain.base_link, self.chain.tip_link): self.chain
        }

    @property
    def base_link(self) -> str:
        return self.chain.base_link

    def chain_between(self, base_link: str, tip_link: str) -> SerialChain:
        """The chain `base_link` → `tip_link` (built on first use, then cached; thread-safe).

        Raises:
            UnknownNameError: a link that is not in the robot (the message lists the links).
            RobotDescriptionError: no moving joint between them, or tip not below base.
        """
        for link in (base_link, tip_link):
            if link not in self.link_names:
                raise UnknownNameError("link", link, self.tree.links)
        key = (base_link, tip_link)
        with self._lock:
            cached = self._chains.get(key)
        if cached is None:
            try:
                cached = SerialChain.from_spec(self.description.chain_spec(base_link, tip_link))
            except KinematicsError as exc:  # remember failures too: rebuilding them is as slow
                cached = exc
            with self._lock:
                cached = self._chains.setdefault(key, cached)
        if isinstance(cached, KinematicsError):
            raise cached
        return cached

    def chain_to(self, tip_link: str) -> SerialChain:
        """The chain from the default base to `tip_link`; empty = the default chain."""
        if not tip_link or tip_link == self.chain.tip_link:
            return self.chain
        return self.chain_between(self.chain.base_link, tip_link)

    def link_pose_source(self, link: str) -> SerialChain | FloatArray:
        """How the pose of `link` in the base follows from the joints: the default chain when
        `link` is one of its links (`SerialChain.link_pose`), else the chain base → `link`
        (its `fk`), or, when no moving joint lies between them (the base itself, a camera fixed
        to it), the constant pose T_base_link (4×4, read-only).

        Raises:
            UnknownNameError: not a link of the robot (the message lists the links).
            RobotDescriptionError: `link` is not below the base, or a floating or planar joint
                lies between them.
        """
        if link in self.chain.link_names:
            return self.chain
        if link not in self.link_names:
            raise UnknownNameError("link", link, self.tree.links)
        path = self.tree.path(self.base_link, link)
        if path is None:
            raise RobotDescriptionError(
                f"link {link!r} is not below base_link {self.base_link!r}: poses are given for "
                "the base and the links below it"
            )
        if any(j.kind in MOVING_JOINT_TYPES for j in path):
            return self.chain_between(self.base_link, link)  # refuses floating/planar joints
        for joint in path:
            if joint.kind != "fixed":
                raise RobotDescriptionError(
                    f"joint {joint.name!r} between {self.base_link!r} and {link!r} is of type "
                    f"{joint.kind!r}; only revolute, continuous, prismatic and fixed joints are "
                    "supported"
                )
        T = np.eye(4)
        for joint in path:  # T_base_link = Π T_parent_child of the fixed joints
            T = T @ joint.origin
        return readonly(T)
