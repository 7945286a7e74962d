"""The held joint of a 7R arm: which values to sweep, and in what order to try them."""

from __future__ import annotations

import functools
import math

import numpy as np
from numpy.typing import ArrayLike

from ..._checks import as_float_array, check_finite
from ...exceptions import InvalidInputError
from ...model import TWO_PI, KinematicChain
from .chain_solver import ChainSolver
from .detection import require_solver
from .geometry import FloatArray

#: Default number of held-joint values swept by a 7R arm, spread evenly over its limits.
DEFAULT_HELD_SAMPLES = 36


def held_values_of(
    solver: ChainSolver, held: ArrayLike | None, n_targets: int | None
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


def held_order(chain: KinematicChain, q_seeds: FloatArray, count: int) -> FloatArray:
    """(N, count) values of a 7R arm's held joint to try, in order, for targets with seeds (N, n):
    the seed's value, then points of the van der Corput sequence over the joint's range (½, ¼,
    ¾, ⅛, ⅝, …: each new value halves the largest stretch not yet tried), skipping values within
    a 72nd of the range of one already chosen. A target's feasible values of the held joint form
    stretches (on Panda each value of joint 7 reaches about 37 % of random targets, and stretches
    a third of the range apart cover different targets), so spreading the tries finds one sooner
    than stepping away from the seed. A continuous joint's range, or one wider than a turn, is
    taken as the seed ± π (values a turn apart hold the arm alike)."""
    solver = require_solver(chain)
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


def held_order_one(solver: ChainSolver, s: float, count: int) -> list[float]:
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
