"""Task scaling under joint velocity bounds: the largest share of a commanded task velocity that
the joints can carry exactly, the rest of the task kept whole.

For a task Jacobian J (m, n), a commanded task velocity c and a correction r (the loop's), and
per-joint velocity bounds lo ≤ q̇ ≤ hi, find the largest s ∈ [0, 1] and q̇ with

    J q̇ = s c + r,    lo ≤ q̇ ≤ hi.

The solution keeps the direction of the commanded motion in the task space: the tool slows along
its path rather than leaving it, as a least-squares fit of the whole command would (a pure
rotation whose joints are held keeps its point only if the rotation slows). This is the
Saturation in the Null Space algorithm of Flacco, De Luca & Khatib (2015, "Control of redundant
robots under hard joint constraints: saturation in the null space", IEEE T-RO 31(3), Algorithms 1
and 2): the joint that limits s most is held at its bound, the task is solved again by the others
(with that joint's motion subtracted), and the best s of the sets tried is kept; it stops when the
joints left cannot do the task exactly (fewer than m, or their Jacobian's smallest singular value
below the threshold), since any fit then moves the tool in directions nobody commanded.
"""

from __future__ import annotations

import itertools
import math
from functools import lru_cache
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from . import dls

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


class ScaledMotion(NamedTuple):
    """Joint velocities that carry a share of a commanded task velocity exactly.

    Attributes:
        velocities: (n,) q̇, with J q̇ = share · c + r.
        share: s ∈ [0, 1], the share of the command c carried.
        active: (n,) the joints left free; the others are held at a bound.
        row_basis: (k, n_active) the right singular vectors of J over the active joints (an
            orthonormal basis of its row space: the complement is the null space left for
            motion that does not move the task).
    """

    velocities: FloatArray
    share: float
    active: BoolArray
    row_basis: FloatArray


def largest_share(
    base: list[float], part: list[float], lo: list[float], hi: list[float]
) -> tuple[float, int]:
    """(s, k): the largest s ∈ [0, 1] with lo ≤ base + s·part ≤ hi, and the joint k that limits
    it (−1 when none does: s = 1). When no s ∈ [0, 1] fits, s = −1 and k is the joint whose
    own interval of s ends first (one that fits for no s at all comes first)."""
    s_low, s_high, critical, critical_end = 0.0, 1.0, -1, math.inf
    for k, (b, p, a, c) in enumerate(zip(base, part, lo, hi, strict=True)):
        # this joint's interval [start, end] of s
        if p > 0.0:
            start, end = (a - b) / p, (c - b) / p
        elif p < 0.0:
            start, end = (c - b) / p, (a - b) / p
        elif a <= b <= c:
            continue
        else:
            start, end = math.inf, -math.inf
        if end < 0.0 or start > 1.0 or start > end:
            end = -math.inf  # fits for no s in [0, 1]
        if end < critical_end:
            critical, critical_end = k, end
        if start > s_low:
            s_low = start
        if end < s_high:
            s_high = end
    if s_low > s_high:
        return -1.0, critical
    return (1.0, -1) if s_high >= 1.0 else (s_high, critical)


def scale_into_bounds(
    J: FloatArray,
    command: FloatArray,
    correction: FloatArray,
    lo: list[float],
    hi: list[float],
    first: tuple[FloatArray, FloatArray, FloatArray],
    threshold: float,
) -> ScaledMotion | None:
    """The largest share s of `command` that the joints carry within [lo, hi] exactly, with the
    whole `correction` (see the module docstring).

    Args:
        J: (m, n) task Jacobian.
        command: (m,) c, the commanded task velocity (the part that may be slowed).
        correction: (m,) r, the part kept whole (the loop's correction).
        lo, hi: (n,) joint velocity bounds, lo ≤ 0 ≤ hi.
        first: (a, b, row basis): the solution over all joints, q̇ = s a + b for J q̇ = s c + r
            (the caller's, possibly damped near a singularity), and its right singular vectors.
        threshold: joints whose Jacobian has a singular value below this are not asked to take
            over the task.

    Returns:
        The motion with the largest s found, or None when none fits even at s = 0 (the
        correction alone asks more than the bounds allow).
    """
    n = J.shape[1]
    m = J.shape[0]
    a, b, rows = first
    active = np.ones(n, dtype=bool)
    fixed = np.zeros(n)
    best: ScaledMotion | None = None
    for _ in range(n):
        a_list = a.tolist()
        base = (fixed + b).tolist()
        share, k = largest_share(base, a_list, lo, hi)
        if share >= 0.0 and (best is None or share > best.share):
            best = ScaledMotion(fixed + b + share * a, share, active.copy(), rows)
            if share >= 1.0:
                break
        if k < 0:
            break
        # hold joint k at the bound it passes when the whole command is carried
        value = base[k] + a_list[k]
        fixed[k] = hi[k] if value > hi[k] else lo[k] if value < lo[k] else value
        if base[k] > hi[k]:
            fixed[k] = hi[k]
        elif base[k] < lo[k]:
            fixed[k] = lo[k]
        active[k] = False
        if int(active.sum()) < m:
            break
        J_active = J[:, active]
        part = dls.solve(J_active, command, threshold, 1.0)
        if float(part.singular_values[-1]) < threshold:
            break
        a = np.zeros(n)
        a[active] = part.undamped
        b = np.zeros(n)
        b[active] = dls.apply(part, correction - J[:, ~active].dot(fixed[~active]))
        rows = part.row_basis
    return best


_EXACT_TOL = 1e-11  # [rad/s or m/s] slack on the bounds of `exact_share` (rounding of the solves)
_ENUMERATED = 3  # up to this many free dimensions the vertices are enumerated, beyond: HiGHS


