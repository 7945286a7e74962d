"""The robot model's shared types, below everything that builds or uses a chain.

* `JointModel`, `ChainSpec`: what a description parser (`urdf`, `dh`) hands to `SerialChain`.
* `MimicJoint`: one mimic follower of a chain (`SerialChain.mimic_joints`).
* `SolverModel`: the small interface the numeric solvers use beyond the chain's public attributes
  (`SerialChain.solver_model`).
* `KinematicChain`: the part of `SerialChain` the solvers and the closed-form module rely on, as a
  `Protocol`, so that they need not import `chain` (which imports them).
* One source each for `TWO_PI`, `MOVING_JOINT_TYPES`, `readonly`, `middle_of_limits` and
  `mimic_rule`.

Imports numpy and `_kernel` only.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Literal, NamedTuple, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._kernel import Kernel

FloatArray = NDArray[np.float64]
Frame = Literal["space", "body", "world"]

TWO_PI = 2.0 * math.pi
#: URDF joint types that move (mimic followers included); "fixed" joints do not.
MOVING_JOINT_TYPES = ("revolute", "continuous", "prismatic")


def readonly(a: ArrayLike, dtype: type = np.float64) -> NDArray[Any]:
    """A read-only copy of `a` as an array of `dtype`."""
    arr: NDArray[Any] = np.array(a, dtype=dtype)
    arr.setflags(write=False)
    return arr


def middle_of_limits(lower: ArrayLike, upper: ArrayLike) -> FloatArray:
    """The middle of each joint's limits; 0 where a side is unbounded, clipped into the limits
    (so a half-bounded joint gets its finite limit when 0 lies outside)."""
    lo, hi = np.asarray(lower, dtype=np.float64), np.asarray(upper, dtype=np.float64)
    finite = np.isfinite(lo) & np.isfinite(hi)
    mid = np.where(finite, 0.5 * (np.where(finite, lo, 0.0) + np.where(finite, hi, 0.0)), 0.0)
    return np.clip(mid, lo, hi)


def frame_aligned_with(axis: ArrayLike) -> FloatArray:
    """A rotation matrix whose third column is the unit vector `axis` (x, y chosen deterministically)."""
    z = np.asarray(axis, dtype=np.float64)
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    return np.column_stack((x, np.cross(z, x), z))


@dataclass(frozen=True)
class JointModel:
    """One moving joint of the chain at the home configuration.

    Attributes:
        name: joint name.
        prismatic: True for prismatic (value in m), False for revolute/continuous (value in rad).
        H: 4×4 home pose of the joint frame in the base: origin on the axis, z along the axis.
        lower, upper: the joint's own position limits [rad or m] as its description gives them
            (±inf: unbounded). For a mimic follower these bound its own value θ = m·q + c, and
            `SerialChain` narrows its leader's limits so that θ stays inside them.
    """

    name: str
    prismatic: bool
    H: FloatArray
    lower: float = -math.inf
    upper: float = math.inf


def mimic_rule(leader: str, multiplier: float, offset: float) -> str:
    """A mimic follower's value as users read it, e.g. "-0.5·finger_joint + 0.1"."""
    sign = "−" if offset < 0 else "+"
    return f"{multiplier:g}·{leader} {sign} {abs(offset):g}"


class MimicJoint(NamedTuple):
    """A mimic follower on a chain: its value is θ = multiplier · q[leader] + offset.

    Attributes:
        name: the follower (a moving joint of the chain, not an actuated variable).
        leader: the actuated joint it follows (in `SerialChain.joint_names`).
        multiplier: m [1 or m/rad, …, as the units of the two joints require].
        offset: c [rad or m].
    """

    name: str
    leader: str
    multiplier: float
    offset: float


@dataclass(frozen=True)
class ChainSpec:
    """Everything a description parser hands to `SerialChain` (internal, but documented).

    `joints` are all m moving joints on the path, including mimic followers. The n actuated
    variables map to them as θ_internal = G q + offset (G is the identity unless there are mimic
    joints). `lower`/`upper` are the actuated joints' own limits (a leader's own, before
    `SerialChain` narrows them by its followers'). `leader_index[k]` is the actuated variable
    moving joint k follows (None: from G's non-zero entries; needed where a multiplier is 0).
    `links` lists the chain's links base→tip as (name, home pose in base, index of the last moving
    joint before the link or −1). `notes` says what the parser accepted and adjusted or ignored on
    this chain (human-readable sentences).
    """

    base_link: str
    tip_link: str
    joints: list[JointModel]
    M: FloatArray
    actuated_names: list[str]
    joint_types: list[str]
    lower: FloatArray
    upper: FloatArray
    velocity_limit: FloatArray
    G: FloatArray
    offset: FloatArray
    links: list[tuple[str, FloatArray, int]]
    leader_index: tuple[int, ...] | None = None
    notes: tuple[str, ...] = ()


@dataclass(frozen=True)
class SolverModel:
    """What the numeric IK solvers need from a chain beyond its public arrays.

    The chain's moving joints ("internal" joints, mimic followers included) take the values
    θ = G q + offset of the actuated values q; without mimic joints θ = q.

    Attributes:
        kernel: generated forward kinematics of the internal joints: `kernel.fk_world(θ)` gives
            the tip pose (12 floats: rotation row-major, then position) and the world Jacobian's
            columns, `kernel.fk_axes(θ)` the pose and each joint's (axis z, point o) in the base;
            `kernel.A` the joint-to-joint transforms, `kernel.prismatic` the joint kinds.
        to_internal: θ from q as lists of floats, or None when θ = q.
        G: (internal, n) read-only matrix of θ = G q + offset, or None when θ = q (Jacobian
            columns of the actuated variables are J_internal G).
        periodic: (n,) read-only; actuated joints whose pose repeats every 2π (see `ik.joint_space`).
    """

    kernel: Kernel
    to_internal: Callable[[Sequence[float]], list[float]] | None
    G: FloatArray | None
    periodic: NDArray[np.bool_]


class KinematicChain(Protocol):
    """The part of `SerialChain` that the IK and closed-form solvers use (see `chain.py`)."""

    @property
    def base_link(self) -> str: ...
    @property
    def tip_link(self) -> str: ...
    @property
    def joint_names(self) -> tuple[str, ...]: ...
    @property
    def joint_types(self) -> tuple[str, ...]: ...
    @property
    def lower(self) -> FloatArray: ...
    @property
    def upper(self) -> FloatArray: ...
    @property
    def S(self) -> FloatArray: ...
    @property
    def M(self) -> FloatArray: ...
    @property
    def dof(self) -> int: ...
    @property
    def solver_model(self) -> SolverModel: ...
    @property
    def reach_sphere(self) -> tuple[FloatArray, float]: ...
    def check_q(self, q: ArrayLike, name: str = "q") -> FloatArray: ...
    def check_target(self, T: ArrayLike, name: str = "T_target") -> FloatArray: ...
    def fk(self, q: ArrayLike) -> FloatArray: ...
    def fk_jacobian(self, q: ArrayLike, frame: Frame = ...) -> tuple[FloatArray, FloatArray]: ...
