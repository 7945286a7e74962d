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
from ._closed_form_scalar import Spherical, ThreeParallel, Vec
from .subproblems import TANGENT_TOLERANCE

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
    case: str,
    g: Geometry,
    R: FloatArray,
    p: FloatArray,
    dflt: FloatArray,
    trace: Trace,
    prepared: Spherical | None = None,
) -> tuple[FloatArray, BoolArray]:
    """All 8 branches of a spherical-wrist 6R arm. `prepared`: the constants of a geometry g that
    is the same for every lane (`_closed_form_scalar.Spherical`): the wrist then runs on them
    (`_wrist_prepared`)."""
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

    if prepared is not None:
        q1, q2, q3 = (_grow(a, 8) for a in (q1, q2, q3))
        q4, q5, q6, okC, frD = _wrist_prepared(prepared, R, q1, q2, q3, dflt)
        return _finish(trace, fails, frees, okC, frD, L, (q1, q2, q3, q4, q5, q6))

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
    return _finish(trace, fails, frees, okC, frD, L, (q1, q2, q3, q4, q5, q6))


def _finish(
    trace: Trace,
    fails: list[tuple[str, NDArray]],
    frees: list[tuple[str, NDArray]],
    okC: NDArray,
    frD: NDArray,
    L: int,
    angles: tuple[FloatArray, ...],
) -> tuple[FloatArray, BoolArray]:
    """`solve_spherical`'s trace and result from its flags and the six (L, 8) angles."""
    for name, f in fails + [("wrist", okC)]:
        trace.fails.append((name, _flag(f, L, 8)))
    for name, f in frees + [("wrist axes aligned (joints 4 and 6 coincide)", frD)]:
        trace.frees.append((name, _flag(f, L, 8)))
    Q = np.stack(angles, axis=-1)
    ok = np.ones((L, 8), dtype=bool)
    for _, f in trace.fails:
        ok &= f
    return Q, ok


