"""A detected closed-form structure applied to one chain: candidates and their FK check.

`ChainSolver` holds everything precomputed for a chain (geometry, prepared family solvers, limits, and
for a 7R arm the geometry of the 6R arm left at each value of the held joint). `solve_branches` /
`solve_arrays` solve many targets (lanes) at once; `scalar_candidates` / `solve_single` one
target on floats. Every candidate is checked by forward kinematics against the target; candidates
within `REFINE_BELOW` are first refined by Gauss–Newton steps (this restores full precision near
singularities and on URDFs whose axes meet only to within the tolerances).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TypeVar

import numpy as np
from scipy.linalg.lapack import dposv

from ...model import TWO_PI, KinematicChain
from .general_6r import (
    Arm,
    MovedFirst,
    shifted_base,
    solve_general_6r,
    solve_general_6r_shifted,
    solve_one_rows,
    solve_one_shifted,
)
from .geometry import (
    INV_TWO_PI,
    BoolArray,
    Candidate,
    FloatArray,
    Geometry,
    IntArray,
    LaneGeometry,
    Mat,
    Rows,
    Stages,
    Trace,
    Vec,
    axis_lines,
    chord_angle,
    exp_rotation,
    insert_held,
    inverse_transforms,
    perpendicular,
    perpendicular_lanes,
    pose_errors,
    pose_errors_list,
    rotate,
    rotate_about,
    scalar_lane,
    tile_lanes,
    transform_points,
    wrap_angle,
    wrap_angles,
)
from .solution_set import (
    JointLimits,
    duplicate_branches,
    empty_reason,
    empty_set_reason,
    equivalents_within_limits,
    equivalents_within_limits_two,
    expand_sorted,
    order_within_targets,
    same_solution,
    seen_before,
)
from .spherical_wrist import Spherical, solve_spherical
from .structure import CASE_LABEL, ClosedFormFamily, Structure, lane_geometry
from .three_parallel import (
    ThreeParallel,
    solve_three_parallel,
    solve_three_parallel_prepared,
)

#: Candidates closer than this to the target (position [m] or rotation [rad]) are refined ...
REFINE_BELOW = 1e-2


#: ... unless already within this (× the arm's scale for positions). Exact arithmetic gives
#: ~1e-15; near a singularity the subproblems lose digits in a square root (SP2's γ when the
#: middle point nearly lies in the plane of the two axes), which one Newton step restores.
_REFINE_ABOVE = 1e-12


#: A candidate that refinement moved by more than this [rad] in some joint may have been the
#: middle of two solutions that nearly coincide (a near-double root, which rounding turns into
#: a complex pair of roots and the elimination then gives once, half-way): its twin lies near
#: the mirror image 2 c − s of the refined solution s in the candidate c, which is refined too
#: (`solve_single`, `solve_arrays`). Roots found to round-off move ~1e-10 rad at most.
REFLECT_ABOVE = 1e-6

#: `nearest` (`ik`, which returns one solution) refines only above this: real URDFs whose axes
#: meet to ~1e-13 leave every candidate of some arms a few 1e-13 off (Kinova j2s6s200: 2 in 3
#: targets), and a refinement (~40 µs) to 1e-16 there buys nothing against the 1e-9 guaranteed.
NEAREST_REFINE_ABOVE = 1e-10

#: A family's single-target solver with the constants of one geometry prepared.
Prepared = ThreeParallel | Spherical


def _solve_6r(
    st: Structure,
    g: LaneGeometry | None,
    R: FloatArray,
    p: FloatArray,
    dflt: FloatArray,
    trace: Trace,
    prepared: Prepared | Arm | None = None,
) -> tuple[FloatArray, BoolArray]:
    """All (≤ 8, or ≤ 16 for the general 6R) solutions of e₁ ⋯ e₆ = G = (R, p) for L lanes:
    Q (L, B, 6) and ok (L, B).

    `dflt` (L, 6) gives the value of an angle that the target leaves free (singular poses).
    `prepared`: the constants of a geometry g that is the same for every lane (three-parallel,
    spherical-wrist, or the general 6R's arm coefficients).
    """
    if st.kind == "general_6r":
        arm = prepared if isinstance(prepared, Arm) else None
        if g is None:  # (the arm alone: `held_general`)
            assert arm is not None and not st.case
            return solve_general_6r(arm, R, p, trace)
        return solve_general_6r_shifted(g.w, g.r, arm, R, p, g.scale, trace, int(st.case or 0))
    if isinstance(prepared, ThreeParallel):
        return solve_three_parallel_prepared(prepared, R, p, dflt, trace)
    assert g is not None
    if st.kind == "three_parallel":
        return solve_three_parallel(g, R, p, dflt, trace)
    return solve_spherical(
        st.case, g, R, p, dflt, trace, prepared if isinstance(prepared, Spherical) else None
    )


class ChainSolver(JointLimits):
    """The detected structure of one chain and everything precomputed for it (immutable)."""

    def __init__(
        self,
        chain: KinematicChain,
        structure: Structure,
        held: int | None,
    ) -> None:
        super().__init__(chain)
        self.structure = structure
        self.held = held
        w, r = axis_lines(np.asarray(chain.S))
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
        self.geometry = (
            lane_geometry(structure, w[None], r[None], self.scale) if held is None else None
        )
        self.scalar_geometry = None if self.geometry is None else scalar_lane(self.geometry, 0)
        # The general 6R solver's precomputed arm (`general_6r.Arm`), for a 6R arm.
        self.general = (
            Arm(self.geometry.w, self.geometry.r, self.scale)
            if self.geometry is not None and structure.kind == "general_6r" and not structure.case
            else None
        )
        # For a 6R arm whose loop is read from another joint: the joints that the target does
        # not move, prepared once for the arm built per target (`general_6r.shifted_base`).
        self.general_base = (
            shifted_base(self.geometry.w, self.geometry.r, self.scale, int(structure.case))
            if self.geometry is not None and structure.kind == "general_6r" and structure.case
            else None
        )
        # ... and read from joint 5 or 6: one target's right-hand side on that arm as it stands
        self.general_moved = (
            MovedFirst(self.general_base, int(structure.case))
            if self.general_base is not None and int(structure.case) >= 4
            else None
        )
        # The three-parallel solver with its constants prepared, for one target of a 6R arm.
        self.three_parallel = (
            ThreeParallel(self.scalar_geometry)
            if self.scalar_geometry is not None and structure.kind == "three_parallel"
            else None
        )
        # The spherical-wrist solver with its constants prepared, for one target of a 6R arm.
        self.spherical = (
            Spherical(structure.case, self.scalar_geometry)
            if self.scalar_geometry is not None and structure.kind == "spherical_wrist"
            else None
        )
        self.info = self.family()
        self.held_moves = None if held is None else self._held_moves()
        # A 7R arm, per value of the held joint: (geometry, its prepared spherical-wrist solver or
        # None, the rows of M⁻¹ E⁻¹); see `held_prepared`. A plain dict (a lost race only
        # recomputes an entry), emptied when full.
        self._held_cache: dict[float, tuple[Geometry, Prepared, Rows]] = {}
        # A 7R arm held for the general 6R solver: its one-lane Arm per held value (`held_general`),
        # and how long its chunks of held values take against their estimate (a running mean,
        # `closed_form.api._nearest_in_chunks`).
        self._general_cache: dict[float, Arm] = {}
        self._stacked_cache: dict[bytes, Arm] = {}  # the stacks, per tuple of values
        # (a loop read shifted: per value the axes and the prepared arm, `held_shifted`)
        self._shifted_cache: dict[float, tuple[FloatArray, FloatArray, Arm]] = {}
        self._shifted_stacks: dict[bytes, tuple[FloatArray, FloatArray, Arm]] = {}
        self.chunk_speed = 1.0
        self._held_static = self.held_moves is not None and not any(
            any(flags) for flags in self.held_moves.values()
        )
        model = chain.solver_model  # the generated scalar FK, where joints are the internal ones
        self.kernel = model.kernel
        self.fk_pose = model.kernel.fk_pose if model.to_internal is None else None
        self.fk_world = model.kernel.fk_world if model.to_internal is None else None
        # How far the family's candidates of a 6R arm miss their targets at ordinary poses
        # (`_family_defect`): 0 where the axes have the structure to round-off.
        self.defect = (
            self._family_defect()
            if held is None and structure.kind in ("three_parallel", "spherical_wrist")
            else 0.0
        )

    def _family_defect(self) -> float:
        """The largest error (position / scale, or rotation [rad]) of the candidate nearest the
        configuration, over 16 random configurations within the limits: ~1e-15 for an arm whose
        axes have the family's structure exactly; for one that has it only to rounding (the
        Puma 560 of rtbdata: wrist axes that meet to ~1e-10 m) every candidate is off by about
        the geometry's own error (there 2e-10 m), which `refine_floor` then leaves unrefined."""
        rng = np.random.default_rng(5)
        lo = np.where(np.isfinite(self.lower_arr), self.lower_arr, -math.pi)
        hi = np.where(np.isfinite(self.upper_arr), self.upper_arr, math.pi)
        worst = 0.0
        for q in rng.uniform(lo, hi, size=(16, self.chain.dof)):
            T = self.chain.fk(q).tolist()
            cands, _ = scalar_candidates(self, T, self.default_seed_list, None)
            if not cands:
                continue
            Q = np.array([c for c, _ in cands])
            near = int(np.abs(wrap_angles(Q - q)).max(axis=1).argmin())
            ep, er = fk_errors(self, cands[near][0], T)
            worst = max(worst, ep / self.scale, er)
        return worst

    def refine_floor(self, tol: float) -> float:
        """`solve_single` and `solve_arrays` refine a candidate whose error (position / scale,
        rotation [rad]) exceeds this: `_REFINE_ABOVE`, or on an arm in its family only to
        rounding, twice its `defect` up to half the tolerance. Such an arm's candidates are all
        off by about the defect, and refining each (a Gauss–Newton step and an FK check: ~15 µs)
        doubled `ik_all` on the Puma 560 for digits below the tolerance; near a singularity,
        where a subproblem loses digits, the error grows beyond the floor and the candidate is
        refined as before."""
        return max(_REFINE_ABOVE, min(2.0 * self.defect, 0.5 * tol))

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
        self._held_base = scalar_lane(g, 0)
        self._held_base_vec = g  # lane 0 is θ = 0
        return out

    def held_lanes(self, theta: FloatArray) -> tuple[LaneGeometry, FloatArray]:
        """`held_geometry` (K lanes for K values θ), by moving the parts that move with the held
        joint (`_held_moves`) instead of deriving every point again: a few einsums."""
        if self.held_moves is None:
            return self.held_geometry(theta)
        j = self.held
        assert j is not None
        E = exp_rotation(self.w_all[j], self.r_all[j], theta)
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
        x = perpendicular_lanes(h if self.structure.kind == "three_parallel" else w[:, 5])
        s = np.broadcast_to(g0.s[0], (K, 3)).copy()
        g = LaneGeometry(w, r, pt(g0.c[0], m["c"][0]), pt(g0.b[0], m["b"][0]), h, x, s, self.scale)
        return g, E

    def held_general(self, theta: FloatArray) -> tuple[FloatArray, Arm]:
        """E = e^{[S_j]θ} (K, 4, 4) of K held values θ (K,) and the general 6R solver's `Arm` of
        the K lanes (no `LaneGeometry`: that solver reads the arm alone), its lanes kept per
        value: building an Arm costs ~0.1-0.3 ms a lane (its eigenproblem's deflating basis is a
        complex SVD), and `ik_all` sweeps the same 36 values, `ik` the same spread of them after
        the seed's own, on every call. The values not kept are built as one stack; the lanes are
        then stacked in θ's order (`Arm.stack`), and the stack kept too: `ik_all` asks for the
        same 36 values every call (stacking them costs ~0.4 ms)."""
        j = self.held
        assert j is not None

        def lanes(values: FloatArray) -> list[Arm]:
            g, _ = self.held_lanes(values)
            built = Arm(g.w, g.r, self.scale, fit=False)
            return [built.lane(k) for k in range(len(values))] if len(values) > 1 else [built]

        def stack(values: list[float]) -> Arm:
            return Arm.stack(_kept_per_value(self._general_cache, values, lanes))

        E = exp_rotation(self.w_all[j], self.r_all[j], theta)
        return E, _kept_per_tuple(self._stacked_cache, theta, stack)

    def held_shifted(
        self, theta: FloatArray
    ) -> tuple[FloatArray, tuple[FloatArray, FloatArray, Arm]]:
        """`held_general` for an arm whose loop is read from another joint (`Structure.case`):
        E (K, 4, 4) and the K values' 6R axes w, r (K, 6, 3) with their prepared arms in the
        loop's order (`shifted_base`, one lane per value, stacked), kept per value and per tuple
        of values. `solve_general_6r_shifted` then solves every lane on its value's arm in one
        stack (a random 7R arm read from joint 6: one value 2.3 → ~1.8 ms with its arm built per
        call before; `ik_all`'s 36 values as one stack, not one solve per value)."""
        j = self.held
        assert j is not None
        shift = int(self.structure.case or 0)

        def lanes(values: FloatArray) -> list[tuple[FloatArray, FloatArray, Arm]]:
            g, _ = self.held_lanes(values)
            w, r = g.w[:, None], g.r[:, None]  # (K, 1, 6, 3): one lane per value
            return [
                (w[k], r[k], shifted_base(w[k], r[k], self.scale, shift)) for k in range(len(w))
            ]

        def stack(values: list[float]) -> tuple[FloatArray, FloatArray, Arm]:
            parts = _kept_per_value(self._shifted_cache, values, lanes)
            return (
                np.concatenate([w for w, _, _ in parts]),
                np.concatenate([r for _, r, _ in parts]),
                Arm.stack([a for _, _, a in parts]),
            )

        E = exp_rotation(self.w_all[j], self.r_all[j], theta)
        return E, _kept_per_tuple(self._shifted_stacks, theta, stack)

    def held_scalar_geometry(self, theta: float) -> tuple[Geometry, list[list[float]]]:
        """`held_geometry` of one value θ as the scalar solvers' geometry, and E⁻¹ (4 × 4 lists),
        by moving the parts that move with the held joint (see `_held_moves`)."""
        j = self.held
        assert j is not None and self.held_moves is not None
        k = (float(self.w_all[j, 0]), float(self.w_all[j, 1]), float(self.w_all[j, 2]))
        o = (float(self.r_all[j, 0]), float(self.r_all[j, 1]), float(self.r_all[j, 2]))
        m, g0 = self.held_moves, self._held_base

        def d(v: Vec, move: bool) -> Vec:
            return rotate(k, theta, v) if move else v

        def pt(v: Vec, move: bool) -> Vec:
            return rotate_about(k, o, theta, v) if move else v

        w = [d(v, f) for v, f in zip(g0.w, m["w"], strict=True)]
        r = [pt(v, f) for v, f in zip(g0.r, m["r"], strict=True)]
        h = d(g0.h, m["h"][0])
        x = perpendicular(h if self.structure.kind == "three_parallel" else w[5])
        g = Geometry(w, r, pt(g0.c, m["c"][0]), pt(g0.b, m["b"][0]), h, x, g0.s, self.scale)
        return g, self._held_inverse(theta)

    def _held_inverse(self, theta: float) -> list[list[float]]:
        """E⁻¹ = e^{−[S_j]θ} of the held joint j (4 × 4 lists): columns R(k, −θ) eᵢ, translation
        o − R o."""
        j = self.held
        assert j is not None
        k = (float(self.w_all[j, 0]), float(self.w_all[j, 1]), float(self.w_all[j, 2]))
        o = (float(self.r_all[j, 0]), float(self.r_all[j, 1]), float(self.r_all[j, 2]))
        cols = [rotate(k, -theta, e) for e in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))]
        Ro = rotate(k, -theta, o)
        E_inv = [[cols[0][i], cols[1][i], cols[2][i], o[i] - Ro[i]] for i in range(3)]
        E_inv.append([0.0, 0.0, 0.0, 1.0])
        return E_inv

    def held_prepared(self, theta: float) -> tuple[Geometry, Prepared, Rows]:
        """For the held joint at θ: the scalar geometry, its prepared family solver and the rows of M⁻¹ E⁻¹ (so G = T M⁻¹ E⁻¹), kept per θ:
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
        prep = self._held_static_solver if self._held_static else self._prepare(g)
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
    def _held_static_solver(self) -> Prepared:
        """The prepared solver of a held geometry that does not move with the held joint."""
        return self._prepare(self._held_base)

    def _prepare(self, g: Geometry) -> Prepared:
        """The family's single-target solver with the constants of geometry g prepared."""
        if self.structure.kind == "three_parallel":
            return ThreeParallel(g)
        return Spherical(self.structure.case, g)

    # -- per-call geometry for a 7R arm with the held joint at values θ (K,)
    def held_geometry(self, theta: FloatArray) -> tuple[LaneGeometry, FloatArray]:
        """Lane geometry of the 6R arm left when joint `held` is at θ, and E = e^{[S_j]θ} (K, 4, 4)."""
        j = self.held
        assert j is not None
        E = exp_rotation(self.w_all[j], self.r_all[j], theta)
        K = theta.shape[0]
        w = np.broadcast_to(self.w_all, (K,) + self.w_all.shape).copy()
        r = np.broadcast_to(self.r_all, (K,) + self.r_all.shape).copy()
        w[:, j + 1 :] = np.einsum("kij,kmj->kmi", E[:, :3, :3], w[:, j + 1 :])
        r[:, j + 1 :] = transform_points(E, r[:, j + 1 :])
        keep = self.keep
        return lane_geometry(self.structure, w[:, keep], r[:, keep], self.scale), E

    def family(self) -> ClosedFormFamily:
        st = self.structure
        kind = st.kind if self.held is None else f"7r_{st.kind}"
        names = self.chain.joint_names
        idx = [i + 1 for i in self.keep]
        if st.reversed:
            idx = idx[::-1]
        if st.kind == "general_6r":
            desc = (
                f"joints {', '.join(map(str, sorted(idx)))} in no named family: every solution "
                "from one eigenvalue problem (Raghavan–Roth)"
            )
        elif st.kind == "three_parallel":
            desc = (
                f"joints {idx[1]}, {idx[2]}, {idx[3]} parallel; joints {idx[4]} and {idx[5]} meet"
            )
        else:
            rel = CASE_LABEL[st.case]
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
        return ClosedFormFamily(kind, held, st.reversed, CASE_LABEL.get(st.case, ""), desc)


