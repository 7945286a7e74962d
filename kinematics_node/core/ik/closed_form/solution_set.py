"""The solution set: result types, whole-turn equivalents within the limits, duplicates, ranking.

Solutions come from the families with angles in (−π, π]; each joint's whole-turn equivalents within
its limits are then added (limits widened by 1e-10 rad, values clipped back), duplicates (equal
modulo 2π to `_SAME_SOLUTION`) dropped, and the set sorted by distance to the seed. An empty set
carries the reason: the first solver stage at which every branch failed, or the limits.
"""

from __future__ import annotations

import functools
import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from ...model import TWO_PI, KinematicChain
from ..result import IKResult, default_seed
from .geometry import INV_TWO_PI, BoolArray, Candidate, FloatArray, IntArray

#: A solution counts once: two that agree to this [rad] in every joint (modulo 2π) are one.
_SAME_SOLUTION = 1e-9


class JointLimits:
    """A chain's joint limits [rad] in the forms the solution set reads them (immutable)."""

    def __init__(self, chain: KinematicChain) -> None:
        self.chain = chain
        self.lower = [float(x) for x in chain.lower]
        self.upper = [float(x) for x in chain.upper]
        # Every angle of [−π, π] lies within the limits (±π, ±2π, continuous joints).
        self.holds_turn = all(
            a <= -math.pi and b >= math.pi for a, b in zip(self.lower, self.upper, strict=True)
        )
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

    def clipped(self, q: list[float]) -> list[float]:
        """q (floats) clipped into the limits."""
        return [min(max(x, a), b) for x, a, b in zip(q, self.lower, self.upper, strict=True)]

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