def _wrist_prepared(
    c: Spherical, R: FloatArray, q1: FloatArray, q2: FloatArray, q3: FloatArray, dflt: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray, BoolArray, BoolArray]:
    """The wrist of `solve_spherical` (q₄, q₅, q₆ (L, 8), ok (L, 4), free (L, 8)) for a geometry
    whose constants `c` were prepared once (`_closed_form_scalar.Spherical.solve`'s wrist, on
    arrays).

    Hand-written for speed (`ik_batch` on Panda runs it for every held value tried): vectors are
    three (L, b) component arrays and the axes floats, so a rotation costs a few scaled sums
    instead of cross products of stacked (L, b, 3) arrays. Same equations, branch layout, flags
    and tolerances as the general wrist (‖x‖ ≤ ε tested as ‖x‖² ≤ ε²; the tests compare them).
    """
    w0, w1, w2, w3, w4, w5 = c.W
    sp2w = c.wsp2
    c34, den, n12 = sp2w.c, sp2w.den, sp2w.n12
    k12x, k12y, k12z = sp2w.k12
    w3x, w3y, w3z = w3
    w4x, w4y, w4z = w4
    w5x, w5y, w5z = w5
    L = R.shape[0]
    Rc = [[R[:, i, j][:, None] for j in range(3)] for i in range(3)]

    def applied(v: Vec) -> tuple[FloatArray, FloatArray, FloatArray]:
        return tuple(Rc[i][0] * v[0] + Rc[i][1] * v[1] + Rc[i][2] * v[2] for i in range(3))  # type: ignore[return-value]

    # v₆ and y₀: Rω₆ and Rx turned by −q₁, −q₂, −q₃ (per arm: the branches' pairs share them).
    a1, a2, a3 = q1[:, ::2], q2[:, ::2], q3[:, ::2]  # (L, 4)
    cs1, sn1 = np.cos(a1), -np.sin(a1)
    cs2, sn2 = np.cos(a2), -np.sin(a2)
    cs3, sn3 = np.cos(a3), -np.sin(a3)
    v = _turn(w2, cs3, sn3, *_turn(w1, cs2, sn2, *_turn(w0, cs1, sn1, *applied(w5))))
    y = _turn(w2, cs3, sn3, *_turn(w1, cs2, sn2, *_turn(w0, cs1, sn1, *applied(c.x))))
    # SP2 (ω₄, ω₅) of p = ω₆ onto q = v₆.
    kp, pp = c.kp_w, c.pp_w
    kq = w3x * v[0] + w3y * v[1] + w3z * v[2]
    alpha = (c34 * kp - kq) / den
    beta = (c34 * kq - kp) / den
    g2 = (pp - alpha * alpha - beta * beta - 2.0 * alpha * beta * c34) / n12
    ok = g2 >= -TANGENT_TOLERANCE * max(pp, 1e-18)
    gamma = np.sqrt(np.maximum(g2, 0.0))
    gs = np.stack((gamma, -gamma), axis=-1).reshape(L, 8)

    def two(a: FloatArray) -> FloatArray:
        return np.repeat(a, 2, axis=1)

    alpha, beta, kq = two(alpha), two(beta), two(kq)
    vx, vy, vz = (two(a) for a in v)
    y0x, y0y, y0z = (two(a) for a in y)
    # q₅ = SP1(ω₅, ω₆ → z), z = α ω₄ + β ω₅ + γ (ω₄ × ω₅)
    zx = alpha * w3x + beta * w4x + gs * k12x
    zy = alpha * w3y + beta * w4y + gs * k12y
    zz = alpha * w3z + beta * w4z + gs * k12z
    kz = w4x * zx + w4y * zy + w4z * zz
    bx, by, bz = zx - w4x * kz, zy - w4y * kz, zz - w4z * kz
    apx, apy, apz = c.w5p4
    a_small = apx * apx + apy * apy + apz * apz <= 1e-18
    fr5 = (bx * bx + by * by + bz * bz <= 1e-18) | a_small
    q5 = np.arctan2(
        w4x * (apy * bz - apz * by) + w4y * (apz * bx - apx * bz) + w4z * (apx * by - apy * bx),
        apx * bx + apy * by + apz * bz,
    )
    q5 = np.where(fr5, dflt[:, 4:5], q5)
    # q₄ = SP1(ω₄, R(ω₅, q₅) ω₆ → v₆)
    cs5, sn5 = np.cos(q5), np.sin(q5)
    uxw, f = c.w4xw5, c.w4w5 * (1.0 - cs5)
    rx = w5x * cs5 + uxw[0] * sn5 + w4x * f
    ry = w5y * cs5 + uxw[1] * sn5 + w4y * f
    rz = w5z * cs5 + uxw[2] * sn5 + w4z * f
    kr = w3x * rx + w3y * ry + w3z * rz
    ax, ay, az = rx - w3x * kr, ry - w3y * kr, rz - w3z * kr
    bvx, bvy, bvz = vx - w3x * kq, vy - w3y * kq, vz - w3z * kq
    fr4 = (ax * ax + ay * ay + az * az <= 1e-18) | (bvx * bvx + bvy * bvy + bvz * bvz <= 1e-18)
    q4 = np.arctan2(
        w3x * (ay * bvz - az * bvy) + w3y * (az * bvx - ax * bvz) + w3z * (ax * bvy - ay * bvx),
        ax * bvx + ay * bvy + az * bvz,
    )
    q4 = np.where(fr4, dflt[:, 3:4], q4)
    # y = R(ω₅, −q₅) R(ω₄, −q₄) y₀; q₆ = SP1(ω₆, x → y)
    yx, yy, yz = _turn(w4, cs5, -sn5, *_turn(w3, np.cos(q4), -np.sin(q4), y0x, y0y, y0z))
    ky = w5x * yx + w5y * yy + w5z * yz
    bx, by, bz = yx - w5x * ky, yy - w5y * ky, yz - w5z * ky
    xpx, xpy, xpz = c.xp5
    fr6 = (bx * bx + by * by + bz * bz <= 1e-18) | c.x_small
    q6 = np.arctan2(
        w5x * (xpy * bz - xpz * by) + w5y * (xpz * bx - xpx * bz) + w5z * (xpx * by - xpy * bx),
        xpx * bx + xpy * by + xpz * bz,
    )
    q6 = np.where(fr6, dflt[:, 5:6], q6)
    return q4, q5, q6, ok, fr4 | fr5


