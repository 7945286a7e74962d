"""`SerialChain`: an immutable product-of-exponentials model of a serial manipulator.

Conventions (see docs/conventions.md):
* Twists and Jacobian rows are ordered (ω, v), as in Modern Robotics.
* ``frame="space"``: J_s, columns are the space-frame screw axes at q (MR eq. 5.11); the linear
  part is the velocity of the point at the base origin.
* ``frame="body"``: J_b = [Ad_{T⁻¹}] J_s, expressed in the tip frame (MR eq. 5.18).
* ``frame="world"``: the geometric Jacobian of De Luca's slides: angular velocity and the linear
  velocity of the tip origin, both in base-frame axes, still ordered (ω, v).
* Angles in rad, lengths in m (prismatic joint values in m).
* Mimic joints: the n actuated variables q drive the m moving joints of the chain through
  θ = G q + offset (G is (m, n)); `S`, `B` are the screw axes of the m moving joints, so
  T(q) = e^{[S₁]θ₁} ⋯ e^{[Sₘ]θₘ} M, and every Jacobian is J_θ(θ) G, (6, n). Without mimic joints
  m = n, G = I, offset = 0 and θ = q.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property, partial
from os import PathLike
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import se3
from ._checks import as_float_array, check_finite, check_transform
from ._kernel import Kernel
from .exceptions import InvalidInputError, RobotDescriptionError, UnknownNameError
from .ik.joint_space import periodic_mask
from .model import ChainSpec, Frame, MimicJoint, SolverModel, mimic_rule, readonly

if TYPE_CHECKING:
    from .dh import DHTable
    from .ik.closed_form import ClosedFormBatchResult, ClosedFormResult
    from .ik.options import IKOptions
    from .ik.result import IKBatchResult, IKResult

FloatArray = NDArray[np.float64]
_FRAMES = ("space", "body", "world")


MAX_REACH = 1e6
"""[m] Longest chain accepted: the sum of the joint-to-joint distances at home. Anything longer is
a typo or overflow bait (1e300 m links make FK return inf), not a robot."""


def _check_spec_numbers(spec: ChainSpec) -> None:
    """Refuse what would make FK/Jacobians non-finite: non-finite frames, an absurd reach, limits
    that are NaN or leave no finite value (lower = +inf, upper = −inf), NaN/negative velocities.

    Raises:
        RobotDescriptionError: naming the joint.
    """
    frames = [j.H for j in spec.joints] + [spec.M]
    if not all(np.all(np.isfinite(T)) for T in frames):
        raise RobotDescriptionError(
            f"chain {spec.base_link!r} → {spec.tip_link!r} has non-finite joint frames"
        )
    points = np.array([T[:3, 3] for T in frames])
    with np.errstate(over="ignore"):  # inf is the answer for 1e300 m links
        reach = float(
            np.linalg.norm(points[0]) + np.linalg.norm(np.diff(points, axis=0), axis=1).sum()
        )
    if not reach <= MAX_REACH:
        raise RobotDescriptionError(
            f"chain {spec.base_link!r} → {spec.tip_link!r} is {reach:.3g} m long; chains longer "
            f"than {MAX_REACH:.0e} m are refused as unphysical"
        )
    for name, lo, up, vel in zip(
        spec.actuated_names, spec.lower, spec.upper, spec.velocity_limit, strict=True
    ):
        if not (lo <= up and lo < np.inf and up > -np.inf):
            raise RobotDescriptionError(
                f"joint {name!r} has limits [{lo}, {up}]; need lower ≤ upper with a finite value "
                "in between"
            )
        if any(math.isfinite(x) and abs(x) > MAX_REACH for x in (lo, up)):
            raise RobotDescriptionError(
                f"joint {name!r} has limits [{lo:g}, {up:g}]; finite limits beyond ±{MAX_REACH:.0e} "
                "(m or rad) are refused as unphysical (leave a limit out for an unbounded joint)"
            )
        if not vel >= 0:
            raise RobotDescriptionError(f"joint {name!r} has velocity limit {vel}; need ≥ 0")
    if not (np.all(np.isfinite(spec.G)) and np.all(np.isfinite(spec.offset))):
        raise RobotDescriptionError("a mimic joint has a non-finite multiplier or offset")
    for j in spec.joints:
        if not j.lower <= j.upper:
            raise RobotDescriptionError(
                f"joint {j.name!r} has lower limit {j.lower} > upper limit {j.upper}"
            )


def _leaders(spec: ChainSpec) -> tuple[int, ...]:
    """The actuated variable each moving joint follows (`ChainSpec.leader_index`, else the first
    non-zero entry of its row of G; 0 for a row of zeros, whose joint does not move)."""
    if spec.leader_index is not None:
        if len(spec.leader_index) != len(spec.joints) or not all(
            0 <= i < len(spec.actuated_names) for i in spec.leader_index
        ):
            raise RobotDescriptionError("the mimic map's leader indices do not fit the chain")
        return tuple(int(i) for i in spec.leader_index)
    out = []
    for row in spec.G:
        nz = np.flatnonzero(row)
        out.append(int(nz[0]) if nz.size else 0)
    return tuple(out)


#: [rad or m] Narrowing of a leader's range by less than this is round-off, not a note.
_NARROWING_NOTED = 1e-12


def _limits_with_followers(
    spec: ChainSpec, leaders: tuple[int, ...]
) -> tuple[FloatArray, FloatArray, list[str]]:
    """(lower, upper, notes): the actuated joints' own limits intersected with what each mimic
    follower on the chain allows, lower_f ≤ m·q + c ≤ upper_f, i.e. q between (lower_f − c)/m and
    (upper_f − c)/m (swapped for m < 0; for m = 0 the follower stays at c, which must lie within
    its limits).

    Raises:
        RobotDescriptionError: a follower held outside its limits, or a leader whose range and a
            follower's leave no common value; naming both joints.
    """
    lower = np.array(spec.lower, dtype=np.float64)
    upper = np.array(spec.upper, dtype=np.float64)
    notes: list[str] = []
    for k, joint in enumerate(spec.joints):
        i = leaders[k]
        leader = spec.actuated_names[i]
        m, c = float(spec.G[k, i]), float(spec.offset[k])
        if joint.name == leader or not (math.isfinite(joint.lower) or math.isfinite(joint.upper)):
            continue
        rule = f"value {mimic_rule(leader, m, c)}"
        own = f"[{joint.lower:g}, {joint.upper:g}]"
        if m == 0.0:
            if not joint.lower <= c <= joint.upper:
                raise RobotDescriptionError(
                    f"mimic joint {joint.name!r} is held at {c:g} (multiplier 0 of {leader!r}, "
                    f"offset {c:g}), outside its limits {own}"
                )
            continue
        a, b = (joint.lower - c) / m + 0.0, (joint.upper - c) / m + 0.0  # (+ 0.0: no −0)
        lo_f, hi_f = (a, b) if m > 0 else (b, a)
        lo, hi = max(lower[i], lo_f), min(upper[i], hi_f)
        if lo > hi:
            raise RobotDescriptionError(
                f"joint {leader!r} (limits [{lower[i]:g}, {upper[i]:g}]) and its mimic joint "
                f"{joint.name!r} ({rule}, limits {own}) have no value in common: {leader!r} would "
                f"need to lie in [{lo_f:g}, {hi_f:g}]"
            )
        if lo > lower[i] + _NARROWING_NOTED or hi < upper[i] - _NARROWING_NOTED:
            notes.append(
                f"joint {leader!r}: limits [{lower[i]:g}, {upper[i]:g}] narrowed to "
                f"[{lo:g}, {hi:g}] so that its mimic joint {joint.name!r} ({rule}) stays "
                f"within its own limits {own}"
            )
        lower[i], upper[i] = lo, hi
    return lower, upper, notes


@dataclass(frozen=True, eq=False, repr=False)
class SerialChain:
    """Immutable PoE model of a serial chain from `base_link` to `tip_link`.

    Build with `from_urdf`, `from_dh` or `from_poe`; never mutated afterwards, so one instance can
    serve many threads. Exposed arrays are read-only.

    The n actuated variables q (`joint_names`) drive the m moving joints of the chain
    (`moving_joint_names`: mimic followers included) through θ = G q + offset. Without mimic
    joints, m = n, G = I, offset = 0 and θ = q; with them, S and B have one column per moving
    joint: T(q) = e^{[S₁]θ₁} ⋯ e^{[Sₘ]θₘ} M = M e^{[B₁]θ₁} ⋯ e^{[Bₘ]θₘ} and J(q) = J_θ(θ) G.

    Attributes:
        joint_names: actuated joints, base to tip (a mimic leader off the chain included).
        joint_types: "revolute", "continuous" or "prismatic" per actuated joint.
        lower, upper: (n,) the limits IK enforces [rad or m]: each joint's own limits, narrowed
            where a mimic follower on the chain would otherwise leave its own limits
            (lower_f ≤ m q + c ≤ upper_f); ±inf for continuous joints.
        own_lower, own_upper: (n,) the actuated joints' own limits, as the description gives them.
        velocity_limit: [rad/s or m/s]; inf when the description gives none.
        S: (6, m) space screw axes of the moving joints at home, rows (ω, v) (MR eq. 4.14).
        B: (6, m) body screw axes at home, B = [Ad_{M⁻¹}] S (MR eq. 4.16).
        M: (4, 4) home pose of the tip in the base (every joint value 0).
        moving_joint_names: (m,) the moving joints on the chain, base to tip.
        moving_lower, moving_upper: (m,) each moving joint's own limits [rad or m].
        G: (m, n) mimic map, θ = G q + offset (G[k, i] = multiplier of leader i for joint k).
        offset: (m,) [rad or m].
        mimic_joints: the followers on the chain (moving joints that are not actuated variables,
            or whose value is not q itself), as `MimicJoint(name, leader, multiplier, offset)`.
        notes: what building the model accepted and adjusted or ignored (axes normalised,
            followers on the chain, limits narrowed), as sentences for users; () when nothing.
        link_names: links of the chain, base to tip (fixed-joint links included).
        solver_model: what the numeric IK solvers use beyond the arrays above (the generated
            scalar kernel, the mimic map, the 2π-periodic joints); see `model.SolverModel`.
    """

    base_link: str
    tip_link: str
    joint_names: tuple[str, ...]
    joint_types: tuple[str, ...]
    lower: FloatArray
    upper: FloatArray
    velocity_limit: FloatArray
    S: FloatArray
    B: FloatArray
    M: FloatArray
    link_names: tuple[str, ...]
    own_lower: FloatArray
    own_upper: FloatArray
    moving_joint_names: tuple[str, ...]
    moving_lower: FloatArray
    moving_upper: FloatArray
    G: FloatArray
    offset: FloatArray
    mimic_joints: tuple[MimicJoint, ...]
    notes: tuple[str, ...]
    solver_model: SolverModel = field(compare=False)
    _kernel: Kernel = field(compare=False)
    _G: FloatArray | None = field(compare=False)
    _offset: FloatArray | None = field(compare=False)
    _mimic_index: tuple[tuple[int, float, float], ...] | None = field(compare=False)
    _link_joint: tuple[int, ...] = field(compare=False)
    _link_offset: FloatArray = field(compare=False)

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_spec(cls, spec: ChainSpec) -> SerialChain:
        """Build the model from a parsed description (used by the URDF/DH/PoE constructors)."""
        joints = spec.joints
        n_int = len(joints)
        H = [j.H for j in joints]
        A = np.empty((n_int + 1, 4, 4))
        if n_int == 0:
            raise RobotDescriptionError(
                f"chain {spec.base_link!r} → {spec.tip_link!r} has no moving joint"
            )
        _check_spec_numbers(spec)
        A[0] = H[0]
        for k in range(1, n_int):
            A[k] = se3.inverse(H[k - 1]) @ H[k]
        A[n_int] = se3.inverse(H[-1]) @ spec.M
        kernel = Kernel(A, np.array([j.prismatic for j in joints]))

        # Space screw axes of the internal joints at home: (z, o × z) or (0, z).
        S_int = np.empty((6, n_int))
        for k, j in enumerate(joints):
            z, o = j.H[:3, 2], j.H[:3, 3]
            S_int[:, k] = np.r_[0.0, 0.0, 0.0, z] if j.prismatic else np.r_[z, np.cross(o, z)]
        G, offset = spec.G, spec.offset
        n = len(spec.actuated_names)
        if G.shape != (n_int, n) or offset.shape != (n_int,):
            raise RobotDescriptionError(
                f"the mimic map has shape {G.shape} and offsets {offset.shape}; expected "
                f"({n_int}, {n}) and ({n_int},)"
            )
        trivial = n_int == n and np.array_equal(G, np.eye(n)) and not offset.any()
        # The PoE model of the moving joints: T = e^{[S₁]θ₁} ⋯ e^{[Sₘ]θₘ} M with θ = G q + offset.
        S = S_int
        B = se3.adjoint(se3.inverse(spec.M)) @ S
        leaders = _leaders(spec)
        lower, upper, limit_notes = _limits_with_followers(spec, leaders)

        mimic_index = None
        if not trivial:  # θ_int[k] = m·q[i] + c, with one leader per internal joint
            mimic_index = tuple(
                (i, float(G[k, i]), float(offset[k])) for k, i in enumerate(leaders)
            )
        mimic_joints = tuple(
            MimicJoint(j.name, spec.actuated_names[i], float(G[k, i]), float(offset[k]))
            for k, (j, i) in enumerate(zip(joints, leaders, strict=True))
            if j.name != spec.actuated_names[i] or G[k, i] != 1.0 or offset[k] != 0.0
        )

        G_used = None if trivial else readonly(G)
        to_internal = None if mimic_index is None else partial(_internal_from_index, mimic_index)
        periodic = periodic_mask(spec.joint_types, G_used, kernel.prismatic)
        link_joint, link_offset = [], []
        for _name, T_home, k in spec.links:
            link_joint.append(k)
            link_offset.append(T_home if k < 0 else se3.inverse(H[k]) @ T_home)
        return cls(
            base_link=spec.base_link,
            tip_link=spec.tip_link,
            joint_names=tuple(spec.actuated_names),
            joint_types=tuple(spec.joint_types),
            lower=readonly(lower),
            upper=readonly(upper),
            velocity_limit=readonly(spec.velocity_limit),
            S=readonly(S),
            B=readonly(B),
            M=readonly(spec.M),
            link_names=tuple(name for name, _, _ in spec.links),
            own_lower=readonly(spec.lower),
            own_upper=readonly(spec.upper),
            moving_joint_names=tuple(j.name for j in joints),
            moving_lower=readonly([j.lower for j in joints]),
            moving_upper=readonly([j.upper for j in joints]),
            G=readonly(G),
            offset=readonly(offset),
            mimic_joints=mimic_joints,
            notes=tuple(spec.notes) + tuple(limit_notes),
            solver_model=SolverModel(kernel, to_internal, G_used, readonly(periodic, np.bool_)),
            _kernel=kernel,
            _G=G_used,
            _offset=None if trivial else readonly(offset),
            _mimic_index=mimic_index,
            _link_joint=tuple(link_joint),
            _link_offset=readonly(np.array(link_offset)),
        )

    @classmethod
    def from_urdf(
        cls,
        path_or_xml: str | bytes | PathLike[str],
        base_link: str | None = None,
        tip_link: str | None = None,
    ) -> SerialChain:
        """Model of the chain `base_link` → `tip_link` of a URDF or xacro description.

        Args:
            path_or_xml: a file path (.urdf, .xacro, …), the XML text itself, or XML bytes (decoded
                as XML says: byte-order mark, else the declared encoding, else UTF-8).
            base_link: defaults to the root link (None or "", as in the node and the CLI).
            tip_link: defaults to the single leaf below `base_link` (an error lists them if
                several); None or "".

        Raises:
            RobotDescriptionError: malformed or unsupported description, naming the joint or link.
            UnknownNameError: `base_link` or `tip_link` is not a link of the robot.
        """
        from .urdf import spec_from_urdf

        return cls.from_spec(spec_from_urdf(path_or_xml, base_link, tip_link))

    @classmethod
    def from_dh(
        cls,
        table: DHTable,
        *,
        base: ArrayLike | None = None,
        tool: ArrayLike | None = None,
    ) -> SerialChain:
        """Model from a standard Denavit–Hartenberg table (De Luca's convention).

        Rows are lists ``[a, alpha, d, theta, type]`` (type optional, "R"/"P") or mappings with
        those keys and optionally name, lower, upper, velocity; lengths in m, angles in rad.
        See `kinematics_node.core.dh` for the table format.
        """
        from .dh import spec_from_dh

        return cls.from_spec(spec_from_dh(table, base=base, tool=tool))

    @classmethod
    def from_poe(
        cls,
        S: ArrayLike,
        M: ArrayLike,
        *,
        joint_names: Sequence[str] | None = None,
        lower: ArrayLike | None = None,
        upper: ArrayLike | None = None,
    ) -> SerialChain:
        """Model from space screw axes S (6, n) and home pose M, as Modern Robotics states them.

        Each column must be a revolute (‖ω‖ = 1, pitch ωᵀv = 0) or prismatic (ω = 0, ‖v‖ = 1) axis.
        """
        from .dh import spec_from_poe

        return cls.from_spec(spec_from_poe(S, M, joint_names=joint_names, lower=lower, upper=upper))

    # ------------------------------------------------------------------ basics
    @property
    def dof(self) -> int:
        """Number of actuated joints n."""
        return len(self.joint_names)

    @property
    def continuous(self) -> NDArray[np.bool_]:
        """Mask of joints without position limits (wrapped to the seed by IK)."""
        return np.isinf(self.lower) & np.isinf(self.upper)

    @cached_property
    def reach_sphere(self) -> tuple[FloatArray, float]:
        """(c, R): every tip position lies within R [m] of c, a point of the base frame [m].

        c is the origin of the first joint's frame, which no joint moves. Joint k turns about (or
        slides along) an axis through its frame's origin o_k, so a revolute joint keeps
        |o_{k+1} − o_k| constant and a prismatic one changes it by at most its travel: the
        triangle inequality along the chain gives R = Σ |o_{k+1} − o_k| at home (o_{n+1} = the
        tip) + the prismatic travels, max |θ_k| over the limits (θ = G q + offset for a mimic
        follower). An upper bound, cheap to test: a target farther than R from c is out of reach.
        R is inf when a prismatic joint has no limits.
        """
        A = self._kernel.A
        radius = float(np.sum(np.linalg.norm(A[1:, :3, 3], axis=1)))
        for k, prismatic in enumerate(self._kernel.prismatic):
            if not prismatic:
                continue
            i = int(np.flatnonzero(self.G[k])[0]) if self.G[k].any() else 0
            m, c = float(self.G[k, i]), float(self.offset[k])
            ends = [c] if m == 0.0 else [m * self.lower[i] + c, m * self.upper[i] + c]
            radius += float(max(abs(x) for x in ends))
        return readonly(A[0, :3, 3]), radius

    def __repr__(self) -> str:
        return (
            f"SerialChain({self.base_link!r} → {self.tip_link!r}, dof={self.dof}, "
            f"joints={list(self.joint_names)})"
        )

    def joint_index(self, name: str) -> int:
        """Column index of an actuated joint; `UnknownNameError` lists the valid names."""
        try:
            return self.joint_names.index(name)
        except ValueError:
            raise UnknownNameError("joint", name, self.joint_names) from None

    def check_q(self, q: ArrayLike, name: str = "q") -> FloatArray:
        """Validate joint values of shape (..., n): numeric and finite. Returns a float64 array."""
        arr = as_float_array(q, name)
        if arr.ndim == 0 or arr.shape[-1] != self.dof:
            raise InvalidInputError(
                f"{name} must have {self.dof} values (one per joint {list(self.joint_names)}), "
                f"got shape {arr.shape}"
            )
        check_finite(arr, name)
        return arr

    def within_limits(self, q: ArrayLike, tolerance: float = 0.0) -> NDArray[np.bool_]:
        """True where every joint value lies in [lower − tol, upper + tol]; shape (...)."""
        arr = self.check_q(q)
        return np.all((arr >= self.lower - tolerance) & (arr <= self.upper + tolerance), axis=-1)

    # ------------------------------------------------------------------ forward kinematics
    def _internal_scalar(self, q: Sequence[float]) -> list[float]:
        mi = self._mimic_index
        if mi is None:
            return list(q)
        return _internal_from_index(mi, q)

    def _scalar_q(self, q: ArrayLike) -> list[float] | None:
        """Fast validation of a single configuration; None if `q` is a batch."""
        if isinstance(q, np.ndarray):
            if q.ndim != 1:
                return None
            vals = q.tolist()
        elif isinstance(q, (list, tuple)) and all(isinstance(v, (int, float)) for v in q):
            vals = list(q)
        else:
            return None
        if len(vals) != self.dof:
            self.check_q(q)  # raises with the full message
        for v in vals:
            if not math.isfinite(v):
                self.check_q(q)
        return [float(v) for v in vals]

    def fk(self, q: ArrayLike) -> FloatArray:
        """Pose T_base_tip(q) of the tip in the base (MR eq. 4.14): (n,) → (4, 4), (..., n) → (..., 4, 4).

        Raises:
            InvalidInputError: wrong number of values or a non-finite value.
        """
        qs = self._scalar_q(q)
        if qs is not None:
            t, _ = self._kernel.fk_jacobian_scalar(self._internal_scalar(qs), False)
            return _pose_from_flat(t)
        arr = self.check_q(q)
        C, p, *_ = self._kernel.frames_batch(self._internal_batch(arr.reshape(-1, self.dof)), False)
        return _poses_from_soa(C, p).reshape(arr.shape[:-1] + (4, 4))

    def _internal_batch(self, q: FloatArray) -> FloatArray:
        if self._G is None or self._offset is None:
            return q
        return q @ self._G.T + self._offset

    def fk_jacobian(self, q: ArrayLike, frame: Frame = "world") -> tuple[FloatArray, FloatArray]:
        """(T_base_tip, J) from one pass of the recursion; shapes (..., 4, 4) and (..., 6, n)."""
        if frame not in _FRAMES:
            raise InvalidInputError(f"frame must be one of {_FRAMES}, got {frame!r}")
        qs = self._scalar_q(q)
        if qs is not None:
            q_int = self._internal_scalar(qs)
            if frame == "space":
                t, axes = self._kernel.fk_jacobian_scalar(q_int, True)
                J = _space_jacobian_from_axes(axes, self._kernel.prismatic)
            else:
                t, cols = self._kernel.fk_world(q_int)
                J = np.array(cols).T
                if frame == "body":  # J_b = diag(Rᵀ, Rᵀ) J_world
                    Rt = np.array(((t[0], t[3], t[6]), (t[1], t[4], t[7]), (t[2], t[5], t[8])))
                    J = np.concatenate((Rt @ J[:3], Rt @ J[3:]))
            if self._G is not None:
                J = J @ self._G
            return _pose_from_flat(t), J
        arr = self.check_q(q)
        flat = arr.reshape(-1, self.dof)
        C, p, Z, O, _ = self._kernel.frames_batch(self._internal_batch(flat), True)
        assert Z is not None and O is not None  # requested above
        J = _jacobian_batch(C, p, Z, O, self._kernel.prismatic, frame)
        if self._G is not None:
            J = J @ self._G
        lead = arr.shape[:-1]
        return _poses_from_soa(C, p).reshape(lead + (4, 4)), J.reshape(lead + (6, self.dof))

    def jacobian(self, q: ArrayLike, frame: Frame = "world") -> FloatArray:
        """Jacobian (..., 6, n) with rows (ω, v) in the chosen `frame` (see the module docstring).

        * "world" (the default, as for `fk_jacobian`, the node and the CLI): geometric Jacobian
          of the tip origin in base axes (De Luca), J_world = [[I, 0], [−[p], I]] J_s,
        * "space": J_s (MR eq. 5.11), * "body": J_b (MR eq. 5.18).
        With mimic joints the columns are those of the actuated variables: J = J_θ G.
        """
        return self.fk_jacobian(q, frame)[1]

    def link_poses(self, q: ArrayLike) -> FloatArray:
        """Poses of every link in `link_names` in the base: (n,) → (L, 4, 4), (..., n) → (..., L, 4, 4)."""
        arr = self.check_q(q)
        flat = arr.reshape(-1, self.dof)
        _, _, _, _, F = self._kernel.frames_batch(self._internal_batch(flat), False, True)
        assert F is not None
        N = flat.shape[0]
        out = np.empty((N, len(self.link_names), 4, 4))
        for i, (k, off) in enumerate(zip(self._link_joint, self._link_offset, strict=True)):
            if k < 0:
                out[:, i] = off
            else:
                Fk = np.zeros((N, 4, 4))
                Fk[:, :3, :] = np.moveaxis(F[k], 2, 0)
                Fk[:, 3, 3] = 1.0
                out[:, i] = Fk @ off
        return out.reshape(arr.shape[:-1] + out.shape[1:])

    def link_pose(self, q: ArrayLike, link: str) -> FloatArray:
        """Pose of one chain link in the base; `UnknownNameError` lists the chain's links."""
        if link not in self.link_names:
            raise UnknownNameError("link", link, self.link_names)
        return self.link_poses(q)[..., self.link_names.index(link), :, :]

    # ------------------------------------------------------------------ velocity and statics
    def twist(self, q: ArrayLike, qdot: ArrayLike, frame: Frame = "world") -> FloatArray:
        """End-effector twist V = J(q) q̇, rows (ω, v), in `frame` (..., 6)."""
        qd = self.check_q(qdot, "qdot")
        return (self.jacobian(q, frame) @ qd[..., None])[..., 0]

    def joint_torques(self, q: ArrayLike, wrench: ArrayLike, frame: Frame = "world") -> FloatArray:
        """Statics τ = J(q)ᵀ F (MR eq. 5.26) for a wrench F = (m, f) the tip applies, in `frame`.

        With frame="world" the moment is about the tip origin in base axes; "space" about the base
        origin; "body" in the tip frame.
        """
        F = as_float_array(wrench, "wrench")
        if F.shape[-1:] != (6,):
            raise InvalidInputError(
                f"wrench must have shape (..., 6) ordered (m, f), got {F.shape}"
            )
        check_finite(F, "wrench")
        J = self.jacobian(q, frame)
        return (np.swapaxes(J, -1, -2) @ F[..., None])[..., 0]

    def analytic_jacobian_rpy(self, q: ArrayLike) -> FloatArray:
        """Analytic Jacobian (..., 6, n) mapping q̇ to (roll, pitch, yaw rates, ṗ) of the tip.

        ω = T(φ) φ̇ with T = [R_Z R_Y e_x, R_Z e_y, e_z] for R = R_Z(y) R_Y(p) R_X(r), so the angular
        rows are T⁻¹ J_ω (De Luca, geometric vs analytic Jacobian). Singular at pitch = ±π/2.

        Raises:
            InvalidInputError: at (or within 1e-9 of) the representation singularity.
        """
        from .rotations import rpy_from_matrix

        T, J = self.fk_jacobian(q, "world")
        _, pitch, yaw = np.moveaxis(rpy_from_matrix(T[..., :3, :3]), -1, 0)
        cp, sp, cy, sy = np.cos(pitch), np.sin(pitch), np.cos(yaw), np.sin(yaw)
        if np.any(np.abs(cp) < 1e-9):
            raise InvalidInputError("roll-pitch-yaw rates are undefined at pitch = ±π/2")
        # T⁻¹ for T = [[cy cp, −sy, 0], [sy cp, cy, 0], [−sp, 0, 1]].
        Tinv = np.zeros(cp.shape + (3, 3))
        Tinv[..., 0, 0], Tinv[..., 0, 1] = cy / cp, sy / cp
        Tinv[..., 1, 0], Tinv[..., 1, 1] = -sy, cy
        Tinv[..., 2, 0], Tinv[..., 2, 1], Tinv[..., 2, 2] = cy * sp / cp, sy * sp / cp, 1.0
        out = J.copy()
        out[..., :3, :] = Tinv @ J[..., :3, :]
        return out

    # ------------------------------------------------------------------ inverse kinematics
    def ik(
        self, T_target: ArrayLike, q_seed: ArrayLike | None = None, options: IKOptions | None = None
    ) -> IKResult:
        """Joint values q with T_base_tip(q) = T_target (4×4, tip pose in the base frame).

        Levenberg–Marquardt on the body error twist log(T(q)⁻¹ T_target) with the body Jacobian,
        joint limits enforced every step, random restarts until success or `options.timeout`
        (default 50 ms); see `kinematics_node.core.ik.solver` for the algorithm and `IKOptions`.
        `q_seed` defaults to the middle of the limits; a seed outside the limits is clamped.
        On failure `IKResult.success` is False and `q` is the best configuration found.

        Raises:
            InvalidInputError: T_target not a finite rigid transform, bad seed or options.
        """
        from .ik.solver import solve

        return solve(self, T_target, q_seed, options)

    def ik_batch(
        self,
        T_targets: ArrayLike,
        q_seeds: ArrayLike | None = None,
        options: IKOptions | None = None,
    ) -> IKBatchResult:
        """Vectorised IK for (N, 4, 4) targets and optional (N, n) seeds → `IKBatchResult`.

        Same algorithm as `ik`, run in lock-step over the targets with batched NumPy kernels
        (fewer than 48 targets: `ik` per target, which is faster there).
        Time budget for the whole call: `options.batch_timeout` if set, else `options.timeout` × N.
        Only mode "speed" with num_solutions = 1; see `kinematics_node.core.ik.solver.solve_batch`.
        """
        from .ik.solver import solve_batch

        return solve_batch(self, T_targets, q_seeds, options)

    @cached_property
    def ik_family(self) -> str | None:
        """Name of the closed-form IK family found in the screw axes, or None (see docs/closed_form.md).

        "three_parallel" (UR), "spherical_wrist" (Puma, OPW arms), or "7r_three_parallel" /
        "7r_spherical_wrist" (7R arms that become one when a joint is held: Panda, iiwa).
        `kinematics_node.core.ik.closed_form.family_of(chain)` gives the details.
        """
        from .ik.closed_form import family_of

        family = family_of(self)
        return None if family is None else family.name

    def ik_all(
        self,
        T_target: ArrayLike,
        q_seed: ArrayLike | None = None,
        held: ArrayLike | None = None,
        tolerance: float = 1e-9,
    ) -> ClosedFormResult:
        """Every solution within the limits of T_base_tip(q) = T_target (4×4), in closed form.

        `solutions` are sorted by distance to `q_seed` (default: middle of the limits); with limits
        wider than 2π every whole-turn equivalent is included; each reproduces the target by FK to
        `tolerance` [m, rad]. 7R arms sweep the held joint over `held` [rad] (default: 36 values
        across its limits). Singular targets give a valid set with `singular` True; unreachable
        ones an empty set and the reason in `message`.
        See `kinematics_node.core.ik.closed_form.solve_all`.

        Raises:
            NoClosedFormError: `ik_family` is None.
            InvalidInputError: bad target, seed, held values or tolerance.
        """
        from .ik.closed_form import solve_all

        return solve_all(self, T_target, q_seed, held, tolerance)

    def ik_all_batch(
        self,
        T_targets: ArrayLike,
        q_seeds: ArrayLike | None = None,
        held: ArrayLike | None = None,
        tolerance: float = 1e-9,
    ) -> ClosedFormBatchResult:
        """`ik_all` for (N, 4, 4) targets at once, vectorised; see `closed_form.solve_all_batch`."""
        from .ik.closed_form import solve_all_batch

        return solve_all_batch(self, T_targets, q_seeds, held, tolerance)

    def check_target(self, T: ArrayLike, name: str = "T_target") -> FloatArray:
        """Validate a homogeneous transform (or a batch of them)."""
        return check_transform(T, name)


