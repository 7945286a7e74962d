"""Parent → child transforms of a set of a description's joints, as /tf carries them.

robot_state_publisher publishes, for every joint of a robot description, the pose of its child
link in its parent link: the moving joints' on /tf (from joint_states), the fixed joints' once on
/tf_static. `JointTransforms` computes exactly that for any set of the description's joints (the
node: the whole tree; a recording: the chain's), batched, without forming matrices:

    T_parent_child = O · M(θ),  O = the joint's <origin>,
    M(θ) = a rotation by θ about the unit <axis> (revolute, continuous) or a translation θ·axis
    (prismatic); the identity for fixed joints.

So a revolute joint's translation is its origin's, and its rotation the quaternion
q_O ⊗ (sin(θ/2) a, cos(θ/2)) = cos(θ/2) q_O + sin(θ/2) (q_O ⊗ a), with a constant per joint; a
prismatic joint's translation t_O + θ R_O a. Mimic joints follow their leader (θ = multiplier ·
θ_leader + offset, through chains of mimics), so their values come from the leader's. Floating and
planar joints (whose values joint_states cannot give) are left out, as robot_state_publisher
leaves them to other publishers. Quaternions are (x, y, z, w) with w ≥ 0.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .exceptions import RobotDescriptionError, UnknownNameError
from .rotations import matrix_from_rpy
from .so3 import quaternion_from_matrix
from .urdf import RobotDescription, check_kinematic_elements

FloatArray = NDArray[np.float64]

_MOVING = ("revolute", "continuous", "prismatic")


@dataclass(frozen=True)
class _Joint:
    name: str
    kind: str
    parent: str
    child: str
    translation: FloatArray  # t_O (3,)
    rotation: FloatArray  # R_O (3, 3)
    quaternion: FloatArray  # q_O (4,), x y z w
    axis: FloatArray  # unit (3,)
    leader: str  # the joint whose value drives this one (itself unless a mimic)
    multiplier: float
    offset: float


def _quat_mul(a: FloatArray, b: FloatArray) -> FloatArray:
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return np.array(
        [
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ]
    )


def _read_joints(root: ET.Element) -> dict[str, _Joint]:
    check_kinematic_elements(root)
    raw = {}
    for el in root.findall("joint"):
        name, kind = str(el.get("name")), str(el.get("type"))
        parent, child = el.find("parent"), el.find("child")
        origin, axis_el, mimic = el.find("origin"), el.find("axis"), el.find("mimic")
        xyz = (
            [0.0, 0.0, 0.0]
            if origin is None
            else [float(v) for v in origin.get("xyz", "0 0 0").split()]
        )
        rpy = (
            [0.0, 0.0, 0.0]
            if origin is None
            else [float(v) for v in origin.get("rpy", "0 0 0").split()]
        )
        axis = np.array(
            [1.0, 0.0, 0.0]
            if axis_el is None
            else [float(v) for v in axis_el.get("xyz", "1 0 0").split()]
        )
        norm = float(np.linalg.norm(axis))
        if kind in _MOVING and not norm > 0.0:
            raise RobotDescriptionError(f"joint {name!r} has a zero <axis>")
        leader, multiplier, offset = name, 1.0, 0.0
        if mimic is not None and kind in _MOVING:
            leader = str(mimic.get("joint"))
            multiplier = float(mimic.get("multiplier", "1"))
            offset = float(mimic.get("offset", "0"))
        raw[name] = _Joint(
            name,
            kind,
            "" if parent is None else str(parent.get("link")),
            "" if child is None else str(child.get("link")),
            np.array(xyz),
            matrix_from_rpy(rpy),
            quaternion_from_matrix(matrix_from_rpy(rpy)),
            axis / norm if norm > 0 else axis,
            leader,
            multiplier,
            offset,
        )
    return raw


def _resolve(joints: dict[str, _Joint], name: str) -> tuple[str, float, float]:
    """(actuated leader, multiplier, offset) of joint `name`, through chains of mimics."""
    multiplier, offset, seen = 1.0, 0.0, [name]
    joint = joints[name]
    while joint.leader != joint.name:
        leader = joints.get(joint.leader)
        if leader is None or leader.kind not in _MOVING:
            raise RobotDescriptionError(
                f"joint {joint.name!r} mimics {joint.leader!r}, which is not a moving joint"
            )
        if leader.name in seen:
            raise RobotDescriptionError(f"mimic joints {seen} follow each other in a circle")
        multiplier, offset = multiplier * joint.multiplier, multiplier * joint.offset + offset
        seen.append(leader.name)
        joint = leader
    return joint.name, multiplier, offset


class JointTransforms:
    """Transforms parent → child of a set of a description's joints (see the module docstring).

    Attributes:
        joint_names: the joints, in the order given (floating and planar ones left out).
        parents, children: their links.
        moving: for each joint, whether it moves (its transform depends on `inputs`).
        inputs: the actuated joints whose values the moving ones need (a mimic's leader), in
            order of first need: the columns of `transforms`' argument.

    Raises:
        UnknownNameError: a joint that the description does not have.
        RobotDescriptionError: a malformed joint, or a mimic of no moving joint (or a circle).
    """

    def __init__(self, description: RobotDescription, joints: Iterable[str] | None = None):
        every = _read_joints(description.root)
        names = list(every) if joints is None else list(joints)
        for name in names:
            if name not in every:
                raise UnknownNameError("joint", name, sorted(every))
        chosen = [every[n] for n in names if every[n].kind in _MOVING or every[n].kind == "fixed"]
        self.joint_names = tuple(j.name for j in chosen)
        self.parents = tuple(j.parent for j in chosen)
        self.children = tuple(j.child for j in chosen)
        self.moving = np.array([j.kind in _MOVING for j in chosen], dtype=bool)
        inputs: list[str] = []
        column, multiplier, offset = [], [], []
        for j in chosen:
            if j.kind not in _MOVING:
                continue
            leader, m, c = _resolve(every, j.name)
            if leader not in inputs:
                inputs.append(leader)
            column.append(inputs.index(leader))
            multiplier.append(m)
            offset.append(c)
        self.inputs = tuple(inputs)
        #: for each moving joint (in order), the index of its input in `inputs`
        self.input_columns = tuple(column)
        self._column = np.array(column, dtype=np.int64)
        self._multiplier = np.array(multiplier)
        self._offset = np.array(offset)
        moving = [j for j in chosen if j.kind in _MOVING]
        self._prismatic = np.array([j.kind == "prismatic" for j in moving], dtype=bool)
        self._t0 = np.array([j.translation for j in chosen]).reshape(-1, 3)
        self._q0 = np.array([j.quaternion for j in chosen]).reshape(-1, 4)
        qm = np.array([j.quaternion for j in moving]).reshape(-1, 4)
        self._q_axis = np.array(
            [_quat_mul(j.quaternion, np.append(j.axis, 0.0)) for j in moving]
        ).reshape(-1, 4)  # q_O ⊗ a
        self._t_axis = np.array([j.rotation @ j.axis for j in moving]).reshape(-1, 3)  # R_O a
        self._qm = qm

    @classmethod
    def of_links(cls, description: RobotDescription, links: Sequence[str]) -> JointTransforms:
        """The joints between consecutive links of `links` (a chain's `link_names`: each link
        after the first is the child of the joint from the one before)."""
        by_child = {
            str(c.get("link")): str(j.get("name"))
            for j in description.root.findall("joint")
            for c in j.findall("child")
        }
        joints = []
        for child in links[1:]:
            name = by_child.get(child)
            if name is None:
                raise UnknownNameError("link", child, sorted(by_child))
            joints.append(name)
        made = cls(description, joints)
        if made.parents != tuple(links[:-1]):
            raise RobotDescriptionError(f"the links {list(links)} are not a chain of joints")
        return made

    def transforms(self, values: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Translations (N, k, 3) [m] and quaternions (N, k, 4), x y z w with w ≥ 0, of every
        joint, for values (N, len(inputs)) of `inputs` [rad or m] (NaN values give NaN rows)."""
        v = np.asarray(values, dtype=np.float64)
        if v.ndim != 2 or v.shape[1] != len(self.inputs):
            raise ValueError(
                f"expected values (N, {len(self.inputs)}) of {list(self.inputs)}, got {v.shape}"
            )
        N = v.shape[0]
        t = np.broadcast_to(self._t0, (N, *self._t0.shape)).copy()
        quat = np.broadcast_to(self._q0, (N, *self._q0.shape)).copy()
        if self._column.size:
            theta = v[:, self._column] * self._multiplier + self._offset  # (N, m)
            prismatic = self._prismatic
            t[:, self.moving] += np.where(prismatic, theta, 0.0)[:, :, None] * self._t_axis
            half = np.where(prismatic, 0.0, 0.5 * theta)[:, :, None]
            quat[:, self.moving] = np.cos(half) * self._qm + np.sin(half) * self._q_axis
        quat = np.where(quat[..., 3:] < 0.0, -quat, quat)
        return t, quat