@lru_cache(maxsize=16)
def _vertex_patterns(count: int, d: int) -> tuple[NDArray[np.intp], FloatArray]:
    """(which coordinates, (C, d); which bound of each, (2^d, d) of 0.0 lower / 1.0 upper)."""
    combos = np.array(list(itertools.combinations(range(count), d)), dtype=np.intp)
    sides = np.array(list(itertools.product((0.0, 1.0), repeat=d)), dtype=np.float64)
    return combos.reshape(-1, d), sides.reshape(-1, d)


class ShareProblem:
    """The linear program of `exact_share` for one (J, command, correction), prepared once for
    several boxes: the SVD of [J, −c], its null space N and, for the vertex enumeration, the
    inverses of N's square blocks. A box then costs a few small array operations (the servo
    tries up to three ranges of the share in up to five boxes per period: one SVD, not 15).

    `usable` is False where [J, −c] loses rank (a singularity the command does not fill):
    `solve` then finds nothing."""

    def __init__(self, J: FloatArray, command: FloatArray, correction: FloatArray) -> None:
        m, n = J.shape
        self._n = n
        A = np.hstack((J, -np.asarray(command, dtype=np.float64)[:, None]))
        U, sv, Vt = np.linalg.svd(A)
        self.usable = not (sv.shape[0] < m or float(sv[-1]) <= 1e-9 * max(float(sv[0]), 1e-300))
        if not self.usable:
            return
        self._y_p = Vt[:m].T.dot(U.T.dot(correction) / sv)
        N = Vt[m:].T  # (n + 1, d), the null space of [J, −c]
        self._N = N
        d = n + 1 - m
        self._d = d
        self._blocks: tuple[NDArray[np.intp], FloatArray, FloatArray] | None = None
        if 0 < d <= _ENUMERATED:
            combos, sides = _vertex_patterns(n + 1, d)
            M = N[combos]  # (C, d, d)
            good = np.abs(np.linalg.det(M)) > 1e-12
            if good.any():
                self._blocks = (combos[good], np.linalg.inv(M[good]), sides)

    def solve(
        self,
        lo: list[float],
        hi: list[float],
        prefer: list[float],
        shares: tuple[float, float] = (0.0, 1.0),
        largest: bool = True,
    ) -> tuple[FloatArray, float] | None:
        """`exact_share` in the box [lo, hi] (see there)."""
        if not self.usable:
            return None
        low = np.array(list(lo) + [shares[0]])
        high = np.array(list(hi) + [shares[1]])
        if not np.all(low <= high):
            return None
        y_p, N, d = self._y_p, self._N, self._d
        L, H = low - y_p, high - y_p
        if d == 0:
            points = np.zeros((1, 0))
        elif d > _ENUMERATED:
            from scipy.optimize import linprog  # noqa: PLC0415 - rare, and SciPy loads slowly

            res = linprog(
                -N[-1] if largest else N[-1],
                A_ub=np.vstack((N, -N)),
                b_ub=np.concatenate((H, -L)),
                bounds=[(None, None)] * d,
                method="highs",
            )
            if res.status != 0:
                return None
            points = res.x[None, :]
        else:
            if self._blocks is None:
                return None
            combos, inv, sides = self._blocks
            Lc, Hc = L[combos], H[combos]  # (C, d)
            rhs = Lc[:, None, :] + sides[None, :, :] * (Hc - Lc)[:, None, :]  # (C, 2^d, d)
            points = np.einsum("cij,cpj->cpi", inv, rhs).reshape(-1, d)
        values = points.dot(N.T)  # (P, n + 1): y − y_p
        feasible = np.all((values >= L - _EXACT_TOL) & (values <= H + _EXACT_TOL), axis=1)
        if not feasible.any():
            return None
        ys = values[feasible] + y_p
        s_all = ys[:, -1] if largest else -ys[:, -1]
        best = float(s_all.max())
        top = ys[s_all >= best - 1e-12]
        if top.shape[0] > 1:
            gap = top[:, :-1] - np.asarray(prefer)
            top = top[int(np.argmin(np.einsum("ij,ij->i", gap, gap)))][None, :]
        y = top[0]
        qd = np.minimum(np.maximum(y[:-1], low[:-1]), high[:-1])
        return qd, min(shares[1], max(shares[0], float(y[-1])))


def exact_share(
    J: FloatArray,
    command: FloatArray,
    correction: FloatArray,
    lo: list[float],
    hi: list[float],
    prefer: list[float],
    shares: tuple[float, float] = (0.0, 1.0),
    largest: bool = True,
) -> tuple[FloatArray, float] | None:
    """(q̇, s): the largest share s ∈ [0, 1] of `command` with J q̇ = s·command + correction and
    lo ≤ q̇ ≤ hi, exactly: a linear program, max s over y = (q̇, s) with [J, −c] y = r.

    Unlike `scale_into_bounds` the box need not hold q̇ = 0 (the servo's box is what the joints
    reach in one period from their motion), and the optimum is the optimum, not a greedy one.
    With d = n + 1 − m free dimensions (2 for a 7-joint arm following 6 axes, 1 for 6 joints)
    the polytope's vertices are enumerated (C(n+1, d)·2^d small solves at once); of those that
    reach the largest s, the one nearest `prefer` (n,) is taken. Beyond `_ENUMERATED`
    dimensions, SciPy's HiGHS solves it (about 1 ms). `shares`: the range of s ([0, 1] unless
    the caller allows more); `largest` False: the smallest s instead. (`ShareProblem` solves
    the same for several boxes at the cost of one.)

    Returns None when no q̇ in the box does the correction with any s ∈ [0, 1], or when
    [J, −c] loses rank (a singularity the command does not fill).
    """
    return ShareProblem(J, command, correction).solve(lo, hi, prefer, shares, largest)
