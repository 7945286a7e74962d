"""Vectorised closed-form solvers of the 6R families (see `closed_form` for the equations).

Each solver takes L lanes (targets, or target × held-joint value) and returns all 8 branches per
lane: Q (L, 8, 6) and ok (L, 8). Branch layout: the first subproblem's two branches are split in
halves, the next in quarters, … (branch index = 4·i₁ + 2·i₂ + i₃). `_closed_form_scalar` holds
the same equations, in the same branch order, for one target on plain floats.
Angles [rad], lengths [m].
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from . import subproblems as sp

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


@dataclass(frozen=True)
class Geometry:
    """Per-lane geometry of a 6R problem, in the order the solver reads the axes (reversed if so).

    Arrays have a leading lane axis of length 1 (one 6R arm) or L (one per held value).
    """

    w: FloatArray  # (L, 6, 3) unit axis directions ωᵢ
    r: FloatArray  # (L, 6, 3) a point on each axis
    c: FloatArray  # (L, 3) wrist centre, or the meeting point of axes 5 and 6
    b: FloatArray  # (L, 3) meeting point of the position case (int12/int23), else zeros
    h: FloatArray  # (L, 3) direction of the parallel axes, else zeros
    x: FloatArray  # (L, 3) a unit vector normal to the last axis (3-parallel: normal to h)
    s: FloatArray  # (L, 3) signs ωᵢᵀh of axes 2, 3, 4 (3-parallel), else ones
    scale: float  # characteristic length [m] for the round-off tolerances


@dataclass
class Trace:
    """Per-branch bookkeeping of a 6R solve: where branches died and which angles were free."""

    fails: list[tuple[str, BoolArray]] = field(default_factory=list)
    frees: list[tuple[str, BoolArray]] = field(default_factory=list)


def _spread(a: NDArray, n: int) -> NDArray:
    """Repeat the branch axis (axis 1) of a (L, B, …) array for n sub-branches: (L, B·n, …)."""
    return np.repeat(a, n, axis=1)


def _v(a: FloatArray) -> FloatArray:
    """A per-lane vector (L, 3) → (L, 1, 3), to broadcast over branches."""
    return a[:, None, :]


def _apply(R: FloatArray, x: FloatArray) -> FloatArray:
    """R x for per-lane R (L, 3, 3) and x (L, B, 3) or (L, 3)."""
    if x.ndim == 3:
        R = R[:, None]
    x0, x1, x2 = x[..., 0], x[..., 1], x[..., 2]
    return np.stack(
        [R[..., i, 0] * x0 + R[..., i, 1] * x1 + R[..., i, 2] * x2 for i in range(3)], axis=-1
    )  # written out: faster than einsum or stacked matmul for 3-vectors


def solve_three_parallel(
    g: Geometry, R: FloatArray, p: FloatArray, dflt: FloatArray, trace: Trace
) -> tuple[FloatArray, BoolArray]:
    w, r, h, c = g.w, g.r, g.h, g.c
    eL, eL2, e1 = 1e-9 * g.scale, 1e-12 * g.scale**2, 1e-9
    W = [w[:, i] for i in range(6)]
    P = [r[:, i] for i in range(6)]
    L = R.shape[0]
    # q₁: hᵀ e₁⁻¹(G c) = hᵀc, with e₁⁻¹x = r₁ + R(ω₁, −q₁)(x − r₁)  (SP4 in φ = −q₁).
    pc = _apply(R, np.broadcast_to(c, (L, 3))) + p
    phi, ok1, fr1 = sp.sp4(W[0], pc - P[0], h, sp.dot(h, c - P[0]), -dflt[:, 0], eL)
    q1 = -phi  # (L, 2)
    trace.fails.append(("shoulder", _flag(ok1, L, 8)))
    trace.frees.append(("the wrist point lies on joint 1's axis", _flag(fr1, L, 8)))
    # (q₅, q₆): R₅ R₆ (R_Gᵀ R₁ h) = h  (SP2).
    u = _apply(R.swapaxes(1, 2), sp.rotate(_v(W[0]), q1, _v(h)))  # R_Gᵀ R₁ h
    d5 = np.broadcast_to(dflt[:, 4:5], q1.shape)
    d6 = np.broadcast_to(dflt[:, 5:6], q1.shape)
    t5, t6, ok2, fr2 = sp.sp2(_v(W[4]), _v(W[5]), u, np.broadcast_to(_v(h), u.shape), d5, d6, e1)
    q1 = _spread(q1, 2)
    q5, q6 = t5.reshape(L, 4), t6.reshape(L, 4)
    trace.fails.append(("wrist", _flag(ok2, L, 8)))
    trace.frees.append(("wrist axes aligned (joint 6 parallel to joints 2-4)", _flag(fr2, L, 8)))
    # Sum angle θ₂₃₄ of R_K = R₁ᵀ R_G R₆ᵀ R₅ᵀ = R(h, θ₂₃₄), from a vector x normal to h.
    x = np.broadcast_to(_v(g.x), (L, 4, 3))
    y = sp.rotate(_v(W[4]), -q5, x)
    y = sp.rotate(_v(W[5]), -q6, y)
    y = sp.rotate(_v(W[0]), -q1, _apply(R, y))
    t234 = np.arctan2(sp.dot(_v(h), sp.cross(x, y)), sp.dot(x, y))
    # Point K r₄ with K = e₁⁻¹ G e₆⁻¹ e₅⁻¹ = e₂ e₃ e₄ (r₄ on axis 4 is fixed by e₄).
    k = sp.rotate_about(_v(W[4]), _v(P[4]), -q5, np.broadcast_to(_v(P[3]), (L, 4, 3)))
    k = sp.rotate_about(_v(W[5]), _v(P[5]), -q6, k)
    k = sp.rotate_about(_v(W[0]), _v(P[0]), -q1, _apply(R, k) + _v(p))
    # q₃: ‖e₃ r₄ − r₂‖ = ‖K r₄ − r₂‖  (SP3; r₂ on axis 2 is fixed by e₂).
    d3 = np.broadcast_to(dflt[:, 2:3], (L, 4))
    q3, ok3, fr3 = sp.sp3(
        _v(W[2]), _v(P[3] - P[2]), _v(P[1] - P[2]), sp.norm(k - _v(P[1])), d3, eL2
    )
    trace.fails.append(("elbow", _flag(ok3, L, 8)))
    trace.frees.append(("joint 4's axis passes through joint 3's axis", _flag(fr3, L, 8)))
    q3 = q3.reshape(L, 8)
    q1, q5, q6, t234, k = (_spread(a, 2) for a in (q1, q5, q6, t234, k))
    # q₂: e₂ (e₃ r₄) = K r₄  (SP1).
    x3 = sp.rotate_about(_v(W[2]), _v(P[2]), q3, np.broadcast_to(_v(P[3]), (L, 8, 3)))
    d2 = np.broadcast_to(dflt[:, 1:2], (L, 8))
    q2, fr4 = sp.sp1(_v(W[1]), x3 - _v(P[1]), k - _v(P[1]), d2, eL)
    trace.frees.append(("the elbow point lies on joint 2's axis", _flag(fr4, L, 8)))
    s = g.s[:, None, :]
    q4 = s[..., 2] * (t234 - s[..., 0] * q2 - s[..., 1] * q3)
    Q = np.stack((q1, q2, q3, q4, q5, q6), axis=-1)
    ok = np.ones((L, 8), dtype=bool)
    for _, f in trace.fails:
        ok &= f
    return Q, ok


def _flag(a: NDArray, L: int, n: int) -> BoolArray:
    """Per-branch flags in any branch layout ((Lg,), (Lg, b), (Lg, b, b′)) → (L, n)."""
    a = np.asarray(a, dtype=bool)
    a = a.reshape(a.shape[0], -1)
    a = np.broadcast_to(a, (L, a.shape[1]))
    return np.repeat(a, n // a.shape[1], axis=1)


def _grow(a: NDArray, n: int) -> NDArray:
    """Branch layout (L,), (L, b) or (L, b, 3) → (L, n[, 3]): each branch repeated n/b times."""
    L = a.shape[0]
    if a.ndim == 1:
        a = a[:, None]
    return np.repeat(a, n // a.shape[1], axis=1).reshape((L, n) + a.shape[2:])


def solve_spherical(
    case: str, g: Geometry, R: FloatArray, p: FloatArray, dflt: FloatArray, trace: Trace
) -> tuple[FloatArray, BoolArray]:
    w, r, c, b, h = g.w, g.r, g.c, g.b, g.h
    eL, eL2 = 1e-9 * g.scale, 1e-12 * g.scale**2
    W = [_v(w[:, i]) for i in range(6)]  # (L, 1, 3): broadcast over branches
    P = [_v(r[:, i]) for i in range(6)]
    cv, bv, hv = _v(c), _v(b), _v(h)
    L = R.shape[0]
    pc = _v(_apply(R, np.broadcast_to(c, (L, 3))) + p)  # wrist centre: e₁e₂e₃ c = G c, (L, 1, 3)
    d = [dflt[:, i : i + 1] for i in range(6)]  # (L, 1)
    fails: list[tuple[str, NDArray]] = []
    frees: list[tuple[str, NDArray]] = []
    if case == "par23":
        # hᵀ e₁⁻¹(G c) = hᵀc (SP4 in φ = −q₁); ‖e₃c − r₂‖ = ‖e₁⁻¹Gc − r₂‖ (SP3); e₂(e₃c) = e₁⁻¹Gc (SP1).
        phi, okA, frA = sp.sp4(W[0], pc - P[0], hv, sp.dot(hv, cv - P[0]), -d[0], eL)
        q1 = -phi.reshape(L, 2)
        wp = sp.rotate_about(W[0], P[0], -q1, pc)  # (L, 2, 3)
        q3, okB, frB = sp.sp3(W[2], cv - P[2], P[1] - P[2], sp.norm(wp - P[1]), d[2], eL2)
        q1, wp, q3 = _grow(q1, 4), _grow(wp, 4), q3.reshape(L, 4)
        x = sp.rotate_about(W[2], P[2], q3, np.broadcast_to(cv, (L, 4, 3)))
        q2, frC = sp.sp1(W[1], x - P[1], wp - P[1], d[1], eL)
        fails += [("shoulder", okA), ("elbow", okB)]
        frees += [
            ("the wrist centre lies on joint 1's axis", frA),
            ("the wrist centre lies on joint 3's axis", frB),
            ("the wrist centre lies on joint 2's axis", frC),
        ]
    elif case == "int12":
        # ‖e₃c − b‖ = ‖Gc − b‖ (SP3); e₁e₂(e₃c) = Gc about b (SP2).
        q3, okA, frA = sp.sp3(W[2], cv - P[2], bv - P[2], sp.norm(pc - bv), d[2], eL2)
        q3 = q3.reshape(L, 2)
        x = sp.rotate_about(W[2], P[2], q3, np.broadcast_to(cv, (L, 2, 3)))
        t1, t2, okB, frB = sp.sp2(
            W[0], W[1], x - bv, np.broadcast_to(pc - bv, x.shape), d[0], d[1], eL
        )
        q1, q2, q3 = t1.reshape(L, 4), t2.reshape(L, 4), _grow(q3, 4)
        fails += [("elbow", okA), ("shoulder", okB)]
        frees += [
            ("the wrist centre lies on joint 3's axis", frA),
            ("the wrist centre lies on joint 1's axis", frB),
        ]
    elif case == "int23":
        # ‖e₁⁻¹Gc − b‖ = ‖c − b‖ (SP3 in φ = −q₁); e₂e₃ c = e₁⁻¹Gc about b (SP2).
        phi, okA, frA = sp.sp3(W[0], pc - P[0], bv - P[0], sp.norm(cv - bv), -d[0], eL2)
        q1 = -phi.reshape(L, 2)
        wp = sp.rotate_about(W[0], P[0], -q1, pc)
        t2, t3, okB, frB = sp.sp2(
            W[1], W[2], np.broadcast_to(cv - bv, wp.shape), wp - bv, d[1], d[2], eL
        )
        q1, q2, q3 = _grow(q1, 4), t2.reshape(L, 4), t3.reshape(L, 4)
        fails += [("shoulder", okA), ("elbow", okB)]
        frees += [
            ("the wrist centre lies on joint 1's axis", frA),
            ("the wrist centre lies on joint 2's axis", frB),
        ]
    else:  # "par12"
        # hᵀ e₃c = hᵀGc (SP4); ‖e₂(e₃c) − r₁‖ = ‖Gc − r₁‖ (SP3); e₁(e₂e₃c) = Gc (SP1).
        q3, okA, frA = sp.sp4(W[2], cv - P[2], hv, sp.dot(hv, pc - P[2]), d[2], eL)
        q3 = q3.reshape(L, 2)
        x = sp.rotate_about(W[2], P[2], q3, np.broadcast_to(cv, (L, 2, 3)))
        q2, okB, frB = sp.sp3(W[1], x - P[1], P[0] - P[1], sp.norm(pc - P[0]), d[1], eL2)
        q3, x, q2 = _grow(q3, 4), _grow(x, 4), q2.reshape(L, 4)
        y = sp.rotate_about(W[1], P[1], q2, x)
        q1, frC = sp.sp1(W[0], y - P[0], pc - P[0], d[0], eL)
        fails += [("shoulder", okA), ("elbow", okB)]
        frees += [
            ("the wrist centre lies on joint 3's axis", frA),
            ("the wrist centre lies on joint 2's axis", frB),
            ("the wrist centre lies on joint 1's axis", frC),
        ]

    # Orientation R₄R₅R₆ = R_w = R₃ᵀR₂ᵀR₁ᵀR_G: R₄R₅ ω₆ = R_w ω₆ (SP2), R₆ x = (R₄R₅)ᵀR_w x (SP1).
    def to_wrist(v: FloatArray, q1: FloatArray, q2: FloatArray, q3: FloatArray) -> FloatArray:
        v = sp.rotate(W[0], -q1, v)
        v = sp.rotate(W[1], -q2, v)
        return sp.rotate(W[2], -q3, v)

    v6 = to_wrist(np.broadcast_to(_v(_apply(R, w[:, 5])), (L, 4, 3)), q1, q2, q3)
    t4, t5, okC, frD = sp.sp2(W[3], W[4], np.broadcast_to(W[5], v6.shape), v6, d[3], d[4], 1e-9)
    q1, q2, q3 = (_grow(a, 8) for a in (q1, q2, q3))
    q4, q5 = t4.reshape(L, 8), t5.reshape(L, 8)
    x6 = np.broadcast_to(_v(g.x), (L, 8, 3))
    y = to_wrist(_apply(R, x6), q1, q2, q3)
    y = sp.rotate(W[4], -q5, sp.rotate(W[3], -q4, y))
    q6, _ = sp.sp1(W[5], x6, y, d[5], 1e-9)
    for name, f in fails + [("wrist", okC)]:
        trace.fails.append((name, _flag(f, L, 8)))
    for name, f in frees + [("wrist axes aligned (joints 4 and 6 coincide)", frD)]:
        trace.frees.append((name, _flag(f, L, 8)))
    Q = np.stack((q1, q2, q3, q4, q5, q6), axis=-1)
    ok = np.ones((L, 8), dtype=bool)
    for _, f in trace.fails:
        ok &= f
    return Q, ok