# ---------------------------------------------------------------------- helpers
def _internal_from_index(
    mimic_index: tuple[tuple[int, float, float], ...], q: Sequence[float]
) -> list[float]:
    """θ_internal[k] = m·q[i] + c for each internal joint's (leader i, multiplier m, offset c)."""
    return [m * q[i] + c for i, m, c in mimic_index]


def _pose_from_flat(t: tuple[float, ...]) -> FloatArray:
    return np.array(
        (
            (t[0], t[1], t[2], t[9]),
            (t[3], t[4], t[5], t[10]),
            (t[6], t[7], t[8], t[11]),
            (0.0, 0.0, 0.0, 1.0),
        )
    )


def _poses_from_soa(C: FloatArray, p: FloatArray) -> FloatArray:
    N = p.shape[1]
    T = np.zeros((N, 4, 4))
    T[:, :3, :3] = np.moveaxis(C, 2, 0).swapaxes(1, 2)
    T[:, :3, 3] = p.T
    T[:, 3, 3] = 1.0
    return T


def _space_jacobian_from_axes(
    axes: list[tuple[float, float, float, float, float, float]], prismatic: tuple[bool, ...]
) -> FloatArray:
    """J_s from each joint's axis z and point o in the base: (z, o × z), or (0, z) if prismatic."""
    cols = []
    for (zx, zy, zz, ox, oy, oz), prism in zip(axes, prismatic, strict=True):
        if prism:
            cols.append((0.0, 0.0, 0.0, zx, zy, zz))
        else:
            cols.append((zx, zy, zz, oy * zz - oz * zy, oz * zx - ox * zz, ox * zy - oy * zx))
    return np.array(cols).T


