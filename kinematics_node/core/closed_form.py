"""Closed-form IK: every solution, from Paden–Kahan subproblems, where the geometry allows.

Problem. The PoE model T(q) = e^{[S₁]q₁} ⋯ e^{[Sₙ]qₙ} M (MR eq. 4.14). For a target T_t (tip pose in
the base frame) put G = T_t M⁻¹ = e^{[S₁]q₁} ⋯ e^{[Sₙ]qₙ}, a product of rotations about the home
axes (ωᵢ, a point rᵢ on each). A point x on an axis is fixed by that joint's exponential; the
component hᵀx along h is kept by rotations about axes parallel to h; the distance from a point on
an axis is kept by that joint. These three invariants split the 6R problem into subproblems
(`kinematics_node.core.subproblems`), each with at most two solutions, so at most 8 in all.

Families, detected from the screw axes S alone (never from names or DH tables), with tolerances
`ANGLE_TOLERANCE` [rad] and `DISTANCE_TOLERANCE` [m] that absorb the rounding of real URDFs:

* ``"three_parallel"`` (UR family): axes 2, 3, 4 parallel (direction h), axes 5 and 6 meet at c.
  hᵀ e₁⁻¹(G c) = hᵀc gives q₁ (SP4); hᵀR₁ᵀR_G = hᵀR₅R₆ gives (q₅, q₆) (SP2); then e₂e₃e₄ =
  e₁⁻¹ G e₆⁻¹ e₅⁻¹ gives q₃ (SP3, distance from axis 2), q₂ (SP1) and q₄ from the sum angle.
* ``"spherical_wrist"`` (Puma, ABB IRB, KUKA KR, Fanuc: OPW arms): axes 4, 5, 6 meet at the wrist
  centre c, so e₁e₂e₃ c = G c. The position problem is solved when the first three axes have one of
  four relations: 2 ∥ 3 (SP4, SP3, SP1), 1 ∩ 2 (SP3, SP2), 2 ∩ 3 (SP3, SP2) or 1 ∥ 2 (SP4, SP3,
  SP1). Then R₄R₅R₆ = R₃ᵀR₂ᵀR₁ᵀR_G gives (q₄, q₅) by SP2 and q₆ by SP1.
* Either of them read from the tip: the same structure in the reversed chain G⁻¹ = e^{−[S₆]q₆} ⋯
  e^{−[S₁]q₁} (e.g. a spherical shoulder).
* ``"7r_three_parallel"``, ``"7r_spherical_wrist"``: a 7R arm that becomes one of the above when one
  joint j is held at θ (the later axes move to Ad_{e^{[S_j]θ}} Sₖ, M to e^{[S_j]θ} M). The held
  joint's values are swept, vectorised (Panda: q₇; iiwa: q₃).

A detected structure is confirmed before it is used: random configurations must come back from
their own forward kinematics, which rejects degenerate cases (e.g. an iiwa with its elbow held).

Every candidate is checked by forward kinematics against the target; candidates within 1e-2 are
first refined by two Gauss–Newton steps (this restores full precision near singularities and on
URDFs whose axes meet only to within the tolerances). Only those within `tolerance` are returned.

Units: lengths [m], angles [rad]. Frames: targets are tip poses in the base frame.
"""

from __future__ import annotations

import functools
import math
import time
import weakref
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import _closed_form_scalar as scalar
from . import _closed_form_vector as vector
from . import subproblems as sp
from ._checks import as_float_array, check_finite, rigid_on_floats
from .exceptions import InvalidInputError, NoClosedFormError
from .ik_result import IKResult, check_seed, default_seed
from .model import TWO_PI, KinematicChain, readonly

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]
IntArray = NDArray[np.int64]
Rows = list[list[float]]

#: Axes closer to parallel than this count as parallel [rad].
ANGLE_TOLERANCE = 1e-5
#: Axes that pass closer than this count as meeting [m].
DISTANCE_TOLERANCE = 1e-5
#: Default number of held-joint values swept by a 7R arm, spread evenly over its limits.
DEFAULT_HELD_SAMPLES = 36
#: Candidates closer than this to the target (position [m] or rotation [rad]) are refined ...
_REFINE_BELOW = 1e-2
#: ... unless already within this (× the arm's scale for positions). Exact arithmetic gives
#: ~1e-15; near a singularity the subproblems lose digits in a square root (SP2's γ when the
#: middle point nearly lies in the plane of the two axes), which one Newton step restores.
_REFINE_ABOVE = 1e-12
#: `nearest` (`ik`, which returns one solution) refines only above this: real URDFs whose axes
#: meet to ~1e-13 leave every candidate of some arms a few 1e-13 off (Kinova j2s6s200: 2 in 3
#: targets), and a refinement (~40 µs) to 1e-16 there buys nothing against the 1e-9 guaranteed.
_NEAREST_REFINE_ABOVE = 1e-10
#: A solution counts once: two that agree to this [rad] in every joint (modulo 2π) are one.
_SAME_SOLUTION = 1e-9
_INVTWO_PI = 1.0 / TWO_PI


# ---------------------------------------------------------------------- public types
@dataclass(frozen=True)
class ClosedFormFamily:
    """The closed-form structure detected in a chain.

    Attributes:
        name: "three_parallel", "spherical_wrist", "7r_three_parallel" or "7r_spherical_wrist".
        held_joint: for 7R arms the joint whose values are swept; None for 6R.
        reversed: True when the structure is read from the tip (e.g. a spherical shoulder).
        position_case: for spherical wrists, how the first three axes are related
            ("2∥3", "1∩2", "2∩3", "1∥2"); "" otherwise.
        description: one line for people, naming the axes (1-based) and the special points.
    """

    name: str
    held_joint: str | None
    reversed: bool
    position_case: str
    description: str


@dataclass(frozen=True)
class ClosedFormResult(IKResult):
    """`IKResult` of `SerialChain.ik_all`: every solution, closest to the seed first.

    Attributes (in addition to `IKResult`'s):
        solutions: every solution within the limits, sorted by ‖q − q_seed‖; with limits wider than
            2π every whole-turn equivalent within the limits is included. Empty if none.
        q: solutions[0], or the (clamped) seed when there is none. Always finite.
        position_error, orientation_error: residual of q [m], [rad].
        singular: the target is at (or within round-off of) a singular configuration; a joint
            left undetermined there took its value from the seed (the message says which).
        family: the detected family name.
        held_values: for 7R arms the held joint's values that were swept [rad]; else empty.
    """

    singular: bool = False
    family: str = ""
    held_values: FloatArray = field(default_factory=lambda: np.empty(0))


@dataclass(frozen=True)
class ClosedFormBatchResult:
    """`SerialChain.ik_all_batch` for N targets; solutions of target i are
    ``solutions[offsets[i]:offsets[i + 1]]``, closest to its seed first. Arrays are read-only.

    Attributes:
        q: (N, n) nearest solution per target, or the seed where there is none.
        success: (N,) at least one solution.
        count: (N,) number of solutions per target.
        offsets: (N + 1,) start of each target's solutions in `solutions`.
        solutions: (K, n) all solutions, grouped by target.
        singular: (N,) the target is at a singular configuration.
        message: one summary line.
    """

    q: FloatArray
    success: BoolArray
    count: IntArray
    offsets: IntArray
    solutions: FloatArray
    singular: BoolArray
    message: str = ""

    def solutions_of(self, i: int) -> FloatArray:
        """(k, n) solutions of target i, closest to its seed first."""
        return self.solutions[self.offsets[i] : self.offsets[i + 1]]


# ---------------------------------------------------------------------- structure and geometry
@dataclass(frozen=True)
class _Structure:
    kind: str  # "three_parallel" | "spherical_wrist"
    case: str  # spherical wrist: "par23" | "int12" | "int23" | "par12"; else ""
    reversed: bool


_CASE_LABEL = {"par23": "2∥3", "int12": "1∩2", "int23": "2∩3", "par12": "1∥2", "": ""}