def _refine(
    chain: KinematicChain, Q: FloatArray, T_t: FloatArray, frozen: int | None, steps: int = 2
) -> FloatArray:
    """Gauss–Newton steps J_world Δq = (ω_err, p_t − p) toward T_t, with ω_err the rotation vector of
    R_t Rᵀ to first order, vee((A − Aᵀ)/2) (damped so a singular J stays solvable: `_damped`)."""
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
        y = np.linalg.solve(_damped(Jc @ Jc.swapaxes(1, 2)), e[..., None])
        dq = (Jc.swapaxes(1, 2) @ y)[..., 0]
        Q = Q.copy()
        Q[:, cols] += dq
    return Q


def _batch_fk_errors(
    solver: ChainSolver, Q: FloatArray, T_t: FloatArray
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


#: Candidates up to this many are checked by the scalar FK, one by one (~5 µs each), not by the
#: batched kernel (~100 µs however few): `ik` sweeping a 7R arm's held joint checks a few
#: candidates of one target per chunk of held values.
SCALAR_FK_CHECK = 16


def fk_check(
    solver: ChainSolver,
    Q: FloatArray,
    T_t: FloatArray,
    fix: Callable[[FloatArray], FloatArray],
    floor: float = _REFINE_ABOVE,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Candidates Q (k, n) checked against their targets T_t (k, 4, 4) by forward kinematics:
    near misses (off by more than `floor`: position / scale, rotation [rad]; `refine_floor`)
    refined (kept only where that helps; `fix` maps refined rows back into the candidates'
    range), and the position [m] and rotation [rad] errors."""
    chain = solver.chain
    Q = Q.copy()
    if Q.shape[0] <= SCALAR_FK_CHECK and solver.fk_pose is not None:  # (`SCALAR_FK_CHECK`)
        errors = [fk_errors(solver, q, t) for q, t in zip(Q.tolist(), T_t.tolist(), strict=True)]
        ep, er = np.array(errors).reshape(-1, 2).T.copy()
    else:
        ep, er = _batch_fk_errors(solver, Q, T_t)
    redo = (
        ((ep > floor * solver.scale) | (er > floor))
        & (ep < REFINE_BELOW * solver.scale)
        & (er < REFINE_BELOW)
    )
    # Gauss–Newton on the near misses, the best of each kept where it helps; those still off (near
    # a singularity, where the steps converge slowly and not monotonically) go on one step a round
    sel, steps = np.flatnonzero(redo), 2
    cur = Q[sel]
    for _ in range(MAX_REFINE_ROUNDS):
        if not sel.size:
            break
        cur = fix(_refine(chain, cur, T_t[sel], solver.held, steps))
        ep_r, er_r = pose_errors(chain.fk(cur), T_t[sel])
        better = np.maximum(ep_r / solver.scale, er_r) < np.maximum(ep[sel] / solver.scale, er[sel])
        b = sel[better]
        Q[b], ep[b], er[b] = cur[better], ep_r[better], er_r[better]
        go = ((ep[sel] > floor * solver.scale) | (er[sel] > floor)) & (
            (ep_r < REFINE_BELOW * solver.scale) & (er_r < REFINE_BELOW)
        )
        sel, cur, steps = sel[go], cur[go], 1
    return Q, ep, er


@dataclass
class _Outcome:
    """Internal result of `solve_arrays` (CSR layout, like ClosedFormBatchResult)."""

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


def solve_branches(
    solver: ChainSolver, T: FloatArray, seeds: FloatArray, held: FloatArray | None
) -> tuple[FloatArray, BoolArray, IntArray, FloatArray | None, Trace]:
    """The 8 branches of every lane, unchecked: Q (L, 8, n) with angles in (−π, π], ok (L, 8) where
    every subproblem had a solution, the target of each lane, the held value of each lane (None
    for a 6R arm), and the trace. A 6R arm has one lane per target; a 7R arm one per (target,
    held value): `held` (K,) values for every target or (N, K) per target, lane i·K + k."""
    st = solver.structure
    N = T.shape[0]
    general_arm: Arm | None = None
    shifted: tuple[FloatArray, FloatArray, Arm] | None = None
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
        if held.ndim == 2 and N == 1:  # one target's values: as shared ones (kept Arms)
            held = held[0]
        if held.ndim == 1 and st.kind == "general_6r" and not st.case:
            # shared values of an arm read by the general solver alone: its K lanes' arms, tiled
            EK, armK = solver.held_general(held)
            general_arm, g = armK.tile(N), None
            E = np.tile(EK, (N, 1, 1))
            held_lane = np.tile(held, N)
        elif held.ndim == 1 and st.kind == "general_6r":  # the same, its loop read shifted
            EK, shifted = solver.held_shifted(held)
            g = None
            E = np.tile(EK, (N, 1, 1))
            held_lane = np.tile(held, N)
        elif held.ndim == 1:  # shared values: the geometry of K lanes, tiled over the targets
            gK, EK = solver.held_lanes(held)
            g = tile_lanes(gK, N)
            E = np.tile(EK, (N, 1, 1))
            held_lane = np.tile(held, N)
        else:
            held_lane = held.reshape(-1)
            g, E = solver.held_lanes(held_lane)
        # G = T M⁻¹ e^{−[S_j]θ}: the 6R arm left has home pose e^{[S_j]θ} M.
        G = T[owner_lane] @ solver.M_inv @ inverse_transforms(E)
    dflt = seeds[owner_lane][:, solver.keep]
    if st.reversed:
        G = inverse_transforms(G)
        dflt = -dflt[:, ::-1]
    trace = Trace()
    prepared: Prepared | Arm | None = general_arm
    if solver.held is None:
        prepared = (
            solver.three_parallel or solver.spherical or solver.general or solver.general_base
        )
    elif solver._held_static and st.kind == "spherical_wrist":  # every lane has the same geometry
        prepared = solver._held_static_solver
    if shifted is not None:  # each lane on its held value's prepared arm, tiled over targets
        w6, r6, base = shifted
        if N > 1:
            w6, r6, base = np.tile(w6, (N, 1, 1)), np.tile(r6, (N, 1, 1)), base.tile(N)
        shift = int(st.case or 0)
        R6, p6 = G[:, :3, :3], G[:, :3, 3]
        Q6, ok = solve_general_6r_shifted(w6, r6, base, R6, p6, solver.scale, trace, shift)
    else:
        Q6, ok = _solve_6r(st, g, G[:, :3, :3], G[:, :3, 3], dflt, trace, prepared)
    if st.reversed:
        Q6 = -Q6[..., ::-1]
    if held_lane is not None:
        assert solver.held is not None
        Q = insert_held(Q6, solver.held, held_lane)
    else:
        Q = Q6
    return wrap_angles(Q), ok, owner_lane, held_lane, trace


#: Lanes (targets × held values) per pass of `solve_arrays`: its working arrays then stay in the
#: CPU caches. `ik_all_batch` of 20,480 UR5 targets, targets/s in three runs on a busy machine:
#: ±π limits 39–70k in one pass, 58–79k in passes of 2048 (4096: 59–81k, 512: 51–67k); ±2π limits
#: (230 solutions per target) 3.9–5.0k in one pass, 6.6–7.2k in passes of 2048.
SOLVE_CHUNK = 2048


def solve_arrays(
    solver: ChainSolver,
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
    solver: ChainSolver,
    T: FloatArray,
    seeds: FloatArray,
    held: FloatArray | None,
    tol: float,
    use_limits: bool,
) -> _Outcome:
    """`solve_arrays` in one pass."""
    chain = solver.chain
    n = chain.dof
    N = T.shape[0]
    Q, ok, owner_lane, held_lane, trace = solve_branches(solver, T, seeds, held)
    L = Q.shape[0]
    B = Q.shape[1]  # branches per lane: 8 for the named families, 16 for the general 6R
    free = np.zeros((L, B), dtype=bool)
    free_codes = np.full((L, B), -1)
    for code, (_, f) in enumerate(trace.frees):
        free_codes = np.where(f & (free_codes < 0), code, free_codes)
        free |= f
    # Forward-kinematics check (refining near misses) on branches that passed every subproblem.
    flat_Q = Q.reshape(L * B, n)
    flat_owner = np.repeat(owner_lane, B)
    idx = np.flatnonzero(ok.reshape(-1))
    acc = np.zeros(L * B, dtype=bool)
    if idx.size:
        floor = solver.refine_floor(tol)
        Qc, ep, er = fk_check(solver, flat_Q[idx], T[flat_owner[idx]], wrap_angles, floor)
        acc[idx] = (ep <= tol) & (er <= tol)
        # the mirror images of candidates that refinement moved far (`REFLECT_ABOVE`), in free
        # slots of their lanes, checked and refined too
        moved = np.abs(wrap_angles(Qc - flat_Q[idx])).max(axis=1) > REFLECT_ABOVE
        mirrors = wrap_angles(2.0 * flat_Q[idx] - Qc)
        flat_Q[idx] = Qc
        free_slots = ~ok
        slots, images = [], []
        for f, m in zip(idx[moved & acc[idx]].tolist(), mirrors[moved & acc[idx]], strict=True):
            lane = f // B
            unused = np.flatnonzero(free_slots[lane])
            if unused.size:
                free_slots[lane, unused[0]] = False
                slots.append(lane * B + int(unused[0]))
                images.append(m)
                free_codes.reshape(-1)[slots[-1]] = free_codes.reshape(-1)[f]
        if slots:
            g = np.array(slots)
            Qm, ep, er = fk_check(solver, np.array(images), T[flat_owner[g]], wrap_angles, floor)
            flat_Q[g] = Qm
            acc[g] = (ep <= tol) & (er <= tol)
            for f in slots:  # a mirror image counts where it found another solution
                lane = slice(f - f % B, f - f % B + B)
                others = flat_Q[lane][acc[lane] & (np.arange(B) != f % B)]
                d = np.abs(wrap_angles(others - flat_Q[f])).max(axis=1, initial=0.0)
                acc[f] &= not bool((d <= REFLECT_ABOVE).any())
    acc2 = acc.reshape(L, B)
    # One solution once: drop a branch equal (mod 2π) to an earlier accepted one of the same lane.
    acc2 &= ~duplicate_branches(flat_Q.reshape(L, B, n), acc2)
    lane_count = acc2.sum(axis=1)
    keep = np.flatnonzero(acc2.reshape(-1))
    Qk, owner = flat_Q[keep], flat_owner[keep]
    sing_code = free_codes.reshape(-1)[keep]
    n_before = np.bincount(owner, minlength=N)
    if use_limits:
        two = (
            equivalents_within_limits_two(solver, Qk, owner, sing_code)
            if solver.all_finite
            else None
        )
        if two is None:
            two = equivalents_within_limits(chain, Qk, owner, sing_code, seeds)
        Qk, owner, sing_code = two
    # Sort by target, then by distance to that target's seed.
    count = np.bincount(owner, minlength=N).astype(np.int64)
    offsets = np.zeros(N + 1, dtype=np.int64)
    np.cumsum(count, out=offsets[1:])
    order = order_within_targets(Qk, owner, seeds, count, offsets)
    Qk, owner, sing_code = Qk.take(order, 0), owner.take(order), sing_code.take(order)
    singular = np.zeros(N, dtype=bool)
    singular[owner[sing_code >= 0]] = True
    # Reasons, for targets without a solution: the first stage at which every branch failed.
    reasons = [""] * N
    empty = np.flatnonzero(count == 0)
    if empty.size:
        ok_so_far = np.ones((L, B), dtype=bool)
        stage_dead: list[tuple[str, BoolArray]] = []
        for name, f in trace.fails:
            ok_so_far = ok_so_far & f
            alive = np.zeros(N, dtype=bool)
            alive[owner_lane[ok_so_far.any(axis=1)]] = True
            stage_dead.append((name, ~alive))
        for i in empty:
            reasons[i] = empty_set_reason(stage_dead, int(i), int(n_before[i]), held is not None)
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


_STAGE_ORDER = {
    "general_6r": ("reach",),
    "three_parallel": ("shoulder", "wrist", "elbow"),
    "int12": ("elbow", "shoulder", "wrist"),
    "par23": ("shoulder", "elbow", "wrist"),
    "int23": ("shoulder", "elbow", "wrist"),
    "par12": ("shoulder", "elbow", "wrist"),
}


def scalar_candidates(
    solver: ChainSolver,
    T: list[list[float]],
    seed: list[float],
    held_value: float | None,
    polish: bool = True,
) -> tuple[list[Candidate], Stages]:
    """The (≤ 8) candidate solutions of one target by the scalar solvers: full configurations with
    angles in (−π, π] (a 7R arm's held joint at `held_value`), unchecked, with the reasons of the
    angles the target left free (taken from `seed`), and the stages the branches passed. Without
    `polish`, the general 6R solver's roots skip their Gauss–Newton polish (`solve_one_rows`)."""
    st = solver.structure
    if st.kind == "general_6r":
        return _general_candidates(solver, T, seed, held_value, polish)
    if held_value is None and not st.reversed and solver.three_parallel is not None:
        R, p = _times_inverse_home(T, solver.M_inv_rows)
        stages = Stages(_STAGE_ORDER["three_parallel"])
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
        prep: Prepared | None
        if held_value is None:
            g, prep = solver.scalar_geometry, solver.spherical
            assert g is not None
            R, p = _times_inverse_home(T, solver.M_inv_rows)
            d = seed
        else:
            g, prep, K = solver.held_prepared(held_value)
            R, p = _times_inverse_home(T, K)
            d = [seed[i] for i in solver.keep]
        if st.reversed:  # G⁻¹
            R, p = _inverse_rp(R, p)
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
        g = scalar_lane(gv, 0)
        G = Ta @ solver.M_inv @ inverse_transforms(E)[0]
        d = [seed[i] for i in solver.keep]
    if st.reversed:  # the structure read from the tip: G⁻¹ = e^{−[S₆]q₆} ⋯ e^{−[S₁]q₁}
        G = inverse_transforms(G[None])[0]
        d = [-x for x in reversed(d)]
    return _candidates_of(solver, g, G.tolist(), d, held_value)


def _general_candidates(
    solver: ChainSolver,
    T: list[list[float]],
    seed: list[float],
    held_value: float | None,
    polish: bool = True,
) -> tuple[list[Candidate], Stages]:
    """`scalar_candidates` of the general 6R solver: its one-target form (`solve_one_rows`) for
    a 6R arm read from the base, else its vectorised form on one lane."""
    stages = Stages(_STAGE_ORDER["general_6r"])
    if held_value is None:
        Q1 = general_solutions(solver, T, polish)
        if Q1 is not None:
            rows = wrap_angles(Q1).tolist()
            stages.passed["reach"] = len(rows)
            return [(q, ()) for q in rows], stages
    held = None if held_value is None else np.array([held_value])
    Q, ok, _, _, _ = solve_branches(solver, np.array([T]), np.array([seed]), held)
    rows = Q[0][ok[0]].tolist()
    stages.passed["reach"] = len(rows)
    return [(q, ()) for q in rows], stages


def general_solutions(
    solver: ChainSolver, T: list[list[float]], polish: bool = True
) -> FloatArray | None:
    """The general 6R solver's solutions (k, 6) of one target T (rows) of a 6R arm, by its
    one-target form (`solve_one_rows`), angles not wrapped; None where that form does not
    decide (or the arm is not a 6R arm of that family): then `scalar_candidates` does."""
    arm, base = solver.general, solver.general_base
    if arm is not None and arm.K is None:
        return None
    if arm is None and base is None:
        return None
    R, p = _times_inverse_home(T, solver.M_inv_rows)
    if solver.structure.reversed:  # G⁻¹ = e^{−[S₆]q₆} ⋯ e^{−[S₁]q₁}
        R, p = _inverse_rp(R, p)
    if arm is not None:
        Q1 = solve_one_rows(arm, R, p, polish)
    elif solver.general_moved is not None:  # the loop read from joint 5 or 6
        Q1 = solver.general_moved.solve(R, p, polish)
    else:  # the loop read from joint 2-4: its arm built per target on the prepared part
        assert base is not None and solver.geometry is not None
        g = solver.geometry
        Q1 = solve_one_shifted(base, g.w, g.r, int(solver.structure.case or 0), R, p, polish)
    if Q1 is None or not solver.structure.reversed:
        return Q1
    return -Q1[:, ::-1]


def _times_inverse_home(T: list[list[float]], Mi: list[list[float]]) -> tuple[Mat, Vec]:
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


def _inverse_rp(R: Mat, p: Vec) -> tuple[Mat, Vec]:
    """The inverse (Rᵀ, −Rᵀp) of the rigid transform (R, p), written out (scalar path)."""
    (a0, a1, a2), (b0, b1, b2), (c0, c1, c2) = R
    return ((a0, b0, c0), (a1, b1, c1), (a2, b2, c2)), (
        -(a0 * p[0] + b0 * p[1] + c0 * p[2]),
        -(a1 * p[0] + b1 * p[1] + c1 * p[2]),
        -(a2 * p[0] + b2 * p[1] + c2 * p[2]),
    )


def _candidates_of(
    solver: ChainSolver,
    g: Geometry,
    Gl: list[list[float]],
    d: list[float],
    held_value: float | None,
) -> tuple[list[Candidate], Stages]:
    """`scalar_candidates` once the 6R problem is set: geometry g, the pose G (rows) the six
    joints must produce from their home, the default angles d."""
    R: Mat = (
        (Gl[0][0], Gl[0][1], Gl[0][2]), (Gl[1][0], Gl[1][1], Gl[1][2]), (Gl[2][0], Gl[2][1], Gl[2][2])
    )  # fmt: skip
    p: Vec = (Gl[0][3], Gl[1][3], Gl[2][3])
    prep = (solver.three_parallel or solver.spherical) if held_value is None else None
    return _candidates_rp(solver, g, prep, R, p, d, held_value)


def _candidates_rp(
    solver: ChainSolver,
    g: Geometry,
    prep: Prepared | None,
    R: Mat,
    p: Vec,
    d: list[float],
    held_value: float | None,
) -> tuple[list[Candidate], Stages]:
    """`_candidates_of` given G as rotation rows R and translation p, and the prepared family
    solver of g (None: prepared here)."""
    st = solver.structure
    case = st.kind if st.kind == "three_parallel" else st.case
    stages = Stages(_STAGE_ORDER[case])
    if st.kind == "three_parallel" and held_value is None and solver.three_parallel is not None:
        raw = solver.three_parallel.solve(R, p, d, stages)  # g is solver.scalar_geometry
        if not st.reversed:
            return raw, stages  # angles already in (−π, π]
    else:
        raw = (prep or solver._prepare(g)).solve(R, p, d, stages)
    out: list[Candidate] = []
    for q6, why in raw:
        q = [-x for x in reversed(q6)] if st.reversed else q6
        q = [  # into (−π, π] (most angles already are: tested first, for speed)
            x if -math.pi < x <= math.pi else x - TWO_PI * math.ceil((x - math.pi) * INV_TWO_PI)
            for x in q
        ]
        if held_value is not None:
            q.insert(solver.held or 0, held_value)
        out.append((q, why))
    return out, stages


def solve_single(
    solver: ChainSolver, T: list[list[float]], seed: list[float], tol: float
) -> tuple[FloatArray, tuple[float, float], str, str]:
    """One target of a 6R arm with the scalar twin of the solvers (`ThreeParallel`, `Spherical`).

    Same steps as `solve_arrays`: candidates, FK check (refining near misses), duplicates out,
    whole-turn equivalents within the limits, sorted by distance to the seed.

    Returns:
        solutions (k, n), the (position, rotation) error of the first, the singular reasons ("" if
        regular), why the set is empty ("" if not).
    """
    chain = solver.chain
    cands, stages = scalar_candidates(solver, T, seed, None)
    fk = solver.fk_pose
    # Candidates exact to round-off (the usual case) are accepted on the squared errors, without
    # the square root and arcsine of `fk_errors`, when that implies the tolerance (hand-written
    # for speed: this loop runs for every candidate of every call).
    quick = fk is not None and tol >= _REFINE_ABOVE * max(solver.scale, 1.0)
    exact_p2, exact_f = solver.exact_p2, solver.exact_f
    floor = solver.refine_floor(tol)
    a0, a1, a2, a3 = T[0]
    b0, b1, b2, b3 = T[1]
    c0, c1, c2, c3 = T[2]
    # (q, position error, rotation error, squared) per candidate: the errors squared (position²,
    # ‖ΔR‖_F²) where `squared`, else [m] and [rad]
    checked: list[tuple[list[float], float, float, bool]] = []
    redo: list[int] = []  # near misses, refined together below
    scale = solver.scale
    for q, _ in cands:  # one scalar FK each: ~3 µs, where a batched FK of 7 costs ~90 µs
        if quick:
            t, _ = fk(q)  # type: ignore[misc]
            dp2 = (t[9] - a3) ** 2 + (t[10] - b3) ** 2 + (t[11] - c3) ** 2
            f = (
                (t[0] - a0) ** 2 + (t[1] - a1) ** 2 + (t[2] - a2) ** 2
                + (t[3] - b0) ** 2 + (t[4] - b1) ** 2 + (t[5] - b2) ** 2
                + (t[6] - c0) ** 2 + (t[7] - c1) ** 2 + (t[8] - c2) ** 2
            )  # fmt: skip
            if dp2 <= exact_p2 and f <= exact_f:
                checked.append((q, dp2, f, True))
                continue
            ep, er = math.sqrt(dp2), chord_angle(f)
        else:
            ep, er = fk_errors(solver, q, T)
        if (ep > floor * scale or er > floor) and ep < REFINE_BELOW * scale and er < REFINE_BELOW:
            redo.append(len(checked))
        checked.append((q, ep, er, False))
    before = {i: checked[i][0] for i in redo}
    _refine_checked(solver, checked, redo, T, floor)
    whys_of = [why for _, why in cands]

    def passes(entry: tuple[list[float], float, float, bool]) -> bool:
        return entry[3] or (entry[1] <= tol and entry[2] <= tol)

    # the mirror images of accepted candidates that refinement moved far (`REFLECT_ABOVE`),
    # refined too, and kept where they found another solution than the others
    mirror = []
    for i, c in before.items():
        sol = checked[i][0]
        if passes(checked[i]) and not same_solution(sol, c, REFLECT_ABOVE):
            m = [wrap_angle(2.0 * b - a) for a, b in zip(sol, c, strict=True)]
            ep, er = fk_errors(solver, m, T)
            if ep < REFINE_BELOW * scale and er < REFINE_BELOW:
                mirror.append(len(checked))
                checked.append((m, ep, er, False))
                whys_of.append(whys_of[i])
    _refine_checked(solver, checked, mirror, T, floor)
    for k in mirror:
        m = checked[k][0]
        if any(passes(c) and same_solution(m, c[0], REFLECT_ABOVE) for c in checked[:k]):
            checked[k] = (m, math.inf, math.inf, False)
    accepted: list[list[float]] = []
    errors: list[tuple[float, float]] = []
    squared: list[bool] = []
    whys: set[str] = set()
    for (q, ep, er, exact), why in zip(checked, whys_of, strict=True):
        if not exact and (ep > tol or er > tol):
            continue
        if seen_before(q, accepted):
            continue
        accepted.append(q)
        errors.append((ep, er))
        squared.append(exact)
        if why:
            whys.update(why)
    none = np.empty((0, chain.dof))
    if not accepted:
        return none, (math.inf, math.inf), "", empty_reason(stages.first_dead(), 0)
    sols, first = expand_sorted(solver, accepted, seed)
    if not sols.shape[0]:
        return none, (math.inf, math.inf), "", empty_reason(None, len(accepted))
    ep, er = errors[first]
    if squared[first]:
        ep, er = math.sqrt(ep), chord_angle(er)
    return sols, (ep, er), "; ".join(sorted(whys)), ""


def _refine_checked(
    solver: ChainSolver,
    checked: list[tuple[list[float], float, float, bool]],
    redo: list[int],
    T: list[list[float]],
    floor: float,
) -> None:
    """Gauss–Newton on the near misses `redo` of `checked` (q, position error, rotation error,
    squared) in place (`solve_single`), stacked (`refine_many`), the best of each kept where it
    helps; those still off (near a singularity: slow, not monotone) go on one step a round."""
    scale = solver.scale
    steps = [steps_for(solver, checked[i][1], checked[i][2]) for i in redo]
    cur = [checked[i][0] for i in redo]
    for _ in range(MAX_REFINE_ROUNDS):
        if not redo:
            break
        refined = refine_many(solver, cur, T, steps)
        again, cur = [], []
        for i, qr in zip(redo, refined, strict=True):
            qr = [wrap_angle(x) for x in qr]
            ep_r, er_r = fk_errors(solver, qr, T)
            _, ep, er, _ = checked[i]
            if max(ep_r / scale, er_r) < max(ep / scale, er):
                checked[i] = (qr, ep_r, er_r, False)
                ep, er = ep_r, er_r
            if (ep > floor * scale or er > floor) and (
                ep_r < REFINE_BELOW * scale and er_r < REFINE_BELOW
            ):
                again.append(i)
                cur.append(qr)
        redo, steps = again, [1] * len(again)


def fk_errors(solver: ChainSolver, q: list[float], T: list[list[float]]) -> tuple[float, float]:
    """`pose_errors_list` of FK(q) against T, from the generated scalar FK's 12 floats (row-major
    R, then p) without building an array (~3 µs instead of ~7)."""
    if solver.fk_pose is None:
        return pose_errors_list(solver.chain.fk(q).tolist(), T)
    t, _ = solver.fk_pose(q)
    a, b, c = T[0], T[1], T[2]
    dp = math.hypot(t[9] - a[3], t[10] - b[3], t[11] - c[3])  # (no overflow for far targets)
    f = (
        (t[0] - a[0]) ** 2 + (t[1] - a[1]) ** 2 + (t[2] - a[2]) ** 2
        + (t[3] - b[0]) ** 2 + (t[4] - b[1]) ** 2 + (t[5] - b[2]) ** 2
        + (t[6] - c[0]) ** 2 + (t[7] - c[1]) ** 2 + (t[8] - c[2]) ** 2
    )  # fmt: skip
    return dp, chord_angle(f)


def _residual(
    t: tuple[float, ...], a: list[float], b: list[float], c: list[float]
) -> tuple[float, float, float, float, float, float]:
    """(ω_err, Δp) of the generated FK's pose t (row-major R, then p) against the target rows
    a, b, c: A = R_t Rᵀ (row i of R_t against row k of R), ω_err = vee((A − Aᵀ)/2) to first
    order, Δp = p_t − p. The right-hand side of `refine_one`'s and `refine_many`'s steps."""
    A = [
        [r[0] * t[3 * k] + r[1] * t[3 * k + 1] + r[2] * t[3 * k + 2] for k in range(3)]
        for r in (a, b, c)
    ]
    return (
        0.5 * (A[2][1] - A[1][2]), 0.5 * (A[0][2] - A[2][0]), 0.5 * (A[1][0] - A[0][1]),
        a[3] - t[9], b[3] - t[10], c[3] - t[11],
    )  # fmt: skip


def refine_one(
    solver: ChainSolver, q: list[float], T: list[list[float]], steps: int = 2
) -> list[float]:
    """`_refine` of one candidate on floats: Gauss–Newton steps J_world Δq = (ω_err, Δp) with the
    generated FK's Jacobian columns and one 6×6 Cholesky solve each (LAPACK's dposv, directly:
    ~10 µs a step, where the batched `_refine` of one row costs ~300 µs: real URDFs whose axes
    meet only to the detection tolerance need it for every candidate). Convergence is quadratic,
    so from a candidate within `ONE_STEP_BELOW` one step is exact to round-off (`steps_for`).
    The held joint of a 7R arm stays fixed."""
    if solver.fk_world is None:
        T_t = np.array(T)[None]
        return _refine(solver.chain, np.array([q]), T_t, solver.held, steps)[0].tolist()
    kept = [i for i in range(len(q)) if i != solver.held]
    q = list(q)
    a, b, c = T[0], T[1], T[2]
    for _ in range(steps):
        t, cols = solver.fk_world(q)
        e = np.array(_residual(t, a, b, c))
        J = np.array([cols[i] for i in kept]).T  # (6, k)
        _, y, info = dposv(_damped(J @ J.T), e)  # positive definite
        if info != 0:
            y = np.linalg.lstsq(J @ J.T, e, rcond=None)[0]
        for i, d in zip(kept, (J.T @ y).tolist(), strict=True):
            q[i] += d
    return q


def refine_until(
    solver: ChainSolver,
    q: list[float],
    T: list[list[float]],
    errors: tuple[float, float],
    floor: float,
    fix: Callable[[list[float]], list[float]],
) -> tuple[list[float], float, float]:
    """`refine_one` of a near miss q with (position, rotation) `errors`, its `steps_for` steps,
    then one step a round while it is still off by more than `floor` (position / scale,
    rotation [rad]) and within `REFINE_BELOW`, at most `MAX_REFINE_ROUNDS` rounds: near a
    singularity Gauss–Newton converges slowly and not monotonically (a candidate 1.4e-7 off went
    to 5e-8, 2e-7, 2e-8, then 1e-12 at its fifth step). `fix` maps a refined q back into the
    candidates' range. Returns the best q met and its errors."""
    ep, er = errors
    steps, cur = steps_for(solver, ep, er), q
    for _ in range(MAX_REFINE_ROUNDS):
        cur = fix(refine_one(solver, cur, T, steps))
        ep_r, er_r = fk_errors(solver, cur, T)
        if max(ep_r / solver.scale, er_r) < max(ep / solver.scale, er):
            q, ep, er = cur, ep_r, er_r
        if ep <= floor * solver.scale and er <= floor:
            break
        if ep_r >= REFINE_BELOW * solver.scale or er_r >= REFINE_BELOW:
            break  # walked off: no longer a near miss
        steps = 1
    return q, ep, er


def refine_many(
    solver: ChainSolver, Q: list[list[float]], T: list[list[float]], steps: list[int]
) -> list[list[float]]:
    """`refine_one` of several candidates of one target, `steps[i]` Gauss–Newton steps for
    candidate i, with the linear solves stacked: one generated-code FK with Jacobian columns per
    candidate and step, and one stacked solve of (J Jᵀ + 1e-12 I) y = e per step. An arm whose
    axes meet only to ~1e-10 (the Puma 560 of rtbdata, detected spherical) leaves all eight
    candidates a few 1e-11 off, and refining them one by one cost most of an `ik_all` call."""
    if len(Q) == 1:
        return [refine_one(solver, Q[0], T, steps[0])]
    if solver.fk_world is None:  # joints other than the kernel's: the batched FK's Jacobian
        out = [list(q) for q in Q]
        for k in range(max(steps)):
            idx = [i for i, s in enumerate(steps) if s > k]
            Qa = _refine(solver.chain, np.array([out[i] for i in idx]), np.array([T] * len(idx)),
                         solver.held, 1).tolist()  # fmt: skip
            for i, q in zip(idx, Qa, strict=True):
                out[i] = q
        return out
    fk_world = solver.fk_world
    held = solver.held
    a, b, c = T[0], T[1], T[2]
    out = [list(q) for q in Q]
    for k in range(max(steps)):
        idx = [i for i, s in enumerate(steps) if s > k]
        errs, cols = [], []
        for i in idx:
            t, col = fk_world(out[i])
            errs.append(_residual(t, a, b, c))
            cols.append(col)
        Jt = np.array(cols)  # (k, n, 6): Jᵀ per candidate
        if held is not None:
            Jt[:, held] = 0.0
        y = np.linalg.solve(_damped(Jt.swapaxes(1, 2) @ Jt), np.array(errs)[:, :, None])
        for i, d in zip(idx, (Jt @ y)[:, :, 0].tolist(), strict=True):
            out[i] = [x + dx for x, dx in zip(out[i], d, strict=True)]
    return out


#: A candidate within this of its target (position / scale, and rotation [rad]) is refined by one
#: Gauss–Newton step (quadratic convergence: the next error is of its square), else by two.
ONE_STEP_BELOW = 1e-6
#: Held values whose general 6R `Arm` a 7R arm keeps (`ChainSolver.held_general`; ~40 KB each).
GENERAL_CACHE_SIZE = 256
#: Tuples of held values whose stacked arms it keeps (`ik_all`'s 36, a sweep's chunks).
STACKED_CACHE_SIZE = 16

_Part = TypeVar("_Part")


def _kept_per_value(
    cache: dict[float, _Part], values: list[float], build: Callable[[FloatArray], list[_Part]]
) -> list[_Part]:
    """The parts of the held values in their order, kept per value in `cache`: those not kept
    are built at once (`build`: values (m,) → m parts). A cache that would grow past
    `GENERAL_CACHE_SIZE` is emptied first, and every value built again. (A plain dict: a lost
    race only recomputes an entry.)"""
    missing = list(dict.fromkeys(v for v in values if v not in cache))
    if missing and len(cache) + len(missing) > GENERAL_CACHE_SIZE:
        cache.clear()
        missing = list(dict.fromkeys(values))
    if missing:
        cache.update(zip(missing, build(np.array(missing)), strict=True))
    return [cache[v] for v in values]


def _kept_per_tuple(
    cache: dict[bytes, _Part], theta: FloatArray, make: Callable[[list[float]], _Part]
) -> _Part:
    """`make`(θ's values), kept per tuple of values θ in `cache` (emptied when full)."""
    key = theta.tobytes()
    got = cache.get(key)
    if got is None:
        got = make(theta.tolist())
        if len(cache) >= STACKED_CACHE_SIZE:
            cache.clear()
        cache[key] = got
    return got


#: Rounds of refinement at most: the first (`steps_for`'s steps), then one step a round for a
#: candidate still off. Near a singular configuration convergence is neither quadratic nor
#: monotone: a random 6R arm's target at σ_min/σ_max ≈ 2e-5 left its candidates 1e-7 off after
#: the first step, and every candidate was rejected, so `ik_all` said the reachable target was
#: unreachable.
MAX_REFINE_ROUNDS = 6
_EYE6 = np.eye(6)


def _damped(JJ: FloatArray) -> FloatArray:
    """J Jᵀ (…, 6, 6) plus 1e-12 (1 + trace) I: solvable where J is singular, at any scale (an
    absolute 1e-12 is below rounding where a fuzzed arm reaches 866 km, and LU then fails)."""
    return JJ + (1e-12 * (1.0 + np.einsum("...ii->...", JJ)))[..., None, None] * _EYE6


def steps_for(solver: ChainSolver, ep: float, er: float) -> int:
    """Gauss–Newton steps that refine a candidate with errors ep [m], er [rad] to round-off."""
    return 1 if ep < ONE_STEP_BELOW * solver.scale and er < ONE_STEP_BELOW else 2