def _cross(a: FloatArray, b: FloatArray) -> FloatArray:
    """Cross product along axis 0 of (3, …) arrays (np.cross wants the vector axis last)."""
    return np.stack(
        (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])
    )


def _jacobian_batch(
    C: FloatArray,
    p: FloatArray,
    Z: FloatArray,
    O: FloatArray,
    prismatic: tuple[bool, ...],
    frame: str,
) -> FloatArray:
    n, _, N = Z.shape
    J = np.empty((6, n, N))
    prism = np.array(prismatic)
    zt, ot = np.moveaxis(Z, 1, 0), np.moveaxis(O, 1, 0)  # (3, n, N)
    if frame == "space":
        lin = _cross(ot, zt)
    else:
        lin = _cross(zt, p[:, None, :] - ot)
    J[:3] = zt
    J[3:] = lin
    if prism.any():
        J[:3, prism] = 0.0
        J[3:, prism] = zt[:, prism]
    if frame == "body":  # rows: Rᵀ x = (C[0]·x, C[1]·x, C[2]·x)
        ang, lin2 = J[:3].copy(), J[3:].copy()
        for i in range(3):
            J[i] = np.einsum("rN,rnN->nN", C[i], ang)
            J[3 + i] = np.einsum("rN,rnN->nN", C[i], lin2)
    return np.moveaxis(J, 2, 0)  # (N, 6, n)