def _lines(S: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Directions ω (n, 3) and the points r = ω × v nearest the origin (n, 3) of revolute screws."""
    w = S[:3].T.copy()
    return w, sp.cross(w, S[3:].T)


def _meet(w: FloatArray, r: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Least-squares point nearest the lines (…, m, 3) and its largest distance from them (…).

    Σ (I − ωωᵀ) x = Σ (I − ωωᵀ) r (normal equations of Σ dist(x, line)²).
    """
    P = np.eye(3) - w[..., :, None] * w[..., None, :]  # (…, m, 3, 3)
    A = P.sum(axis=-3)
    y = (P @ r[..., None])[..., 0].sum(axis=-2)
    x = np.linalg.solve(A, y[..., None])[..., 0]
    d = x[..., None, :] - r
    d = d - w * sp.dot(d, w)[..., None]
    return x, sp.norm(d).max(axis=-1)


def _parallel(w: FloatArray, i: int, j: int) -> bool:
    return bool(sp.norm(sp.cross(w[i], w[j])) <= ANGLE_TOLERANCE)


def _meets(w: FloatArray, r: FloatArray, idx: tuple[int, ...]) -> bool:
    """The lines idx (consecutive joints) pass through one point, and no two neighbours are parallel.

    Only neighbours are compared: their relation is the same in every configuration, while two
    lines further apart may coincide at home (Panda's joints 1 and 3) and not elsewhere.
    """
    for a, b in zip(idx[:-1], idx[1:], strict=True):
        if _parallel(w, a, b):
            return False
    _, miss = _meet(w[list(idx)], r[list(idx)])
    return bool(miss <= DISTANCE_TOLERANCE)


def _candidates(w6: FloatArray, r6: FloatArray) -> list[_Structure]:
    """Structures whose axis relations hold for the 6R lines (w6, r6); not yet confirmed."""
    out: list[_Structure] = []
    for rev in (False, True):
        w, r = (w6[::-1], r6[::-1]) if rev else (w6, r6)
        if (
            _parallel(w, 1, 2)
            and _parallel(w, 2, 3)
            and not _parallel(w, 0, 1)
            and not _parallel(w, 3, 4)
            and _meets(w, r, (4, 5))
        ):
            out.append(_Structure("three_parallel", "", rev))
        if _meets(w, r, (3, 4, 5)):
            if _parallel(w, 1, 2) and not _parallel(w, 0, 1):
                out.append(_Structure("spherical_wrist", "par23", rev))
            if _meets(w, r, (0, 1)):
                out.append(_Structure("spherical_wrist", "int12", rev))
            if _meets(w, r, (1, 2)):
                out.append(_Structure("spherical_wrist", "int23", rev))
            if _parallel(w, 0, 1) and not _parallel(w, 1, 2):
                out.append(_Structure("spherical_wrist", "par12", rev))
    return out


def _perpendicular(a: FloatArray) -> FloatArray:
    """A unit vector normal to each unit vector a (…, 3)."""
    helper = np.where(
        (np.abs(a[..., 0]) < 0.9)[..., None], np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
    )
    x = sp.cross(a, helper)
    return x / sp.norm(x)[..., None]


def _geometry(st: _Structure, w: FloatArray, r: FloatArray, scale: float) -> vector.Geometry:
    """Derived points and directions for lanes of 6R lines w, r (L, 6, 3), forward order."""
    if st.reversed:
        w, r = w[:, ::-1], r[:, ::-1]
    L = w.shape[0]
    zeros, ones = np.zeros((L, 3)), np.ones((L, 3))
    if st.kind == "three_parallel":
        h = w[:, 1]
        c, _ = _meet(w[:, 4:6], r[:, 4:6])
        return vector.Geometry(
            w, r, c, zeros, h, _perpendicular(h), sp.dot(w[:, 1:4], h[:, None]), scale
        )
    c, _ = _meet(w[:, 3:6], r[:, 3:6])
    b, h = zeros, zeros
    if st.case == "int12":
        b, _ = _meet(w[:, 0:2], r[:, 0:2])
    elif st.case == "int23":
        b, _ = _meet(w[:, 1:3], r[:, 1:3])
    elif st.case == "par23":
        h = w[:, 1]
    else:
        h = w[:, 0]
    return vector.Geometry(w, r, c, b, h, _perpendicular(w[:, 5]), ones, scale)


# ---------------------------------------------------------------------- the 6R solve
def _solve_6r(
    st: _Structure,
    g: vector.Geometry,
    R: FloatArray,
    p: FloatArray,
    dflt: FloatArray,
    trace: vector.Trace,
    prepared: scalar.ThreeParallel | scalar.Spherical | None = None,
) -> tuple[FloatArray, BoolArray]:
    """All (≤ 8) solutions of e₁ ⋯ e₆ = G = (R, p) for L lanes: Q (L, 8, 6) and ok (L, 8).

    `dflt` (L, 6) gives the value of an angle that the target leaves free (singular poses).
    `prepared`: the constants of a geometry g that is the same for every lane (three-parallel or
    spherical-wrist).
    """
    if isinstance(prepared, scalar.ThreeParallel):
        return vector.solve_three_parallel_prepared(prepared, R, p, dflt, trace)
    if st.kind == "three_parallel":
        return vector.solve_three_parallel(g, R, p, dflt, trace)
    return vector.solve_spherical(st.case, g, R, p, dflt, trace, prepared)


# ---------------------------------------------------------------------- detection
def _exp_rotation(w: FloatArray, r: FloatArray, theta: FloatArray) -> FloatArray:
    """e^{[S]θ} (K, 4, 4) of a revolute axis through r with unit direction w (MR eq. 3.51, 3.88)."""
    K = theta.shape[0]
    E = np.zeros((K, 4, 4))
    eye = np.eye(3)
    E[:, :3, :3] = sp.rotate(w, theta[:, None], np.broadcast_to(eye, (K, 3, 3))).swapaxes(1, 2)
    E[:, :3, 3] = r - np.einsum("kij,j->ki", E[:, :3, :3], r)
    E[:, 3, 3] = 1.0
    return E


def _transform_points(T: FloatArray, x: FloatArray) -> FloatArray:
    """T x for T (K, 4, 4) and points x (K, m, 3) or (m, 3)."""
    return (
        np.einsum(
            "kij,k...j->k...i", T[:, :3, :3], np.broadcast_to(x, (T.shape[0],) + x.shape[-2:])
        )
        + T[:, None, :3, 3]
    )


def _lane(g: vector.Geometry, k: int) -> scalar.Geometry:
    """Lane k of a vectorised geometry as the scalar solvers' tuples of floats."""

    def t(a: FloatArray) -> scalar.Vec:
        return (float(a[0]), float(a[1]), float(a[2]))

    return scalar.Geometry(
        [t(v) for v in g.w[k]], [t(v) for v in g.r[k]], t(g.c[k]), t(g.b[k]),
        t(g.h[k]), t(g.x[k]), t(g.s[k]), g.scale,
    )  # fmt: skip


class _Solver:
    """The detected structure of one chain and everything precomputed for it (immutable)."""

    def __init__(
        self,
        chain: KinematicChain,
        structure: _Structure,
        held: int | None,
    ) -> None:
        self.chain = chain
        self.structure = structure
        self.held = held
        w, r = _lines(np.asarray(chain.S))
        self.w_all, self.r_all = w, r
        M = np.asarray(chain.M)
        self.M_inv = np.linalg.inv(M)
        self.M_inv_rows: list[list[float]] = self.M_inv.tolist()
        self.M_arr = M
        self.scale = float(max(1e-3, np.abs(r).max(), np.abs(M[:3, 3]).max()))
        # Squared position error and squared ‖ΔR‖_F below which a candidate is exact to round-off
        # (`_REFINE_ABOVE`; ‖ΔR‖_F² = 8 sin²(θ/2), see `pose_errors`).
        self.exact_p2 = (_REFINE_ABOVE * self.scale) ** 2
        self.exact_f = 8.0 * math.sin(0.5 * _REFINE_ABOVE) ** 2
        self.keep = [i for i in range(chain.dof) if i != held]
        self.geometry = _geometry(structure, w[None], r[None], self.scale) if held is None else None
        self.scalar_geometry = None if self.geometry is None else _lane(self.geometry, 0)
        # The three-parallel solver with its constants prepared, for one target of a 6R arm.
        self.three_parallel = (
            scalar.ThreeParallel(self.scalar_geometry)
            if self.scalar_geometry is not None and structure.kind == "three_parallel"
            else None
        )
        # The spherical-wrist solver with its constants prepared, for one target of a 6R arm.
        self.spherical = (
            scalar.Spherical(structure.case, self.scalar_geometry)
            if self.scalar_geometry is not None and structure.kind == "spherical_wrist"
            else None
        )
        self.lower = [float(x) for x in chain.lower]
        self.upper = [float(x) for x in chain.upper]
        # Every angle of [−π, π] lies within the limits (±π, ±2π, continuous joints).
        self.holds_turn = all(
            a <= -math.pi and b >= math.pi for a, b in zip(self.lower, self.upper, strict=True)
        )
        self.info = self.family()
        self.lower_arr, self.upper_arr = np.asarray(chain.lower), np.asarray(chain.upper)
        self.continuous = ~(np.isfinite(self.lower_arr) | np.isfinite(self.upper_arr))
        self.default_seed = default_seed(chain)
        self.default_seed_list: list[float] = self.default_seed.tolist()
        self.all_finite = bool(np.all(np.isfinite(self.lower_arr) & np.isfinite(self.upper_arr)))
        self.lo_wide, self.hi_wide = self.lower_arr - 1e-10, self.upper_arr + 1e-10
        self.lo_wide_list, self.hi_wide_list = self.lo_wide.tolist(), self.hi_wide.tolist()
        # Angles strictly inside (one_lo, one_hi) lie within their limits and have no other
        # whole-turn equivalent within the widened ones (x − 2π < lo − 1e-10, x + 2π > hi + 1e-10),
        # kept 1e-9 away from where that changes (`_single_equivalents`).
        self.one_lo = [
            max(lo, b - TWO_PI) + 1e-9 for lo, b in zip(self.lower, self.hi_wide_list, strict=True)
        ]
        self.one_hi = [
            min(hi, a + TWO_PI) - 1e-9 for hi, a in zip(self.upper, self.lo_wide_list, strict=True)
        ]
        self.held_moves = None if held is None else self._held_moves()
        # A 7R arm, per value of the held joint: (geometry, its prepared spherical-wrist solver or
        # None, the rows of M⁻¹ E⁻¹); see `held_prepared`. A plain dict (a lost race only
        # recomputes an entry), emptied when full.
        self._held_cache: dict[float, tuple[scalar.Geometry, scalar.Spherical | None, Rows]] = {}
        self._held_static = self.held_moves is not None and not any(
            any(flags) for flags in self.held_moves.values()
        )
        model = chain.solver_model  # the generated scalar FK, where joints are the internal ones
        self.kernel = model.kernel
        self.fk_pose = model.kernel.fk_pose if model.to_internal is None else None
        self.fk_world = model.kernel.fk_world if model.to_internal is None else None

    def _held_moves(self) -> dict[str, list[bool]] | None:
        """For a 7R arm: which parts of the held geometry move with the held joint.

        Holding joint j at θ moves the axes after j by E = e^{[S_j]θ}; every derived point and
        direction either moves with them or stays (it may also lie on axis j and do both). Which
        one is found once here, at probe values, so that `held_scalar_geometry` can build the
        geometry for any θ from the one at θ = 0 with a few float operations instead of NumPy
        (a tenth of the time for one target). None if some part does neither (never seen; the
        NumPy route is then used)."""
        probe = np.array([0.0, 1.1, -2.3])
        g, E = self.held_geometry(probe)
        R, t = E[:, :3, :3], E[:, :3, 3]

        def moves(a: FloatArray, point: bool) -> bool | None:
            """a (3, 3): the part at the probe values; moved with E, fixed, or neither (None)."""
            moved = np.einsum("kij,j->ki", R, a[0]) + (t if point else 0.0)
            if np.allclose(a, a[0], atol=1e-12, rtol=0):
                return False
            if np.allclose(a, moved, atol=1e-12, rtol=0):
                return True
            return None

        out: dict[str, list[bool]] = {}
        parts = {"w": (g.w, False), "r": (g.r, True)}
        for name, (arr, point) in parts.items():
            flags = [moves(arr[:, i], point) for i in range(6)]
            if any(f is None for f in flags):
                return None
            out[name] = [bool(f) for f in flags]
        for name, arr, point in (("c", g.c, True), ("b", g.b, True), ("h", g.h, False)):
            f = moves(arr, point)
            if f is None:
                return None
            out[name] = [f]
        self._held_base = _lane(g, 0)
        self._held_base_vec = g  # lane 0 is θ = 0
        return out

    def held_lanes(self, theta: FloatArray) -> tuple[vector.Geometry, FloatArray]:
        """`held_geometry` (K lanes for K values θ), by moving the parts that move with the held
        joint (`_held_moves`) instead of deriving every point again: a few einsums."""
        if self.held_moves is None:
            return self.held_geometry(theta)
        j = self.held
        assert j is not None
        E = _exp_rotation(self.w_all[j], self.r_all[j], theta)
        R, t = E[:, :3, :3], E[:, :3, 3]
        g0, m = self._held_base_vec, self.held_moves
        K = theta.shape[0]

        def d(a: FloatArray, move: bool) -> FloatArray:  # a direction (3,) → (K, 3)
            return np.einsum("kij,j->ki", R, a) if move else np.broadcast_to(a, (K, 3)).copy()

        def pt(a: FloatArray, move: bool) -> FloatArray:  # a point (3,) → (K, 3)
            return d(a, move) + (t if move else 0.0)

        w = np.stack([d(g0.w[0, i], m["w"][i]) for i in range(6)], axis=1)
        r = np.stack([pt(g0.r[0, i], m["r"][i]) for i in range(6)], axis=1)
        h = d(g0.h[0], m["h"][0])
        x = _perpendicular(h if self.structure.kind == "three_parallel" else w[:, 5])
        s = np.broadcast_to(g0.s[0], (K, 3)).copy()
        g = vector.Geometry(
            w, r, pt(g0.c[0], m["c"][0]), pt(g0.b[0], m["b"][0]), h, x, s, self.scale
        )
        return g, E

    def held_scalar_geometry(self, theta: float) -> tuple[scalar.Geometry, list[list[float]]]:
        """`held_geometry` of one value θ as the scalar solvers' geometry, and E⁻¹ (4 × 4 lists),
        by moving the parts that move with the held joint (see `_held_moves`)."""
        j = self.held
        assert j is not None and self.held_moves is not None
        k = (float(self.w_all[j, 0]), float(self.w_all[j, 1]), float(self.w_all[j, 2]))
        o = (float(self.r_all[j, 0]), float(self.r_all[j, 1]), float(self.r_all[j, 2]))
        m, g0 = self.held_moves, self._held_base

        def d(v: scalar.Vec, move: bool) -> scalar.Vec:
            return scalar.rotate(k, theta, v) if move else v

        def pt(v: scalar.Vec, move: bool) -> scalar.Vec:
            return scalar.rotate_about(k, o, theta, v) if move else v

        w = [d(v, f) for v, f in zip(g0.w, m["w"], strict=True)]
        r = [pt(v, f) for v, f in zip(g0.r, m["r"], strict=True)]
        h = d(g0.h, m["h"][0])
        x = scalar.perpendicular(h if self.structure.kind == "three_parallel" else w[5])
        g = scalar.Geometry(w, r, pt(g0.c, m["c"][0]), pt(g0.b, m["b"][0]), h, x, g0.s, self.scale)
        return g, self._held_inverse(theta)

    def _held_inverse(self, theta: float) -> list[list[float]]:
        """E⁻¹ = e^{−[S_j]θ} of the held joint j (4 × 4 lists): columns R(k, −θ) eᵢ, translation
        o − R o."""
        j = self.held
        assert j is not None
        k = (float(self.w_all[j, 0]), float(self.w_all[j, 1]), float(self.w_all[j, 2]))
        o = (float(self.r_all[j, 0]), float(self.r_all[j, 1]), float(self.r_all[j, 2]))
        cols = [
            scalar.rotate(k, -theta, e) for e in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
        ]
        Ro = scalar.rotate(k, -theta, o)
        E_inv = [[cols[0][i], cols[1][i], cols[2][i], o[i] - Ro[i]] for i in range(3)]
        E_inv.append([0.0, 0.0, 0.0, 1.0])
        return E_inv

    def held_prepared(self, theta: float) -> tuple[scalar.Geometry, scalar.Spherical | None, Rows]:
        """For the held joint at θ: the scalar geometry, its prepared spherical-wrist solver (None
        for a three-parallel structure) and the rows of M⁻¹ E⁻¹ (so G = T M⁻¹ E⁻¹), kept per θ:
        `ik` tries the seed's value and then fixed values of `held_order`, the same for every
        target. Requires `held_moves`. When no part of the geometry moves with the held joint
        (Panda, xArm7: the held joint is the last) the geometry and solver are built once."""
        got = self._held_cache.get(theta)
        if got is not None:
            return got
        if self._held_static:  # nothing moves: the geometry at θ = 0; only E⁻¹ changes
            g, E_inv = self._held_base, self._held_inverse(theta)
        else:
            g, E_inv = self.held_scalar_geometry(theta)
        prep: scalar.Spherical | None = None
        if self.structure.kind == "spherical_wrist":
            prep = (
                self._held_static_solver
                if self._held_static
                else scalar.Spherical(self.structure.case, g)
            )
        # K = M⁻¹ E⁻¹, written out (E⁻¹'s last row is 0, 0, 0, 1): a miss costs this per call
        # when the seed's value of the held joint changes from call to call.
        (e00, e01, e02, e03), (e10, e11, e12, e13), (e20, e21, e22, e23) = E_inv[:3]
        K = [
            [
                m0 * e00 + m1 * e10 + m2 * e20,
                m0 * e01 + m1 * e11 + m2 * e21,
                m0 * e02 + m1 * e12 + m2 * e22,
                m0 * e03 + m1 * e13 + m2 * e23 + m3,
            ]
            for m0, m1, m2, m3 in self.M_inv_rows
        ]
        got = (g, prep, K)
        if len(self._held_cache) >= 256:
            self._held_cache.clear()
        self._held_cache[theta] = got
        return got

    @functools.cached_property
    def _held_static_solver(self) -> scalar.Spherical:
        """The prepared solver of a held geometry that does not move with the held joint."""
        return scalar.Spherical(self.structure.case, self._held_base)

    def lo_eff(self, seed: FloatArray) -> FloatArray:
        """Lower bounds for the equivalents: the limit, or seed − π for an unbounded side."""
        return np.where(np.isfinite(self.lower_arr), self.lower_arr, seed - math.pi)

    def hi_eff(self, seed: FloatArray) -> FloatArray:
        """Upper bounds for the equivalents: the limit, or seed + π for an unbounded side."""
        lo = self.lo_eff(seed)
        return np.where(
            self.continuous, lo + TWO_PI - 1e-9,
            np.where(np.isfinite(self.upper_arr), self.upper_arr, seed + math.pi),
        )  # fmt: skip

    # -- per-call geometry for a 7R arm with the held joint at values θ (K,)
    def held_geometry(self, theta: FloatArray) -> tuple[vector.Geometry, FloatArray]:
        """Lane geometry of the 6R arm left when joint `held` is at θ, and E = e^{[S_j]θ} (K, 4, 4)."""
        j = self.held
        assert j is not None
        E = _exp_rotation(self.w_all[j], self.r_all[j], theta)
        K = theta.shape[0]
        w = np.broadcast_to(self.w_all, (K,) + self.w_all.shape).copy()
        r = np.broadcast_to(self.r_all, (K,) + self.r_all.shape).copy()
        w[:, j + 1 :] = np.einsum("kij,kmj->kmi", E[:, :3, :3], w[:, j + 1 :])
        r[:, j + 1 :] = _transform_points(E, r[:, j + 1 :])
        keep = self.keep
        return _geometry(self.structure, w[:, keep], r[:, keep], self.scale), E

    def family(self) -> ClosedFormFamily:
        st = self.structure
        kind = st.kind if self.held is None else f"7r_{st.kind}"
        names = self.chain.joint_names
        idx = [i + 1 for i in self.keep]
        if st.reversed:
            idx = idx[::-1]
        if st.kind == "three_parallel":
            desc = (
                f"joints {idx[1]}, {idx[2]}, {idx[3]} parallel; joints {idx[4]} and {idx[5]} meet"
            )
        else:
            rel = _CASE_LABEL[st.case]
            a, b_ = (idx[1], idx[2]) if st.case in ("par23", "int23") else (idx[0], idx[1])
            desc = (
                f"joints {idx[3]}, {idx[4]}, {idx[5]} meet at a point (spherical wrist); joints "
                f"{a} and {b_} {'are parallel' if '∥' in rel else 'meet'}"
            )
        if st.reversed:
            desc += " (read from the tip)"
        held = None if self.held is None else names[self.held]
        if held is not None:
            desc += f", with {held} held"
        return ClosedFormFamily(kind, held, st.reversed, _CASE_LABEL[st.case], desc)


def _confirm(solver: _Solver) -> bool:
    """True if random configurations come back from their own FK (rejects degenerate structures)."""
    rng = np.random.default_rng(12345)
    q = rng.uniform(-math.pi, math.pi, size=(24, solver.chain.dof))
    T = solver.chain.fk(q)
    held = None if solver.held is None else q[:, solver.held]
    seeds = rng.uniform(-math.pi, math.pi, size=q.shape)  # not q: a free angle must not be guessed
    sol = _solve_arrays(
        solver, T, seeds, None if held is None else held[:, None], 1e-9, use_limits=False
    )
    if not np.all(sol.count > 0):
        return False
    for i in range(q.shape[0]):
        d = np.abs(_wrap(sol.solutions_of(i) - q[i])).max(axis=1)
        if d.min() > 1e-6:
            return False
    return True


def _why_not(chain: KinematicChain) -> str:
    """Why a chain has no closed form, in a sentence (for NoClosedFormError)."""
    if any(t == "prismatic" for t in chain.joint_types):
        return "it has prismatic joints (only all-revolute arms have a closed form here)"
    if chain.dof not in (6, 7):
        return f"it has {chain.dof} joints (closed forms here are for 6R and 7R arms)"
    if chain.solver_model.G is not None:
        return "it has mimic joints (closed forms here are for arms whose joints move alone)"
    w, r = _lines(np.asarray(chain.S))
    parts = []
    for rev, label in ((False, "last"), (True, "first")):
        ww, rr = (w[::-1], r[::-1]) if rev else (w, r)
        _, miss = _meet(ww[3:6], rr[3:6])
        parts.append(f"the {label} three axes miss a common point by {float(miss):.3g} m")
    return (
        "no structure was found: "
        + "; ".join(parts)
        + f" (tolerances {DISTANCE_TOLERANCE:g} m, {ANGLE_TOLERANCE:g} rad), and no three "
        "consecutive parallel axes are followed by two that meet"
    )


def no_closed_form_reason(chain: KinematicChain) -> str:
    """Why `chain` has no closed-form family, in a sentence ("" if it has one)."""
    return "" if _solver(chain) is not None else _why_not(chain)


def detect(chain: KinematicChain) -> _Solver | None:
    """The closed-form solver of `chain`, or None. Geometry only: the lines of the screw axes S."""
    if any(t == "prismatic" for t in chain.joint_types) or chain.dof not in (6, 7):
        return None
    if chain.solver_model.G is not None:
        return None  # mimic joints: S has a column per moving joint, θ = G q + offset ≠ q
    S = np.asarray(chain.S)
    w, r = _lines(S)
    if not np.allclose(sp.norm(w), 1.0, atol=1e-9) or np.abs(sp.dot(w, S[3:].T)).max() > 1e-9:
        return None  # not pure revolute screws
    if chain.dof == 6:
        for st in _candidates(w, r):
            solver = _Solver(chain, st, None)
            if _confirm(solver):
                return solver
        return None
    # 7R: hold joint j; the structure must hold whatever its value.
    probe = np.array([0.0, 1.1, -2.3])
    found_solvers: list[_Solver] = []
    for j in range(7):
        keep = [i for i in range(7) if i != j]
        common: list[_Structure] | None = None
        for theta in probe:
            E = _exp_rotation(w[j], r[j], np.array([theta]))[0]
            wj, rj = w.copy(), r.copy()
            wj[j + 1 :] = wj[j + 1 :] @ E[:3, :3].T
            rj[j + 1 :] = rj[j + 1 :] @ E[:3, :3].T + E[:3, 3]
            found = _candidates(wj[keep], rj[keep])
            common = found if common is None else [s for s in common if s in found]
        for st in common or []:
            solver = _Solver(chain, st, j)
            if _confirm(solver):
                found_solvers.append(solver)
                break
    if not found_solvers:
        return None
    # Prefer the held joint whose values least often make a target unreachable (Panda: joint 7,
    # not the elbow), then the one nearest the middle of the chain (iiwa: joint 3).
    scored = [(_held_coverage(s), s) for s in found_solvers]
    best = max(c for c, _ in scored)
    ties = [s for c, s in scored if c >= best - 0.1]
    return min(ties, key=lambda s: (abs((s.held or 0) - 3), s.held))


def _held_coverage(solver: _Solver) -> float:
    """Fraction of (random target, random held value) pairs with a solution, limits ignored."""
    rng = np.random.default_rng(54321)
    N, K = 32, 8
    q = rng.uniform(-math.pi, math.pi, size=(N, solver.chain.dof))
    held = rng.uniform(-math.pi, math.pi, size=K)
    out = _solve_arrays(solver, solver.chain.fk(q), q, held, 1e-9, use_limits=False)
    # Lanes are target-major; count (target, held value) pairs with at least one solution.
    return float(np.count_nonzero(out.lane_count) / (N * K))


# ---------------------------------------------------------------------- solving
def _wrap(a: FloatArray) -> FloatArray:
    """Angles into (−π, π]."""
    return a - TWO_PI * np.ceil((a - math.pi) / TWO_PI)


def pose_errors(T: FloatArray, T_t: FloatArray) -> tuple[FloatArray, FloatArray]:
    """‖p − p_t‖ [m] and the rotation angle between R and R_t [rad] of poses T (K, 4, 4) against
    T_t (K or 1, 4, 4) (from ‖R − R_t‖_F = 2√2 sin(θ/2), accurate at small angles, unlike arccos
    of the trace)."""
    dp = sp.norm(T[:, :3, 3] - T_t[:, :3, 3])
    f = np.sqrt(((T[:, :3, :3] - T_t[:, :3, :3]) ** 2).sum(axis=(1, 2)))
    return dp, 2.0 * np.arcsin(np.minimum(f / (2.0 * math.sqrt(2.0)), 1.0))


def _refine(
    chain: KinematicChain, Q: FloatArray, T_t: FloatArray, frozen: int | None, steps: int = 2
) -> FloatArray:
    """Gauss–Newton steps J_world Δq = (ω_err, p_t − p) toward T_t, with ω_err the rotation vector of
    R_t Rᵀ to first order, vee((A − Aᵀ)/2) (damped by 1e-12 so a singular J stays solvable)."""
    cols = [i for i in range(chain.dof) if i != frozen]
    for _ in range(steps):
        T, J = chain.fk_jacobian(Q, "world")
        A = T_t[:, :3, :3] @ T[:, :3, :3].swapaxes(1, 2)
        e = np.stack(
            (
                0.5 * (A[:, 2, 1] - A[:, 1, 2]),
                0.5 * (A[:, 0, 2] - A[:, 2, 0]),
                0.5 * (A[:, 1, 0] - A[:, 0, 1]),
                *(T_t[:, :3, 3] - T[:, :3, 3]).T,
            ),
            axis=1,
        )
        Jc = J[:, :, cols]
        JJt = Jc @ Jc.swapaxes(1, 2) + 1e-12 * np.eye(6)
        dq = (Jc.swapaxes(1, 2) @ np.linalg.solve(JJt, e[..., None]))[..., 0]
        Q = Q.copy()
        Q[:, cols] += dq
    return Q


def _batch_fk_errors(
    solver: _Solver, Q: FloatArray, T_t: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """`pose_errors(chain.fk(Q), T_t)` from the FK kernel's column layout (C[j, i] = R[i, j],
    (3, 3, K)) without assembling (K, 4, 4) poses first (a fifth of the batch FK check's time)."""
    if solver.fk_pose is None:  # joints other than the kernel's (mimic): the chain's own FK
        return pose_errors(solver.chain.fk(Q), T_t)
    C, p, *_ = solver.kernel.frames_batch(Q, False)
    d = p - T_t[:, :3, 3].T
    dp = np.sqrt(np.einsum("ik,ik->k", d, d))
    D = C - T_t[:, :3, :3].transpose(2, 1, 0)
    f = np.sqrt(np.einsum("jik,jik->k", D, D))
    return dp, 2.0 * np.arcsin(np.minimum(f / (2.0 * math.sqrt(2.0)), 1.0))


def _fk_check(
    solver: _Solver, Q: FloatArray, T_t: FloatArray, fix: Callable[[FloatArray], FloatArray]
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Candidates Q (k, n) checked against their targets T_t (k, 4, 4) by forward kinematics:
    near misses refined (kept only where that helps; `fix` maps refined rows back into the
    candidates' range), and the position [m] and rotation [rad] errors."""
    chain = solver.chain
    Q = Q.copy()
    ep, er = _batch_fk_errors(solver, Q, T_t)
    redo = (
        ((ep > _REFINE_ABOVE * solver.scale) | (er > _REFINE_ABOVE))
        & (ep < _REFINE_BELOW * solver.scale)
        & (er < _REFINE_BELOW)
    )
    if redo.any():
        Qr = fix(_refine(chain, Q[redo], T_t[redo], solver.held))
        ep_r, er_r = pose_errors(chain.fk(Qr), T_t[redo])
        better = np.maximum(ep_r / solver.scale, er_r) < np.maximum(
            ep[redo] / solver.scale, er[redo]
        )
        sel = np.flatnonzero(redo)[better]
        Q[sel], ep[sel], er[sel] = Qr[better], ep_r[better], er_r[better]
    return Q, ep, er


@dataclass
class _Outcome:
    """Internal result of `_solve_arrays` (CSR layout, like ClosedFormBatchResult)."""

    solutions: FloatArray
    offsets: IntArray
    count: IntArray
    singular: BoolArray
    reasons: list[str]
    singular_reasons: list[str]
    n_before_limits: IntArray
    held_values: FloatArray
    lane_count: IntArray  # accepted solutions per lane (target × held value), before the limits

    def solutions_of(self, i: int) -> FloatArray:
        return self.solutions[self.offsets[i] : self.offsets[i + 1]]


def _branches(
    solver: _Solver, T: FloatArray, seeds: FloatArray, held: FloatArray | None
) -> tuple[FloatArray, BoolArray, IntArray, FloatArray | None, vector.Trace]:
    """The 8 branches of every lane, unchecked: Q (L, 8, n) with angles in (−π, π], ok (L, 8) where
    every subproblem had a solution, the target of each lane, the held value of each lane (None
    for a 6R arm), and the trace. A 6R arm has one lane per target; a 7R arm one per (target,
    held value): `held` (K,) values for every target or (N, K) per target, lane i·K + k."""
    st = solver.structure
    N = T.shape[0]
    if solver.held is None:
        g = solver.geometry
        assert g is not None
        G = T @ solver.M_inv
        owner_lane = np.arange(N)
        held_lane = None
    else:
        assert held is not None
        K = held.shape[-1]
        owner_lane = np.repeat(np.arange(N), K)
        if held.ndim == 1:  # shared values: the geometry of K lanes, tiled over the targets
            gK, EK = solver.held_lanes(held)
            g = _tile_lanes(gK, N)
            E = np.tile(EK, (N, 1, 1))
            held_lane = np.tile(held, N)
        else:
            held_lane = held.reshape(-1)
            g, E = solver.held_lanes(held_lane)
        # G = T M⁻¹ e^{−[S_j]θ}: the 6R arm left has home pose e^{[S_j]θ} M.
        G = T[owner_lane] @ solver.M_inv @ _inverse(E)
    dflt = seeds[owner_lane][:, solver.keep]
    if st.reversed:
        G = _inverse(G)
        dflt = -dflt[:, ::-1]
    trace = vector.Trace()
    prepared: scalar.ThreeParallel | scalar.Spherical | None = None
    if solver.held is None:
        prepared = solver.three_parallel or solver.spherical
    elif solver._held_static and st.kind == "spherical_wrist":  # every lane has the same geometry
        prepared = solver._held_static_solver
    Q6, ok = _solve_6r(st, g, G[:, :3, :3], G[:, :3, 3], dflt, trace, prepared)
    if st.reversed:
        Q6 = -Q6[..., ::-1]
    if held_lane is not None:
        assert solver.held is not None
        Q = _insert(Q6, solver.held, held_lane)
    else:
        Q = Q6
    return _wrap(Q), ok, owner_lane, held_lane, trace


#: Lanes (targets × held values) per pass of `_solve_arrays`: its working arrays then stay in the
#: CPU caches. `ik_all_batch` of 20,480 UR5 targets, targets/s in three runs on a busy machine:
#: ±π limits 39–70k in one pass, 58–79k in passes of 2048 (4096: 59–81k, 512: 51–67k); ±2π limits
#: (230 solutions per target) 3.9–5.0k in one pass, 6.6–7.2k in passes of 2048.
SOLVE_CHUNK = 2048


def _solve_arrays(
    solver: _Solver,
    T: FloatArray,
    seeds: FloatArray,
    held: FloatArray | None,
    tol: float,
    use_limits: bool = True,
) -> _Outcome:
    """Every solution for N targets T (N, 4, 4), sorted per target by distance to its seed (N, n).

    `held` (7R arms): (K,) values of the held joint swept for every target, or (N, K) per target.
    Without `use_limits` solutions are returned in (−π, π] whatever the limits. Works in passes of
    about `SOLVE_CHUNK` lanes.
    """
    N = T.shape[0]
    K = 1 if held is None else held.shape[-1]
    step = max(1, SOLVE_CHUNK // K)
    if N <= step:
        return _solve_arrays_once(solver, T, seeds, held, tol, use_limits)
    parts = [
        _solve_arrays_once(
            solver,
            T[i : i + step],
            seeds[i : i + step],
            held[i : i + step] if held is not None and held.ndim == 2 else held,
            tol,
            use_limits,
        )
        for i in range(0, N, step)
    ]
    count = np.concatenate([o.count for o in parts])
    offsets = np.zeros(N + 1, dtype=np.int64)
    np.cumsum(count, out=offsets[1:])
    return _Outcome(
        np.concatenate([o.solutions for o in parts]),
        offsets,
        count,
        np.concatenate([o.singular for o in parts]),
        [r for o in parts for r in o.reasons],
        [r for o in parts for r in o.singular_reasons],
        np.concatenate([o.n_before_limits for o in parts]),
        np.empty(0) if held is None else np.asarray(held),
        np.concatenate([o.lane_count for o in parts]),
    )


def _solve_arrays_once(
    solver: _Solver,
    T: FloatArray,
    seeds: FloatArray,
    held: FloatArray | None,
    tol: float,
    use_limits: bool,
) -> _Outcome:
    """`_solve_arrays` in one pass."""
    chain = solver.chain
    n = chain.dof
    N = T.shape[0]
    Q, ok, owner_lane, held_lane, trace = _branches(solver, T, seeds, held)
    L = Q.shape[0]
    free = np.zeros((L, 8), dtype=bool)
    free_codes = np.full((L, 8), -1)
    for code, (_, f) in enumerate(trace.frees):
        free_codes = np.where(f & (free_codes < 0), code, free_codes)
        free |= f
    # Forward-kinematics check (refining near misses) on branches that passed every subproblem.
    flat_Q = Q.reshape(L * 8, n)
    flat_owner = np.repeat(owner_lane, 8)
    idx = np.flatnonzero(ok.reshape(-1))
    acc = np.zeros(L * 8, dtype=bool)
    if idx.size:
        Qc, ep, er = _fk_check(solver, flat_Q[idx], T[flat_owner[idx]], _wrap)
        flat_Q[idx] = Qc
        acc[idx] = (ep <= tol) & (er <= tol)
    acc2 = acc.reshape(L, 8)
    # One solution once: drop a branch equal (mod 2π) to an earlier accepted one of the same lane.
    acc2 &= ~_duplicates(flat_Q.reshape(L, 8, n), acc2)
    lane_count = acc2.sum(axis=1)
    keep = np.flatnonzero(acc2.reshape(-1))
    Qk, owner = flat_Q[keep], flat_owner[keep]
    sing_code = free_codes.reshape(-1)[keep]
    n_before = np.bincount(owner, minlength=N)
    if use_limits:
        two = _within_limits_two(solver, Qk, owner, sing_code) if solver.all_finite else None
        if two is None:
            two = _within_limits(chain, Qk, owner, sing_code, seeds)
        Qk, owner, sing_code = two
    # Sort by target, then by distance to that target's seed.
    count = np.bincount(owner, minlength=N).astype(np.int64)
    offsets = np.zeros(N + 1, dtype=np.int64)
    np.cumsum(count, out=offsets[1:])
    order = _order_within_targets(Qk, owner, seeds, count, offsets)
    Qk, owner, sing_code = Qk.take(order, 0), owner.take(order), sing_code.take(order)
    singular = np.zeros(N, dtype=bool)
    singular[owner[sing_code >= 0]] = True
    # Reasons, for targets without a solution: the first stage at which every branch failed.
    reasons = [""] * N
    empty = np.flatnonzero(count == 0)
    if empty.size:
        ok_so_far = np.ones((L, 8), dtype=bool)
        stage_dead: list[tuple[str, BoolArray]] = []
        for name, f in trace.fails:
            ok_so_far = ok_so_far & f
            alive = np.zeros(N, dtype=bool)
            alive[owner_lane[ok_so_far.any(axis=1)]] = True
            stage_dead.append((name, ~alive))
        for i in empty:
            reasons[i] = _reason(stage_dead, int(i), int(n_before[i]), held is not None)
    singular_reasons = [""] * N
    for i in np.flatnonzero(singular):
        codes = np.unique(sing_code[offsets[i] : offsets[i + 1]])
        singular_reasons[i] = "; ".join(trace.frees[c][0] for c in codes if c >= 0)
    return _Outcome(
        Qk,
        offsets,
        count,
        singular,
        reasons,
        singular_reasons,
        n_before,
        np.empty(0) if held is None else np.asarray(held),
        lane_count,
    )


def _order_within_targets(
    Q: FloatArray, owner: IntArray, seeds: FloatArray, count: IntArray, offsets: IntArray
) -> IntArray:
    """The order that sorts rows Q (K, n), grouped by target (`owner` nondecreasing, `count` rows
    per target starting at `offsets`), by target and then by squared distance to the target's
    seed, ties in row order: `np.lexsort((dist, owner))`. Sorted as a (targets × most rows)
    table padded with inf, one short row sort per target (a third of lexsort's time)."""
    K = Q.shape[0]
    if not K:
        return np.zeros(0, dtype=np.int64)
    D = Q - seeds[owner]
    dist = np.einsum("ij,ij->i", D, D)
    m = int(count.max())
    pos = np.arange(K) - offsets[owner]
    table = np.full((count.shape[0], m), np.inf)
    table[owner, pos] = dist
    o = np.argsort(table, axis=1, kind="stable")
    return (o + offsets[:-1, None])[np.arange(m) < count[:, None]]


_STAGE_ORDER = {
    "three_parallel": ("shoulder", "wrist", "elbow"),
    "int12": ("elbow", "shoulder", "wrist"),
    "par23": ("shoulder", "elbow", "wrist"),
    "int23": ("shoulder", "elbow", "wrist"),
    "par12": ("shoulder", "elbow", "wrist"),
}


def _scalar_candidates(
    solver: _Solver, T: list[list[float]], seed: list[float], held_value: float | None
) -> tuple[list[scalar.Candidate], scalar.Stages]:
    """The (≤ 8) candidate solutions of one target by the scalar solvers: full configurations with
    angles in (−π, π] (a 7R arm's held joint at `held_value`), unchecked, with the reasons of the
    angles the target left free (taken from `seed`), and the stages the branches passed."""
    st = solver.structure
    if held_value is None and not st.reversed and solver.three_parallel is not None:
        R, p = _times_inverse_home(T, solver.M_inv_rows)
        stages = scalar.Stages(_STAGE_ORDER["three_parallel"])
        return solver.three_parallel.solve(R, p, seed, stages), stages  # angles in (−π, π]
    if held_value is None and not st.reversed and solver.spherical is None:  # G = T M⁻¹ on floats
        g = solver.scalar_geometry
        assert g is not None
        Mi = solver.M_inv_rows
        Gl = [
            [a * m0 + b * m1 + c * m2 + (t if j == 3 else 0.0)
             for j, m0, m1, m2 in zip(range(4), Mi[0], Mi[1], Mi[2], strict=True)]
            for a, b, c, t in T[:3]
        ]  # fmt: skip
        return _candidates_of(solver, g, Gl, seed, held_value)
    if (held_value is None and solver.spherical is not None) or (
        held_value is not None and solver.held_moves is not None
    ):  # G = T M⁻¹ (E⁻¹) and its inverse on floats (hand-written for speed: every `ik` call)
        if held_value is None:
            g, prep = solver.scalar_geometry, solver.spherical
            assert g is not None
            R, p = _times_inverse_home(T, solver.M_inv_rows)
            d = seed
        else:
            g, prep, K = solver.held_prepared(held_value)
            R, p = _times_inverse_home(T, K)
            d = [seed[i] for i in solver.keep]
        if st.reversed:  # G⁻¹ = (Rᵀ, −Rᵀp)
            (a0, a1, a2), (b0, b1, b2), (c0, c1, c2) = R
            R = ((a0, b0, c0), (a1, b1, c1), (a2, b2, c2))
            p = (
                -(a0 * p[0] + b0 * p[1] + c0 * p[2]),
                -(a1 * p[0] + b1 * p[1] + c1 * p[2]),
                -(a2 * p[0] + b2 * p[1] + c2 * p[2]),
            )
            d = [-x for x in reversed(d)]
        return _candidates_rp(solver, g, prep, R, p, d, held_value)
    Ta = np.array(T)
    if held_value is None:
        g = solver.scalar_geometry
        assert g is not None
        G = Ta @ solver.M_inv
        d = seed
    elif solver.held_moves is not None:
        g, E_inv = solver.held_scalar_geometry(held_value)
        G = Ta @ solver.M_inv @ np.array(E_inv)  # the 6R arm left has home pose e^{[S_j]θ} M
        d = [seed[i] for i in solver.keep]
    else:
        gv, E = solver.held_geometry(np.array([held_value]))
        g = _lane(gv, 0)
        G = Ta @ solver.M_inv @ _inverse(E)[0]
        d = [seed[i] for i in solver.keep]
    if st.reversed:  # the structure read from the tip: G⁻¹ = e^{−[S₆]q₆} ⋯ e^{−[S₁]q₁}
        G = _inverse(G[None])[0]
        d = [-x for x in reversed(d)]
    return _candidates_of(solver, g, G.tolist(), d, held_value)


def _times_inverse_home(
    T: list[list[float]], Mi: list[list[float]]
) -> tuple[scalar.Mat, scalar.Vec]:
    """G = T M⁻¹ as the scalar solvers' (rotation rows, translation), from the rows of T and M⁻¹
    (both rigid). Written out for speed: it runs once per single-target call."""
    (m00, m01, m02, m03), (m10, m11, m12, m13), (m20, m21, m22, m23) = Mi[0], Mi[1], Mi[2]
    rows = []
    for a, b, c, t in T[:3]:
        rows.append((
            a * m00 + b * m10 + c * m20,
            a * m01 + b * m11 + c * m21,
            a * m02 + b * m12 + c * m22,
            a * m03 + b * m13 + c * m23 + t,
        ))  # fmt: skip
    r0, r1, r2 = rows
    R = ((r0[0], r0[1], r0[2]), (r1[0], r1[1], r1[2]), (r2[0], r2[1], r2[2]))
    return R, (r0[3], r1[3], r2[3])


def _candidates_of(
    solver: _Solver,
    g: scalar.Geometry,
    Gl: list[list[float]],
    d: list[float],
    held_value: float | None,
) -> tuple[list[scalar.Candidate], scalar.Stages]:
    """`_scalar_candidates` once the 6R problem is set: geometry g, the pose G (rows) the six
    joints must produce from their home, the default angles d."""
    R: scalar.Mat = (
        (Gl[0][0], Gl[0][1], Gl[0][2]), (Gl[1][0], Gl[1][1], Gl[1][2]), (Gl[2][0], Gl[2][1], Gl[2][2])
    )  # fmt: skip
    p: scalar.Vec = (Gl[0][3], Gl[1][3], Gl[2][3])
    prep = solver.spherical if held_value is None else None
    return _candidates_rp(solver, g, prep, R, p, d, held_value)


def _candidates_rp(
    solver: _Solver,
    g: scalar.Geometry,
    prep: scalar.Spherical | None,
    R: scalar.Mat,
    p: scalar.Vec,
    d: list[float],
    held_value: float | None,
) -> tuple[list[scalar.Candidate], scalar.Stages]:
    """`_candidates_of` given G as rotation rows R and translation p, and the prepared
    spherical-wrist solver of g (None: the general one)."""
    st = solver.structure
    case = st.kind if st.kind == "three_parallel" else st.case
    stages = scalar.Stages(_STAGE_ORDER[case])
    if st.kind == "three_parallel" and held_value is None and solver.three_parallel is not None:
        raw = solver.three_parallel.solve(R, p, d, stages)  # g is solver.scalar_geometry
        if not st.reversed:
            return raw, stages  # angles already in (−π, π]
    elif st.kind == "three_parallel":
        raw = scalar.three_parallel(g, R, p, d, stages)
    elif prep is not None:
        raw = prep.solve(R, p, d, stages)
    else:
        raw = scalar.spherical(st.case, g, R, p, d, stages)
    out: list[scalar.Candidate] = []
    for q6, why in raw:
        q = [-x for x in reversed(q6)] if st.reversed else q6
        q = [  # into (−π, π] (most angles already are: tested first, for speed)
            x if -math.pi < x <= math.pi else x - TWO_PI * math.ceil((x - math.pi) * _INVTWO_PI)
            for x in q
        ]
        if held_value is not None:
            q.insert(solver.held or 0, held_value)
        out.append((q, why))
    return out, stages


def _solve_single(
    solver: _Solver, T: list[list[float]], seed: list[float], tol: float
) -> tuple[FloatArray, tuple[float, float], str, str]:
    """One target of a 6R arm with the scalar twin of the solvers (`_closed_form_scalar`).

    Same steps as `_solve_arrays`: candidates, FK check (refining near misses), duplicates out,
    whole-turn equivalents within the limits, sorted by distance to the seed.

    Returns:
        solutions (k, n), the (position, rotation) error of the first, the singular reasons ("" if
        regular), why the set is empty ("" if not).
    """
    chain = solver.chain
    cands, stages = _scalar_candidates(solver, T, seed, None)
    accepted: list[list[float]] = []
    # (position, rotation) error of each, or (squared position error, ‖ΔR‖_F²) where `squared`
    errors: list[tuple[float, float]] = []
    squared: list[bool] = []
    whys: set[str] = set()
    fk = solver.fk_pose
    # Candidates exact to round-off (the usual case) are accepted on the squared errors, without
    # the square root and arcsine of `_fk_errors`, when that implies the tolerance (hand-written
    # for speed: this loop runs for every candidate of every call).
    quick = fk is not None and tol >= _REFINE_ABOVE * max(solver.scale, 1.0)
    exact_p2, exact_f = solver.exact_p2, solver.exact_f
    a0, a1, a2, a3 = T[0]
    b0, b1, b2, b3 = T[1]
    c0, c1, c2, c3 = T[2]
    for q, why in cands:  # one scalar FK each: ~3 µs, where a batched FK of 7 costs ~90 µs
        if quick:
            t, _ = fk(q)  # type: ignore[misc]
            dp2 = (t[9] - a3) ** 2 + (t[10] - b3) ** 2 + (t[11] - c3) ** 2
            f = (
                (t[0] - a0) ** 2 + (t[1] - a1) ** 2 + (t[2] - a2) ** 2
                + (t[3] - b0) ** 2 + (t[4] - b1) ** 2 + (t[5] - b2) ** 2
                + (t[6] - c0) ** 2 + (t[7] - c1) ** 2 + (t[8] - c2) ** 2
            )  # fmt: skip
            exact = dp2 <= exact_p2 and f <= exact_f
            ep, er = (dp2, f) if exact else (math.sqrt(dp2), _chord_angle(f))
        else:
            exact = False
            ep, er = _fk_errors(solver, q, T)
        if not exact:
            if (
                (ep > _REFINE_ABOVE * solver.scale or er > _REFINE_ABOVE)
                and ep < _REFINE_BELOW * solver.scale
                and er < _REFINE_BELOW
            ):
                qr = [_wrap1(x) for x in _refine_one(solver, q, T)]
                ep_r, er_r = _fk_errors(solver, qr, T)
                if max(ep_r / solver.scale, er_r) < max(ep / solver.scale, er):
                    q, ep, er = qr, ep_r, er_r
            if ep > tol or er > tol:
                continue
        if _seen(q, accepted):
            continue
        accepted.append(q)
        errors.append((ep, er))
        squared.append(exact)
        if why:
            whys.update(why)
    none = np.empty((0, chain.dof))
    if not accepted:
        return none, (math.inf, math.inf), "", _empty_reason(stages.first_dead(), 0)
    sols, first = _expand_sorted(solver, accepted, seed)
    if not sols.shape[0]:
        return none, (math.inf, math.inf), "", _empty_reason(None, len(accepted))
    ep, er = errors[first]
    if squared[first]:
        ep, er = math.sqrt(ep), _chord_angle(er)
    return sols, (ep, er), "; ".join(sorted(whys)), ""


def _seen(q: list[float], accepted: list[list[float]]) -> bool:
    """q equals (`_same`) one of `accepted`; a cheap first test on one joint (branches often
    share the first joint)."""
    q2 = q[2]
    for o in accepted:
        d = abs(q2 - o[2])
        if (d <= _SAME_SOLUTION or abs(d - TWO_PI) <= _SAME_SOLUTION) and _same(q, o):
            return True
    return False


def _same(a: list[float], b: list[float]) -> bool:
    """Two solutions with angles in (−π, π] are equal modulo 2π to `_SAME_SOLUTION`."""
    for x, y in zip(a, b, strict=True):
        d = abs(x - y)
        if d > _SAME_SOLUTION and abs(d - TWO_PI) > _SAME_SOLUTION:
            return False
    return True


def _empty_reason(dead_stage: str | None, n_before_limits: int) -> str:
    if dead_stage is not None:
        return f"unreachable: {_STAGE_TEXT[dead_stage]}"
    if n_before_limits:
        k = n_before_limits
        return (
            f"{k} solution{'s' if k > 1 else ''} reach the target but none lies within the "
            "joint limits"
        )
    return "unreachable: no candidate reproduced the target by forward kinematics"


def _fk_errors(solver: _Solver, q: list[float], T: list[list[float]]) -> tuple[float, float]:
    """`_pose_errors_list` of FK(q) against T, from the generated scalar FK's 12 floats (row-major
    R, then p) without building an array (~3 µs instead of ~7)."""
    if solver.fk_pose is None:
        return _pose_errors_list(solver.chain.fk(q).tolist(), T)
    t, _ = solver.fk_pose(q)
    a, b, c = T[0], T[1], T[2]
    dp = math.hypot(t[9] - a[3], t[10] - b[3], t[11] - c[3])  # (no overflow for far targets)
    f = (
        (t[0] - a[0]) ** 2 + (t[1] - a[1]) ** 2 + (t[2] - a[2]) ** 2
        + (t[3] - b[0]) ** 2 + (t[4] - b[1]) ** 2 + (t[5] - b[2]) ** 2
        + (t[6] - c[0]) ** 2 + (t[7] - c[1]) ** 2 + (t[8] - c[2]) ** 2
    )  # fmt: skip
    return dp, _chord_angle(f)


def _chord_angle(f: float) -> float:
    """The rotation angle [rad] between two rotations with ‖R_a − R_b‖_F² = f (`pose_errors`)."""
    return 2.0 * math.asin(min(math.sqrt(f) / (2.0 * math.sqrt(2.0)), 1.0))


def _refine_one(solver: _Solver, q: list[float], T: list[list[float]]) -> list[float]:
    """`_refine` of one candidate on floats: two Gauss–Newton steps J_world Δq = (ω_err, Δp) with
    the generated FK's Jacobian columns and one 6×6 solve each (~40 µs, where the batched
    `_refine` of one row costs ~300 µs: real URDFs whose axes meet only to the detection
    tolerance need it for every candidate). The held joint of a 7R arm stays fixed."""
    if solver.fk_world is None:
        return _refine(solver.chain, np.array([q]), np.array(T)[None], solver.held)[0].tolist()
    kept = [i for i in range(len(q)) if i != solver.held]
    q = list(q)
    a, b, c = T[0], T[1], T[2]
    for _ in range(2):
        t, cols = solver.fk_world(q)
        # A = R_t Rᵀ (row i of R_t against row k of R); ω_err = vee((A − Aᵀ)/2) to first order
        A = [
            [r[0] * t[3 * k] + r[1] * t[3 * k + 1] + r[2] * t[3 * k + 2] for k in range(3)]
            for r in (a, b, c)
        ]
        e = np.array([
            0.5 * (A[2][1] - A[1][2]), 0.5 * (A[0][2] - A[2][0]), 0.5 * (A[1][0] - A[0][1]),
            a[3] - t[9], b[3] - t[10], c[3] - t[11],
        ])  # fmt: skip
        J = np.array([cols[i] for i in kept]).T  # (6, k)
        dq = J.T @ np.linalg.solve(J @ J.T + 1e-12 * np.eye(6), e)
        for i, d in zip(kept, dq.tolist(), strict=True):
            q[i] += d
    return q


def _pose_errors_list(A: list[list[float]], B: list[list[float]]) -> tuple[float, float]:
    """`pose_errors` of one pose pair given as nested lists: ‖Δp‖ [m], rotation angle [rad]."""
    a0, a1, a2 = A[0], A[1], A[2]
    b0, b1, b2 = B[0], B[1], B[2]
    dp = math.hypot(a0[3] - b0[3], a1[3] - b1[3], a2[3] - b2[3])  # (no overflow for far targets)
    f = 0.0
    for a, b in ((a0, b0), (a1, b1), (a2, b2)):
        f += (a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2 + (a[2] - b[2]) ** 2
    return dp, _chord_angle(f)


def _expand_sorted(
    solver: _Solver, accepted: list[list[float]], seed: list[float]
) -> tuple[FloatArray, int]:
    """Whole-turn equivalents within the limits (`_equivalents`), nearest the seed first, and the
    index into `accepted` of the first."""
    if solver.all_finite:
        few = _single_equivalents(solver, accepted, seed)
        if few is not None:
            return few
    seeds = np.array([seed])
    if solver.all_finite:
        two = _two_equivalents(solver, accepted, seeds)
        if two is not None:
            return two
    Qk, tag = _equivalents(solver, np.array(accepted), seeds)
    if not Qk.shape[0]:
        return Qk, 0
    order = np.argsort(((Qk - seeds) ** 2).sum(axis=1), kind="stable")
    return Qk[order], int(tag[order[0]])


#: Per joint count n: 2π × the (2ⁿ, n) bits of 0 … 2ⁿ − 1, and the codes (`_two_equivalents`).
_TURN_BITS: dict[int, tuple[FloatArray, IntArray]] = {}


def _two_equivalents(
    solver: _Solver, accepted: list[list[float]], seeds: FloatArray
) -> tuple[FloatArray, int] | None:
    """`_expand_sorted` when no angle has more than two whole-turn equivalents within the (finite)
    limits, as with limits of ±2π; None otherwise. Solution i's equivalents are its lowest one
    (angles + 2π k_lo) plus 2π b for the bit patterns b that are 0 wherever an angle has a single
    equivalent: b & fixed = 0, an integer mask test. (`_equivalents` compares all mⁿ offsets per
    joint instead; this, with `take` rather than fancy indexing, is ~4× faster for a UR5.)"""
    n = len(seeds[0])
    Q = np.array(accepted)
    k_lo = np.ceil((solver.lo_wide - Q) * _INVTWO_PI)
    cnt = np.floor((solver.hi_wide - Q) * _INVTWO_PI) - k_lo
    if cnt.max() > 1.0:  # (cnt is the number of equivalents − 1)
        return None
    turns, codes = _turn_bits(n)
    fixed = (cnt == 0.0) @ _powers_of_two(n)  # angles with one equivalent: their bit stays 0
    ok = (codes[None, :] & fixed[:, None]) == 0
    if cnt.min() < 0.0:  # an angle without any: no equivalent of the solution
        ok &= (cnt >= 0.0).all(axis=1)[:, None]
    ok = np.flatnonzero(ok)
    keep = ok >> n  # ok = solution · 2ⁿ + code
    out = (Q + TWO_PI * k_lo).take(keep, 0)
    out += turns.take(ok & (2**n - 1), 0)
    np.minimum(out, solver.upper_arr, out=out)  # (within 1e-10 of the limits: clip into them)
    np.maximum(out, solver.lower_arr, out=out)
    if not out.shape[0]:
        return out, 0
    D = out - seeds
    order = np.argsort(np.einsum("ij,ij->i", D, D), kind="stable")
    return out.take(order, 0), int(keep[order[0]])


def _single_equivalents(
    solver: _Solver, accepted: list[list[float]], seed: list[float]
) -> tuple[FloatArray, int] | None:
    """`_expand_sorted` on floats when no angle has a second whole-turn equivalent within the
    (finite) limits, as with limits of ±π: each solution then stays as it is or drops out (about
    10 µs against the vectorised 21 µs). None as soon as an angle has another equivalent within
    the limits (the caller then takes the vectorised product). Same rule as `_equivalents`: limits
    widened by 1e-10 rad, values then clipped into them."""
    lo, hi = solver.lo_wide_list, solver.hi_wide_list
    rows: list[tuple[float, list[float], int]] = []  # (squared distance to the seed, q, source)
    clip = False  # some angle lies in the 1e-10 margin outside a limit
    for i, q in enumerate(accepted):
        # First the usual case on one test per angle: inside `solver.one_lo/one_hi` an angle is
        # within its limits and has no other equivalent (hand-written for speed).
        dist = 0.0
        for x, z, a, b in zip(q, seed, solver.one_lo, solver.one_hi, strict=True):
            if not a < x < b:
                break
            dist += (x - z) * (x - z)
        else:
            rows.append((dist, q, i))
            continue
        dist = 0.0
        for x, a, b, z, lo_j, hi_j in zip(q, lo, hi, seed, solver.lower, solver.upper, strict=True):
            if x - TWO_PI >= a or x + TWO_PI <= b:
                return None
            if not a <= x <= b:
                break  # no equivalent of this angle within the limits
            if x < lo_j or x > hi_j:
                clip = True
            dist += (x - z) * (x - z)
        else:
            rows.append((dist, q, i))
    if not rows:
        return np.empty((0, len(seed))), 0
    rows.sort(key=lambda r: r[0])  # stable, as the vectorised argsort
    Q = np.array([r[1] for r in rows])
    if clip:
        Q = np.clip(Q, solver.lower_arr, solver.upper_arr)
    return Q, rows[0][2]


_COMBOS: dict[tuple[int, int], IntArray] = {}


def _equivalents(solver: _Solver, Q: FloatArray, seeds: FloatArray) -> tuple[FloatArray, IntArray]:
    """Every whole-turn equivalent within the limits of a few solutions Q (C, n) in (−π, π] for one
    seed (1, n): rows, and the index of the solution each comes from. Same rule as
    `_within_limits`, as one product over joints (at most m equivalents per joint: m^n offsets)."""
    chain = solver.chain
    if solver.all_finite:  # the common case: bounds fixed, widened by 1e-10 rad
        lo, hi = solver.lo_wide, solver.hi_wide
    else:
        lo, hi = solver.lo_eff(seeds[0]) - 1e-10, solver.hi_eff(seeds[0]) + 1e-10
    k_lo = np.ceil((lo - Q) * (1.0 / TWO_PI))
    cnt = (np.floor((hi - Q) * (1.0 / TWO_PI)) - k_lo + 1).astype(np.int64)
    m = int(cnt.max()) if Q.shape[0] else 0
    if m <= 1:
        keep = np.flatnonzero((cnt == 1).all(axis=1))
        out = Q[keep] + TWO_PI * k_lo[keep]
    else:
        n = chain.dof
        combos = _COMBOS.get((m, n))
        if combos is None:
            combos = np.indices((m,) * n).reshape(n, -1).T.copy()
            _COMBOS[(m, n)] = combos
        ok = (combos[None, :, :] < cnt[:, None, :]).all(axis=2)
        keep, which = np.nonzero(ok)
        out = Q[keep] + TWO_PI * (k_lo[keep] + combos[which])
    return np.clip(out, solver.lower_arr, solver.upper_arr), keep


def _wrap1(a: float) -> float:
    """One angle into (−π, π]."""
    return a - TWO_PI * math.ceil((a - math.pi) / TWO_PI)


_STAGE_TEXT = {
    "shoulder": "the wrist centre is out of reach of the shoulder (too close to joint 1's axis "
    "for the arm's offsets, or too far)",
    "elbow": "the wrist centre is out of the arm's reach (too far from or too close to the shoulder)",
    "wrist": "the wrist cannot take the target orientation at any reachable wrist position",
}


def _reason(stage_dead: list[tuple[str, BoolArray]], i: int, n_before: int, swept: bool) -> str:
    for name, dead in stage_dead:
        if dead[i]:
            text = f"unreachable: {_STAGE_TEXT[name]}"
            return text + (" for every held-joint value swept" if swept else "")
    if n_before:
        return (
            f"{n_before} solution{'s' if n_before > 1 else ''} reach the target but none lies "
            "within the joint limits"
        )
    return "unreachable: no candidate reproduced the target by forward kinematics"


_KEY_WEIGHTS = np.random.default_rng(0).uniform(0.5, 1.0, size=(1, 8))


def _duplicates(Q: FloatArray, acc: BoolArray) -> BoolArray:
    """(L, B) True where a branch equals (mod 2π, to `_SAME_SOLUTION`) an earlier accepted one.

    Branches are wrapped into (−π, π], so equal branches have equal keys Σⱼ aⱼ qⱼ unless an angle
    sits at ±π; only pairs whose keys agree (or that touch ±π) are compared joint by joint.
    """
    n = Q.shape[-1]
    key = Q @ _KEY_WEIGHTS[0, :n]  # (L, B)
    key = np.where((np.abs(Q) > math.pi - 1e-6).any(axis=-1), np.nan, key)  # NaN: always compare
    B = Q.shape[1]
    gap = np.abs(key[:, :, None] - key[:, None, :])
    close = (gap <= 8 * _SAME_SOLUTION) | np.isnan(gap)
    close &= np.tril(np.ones((B, B), dtype=bool), -1) & acc[:, None, :] & acc[:, :, None]
    dup = np.zeros(acc.shape, dtype=bool)
    lane, j, i = np.nonzero(close)  # branch j may repeat earlier branch i
    if lane.size:
        d = np.abs(Q[lane, j] - Q[lane, i])
        same = ((d <= _SAME_SOLUTION) | (np.abs(d - TWO_PI) <= _SAME_SOLUTION)).all(axis=1)
        dup[lane[same], j[same]] = True
    return dup


def _tile_lanes(g: vector.Geometry, N: int) -> vector.Geometry:
    """Lane geometry (K lanes) repeated for N targets: lane i·K + k is target i, held value k."""

    def t(a: FloatArray) -> FloatArray:
        return np.tile(a, (N,) + (1,) * (a.ndim - 1))

    return vector.Geometry(t(g.w), t(g.r), t(g.c), t(g.b), t(g.h), t(g.x), t(g.s), g.scale)


def _inverse(T: FloatArray) -> FloatArray:
    """T⁻¹ = (Rᵀ, −Rᵀp) for (K, 4, 4) rigid transforms."""
    out = np.zeros_like(T)
    Rt = T[:, :3, :3].swapaxes(1, 2)
    out[:, :3, :3] = Rt
    out[:, :3, 3] = -(Rt @ T[:, :3, 3:4])[..., 0]
    out[:, 3, 3] = 1.0
    return out


def _insert(Q6: FloatArray, j: int, values: FloatArray) -> FloatArray:
    """Insert the held joint's value as column j: (L, 8, 6) → (L, 8, 7)."""
    L = Q6.shape[0]
    col = np.broadcast_to(values[:, None, None], (L, 8, 1))
    return np.concatenate((Q6[..., :j], col, Q6[..., j:]), axis=2)


def _within_limits_two(
    solver: _Solver, Q: FloatArray, owner: IntArray, tag: IntArray
) -> tuple[FloatArray, IntArray, IntArray] | None:
    """`_within_limits` for finite limits where no angle has more than two whole-turn equivalents
    (limits of ±2π: each solution has up to 2⁵ equivalents), in one gather instead of one per
    joint: row r's equivalents are its lowest one plus 2π b for the bit patterns b with
    b & fixed_r = 0 (`_two_equivalents`, vectorised over rows). None if the rule does not apply.
    Rows stay grouped by target, in the order of `_within_limits`."""
    if not Q.shape[0]:
        return None
    n = Q.shape[1]
    # The same arithmetic as `_within_limits` (the results must not depend on the passes).
    k_lo = np.ceil((solver.lo_wide - Q) / TWO_PI)
    cnt = np.floor((solver.hi_wide - Q) / TWO_PI) - k_lo  # equivalents − 1
    most = cnt.max()
    if most > 1.0 or n > 16:
        return None
    if most < 1.0:  # one equivalent or none per angle (limits of ±π): no product to take
        out = Q + TWO_PI * k_lo
        if cnt.min() < 0.0:
            rows = np.flatnonzero((cnt >= 0.0).all(axis=1))
            out, owner, tag = out.take(rows, 0), owner.take(rows), tag.take(rows)
        if (out < solver.lower_arr).any() or (out > solver.upper_arr).any():
            np.minimum(out, solver.upper_arr, out=out)
            np.maximum(out, solver.lower_arr, out=out)
        return out, owner, tag
    turns, codes = _turn_bits(n)
    fixed = (cnt == 0.0) @ _powers_of_two(n)  # angles with one equivalent: their bit stays 0
    ok: BoolArray = (codes[None, :] & fixed[:, None]) == 0
    if cnt.min() < 0.0:
        ok &= np.asarray((cnt >= 0.0).all(axis=1))[
            :, None
        ]  # an angle without any: none of the solution
    flat = np.flatnonzero(ok)
    rows = flat >> n  # flat = row · 2ⁿ + code
    k = k_lo.take(rows, 0)
    k += turns.take(flat & (2**n - 1), 0) * (1.0 / TWO_PI)  # (the bits, exactly)
    out = Q.take(rows, 0)
    out += TWO_PI * k
    # Clip into the limits (the widening by 1e-10) only where some equivalent lies outside them
    # (elsewhere clipping changes nothing).
    lowest, highest = Q + TWO_PI * k_lo, Q + TWO_PI * (k_lo + cnt)  # (as `out` is computed)
    if (lowest < solver.lower_arr).any() or (highest > solver.upper_arr).any():
        np.minimum(out, solver.upper_arr, out=out)
        np.maximum(out, solver.lower_arr, out=out)
    return out, owner.take(rows), tag.take(rows)


@functools.lru_cache(maxsize=4)
def _powers_of_two(n: int) -> IntArray:
    """1, 2, 4, …, 2ⁿ⁻¹ (read-only)."""
    out = 1 << np.arange(n, dtype=np.int64)
    out.setflags(write=False)
    return out


def _turn_bits(n: int) -> tuple[FloatArray, IntArray]:
    """2π × the (2ⁿ, n) bits of 0 … 2ⁿ − 1 and those codes (cached per n)."""
    if n not in _TURN_BITS:
        all_codes = np.arange(2**n, dtype=np.int64)
        bits = ((all_codes[:, None] >> np.arange(n)) & 1).astype(np.float64)
        _TURN_BITS[n] = (TWO_PI * bits, all_codes)
    return _TURN_BITS[n]


def _within_limits(
    chain: KinematicChain, Q: FloatArray, owner: IntArray, tag: IntArray, seeds: FloatArray
) -> tuple[FloatArray, IntArray, IntArray]:
    """Every whole-turn equivalent of each solution (angles in (−π, π]) within the limits.

    Joint j of a solution q gives q + 2πk for every integer k with lower ≤ q + 2πk ≤ upper (within
    1e-10 rad, then clipped); a continuous joint gives the one value within π of the seed.
    """
    lo, hi = np.asarray(chain.lower), np.asarray(chain.upper)
    eps = 1e-10
    for j in range(chain.dof):
        if not Q.shape[0]:
            break
        qj = Q[:, j]
        if not (np.isfinite(lo[j]) or np.isfinite(hi[j])):
            Q[:, j] = qj + TWO_PI * np.round((seeds[owner, j] - qj) / TWO_PI)
            continue
        lo_j = lo[j] if np.isfinite(lo[j]) else seeds[owner, j] - math.pi
        hi_j = hi[j] if np.isfinite(hi[j]) else seeds[owner, j] + math.pi
        k_lo = np.ceil((lo_j - eps - qj) / TWO_PI)
        k_hi = np.floor((hi_j + eps - qj) / TWO_PI)
        cnt = np.maximum(k_hi - k_lo + 1, 0).astype(np.int64)
        if np.all(cnt == 1):
            Q[:, j] = qj + TWO_PI * k_lo
            continue
        rep = np.repeat(np.arange(Q.shape[0]), cnt)
        start = np.cumsum(cnt) - cnt
        k = k_lo[rep] + (np.arange(rep.size) - start[rep])
        Q, owner, tag = Q[rep], owner[rep], tag[rep]
        Q[:, j] = Q[:, j] + TWO_PI * k
    if Q.shape[0]:
        Q = np.clip(Q, lo, hi)
    return Q, owner, tag


# ---------------------------------------------------------------------- public entry points
_SOLVERS: weakref.WeakKeyDictionary[KinematicChain, _Solver | None] = weakref.WeakKeyDictionary()


def _solver(chain: KinematicChain) -> _Solver | None:
    """The chain's detected solver, detected once per chain (the chain is immutable)."""
    try:
        return _SOLVERS[chain]
    except KeyError:
        solver = detect(chain)
        _SOLVERS[chain] = solver
        return solver


#: What `export_family` gives: the structure found and the held joint, or None (no family).
ExportedFamily = tuple[str, str, bool, int | None] | None


def export_family(chain: KinematicChain) -> ExportedFamily:
    """The chain's detected family (detecting it if needed) as a small picklable value, for a
    process that will solve IK on a copy of the same chain (`import_family` there skips the
    20–100 ms detection: the node's IK workers)."""
    solver = _solver(chain)
    if solver is None:
        return None
    st = solver.structure
    return (st.kind, st.case, st.reversed, solver.held)


def import_family(chain: KinematicChain, exported: ExportedFamily) -> None:
    """Install what `export_family` gave for an equal chain (same screw axes, home pose and
    limits: e.g. an unpickled copy) without detecting it again. A chain whose family is already
    known keeps it.

    Raises:
        InvalidInputError: `exported` is not a value `export_family` gives for this chain's size.
    """
    if chain in _SOLVERS:
        return
    if exported is None:
        _SOLVERS[chain] = None
        return
    try:
        kind, case, rev, held = exported
        ok = kind in ("three_parallel", "spherical_wrist") and case in _CASE_LABEL
        ok = ok and (held is None if chain.dof == 6 else held in range(chain.dof))
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise InvalidInputError(f"not an exported closed-form family of this chain: {exported!r}")
    _SOLVERS[chain] = _Solver(chain, _Structure(kind, case, bool(rev)), held)


def family_of(chain: KinematicChain) -> ClosedFormFamily | None:
    """The closed-form family of `chain` with its details, or None where none applies."""
    solver = _solver(chain)
    return None if solver is None else solver.family()


def _require(chain: KinematicChain) -> _Solver:
    solver = _solver(chain)
    if solver is None:
        raise NoClosedFormError(
            f"no closed-form IK for chain {chain.base_link!r} → {chain.tip_link!r}: "
            f"{_why_not(chain)}; use chain.ik (numeric) instead"
        )
    return solver


def _held_values(
    solver: _Solver, held: ArrayLike | None, n_targets: int | None
) -> FloatArray | None:
    """Validated held-joint values [rad]: (K,) shared, or (N, K) per target when `n_targets` is N
    and `held` has two dimensions. None for 6R arms."""
    chain = solver.chain
    if solver.held is None:
        if held is not None:
            raise InvalidInputError(
                f"held is only for 7R arms; this {chain.dof}R arm's family "
                f"{solver.info.name!r} holds no joint"
            )
        return None
    j = solver.held
    name = chain.joint_names[j]
    lo, hi = float(chain.lower[j]), float(chain.upper[j])
    if held is None:
        if math.isfinite(lo) and math.isfinite(hi):
            return np.linspace(lo, hi, DEFAULT_HELD_SAMPLES)
        return np.linspace(-math.pi, math.pi, DEFAULT_HELD_SAMPLES, endpoint=False)
    arr = np.atleast_1d(as_float_array(held, "held"))
    shapes = "one value or (K,) values" + ("" if n_targets is None else f" or ({n_targets}, K)")
    if arr.size == 0 or not (
        arr.ndim == 1 or (n_targets is not None and arr.ndim == 2 and arr.shape[0] == n_targets)
    ):
        raise InvalidInputError(f"held must be {shapes} of {name} [rad], got shape {arr.shape}")
    check_finite(arr, "held")
    if np.any(arr < lo - 1e-12) or np.any(arr > hi + 1e-12):
        raise InvalidInputError(
            f"held values of {name} must lie within its limits [{lo:g}, {hi:g}] rad, got "
            f"{arr[(arr < lo) | (arr > hi)][:5].tolist()}"
        )
    return np.clip(arr, lo, hi)


def _orthonormal(T: FloatArray) -> FloatArray:
    """Targets with their rotation projected onto SO(3) (R = U Vᵀ of its SVD) when it is off by
    more than round-off; check_transform accepts ‖RᵀR − I‖ up to 1e-6."""
    R = T[:, :3, :3]
    err = np.abs(R.swapaxes(1, 2) @ R - np.eye(3)).max()
    if err <= 1e-13:
        return T
    U, _, Vt = np.linalg.svd(R)
    out = T.copy()
    out[:, :3, :3] = U @ Vt
    return out


def _exact_transform(T: object) -> list[list[float]] | None:
    """T as nested lists if it is a float (4, 4) array with a last row (0, 0, 0, 1), finite, and a
    rotation orthonormal to round-off (‖RᵀR − I‖ ≤ 1e-13, det R > 0); else None, and the caller
    runs the full `check_transform` (which explains what is wrong) and projects R onto SO(3)."""
    if not isinstance(T, np.ndarray) or T.shape != (4, 4) or T.dtype != np.float64:
        return None
    Tl: list[list[float]] = T.tolist()
    return Tl if rigid_on_floats(Tl, 1e-13, 0.0) else None


def _check_tolerance(tolerance: float) -> float:
    if not isinstance(tolerance, (int, float)) or not (0 < tolerance < 1e-2):
        raise InvalidInputError(
            f"tolerance must be a number in (0, 0.01) [m and rad], got {tolerance!r}"
        )
    return float(tolerance)


_NO_HELD_VALUES = readonly(np.empty(0))


def solve_all(
    chain: KinematicChain,
    T_target: ArrayLike,
    q_seed: ArrayLike | None = None,
    held: ArrayLike | None = None,
    tolerance: float = 1e-9,
) -> ClosedFormResult:
    """Every joint solution q within the limits with T_base_tip(q) = T_target, in closed form.

    Args:
        chain: a chain with a closed-form family (`family_of(chain)` is not None).
        T_target: (4, 4) tip pose in the base frame.
        q_seed: (n,) reference: solutions are sorted by ‖q − q_seed‖ and an angle that a singular
            target leaves undetermined takes its value from it. Default: the middle of the limits.
        held: 7R arms only: the held joint's value(s) [rad], scalar or (K,); default
            `DEFAULT_HELD_SAMPLES` values spread evenly over its limits.
        tolerance: a solution must reproduce the target to this, in position [m] and rotation
            angle [rad].

    Returns:
        `ClosedFormResult`: `solutions` all solutions, nearest the seed first (empty if none, with
        the reason in `message`); `singular` flags singular targets.

    Raises:
        NoClosedFormError: the chain has no closed-form family (the message says what is missing).
        InvalidInputError: bad target, seed, held values or tolerance.
    """

    solver = _require(chain)
    tol = _check_tolerance(tolerance)
    Tl = _exact_transform(T_target)  # fast path for a clean 4×4 array
    if Tl is None:
        T = chain.check_target(T_target)
        if T.shape != (4, 4):
            raise InvalidInputError(
                f"T_target must have shape (4, 4) (use ik_all_batch for many), got {T.shape}"
            )
        Tl = _orthonormal(T[None])[0].tolist()
    if q_seed is None:
        seed, seed_list = solver.default_seed, solver.default_seed_list
    else:
        seed = check_seed(chain, q_seed, "q_seed", None)
        seed_list = seed.tolist()
    held_arr = None if held is None and solver.held is None else _held_values(solver, held, None)
    family = solver.info
    if solver.held is None:
        sol_arr, (ep, er), singular_why, reason = _solve_single(solver, Tl, seed_list, tol)
        held_used = _NO_HELD_VALUES
    else:
        out = _solve_arrays(solver, np.array([Tl]), seed[None], held_arr, tol)
        sol_arr, held_used = out.solutions, out.held_values
        singular_why = out.singular_reasons[0] if out.singular[0] else ""
        reason = out.reasons[0]
        ep = er = math.inf
        if sol_arr.shape[0]:
            ep, er = _pose_errors_list(chain.fk(sol_arr[0]).tolist(), Tl)
    k = sol_arr.shape[0]
    sol_arr.setflags(write=False)
    if k:
        q = sol_arr[0]  # a read-only view
        msg = f"{k} solution{'s' if k > 1 else ''} ({family.name}), nearest the seed first"
        if held_arr is not None:
            msg += f"; {held_arr.size} value{'s' if held_arr.size > 1 else ''} of {family.held_joint} swept"
        if singular_why:
            msg += (
                f"; singular target: {singular_why} — the undetermined joint values "
                "were taken from the seed"
            )
    else:
        q = readonly(seed)
        ep, er = _fk_errors(solver, seed_list, Tl)
        msg = reason
    return ClosedFormResult(
        q=q,
        success=bool(k),
        position_error=float(ep),
        orientation_error=float(er),
        iterations=0,
        restarts=0,
        solutions=tuple(sol_arr),  # rows of a read-only array are read-only views
        message=msg,
        singular=bool(singular_why),
        family=family.name,
        held_values=held_used if held_used is _NO_HELD_VALUES else readonly(held_used),
    )


def solve_all_batch(
    chain: KinematicChain,
    T_targets: ArrayLike,
    q_seeds: ArrayLike | None = None,
    held: ArrayLike | None = None,
    tolerance: float = 1e-9,
) -> ClosedFormBatchResult:
    """`solve_all` for N targets at once, vectorised over targets (and held values).

    Args:
        T_targets: (N, 4, 4) tip poses in the base frame. q_seeds: (N, n) or None (middle of the
            limits). held (7R arms): one value, (K,) values swept for every target, or (N, K)
            values per target [rad]. tolerance: as in `solve_all`.

    Raises:
        NoClosedFormError, InvalidInputError: as `solve_all`.
    """

    solver = _require(chain)
    tol = _check_tolerance(tolerance)
    T = chain.check_target(T_targets, "T_targets")
    if T.ndim != 3:
        raise InvalidInputError(f"T_targets must have shape (N, 4, 4), got {T.shape}")
    N = T.shape[0]
    seeds = check_seed(chain, q_seeds, "q_seeds", N)
    held_arr = _held_values(solver, held, N)
    out = _solve_arrays(solver, _orthonormal(T), seeds, held_arr, tol)
    success = out.count > 0
    q = seeds.copy()
    q[success] = out.solutions[out.offsets[:-1][success]]
    n_ok = int(success.sum())
    msg = (
        f"{n_ok}/{N} targets solved ({solver.info.name}), {out.solutions.shape[0]} solutions, "
        f"{int(out.singular.sum())} singular"
    )
    return ClosedFormBatchResult(
        q=readonly(q),
        success=readonly(success, np.bool_),
        count=readonly(out.count, np.int64),
        offsets=readonly(out.offsets, np.int64),
        solutions=readonly(out.solutions),
        singular=readonly(out.singular, np.bool_),
        message=msg,
    )


# ---------------------------------------------------------------------- the nearest solution (`ik`)
@dataclass(frozen=True)
class Nearest:
    """What `ik` takes from the closed form for one target.

    Attributes:
        solutions: configurations (n,) within the limits that reproduce the target to the
            tolerances, nearest the seed first (weighted distance), pairwise more than the
            separation apart; at most the number asked for.
        errors: (position [m], rotation angle [rad]) of each.
        complete: the solutions are every one there is (a 6R arm); False for a 7R arm, whose held
            joint was tried at a few values only.
        reason: why there are none ("" otherwise).
    """

    solutions: list[FloatArray]
    errors: list[tuple[float, float]]
    complete: bool
    reason: str


def _nearest_turn(
    q: list[float], seed: list[float], lo: list[float], hi: list[float]
) -> list[float] | None:
    """The whole-turn equivalent of q (angles in (−π, π]) within the limits nearest the seed, joint
    by joint (each joint's term of the distance is independent); None if a joint has none.
    Unbounded sides are seed ± π, as in `_within_limits`."""
    out = []
    for x, s, a, b in zip(q, seed, lo, hi, strict=True):
        y = x + TWO_PI * round((s - x) * _INVTWO_PI)  # nearest the seed; usually within limits
        if a <= y <= b:
            out.append(y)
            continue
        lo_j = a if a > -math.inf else s - math.pi
        hi_j = b if b < math.inf else s + math.pi
        k_lo = math.ceil((lo_j - 1e-10 - x) * _INVTWO_PI)
        k_hi = math.floor((hi_j + 1e-10 - x) * _INVTWO_PI)
        if k_lo > k_hi:
            return None
        k = min(max(round((s - x) * _INVTWO_PI), k_lo), k_hi)
        out.append(min(max(x + TWO_PI * k, lo_j), hi_j))
    return out


def _ranked(
    cands: list[scalar.Candidate], seed: list[float], solver: _Solver, w: list[float]
) -> list[tuple[float, list[float]]]:
    """The candidates' `_nearest_turn` equivalents with their weighted distances Σ wⱼ (qⱼ − sⱼ)²
    to the seed, nearest first (those without an equivalent within the limits left out).

    Written out for speed (it runs on every candidate of every `ik` call): an angle within π of
    the seed and within the limits is its own nearest equivalent, so only the others go through
    `_nearest_turn`."""
    ranked: list[tuple[float, list[float]]] = []
    lo, hi = solver.lower, solver.upper
    for q, _ in cands:
        dist = 0.0
        if solver.holds_turn:  # no test of the limits per angle
            for x, s, wj in zip(q, seed, w, strict=True):
                d = x - s
                if not -math.pi < d < math.pi:
                    break
                dist += wj * (d * d)
            else:
                ranked.append((dist, q))
                continue
        else:
            for x, s, a, b, wj in zip(q, seed, lo, hi, w, strict=True):
                d = x - s
                if not (-math.pi < d < math.pi and a <= x <= b):
                    break
                dist += wj * (d * d)
            else:
                ranked.append((dist, q))
                continue
        # Each angle at its whole-turn equivalent nearest the seed (the first step of
        # `_nearest_turn`, written out); `_nearest_turn` itself only when that leaves the limits.
        turned: list[float] = []
        dist = 0.0
        for x, s, a, b, wj in zip(q, seed, lo, hi, w, strict=True):
            d = x - s
            if not -math.pi < d < math.pi:
                x = x + TWO_PI * round(-d * _INVTWO_PI)
                d = x - s
            if not a <= x <= b:
                break
            turned.append(x)
            dist += wj * (d * d)
        else:
            ranked.append((dist, turned))
            continue
        qn = _nearest_turn(q, seed, lo, hi)
        if qn is not None:
            ranked.append(
                (sum(wj * (a - b) ** 2 for wj, a, b in zip(w, qn, seed, strict=True)), qn)
            )
    ranked.sort(key=lambda item: item[0])
    return ranked


def nearest(
    chain: KinematicChain,
    T_target: FloatArray,
    q_seed: FloatArray,
    count: int,
    position_tolerance: float,
    orientation_tolerance: float,
    joint_weights: FloatArray,
    separation: float,
    deadline: float,
    tries: int = 1 + DEFAULT_HELD_SAMPLES,
    first: int = 0,
) -> Nearest | None:
    """The `count` solutions nearest `q_seed` of one target, in closed form; None if the chain has
    no closed-form family. For `ik`: its inputs are already checked (T_target a rigid (4, 4)
    transform, q_seed (n,) within the limits).

    Candidates are ranked by the weighted distance Σ wⱼ (qⱼ − q_seedⱼ)² of their nearest whole-turn
    equivalent within the limits, and checked by forward kinematics in that order (near misses
    refined, as in `solve_all`) until `count` pass, so one call usually runs one FK. A 7R arm holds
    its held joint at up to `tries` values of `held_order` (the seed's first) until one gives a
    solution or `deadline` (`time.perf_counter`) passes, starting at value `first` of them (the
    earlier ones already tried, as by `ik_batch`).
    """
    solver = _solver(chain)
    if solver is None:
        return None
    Tl = T_target.tolist()
    seed = q_seed.tolist()
    w = joint_weights.tolist()
    tols = (position_tolerance, orientation_tolerance)
    if solver.held is None and count > 1:
        return _nearest_of_all(solver, Tl, seed, count, tols, joint_weights, separation)
    if solver.held is None:
        sols, reason = _nearest_at(solver, Tl, T_target, seed, None, count, tols, w, separation)
        return Nearest([s for s, _ in sols], [e for _, e in sols], True, reason)
    j = solver.held
    found: list[tuple[FloatArray, tuple[float, float]]] = []
    first_reason = ""
    tried = 0
    for value in _held_order_one(solver, seed[j], tries)[first:]:
        if tried and time.perf_counter() > deadline:
            break
        found, reason = _nearest_at(solver, Tl, T_target, seed, value, 1, tols, w, separation)
        first_reason = first_reason or reason
        tried += 1
        if found:
            break
    if found:
        return Nearest([found[0][0]], [found[0][1]], False, "")
    more = f", and at {tried - 1} more values" if tried > 1 else ""
    why = f"{first_reason} (with {chain.joint_names[j]} held at the seed's value{more})"
    return Nearest([], [], False, why)


def _nearest_of_all(
    solver: _Solver,
    Tl: list[list[float]],
    seed: list[float],
    count: int,
    tols: tuple[float, float],
    joint_weights: FloatArray,
    separation: float,
) -> Nearest:
    """`nearest` for several solutions of a 6R arm: from the whole set of `solve_all` (every
    whole-turn equivalent too, which the nearest-turn ranking of `_nearest_at` leaves out),
    ranked by the weighted distance, taken greedily when more than `separation` from those taken."""
    sols, _, _, reason = _solve_single(solver, Tl, seed, min(tols[0], tols[1], 1e-3))
    if not sols.shape[0]:
        return Nearest([], [], True, reason)
    cost = ((sols - np.asarray(seed)) ** 2 * joint_weights).sum(axis=1)
    taken: list[FloatArray] = []
    errors: list[tuple[float, float]] = []
    for i in np.argsort(cost, kind="stable"):
        q = sols[i]
        if any(np.abs(q - t).max() <= separation for t in taken):
            continue
        taken.append(q)
        errors.append(_fk_errors(solver, q.tolist(), Tl))
        if len(taken) >= count:
            break
    return Nearest(taken, errors, True, "")


def _nearest_at(
    solver: _Solver,
    Tl: list[list[float]],
    T_target: FloatArray,
    seed: list[float],
    held_value: float | None,
    count: int,
    tols: tuple[float, float],
    w: list[float],
    separation: float,
) -> tuple[list[tuple[FloatArray, tuple[float, float]]], str]:
    """`nearest` for one value of the held joint (None for a 6R arm): the solutions with their
    (position, rotation) errors, and why there are none ("" if there are)."""
    cands, stages = _scalar_candidates(solver, Tl, seed, held_value)
    ranked = _ranked(cands, seed, solver, w)
    found: list[tuple[FloatArray, tuple[float, float]]] = []
    for _, q in ranked:
        if any(np.abs(np.asarray(q) - f).max() <= separation for f, _ in found):
            continue  # the same solution as one already taken (branches may coincide)
        ep, er = _fk_errors(solver, q, Tl)
        if (
            (ep > _NEAREST_REFINE_ABOVE * solver.scale or er > _NEAREST_REFINE_ABOVE)
            and ep < _REFINE_BELOW * solver.scale
            and er < _REFINE_BELOW
        ):
            refined = _refine_one(solver, q, Tl)
            qr = [
                min(max(x, a), b)
                for x, a, b in zip(refined, solver.lower, solver.upper, strict=True)
            ]
            ep_r, er_r = _fk_errors(solver, qr, Tl)
            if max(ep_r / solver.scale, er_r) < max(ep / solver.scale, er):
                q, ep, er = qr, ep_r, er_r
        if ep > tols[0] or er > tols[1]:
            continue
        found.append((np.array(q), (ep, er)))
        if len(found) >= count:
            break
    if found:
        return found, ""
    if stages.first_dead() is not None:
        return found, _empty_reason(stages.first_dead(), 0)
    if len(ranked) < len(cands):
        return found, _empty_reason(None, len(cands) - len(ranked))
    return found, "no closed-form candidate reproduced the target to the tolerances"


@dataclass(frozen=True)
class NearestBatch:
    """What `ik_batch` takes from the closed form for N targets: `q` (N, n) the solution nearest
    each seed where `found` (N,), else the seed; position [m] and rotation [rad] errors (inf where
    not found)."""

    q: FloatArray
    found: BoolArray
    position_error: FloatArray
    orientation_error: FloatArray


def nearest_batch(
    chain: KinematicChain,
    T_targets: FloatArray,
    q_seeds: FloatArray,
    position_tolerance: float,
    orientation_tolerance: float,
    joint_weights: FloatArray,
    held: FloatArray | None = None,
) -> NearestBatch | None:
    """`nearest` (one solution) for N targets, vectorised over targets; None without a family.

    Inputs are checked by `ik_batch`: T_targets (N, 4, 4) rigid, q_seeds (N, n) within the limits.
    A 7R arm holds its held joint at each seed's value, or at `held` (N, K) values per target
    (`held_order`).
    """
    solver = _solver(chain)
    if solver is None:
        return None
    N, n = q_seeds.shape
    if solver.held is not None and held is None:
        held = q_seeds[:, solver.held : solver.held + 1]
    Q, ok, owner_lane, _, _ = _branches(solver, T_targets, q_seeds, held)
    Qf = Q.reshape(-1, n)
    owner = np.repeat(owner_lane, 8)
    # The whole-turn equivalent within the limits nearest the seed, joint by joint (`_nearest_turn`).
    S = q_seeds[owner]
    lo = np.where(np.isfinite(solver.lower_arr), solver.lower_arr, S - math.pi)
    hi = np.where(np.isfinite(solver.upper_arr), solver.upper_arr, S + math.pi)
    k_lo = np.ceil((lo - 1e-10 - Qf) * _INVTWO_PI)
    k_hi = np.floor((hi + 1e-10 - Qf) * _INVTWO_PI)
    k = np.clip(np.round((S - Qf) * _INVTWO_PI), k_lo, k_hi)
    cand = np.flatnonzero(ok.reshape(-1) & (k_lo <= k_hi).all(axis=1))
    Qc = np.clip(Qf[cand] + TWO_PI * k[cand], lo[cand], hi[cand])
    own = owner[cand]
    Qc, ep, er = _fk_check(
        solver, Qc, T_targets[own], lambda A: np.clip(A, solver.lower_arr, solver.upper_arr)
    )
    acc = (ep <= position_tolerance) & (er <= orientation_tolerance)
    Qc, own, ep, er = Qc[acc], own[acc], ep[acc], er[acc]
    dist = (((Qc - q_seeds[own]) ** 2) * joint_weights).sum(axis=1)
    order = np.lexsort((dist, own))
    first = order[np.r_[True, own[order][1:] != own[order][:-1]]] if order.size else order
    q = q_seeds.copy()
    found = np.zeros(N, dtype=bool)
    pos, ori = np.full(N, np.inf), np.full(N, np.inf)
    t = own[first]
    q[t], found[t], pos[t], ori[t] = Qc[first], True, ep[first], er[first]
    return NearestBatch(q, found, pos, ori)


def held_order(chain: KinematicChain, q_seeds: FloatArray, count: int) -> FloatArray:
    """(N, count) values of a 7R arm's held joint to try, in order, for targets with seeds (N, n):
    the seed's value, then points of the van der Corput sequence over the joint's range (½, ¼,
    ¾, ⅛, ⅝, …: each new value halves the largest stretch not yet tried), skipping values within
    a 72nd of the range of one already chosen. A target's feasible values of the held joint form
    stretches (on Panda each value of joint 7 reaches about 37 % of random targets, and stretches
    a third of the range apart cover different targets), so spreading the tries finds one sooner
    than stepping away from the seed. A continuous joint's range, or one wider than a turn, is
    taken as the seed ± π (values a turn apart hold the arm alike)."""
    solver = _require(chain)
    assert solver.held is not None
    j = solver.held
    s = q_seeds[:, j]
    lo, hi = float(solver.lower_arr[j]), float(solver.upper_arr[j])
    # A range wider than a turn repeats itself: values a turn apart hold the arm alike, and the
    # solutions' whole-turn equivalents are taken later. So spread over the turn around the seed.
    finite = math.isfinite(lo) and math.isfinite(hi) and hi - lo <= TWO_PI
    fractions = _spread_fractions(count)
    if finite:
        span = hi - lo
        cand = lo + span * fractions[None, :] + np.zeros((s.shape[0], 1))
    else:
        span = TWO_PI
        cand = (s - math.pi)[:, None] + span * fractions[None, :]
    far = np.abs(cand - s[:, None]) > span / 72.0  # not a repeat of the seed's value
    out = np.empty((s.shape[0], count))
    out[:, 0] = s
    for i in range(s.shape[0]):
        rest = cand[i][far[i]][: count - 1]
        out[i, 1 : 1 + rest.size] = rest
        out[i, 1 + rest.size :] = out[i, rest.size]  # (only with a tiny count: repeat the last)
    return out


def _held_order_one(solver: _Solver, s: float, count: int) -> list[float]:
    """`held_order` for one seed whose held joint is at s, on floats (the same values; ~10 µs
    less per `ik` call than the array version)."""
    j = solver.held
    assert j is not None
    lo, hi = solver.lower[j], solver.upper[j]
    fractions = _spread_fraction_list(count)
    if math.isfinite(lo) and math.isfinite(hi) and hi - lo <= TWO_PI:
        span = hi - lo
        cand = [lo + span * f for f in fractions]
    else:
        span = TWO_PI
        cand = [(s - math.pi) + span * f for f in fractions]
    out = [s]
    for c in cand:
        if len(out) >= count:
            break
        if abs(c - s) > span / 72.0:
            out.append(c)
    while len(out) < count:  # (only with a tiny count: repeat the last)
        out.append(out[-1])
    return out


@functools.lru_cache(maxsize=8)
def _spread_fraction_list(count: int) -> list[float]:
    return [float(f) for f in _spread_fractions(count)]


@functools.lru_cache(maxsize=8)
def _spread_fractions(count: int) -> FloatArray:
    """`count` + 1 points of the van der Corput sequence (then 0 and 1) at least 1/72 apart."""
    chosen: list[float] = []
    for v in _van_der_corput(4 * count + 8).tolist():
        if all(abs(v - c) > 1.0 / 72.0 for c in chosen):
            chosen.append(v)
        if len(chosen) > count:
            break
    out = np.array(chosen)
    out.setflags(write=False)
    return out


def _van_der_corput(n: int) -> FloatArray:
    """The first n points of the base-2 van der Corput sequence, 1 (the range's end) replaced by
    its turn: ½, ¼, ¾, ⅛, ⅝, ⅜, ⅞, … (0 and 1 come last: the limits themselves)."""
    out = []
    for k in range(1, n + 1):
        x, f, m = 0.0, 0.5, k
        while m:
            x += f * (m & 1)
            m >>= 1
            f *= 0.5
        out.append(x)
    return np.array(out + [0.0, 1.0])


__all__ = [
    "ANGLE_TOLERANCE",
    "DEFAULT_HELD_SAMPLES",
    "DISTANCE_TOLERANCE",
    "ExportedFamily",
    "Nearest",
    "NearestBatch",
    "ClosedFormBatchResult",
    "ClosedFormFamily",
    "ClosedFormResult",
    "export_family",
    "family_of",
    "held_order",
    "import_family",
    "nearest",
    "nearest_batch",
    "pose_errors",
    "no_closed_form_reason",
    "solve_all",
    "solve_all_batch",
]