def solve_three_parallel_prepared(
    c: ThreeParallel, R: FloatArray, p: FloatArray, dflt: FloatArray, trace: Trace
) -> tuple[FloatArray, BoolArray]:
    """`solve_three_parallel` for one fixed geometry whose constants `c` were prepared once
    (`_closed_form_scalar.ThreeParallel`: the same equations as its `solve`, on arrays).

    Hand-written for speed (`ik_all_batch`): vectors are kept as three (L, b) component arrays
    and constant vectors as floats, so a rotation of a constant vector costs three scaled sums
    instead of a cross product, a dot product and broadcast copies of (L, b, 3) arrays. Same
    branch layout, flags and reasons as `solve_three_parallel` (the tests compare the two).
    """
    L = R.shape[0]
    (R00, R01, R02), (R10, R11, R12), (R20, R21, R22) = (
        [R[:, i, j][:, None] for j in range(3)] for i in range(3)
    )
    px, py, pz = (p[:, i][:, None] for i in range(3))
    w0x, w0y, w0z = c.w0
    r0x, r0y, r0z = c.p0
    hx_, hy_, hz_ = c.h
    # q₁: hᵀ e₁⁻¹(G c) = hᵀc (SP4 in φ = −q₁).
    cx, cy, cz = c.c
    ax = R00 * cx + R01 * cy + R02 * cz + (px - r0x)
    ay = R10 * cx + R11 * cy + R12 * cz + (py - r0y)
    az = R20 * cx + R21 * cy + R22 * cz + (pz - r0z)
    kp = w0x * ax + w0y * ay + w0z * az
    hxw = c.hxw0
    phi, ok1, fr1 = sp.solve_trig(
        (hx_ * ax + hy_ * ay + hz_ * az - c.hw0 * kp)[:, 0],
        (hxw[0] * ax + hxw[1] * ay + hxw[2] * az)[:, 0],
        (c.d1 - c.hw0 * kp)[:, 0],
        -dflt[:, 0],
        c.eL,
    )
    trace.fails.append(("shoulder", _flag(ok1, L, 8)))
    trace.frees.append(("the wrist point lies on joint 1's axis", _flag(fr1, L, 8)))
    q1 = -phi  # (L, 2)
    c1, s1 = np.cos(q1), np.sin(q1)
    f1 = 1.0 - c1

    def turned(v0: Vec, wxv: Vec, wv: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Rᵀ R(ω₁, q₁) v of a constant v, (L, 2) components."""
        b = wv * f1
        vx = v0[0] * c1 + wxv[0] * s1 + w0x * b
        vy = v0[1] * c1 + wxv[1] * s1 + w0y * b
        vz = v0[2] * c1 + wxv[2] * s1 + w0z * b
        return (
            R00 * vx + R10 * vy + R20 * vz,
            R01 * vx + R11 * vy + R21 * vz,
            R02 * vx + R12 * vy + R22 * vz,
        )

    ux, uy, uz = turned(c.h, c.w0xh, c.hw0)
    X1 = turned(c.x, c.w0xx, c.w0x)
    H1 = turned(c.hx, c.w0xhx, c.w0hx)
    # (q₅, q₆): SP2 R(ω₅, q₅) R(ω₆, q₆) u = h, both signs of γ: (L, 2) → (L, 4).
    w4x, w4y, w4z = c.w4
    w5x, w5y, w5z = c.w5
    e2 = 1e-18
    kpu = w5x * ux + w5y * uy + w5z * uz
    alpha = (c.c45 * kpu - c.kq) / c.den
    beta = (c.c45 * c.kq - kpu) / c.den
    pp = ux * ux + uy * uy + uz * uz
    g2 = (pp - alpha * alpha - beta * beta - 2.0 * alpha * beta * c.c45) / c.n12
    ok2 = g2 >= -TANGENT_TOLERANCE * np.maximum(pp, e2)
    gamma = np.sqrt(np.maximum(g2, 0.0))
    upx, upy, upz = ux - w5x * kpu, uy - w5y * kpu, uz - w5z * kpu  # u′ normal to ω₆
    up_small = upx * upx + upy * upy + upz * upz <= e2
    gs = (gamma[:, :, None] * np.array((1.0, -1.0))).reshape(L, 4)
    alpha, beta, kpu, ux, uy, uz, upx, upy, upz, up_small = (
        _spread(a, 2) for a in (alpha, beta, kpu, ux, uy, uz, upx, upy, upz, up_small)
    )
    k12x, k12y, k12z = c.k12
    zx = alpha * w4x + beta * w5x + gs * k12x
    zy = alpha * w4y + beta * w5y + gs * k12y
    zz = alpha * w4z + beta * w5z + gs * k12z
    kz = w5x * zx + w5y * zy + w5z * zz
    bx, by, bz = zx - w5x * kz, zy - w5y * kz, zz - w5z * kz
    fr6 = up_small | (bx * bx + by * by + bz * bz <= e2)
    q6 = np.arctan2(
        w5x * (upy * bz - upz * by) + w5y * (upz * bx - upx * bz) + w5z * (upx * by - upy * bx),
        upx * bx + upy * by + upz * bz,
    )
    q6 = np.where(fr6, dflt[:, 5:6], q6)
    c6, s6 = np.cos(q6), np.sin(q6)
    f6 = kpu * (1.0 - c6)
    yx = ux * c6 + (w5y * uz - w5z * uy) * s6 + w5x * f6
    yy = uy * c6 + (w5z * ux - w5x * uz) * s6 + w5y * f6
    yz = uz * c6 + (w5x * uy - w5y * ux) * s6 + w5z * f6
    ky = w4x * yx + w4y * yy + w4z * yz
    ax, ay, az = yx - w4x * ky, yy - w4y * ky, yz - w4z * ky
    hpx, hpy, hpz = c.hp4
    fr5 = (ax * ax + ay * ay + az * az <= e2) | (c.hp4n <= e2)
    q5 = np.arctan2(
        w4x * (ay * hpz - az * hpy) + w4y * (az * hpx - ax * hpz) + w4z * (ax * hpy - ay * hpx),
        ax * hpx + ay * hpy + az * hpz,
    )
    q5 = np.where(fr5, dflt[:, 4:5], q5)
    trace.fails.append(("wrist", _flag(ok2, L, 8)))
    trace.frees.append(
        ("wrist axes aligned (joint 6 parallel to joints 2-4)", _flag(fr5 | fr6, L, 8))
    )
    # θ₂₃₄ from z₁ = R(ω₆, −q₆) R(ω₅, −q₅) x.
    c5, s5 = np.cos(q5), np.sin(q5)
    f = c.w4x * (1.0 - c5)
    x0 = c.x
    zx = x0[0] * c5 - c.w4xx[0] * s5 + w4x * f
    zy = x0[1] * c5 - c.w4xx[1] * s5 + w4y * f
    zz = x0[2] * c5 - c.w4xx[2] * s5 + w4z * f
    zx, zy, zz = _turn(c.w5, c6, -s6, zx, zy, zz)
    X4 = [_spread(a, 2) for a in X1]
    H4 = [_spread(a, 2) for a in H1]
    t234 = np.arctan2(H4[0] * zx + H4[1] * zy + H4[2] * zz, X4[0] * zx + X4[1] * zy + X4[2] * zz)
    # K r₄ = e₁⁻¹ G e₆⁻¹ e₅⁻¹ r₄
    v, wxv, f = c.v43, c.w4xv, c.w4v * (1.0 - c5)
    o = c.p4
    o5 = c.p5
    mx = (o[0] - o5[0]) + v[0] * c5 - wxv[0] * s5 + w4x * f
    my = (o[1] - o5[1]) + v[1] * c5 - wxv[1] * s5 + w4y * f
    mz = (o[2] - o5[2]) + v[2] * c5 - wxv[2] * s5 + w4z * f
    mx, my, mz = _turn(c.w5, c6, -s6, mx, my, mz)
    mx, my, mz = mx + o5[0], my + o5[1], mz + o5[2]
    nx = R00 * mx + R01 * my + R02 * mz + (px - r0x)
    ny = R10 * mx + R11 * my + R12 * mz + (py - r0y)
    nz = R20 * mx + R21 * my + R22 * mz + (pz - r0z)
    kx, ky, kz = _turn(c.w0, _spread(c1, 2), -_spread(s1, 2), nx, ny, nz)
    r1 = c.p1
    krx, kry, krz = kx + (r0x - r1[0]), ky + (r0y - r1[1]), kz + (r0z - r1[2])
    # q₃: SP3 with constant p = r₄ − r₃, q = r₂ − r₃: (L, 4) → (L, 8).
    delta2 = krx * krx + kry * kry + krz * krz - c.dk3 * c.dk3
    q3, ok3, fr3 = sp.solve_trig(
        np.float64(c.a3), np.float64(c.b3), 0.5 * (c.pq3 - delta2), dflt[:, 2:3], c.eL2
    )
    trace.fails.append(("elbow", _flag(ok3, L, 8)))
    fr3 = np.broadcast_to(fr3, (L, 4))  # (a constant: a and b of this SP3 do not vary)
    trace.frees.append(("joint 4's axis passes through joint 3's axis", _flag(fr3, L, 8)))
    q3 = q3.reshape(L, 8)
    # q₂ = SP1(ω₂, e₃ r₄ − r₂ → K r₄ − r₂); the projection of the latter is shared.
    w1x, w1y, w1z = c.w1
    kk = w1x * krx + w1y * kry + w1z * krz
    bx, by, bz = krx - w1x * kk, kry - w1y * kk, krz - w1z * kk
    b_small = bx * bx + by * by + bz * bz <= c.eLsq
    bx, by, bz, b_small = (_spread(a, 2) for a in (bx, by, bz, b_small))
    c3, s3_ = np.cos(q3), np.sin(q3)
    v, wxv, v21, w2d = c.v32, c.w2xv, c.v21, c.w2
    f = c.w2v * (1.0 - c3)
    ex = v21[0] + v[0] * c3 + wxv[0] * s3_ + w2d[0] * f
    ey = v21[1] + v[1] * c3 + wxv[1] * s3_ + w2d[1] * f
    ez = v21[2] + v[2] * c3 + wxv[2] * s3_ + w2d[2] * f
    ke = w1x * ex + w1y * ey + w1z * ez
    ax, ay, az = ex - w1x * ke, ey - w1y * ke, ez - w1z * ke
    fr4 = b_small | (ax * ax + ay * ay + az * az <= c.eLsq)
    q2 = np.arctan2(
        w1x * (ay * bz - az * by) + w1y * (az * bx - ax * bz) + w1z * (ax * by - ay * bx),
        ax * bx + ay * by + az * bz,
    )
    q2 = np.where(fr4, dflt[:, 1:2], q2)
    trace.frees.append(("the elbow point lies on joint 2's axis", fr4))
    s2, s3, s4 = c.s
    q4 = s4 * (_spread(t234, 2) - s2 * q2 - s3 * q3)
    Q = np.stack((_spread(q1, 4), q2, q3, q4, _spread(q5, 2), _spread(q6, 2)), axis=-1)
    ok = np.ones((L, 8), dtype=bool)
    for _, fl in trace.fails:
        ok &= fl
    return Q, ok


def _turn(
    k: Vec, c: FloatArray, s: FloatArray, x: FloatArray, y: FloatArray, z: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """R(k, θ) (x, y, z) for a constant unit k, with c = cos θ, s = sin θ (component arrays)."""
    k0, k1, k2 = k
    f = (k0 * x + k1 * y + k2 * z) * (1.0 - c)
    return (
        x * c + (k1 * z - k2 * y) * s + k0 * f,
        y * c + (k2 * x - k0 * z) * s + k1 * f,
        z * c + (k0 * y - k1 * x) * s + k2 * f,
    )