def order_within_targets(
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


def seen_before(q: list[float], accepted: list[list[float]]) -> bool:
    """q equals (`same_solution`) one of `accepted`; a cheap first test on one joint (branches often
    share the first joint)."""
    q2 = q[2]
    for o in accepted:
        d = abs(q2 - o[2])
        if (d <= _SAME_SOLUTION or abs(d - TWO_PI) <= _SAME_SOLUTION) and same_solution(q, o):
            return True
    return False


def same_solution(a: list[float], b: list[float], tol: float = _SAME_SOLUTION) -> bool:
    """Two solutions with angles in (−π, π] are equal modulo 2π to `tol` [rad] in every joint."""
    for x, y in zip(a, b, strict=True):
        d = abs(x - y)
        if d > tol and abs(d - TWO_PI) > tol:
            return False
    return True


def empty_reason(dead_stage: str | None, n_before_limits: int) -> str:
    if dead_stage is not None:
        return f"unreachable: {_STAGE_TEXT[dead_stage]}"
    if n_before_limits:
        k = n_before_limits
        return (
            f"{k} solution{'s' if k > 1 else ''} reach the target but none lies within the "
            "joint limits"
        )
    return "unreachable: no candidate reproduced the target by forward kinematics"


def expand_sorted(
    solver: JointLimits, accepted: list[list[float]], seed: list[float]
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
    solver: JointLimits, accepted: list[list[float]], seeds: FloatArray
) -> tuple[FloatArray, int] | None:
    """`expand_sorted` when no angle has more than two whole-turn equivalents within the (finite)
    limits, as with limits of ±2π; None otherwise. Solution i's equivalents are its lowest one
    (angles + 2π k_lo) plus 2π b for the bit patterns b that are 0 wherever an angle has a single
    equivalent: b & fixed = 0, an integer mask test. (`_equivalents` compares all mⁿ offsets per
    joint instead; this, with `take` rather than fancy indexing, is ~4× faster for a UR5.)"""
    n = len(seeds[0])
    Q = np.array(accepted)
    k_lo = np.ceil((solver.lo_wide - Q) * INV_TWO_PI)
    cnt = np.floor((solver.hi_wide - Q) * INV_TWO_PI) - k_lo
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
    solver: JointLimits, accepted: list[list[float]], seed: list[float]
) -> tuple[FloatArray, int] | None:
    """`expand_sorted` on floats when no angle has a second whole-turn equivalent within the
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


def _equivalents(
    solver: JointLimits, Q: FloatArray, seeds: FloatArray
) -> tuple[FloatArray, IntArray]:
    """Every whole-turn equivalent within the limits of a few solutions Q (C, n) in (−π, π] for one
    seed (1, n): rows, and the index of the solution each comes from. Same rule as
    `equivalents_within_limits`, as one product over joints (at most m equivalents per joint: m^n offsets)."""
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
    elif m == 2:
        n = chain.dof
        combos = _COMBOS.get((m, n))
        if combos is None:
            combos = np.indices((m,) * n).reshape(n, -1).T.copy()
            _COMBOS[(m, n)] = combos
        ok = (combos[None, :, :] < cnt[:, None, :]).all(axis=2)
        keep, which = np.nonzero(ok)
        out = Q[keep] + TWO_PI * (k_lo[keep] + combos[which])
    else:  # a joint with three or more (a range over 4π): the product per solution, not mⁿ
        base = (Q + TWO_PI * k_lo).tolist()
        rows: list[tuple[float, ...]] = []
        source: list[int] = []
        for i, (b, c) in enumerate(zip(base, cnt.tolist(), strict=True)):
            options = [[x + TWO_PI * k for k in range(cj)] for x, cj in zip(b, c, strict=True)]
            for row in itertools.product(*options):  # (empty if some joint has none)
                rows.append(row)
                source.append(i)
        out = np.array(rows, dtype=np.float64).reshape(len(rows), Q.shape[1])
        keep = np.array(source, dtype=np.int64)
    return np.clip(out, solver.lower_arr, solver.upper_arr), keep


_STAGE_TEXT = {
    "shoulder": "the wrist centre is out of reach of the shoulder (too close to joint 1's axis "
    "for the arm's offsets, or too far)",
    "elbow": "the wrist centre is out of the arm's reach (too far from or too close to the shoulder)",
    "wrist": "the wrist cannot take the target orientation at any reachable wrist position",
    "reach": "the arm's eigenvalue problem has no real root (the target is out of reach)",
}


def empty_set_reason(
    stage_dead: list[tuple[str, BoolArray]], i: int, n_before: int, swept: bool
) -> str:
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


def duplicate_branches(Q: FloatArray, acc: BoolArray) -> BoolArray:
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


def equivalents_within_limits_two(
    solver: JointLimits, Q: FloatArray, owner: IntArray, tag: IntArray
) -> tuple[FloatArray, IntArray, IntArray] | None:
    """`equivalents_within_limits` for finite limits where no angle has more than two whole-turn equivalents
    (limits of ±2π: each solution has up to 2⁵ equivalents), in one gather instead of one per
    joint: row r's equivalents are its lowest one plus 2π b for the bit patterns b with
    b & fixed_r = 0 (`_two_equivalents`, vectorised over rows). None if the rule does not apply.
    Rows stay grouped by target, in the order of `equivalents_within_limits`."""
    if not Q.shape[0]:
        return None
    n = Q.shape[1]
    # The same arithmetic as `equivalents_within_limits` (the results must not depend on the passes).
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


def equivalents_within_limits(
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


def _nearest_turn(
    q: list[float], seed: list[float], lo: list[float], hi: list[float]
) -> list[float] | None:
    """The whole-turn equivalent of q (angles in (−π, π]) within the limits nearest the seed, joint
    by joint (each joint's term of the distance is independent); None if a joint has none.
    Unbounded sides are seed ± π, as in `equivalents_within_limits`."""
    out = []
    for x, s, a, b in zip(q, seed, lo, hi, strict=True):
        y = x + TWO_PI * round((s - x) * INV_TWO_PI)  # nearest the seed; usually within limits
        if a <= y <= b:
            out.append(y)
            continue
        lo_j = a if a > -math.inf else s - math.pi
        hi_j = b if b < math.inf else s + math.pi
        k_lo = math.ceil((lo_j - 1e-10 - x) * INV_TWO_PI)
        k_hi = math.floor((hi_j + 1e-10 - x) * INV_TWO_PI)
        if k_lo > k_hi:
            return None
        k = min(max(round((s - x) * INV_TWO_PI), k_lo), k_hi)
        out.append(min(max(x + TWO_PI * k, lo_j), hi_j))
    return out


def rank_array(
    Q: FloatArray, seed: list[float], solver: JointLimits, w: list[float]
) -> list[tuple[float, list[float]]]:
    """`rank_candidates` of candidates given as an array Q (R, n) (any angles, not only those in
    (−π, π]): the same equivalents, distances and order, on arrays (a general 6R arm's up to 16
    roots cost ~15 array operations here instead of a Python loop over every angle). `_nearest_turn`
    on every row at once: each angle's whole-turn equivalent nearest the seed, its turns clipped
    to those within the (widened) limits, rows without one left out."""
    s = np.asarray(seed)
    lo, hi = solver.lower_arr, solver.upper_arr  # unbounded sides: seed ± π (`_nearest_turn`)
    lo_w, hi_w = solver.lo_wide, solver.hi_wide
    if not solver.all_finite:
        lo = np.where(np.isfinite(lo), lo, s - math.pi)
        hi = np.where(np.isfinite(hi), hi, s + math.pi)
        lo_w, hi_w = lo - 1e-10, hi + 1e-10
    k_lo = np.ceil((lo_w - Q) * INV_TWO_PI)
    k_hi = np.floor((hi_w - Q) * INV_TWO_PI)
    # (np.rint, a ufunc, rounds halves to even as Python's `round` does)
    k = np.minimum(np.maximum(np.rint((s - Q) * INV_TWO_PI), k_lo), k_hi)
    X = np.minimum(np.maximum(Q + TWO_PI * k, lo), hi)
    D = X - s
    dist = (D * D) @ np.asarray(w)
    keep: list[bool] = np.asarray((k_lo <= k_hi).all(axis=1)).tolist()
    ranked = [(d, x) for d, x, i in zip(dist.tolist(), X.tolist(), keep, strict=True) if i]
    ranked.sort(key=lambda item: item[0])
    return ranked


def rank_candidates(
    cands: list[Candidate], seed: list[float], solver: JointLimits, w: list[float]
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
                x = x + TWO_PI * round(-d * INV_TWO_PI)
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
