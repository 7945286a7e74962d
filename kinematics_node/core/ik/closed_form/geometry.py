"""Geometry shared by the closed-form families: lines of screw axes, points and rotations.

On plain floats (3-tuples, for one target: NumPy's per-call overhead of about 1 µs per operation
on tiny arrays dominates there) and in lanes (arrays with a leading lane axis: targets, or target ×
held-joint value). The scalar subproblems here mirror `kinematics_node.core.ik.subproblems` line by
line (same equations, same branch order, same tolerances). Also: the per-lane `LaneGeometry` of a
6R problem, the scalar `Geometry` (its lane 0), pose errors and angle wrapping.

Angles [rad], lengths [m].
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from math import acos, atan2, ceil, cos, hypot, pi, sin, sqrt
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...model import TWO_PI
from .. import subproblems as sp
from ..subproblems import TANGENT_TOLERANCE

FloatArray = NDArray[np.float64]


BoolArray = NDArray[np.bool_]


IntArray = NDArray[np.int64]


Rows = list[list[float]]


INV_TWO_PI = 1.0 / TWO_PI

#: Three floats, or three arrays of one shape (a vector as components: `turn_parts`, …).
Triple = tuple[Any, Any, Any]


def axis_lines(S: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Directions ω (n, 3) and the points r = ω × v nearest the origin (n, 3) of revolute screws."""
    w = S[:3].T.copy()
    return w, sp.cross(w, S[3:].T)


def meet_point(w: FloatArray, r: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Least-squares point nearest the lines (…, m, 3) and its largest distance from them (…).

    Σ (I − ωωᵀ) x = Σ (I − ωωᵀ) r (normal equations of Σ dist(x, line)²). Where those are
    singular (parallel lines: every point of a line is as near) the least-squares point nearest the
    origin (pseudo-inverse); the distance is the same for each of them.
    """
    P = np.eye(3) - w[..., :, None] * w[..., None, :]  # (…, m, 3, 3)
    A = P.sum(axis=-3)
    y = (P @ r[..., None])[..., 0].sum(axis=-2)
    try:
        x = np.linalg.solve(A, y[..., None])[..., 0]
    except np.linalg.LinAlgError:  # exactly parallel lines (fuzzed and planar arms)
        x = (np.linalg.pinv(A, rcond=1e-12) @ y[..., None])[..., 0]
    d = x[..., None, :] - r
    d = d - w * sp.dot(d, w)[..., None]
    return x, sp.norm(d).max(axis=-1)


def perpendicular_lanes(a: FloatArray) -> FloatArray:
    """A unit vector normal to each unit vector a (…, 3)."""
    helper = np.where(
        (np.abs(a[..., 0]) < 0.9)[..., None], np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
    )
    x = sp.cross(a, helper)
    return x / sp.norm(x)[..., None]


def exp_rotation(w: FloatArray, r: FloatArray, theta: FloatArray) -> FloatArray:
    """e^{[S]θ} (K, 4, 4) of a revolute axis through r with unit direction w (MR eq. 3.51, 3.88)."""
    K = theta.shape[0]
    W = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])  # [ω]×
    E = np.zeros((K, 4, 4))
    s, c = np.sin(theta)[:, None, None], np.cos(theta)[:, None, None]
    E[:, :3, :3] = np.eye(3) + s * W + (1.0 - c) * (W @ W)  # Rodrigues
    E[:, :3, 3] = r - E[:, :3, :3] @ r
    E[:, 3, 3] = 1.0
    return E


def transform_points(T: FloatArray, x: FloatArray) -> FloatArray:
    """T x for T (K, 4, 4) and points x (K, m, 3) or (m, 3)."""
    return (
        np.einsum(
            "kij,k...j->k...i", T[:, :3, :3], np.broadcast_to(x, (T.shape[0],) + x.shape[-2:])
        )
        + T[:, None, :3, 3]
    )


def scalar_lane(g: LaneGeometry, k: int) -> Geometry:
    """Lane k of a vectorised geometry as the scalar solvers' tuples of floats."""

    def t(a: FloatArray) -> Vec:
        return (float(a[0]), float(a[1]), float(a[2]))

    return Geometry(
        [t(v) for v in g.w[k]], [t(v) for v in g.r[k]], t(g.c[k]), t(g.b[k]),
        t(g.h[k]), t(g.x[k]), t(g.s[k]), g.scale,
    )  # fmt: skip


def wrap_angles(a: FloatArray) -> FloatArray:
    """Angles into (−π, π]."""
    return a - TWO_PI * np.ceil((a - math.pi) / TWO_PI)


def wrap_angle(a: float) -> float:
    """One angle into (−π, π]."""
    return a - TWO_PI * math.ceil((a - math.pi) / TWO_PI)


def inverse_transforms(T: FloatArray) -> FloatArray:
    """T⁻¹ = (Rᵀ, −Rᵀp) for (K, 4, 4) rigid transforms."""
    out = np.zeros_like(T)
    Rt = T[:, :3, :3].swapaxes(1, 2)
    out[:, :3, :3] = Rt
    out[:, :3, 3] = -(Rt @ T[:, :3, 3:4])[..., 0]
    out[:, 3, 3] = 1.0
    return out


def tile_lanes(g: LaneGeometry, N: int) -> LaneGeometry:
    """Lane geometry (K lanes) repeated for N targets: lane i·K + k is target i, held value k."""

    def t(a: FloatArray) -> FloatArray:
        return np.tile(a, (N,) + (1,) * (a.ndim - 1))

    return LaneGeometry(t(g.w), t(g.r), t(g.c), t(g.b), t(g.h), t(g.x), t(g.s), g.scale)


def insert_held(Q6: FloatArray, j: int, values: FloatArray) -> FloatArray:
    """Insert the held joint's value as column j: (L, B, 6) → (L, B, 7)."""
    L = Q6.shape[0]
    col = np.broadcast_to(values[:, None, None], (L, Q6.shape[1], 1))
    return np.concatenate((Q6[..., :j], col, Q6[..., j:]), axis=2)


def pose_errors(T: FloatArray, T_t: FloatArray) -> tuple[FloatArray, FloatArray]:
    """‖p − p_t‖ [m] and the rotation angle between R and R_t [rad] of poses T (K, 4, 4) against
    T_t (K or 1, 4, 4) (from ‖R − R_t‖_F = 2√2 sin(θ/2), accurate at small angles, unlike arccos
    of the trace)."""
    dp = sp.norm(T[:, :3, 3] - T_t[:, :3, 3])
    f = np.sqrt(((T[:, :3, :3] - T_t[:, :3, :3]) ** 2).sum(axis=(1, 2)))
    return dp, 2.0 * np.arcsin(np.minimum(f / (2.0 * math.sqrt(2.0)), 1.0))


def chord_angle(f: float) -> float:
    """The rotation angle [rad] between two rotations with ‖R_a − R_b‖_F² = f (`pose_errors`)."""
    return 2.0 * math.asin(min(math.sqrt(f) / (2.0 * math.sqrt(2.0)), 1.0))


def pose_errors_list(A: list[list[float]], B: list[list[float]]) -> tuple[float, float]:
    """`pose_errors` of one pose pair given as nested lists: ‖Δp‖ [m], rotation angle [rad]."""
    a0, a1, a2 = A[0], A[1], A[2]
    b0, b1, b2 = B[0], B[1], B[2]
    dp = math.hypot(a0[3] - b0[3], a1[3] - b1[3], a2[3] - b2[3])  # (no overflow for far targets)
    f = 0.0
    for a, b in ((a0, b0), (a1, b1), (a2, b2)):
        f += (a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2 + (a[2] - b[2]) ** 2
    return dp, chord_angle(f)


Vec = tuple[float, float, float]


Mat = tuple[Vec, Vec, Vec]  # rows


def dot(a: Vec, b: Vec) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a: Vec, b: Vec) -> Vec:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def sub(a: Vec, b: Vec) -> Vec:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def add(a: Vec, b: Vec) -> Vec:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def norm(a: Vec) -> float:
    return sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


def matvec(R: Mat, x: Vec) -> Vec:
    return (dot(R[0], x), dot(R[1], x), dot(R[2], x))


def rotate(k: Vec, theta: float, x: Vec) -> Vec:
    """R(k, θ) x = x cos θ + (k × x) sin θ + k (kᵀx)(1 − cos θ) (written out: the hot loop)."""
    c, s = cos(theta), sin(theta)
    k0, k1, k2 = k
    x0, x1, x2 = x
    f = (k0 * x0 + k1 * x1 + k2 * x2) * (1.0 - c)
    return (
        x0 * c + (k1 * x2 - k2 * x1) * s + k0 * f,
        x1 * c + (k2 * x0 - k0 * x2) * s + k1 * f,
        x2 * c + (k0 * x1 - k1 * x0) * s + k2 * f,
    )


def rotate_about(k: Vec, r: Vec, theta: float, x: Vec) -> Vec:
    """r + R(k, θ)(x − r) (written out: the hot loop)."""
    c, s = cos(theta), sin(theta)
    k0, k1, k2 = k
    r0, r1, r2 = r
    x0, x1, x2 = x[0] - r0, x[1] - r1, x[2] - r2
    f = (k0 * x0 + k1 * x1 + k2 * x2) * (1.0 - c)
    return (
        r0 + x0 * c + (k1 * x2 - k2 * x1) * s + k0 * f,
        r1 + x1 * c + (k2 * x0 - k0 * x2) * s + k1 * f,
        r2 + x2 * c + (k0 * x1 - k1 * x0) * s + k2 * f,
    )


def perpendicular(a: Vec) -> Vec:
    """A unit vector normal to the unit vector a (the same choice as `perpendicular_lanes`)."""
    x = cross(a, (1.0, 0.0, 0.0) if abs(a[0]) < 0.9 else (0.0, 1.0, 0.0))
    n = norm(x)
    return (x[0] / n, x[1] / n, x[2] / n)


def project_out(k: Vec, p: Vec) -> Vec:
    kp = dot(k, p)
    return (p[0] - k[0] * kp, p[1] - k[1] * kp, p[2] - k[2] * kp)


def solve_trig(
    a: float, b: float, c: float, default: float, eps: float
) -> tuple[tuple[float, float], bool, bool]:
    """Both θ with a cos θ + b sin θ = c (see `subproblems.solve_trig`): (θ₊, θ₋), ok, free."""
    rho = hypot(a, b)
    if rho <= eps:
        return (default, default), abs(c) <= eps, True
    x = c / rho
    if abs(x) > 1.0 + TANGENT_TOLERANCE:
        return (default, default), False, False
    phi = atan2(b, a)
    d = acos(min(1.0, max(-1.0, x)))
    return (phi + d, phi - d), True, False


def sp1(k: Vec, p: Vec, q: Vec, default: float, eps: float) -> tuple[float, bool]:
    """θ with R(k, θ) p = q (see `subproblems.sp1`): θ, free. (Written out: the hot loop;
    ‖x‖ ≤ ε is tested as ‖x‖² ≤ ε².)"""
    k0, k1, k2 = k
    p0, p1, p2 = p
    q0, q1, q2 = q
    kp = k0 * p0 + k1 * p1 + k2 * p2
    kq = k0 * q0 + k1 * q1 + k2 * q2
    a0, a1, a2 = p0 - k0 * kp, p1 - k1 * kp, p2 - k2 * kp  # p projected onto the plane ⟂ k
    b0, b1, b2 = q0 - k0 * kq, q1 - k1 * kq, q2 - k2 * kq
    e2 = eps * eps
    if a0 * a0 + a1 * a1 + a2 * a2 <= e2 or b0 * b0 + b1 * b1 + b2 * b2 <= e2:
        return default, True
    return atan2(*turn_parts(k, (a0, a1, a2), (b0, b1, b2))), False


def sp2(
    k1: Vec, k2: Vec, p: Vec, q: Vec, default1: float, default2: float, eps: float
) -> list[tuple[float, float, bool]]:
    """(θ₁, θ₂, free) for both signs of γ with R(k₁, θ₁) R(k₂, θ₂) p = q, or [] (see `subproblems.sp2`)."""
    return PreparedSP2(k1, k2).solve(p, q, default1, default2, eps)


def sp3(
    k: Vec, p: Vec, q: Vec, delta: float, default: float, eps: float
) -> tuple[tuple[float, float], bool, bool]:
    """θ with ‖R(k, θ) p − q‖ = δ (see `subproblems.sp3`): (θ₊, θ₋), ok, free."""
    pp, qp = project_out(k, p), project_out(k, q)
    dk = dot(k, sub(p, q))
    c = 0.5 * (dot(pp, pp) + dot(qp, qp) - (delta * delta - dk * dk))
    return solve_trig(dot(pp, qp), dot(k, cross(pp, qp)), c, default, eps)


def sp4(
    k: Vec, p: Vec, h: Vec, d: float, default: float, eps: float
) -> tuple[tuple[float, float], bool, bool]:
    """θ with hᵀ R(k, θ) p = d (see `subproblems.sp4`): (θ₊, θ₋), ok, free."""
    kp = dot(k, p)
    a = dot(h, project_out(k, p))
    b = dot(h, cross(k, p))
    return solve_trig(a, b, d - dot(h, k) * kp, default, eps)


class Geometry:
    """Lane 0 of a `LaneGeometry` as tuples of floats."""

    def __init__(self, w: Sequence[Vec], r: Sequence[Vec], c: Vec, b: Vec, h: Vec, x: Vec,
                 s: Vec, scale: float) -> None:  # fmt: skip
        self.w, self.r, self.c, self.b, self.h, self.x, self.s = list(w), list(r), c, b, h, x, s
        self.eL, self.eL2 = 1e-9 * scale, 1e-12 * scale * scale
        # Constants of the three-parallel elbow SP3 (k = ω₃, p = r₄ − r₃, q = r₂ − r₃).
        k, p, q = self.w[2], sub(self.r[3], self.r[2]), sub(self.r[1], self.r[2])
        pp, qp = project_out(k, p), project_out(k, q)
        self.a3, self.b3 = dot(pp, qp), dot(k, cross(pp, qp))
        self.pq3, self.dk3 = dot(pp, pp) + dot(qp, qp), dot(k, sub(p, q))


#: A candidate: six angles and the reasons of the angles the target left free.
Candidate = tuple[list[float], tuple[str, ...]]


class Stages:
    """How many branches passed each stage; the first stage none passed explains an empty set."""

    def __init__(self, names: Sequence[str]) -> None:
        self.passed = dict.fromkeys(names, 0)

    def first_dead(self) -> str | None:
        for name, n in self.passed.items():
            if n == 0:
                return name
        return None


def rotate_cs(k: Vec, c: float, s: float, x: Vec) -> Vec:
    """R(k, θ) x with c = cos θ, s = sin θ given (Rodrigues, written out)."""
    k0, k1, k2 = k
    x0, x1, x2 = x
    f = (k0 * x0 + k1 * x1 + k2 * x2) * (1.0 - c)
    return (
        x0 * c + (k1 * x2 - k2 * x1) * s + k0 * f,
        x1 * c + (k2 * x0 - k0 * x2) * s + k1 * f,
        x2 * c + (k0 * x1 - k1 * x0) * s + k2 * f,
    )


def turn_parts(k: Vec, a: Triple, b: Triple) -> tuple[Any, Any]:
    """(kᵀ(a × b), aᵀb) of vectors a, b normal to the unit axis k: the angle about k that turns a
    onto b is atan2 of the pair (SP1 once both are projected normal to k). Works on floats and,
    unchanged, on component arrays (a, b as triples of arrays): the families' scalar solvers and
    their vectorised twins share it. Written out: it runs for every branch of every call."""
    k0, k1, k2 = k
    a0, a1, a2 = a
    b0, b1, b2 = b
    return (
        k0 * (a1 * b2 - a2 * b1) + k1 * (a2 * b0 - a0 * b2) + k2 * (a0 * b1 - a1 * b0),
        a0 * b0 + a1 * b1 + a2 * b2,
    )


def sp2_parts(c: float, den: float, n12: float, kp: Any, kq: Any, pp: Any) -> tuple[Any, Any, Any]:
    """SP2's (α, β, γ²) with z = α k₁ + β k₂ + γ (k₁ × k₂) (`subproblems.sp2`), from the axes'
    constants c = k₁ᵀk₂, den = c² − 1, n12 = ‖k₁ × k₂‖² and kp = k₂ᵀp, kq = k₁ᵀq, pp = ‖p‖².
    Floats or arrays alike (as `turn_parts`)."""
    alpha = (c * kp - kq) / den
    beta = (c * kq - kp) / den
    return alpha, beta, (pp - alpha * alpha - beta * beta - 2.0 * alpha * beta * c) / n12


def sp2_between(k1: Vec, k2: Vec, k12: Vec, alpha: Any, beta: Any, gamma: Any) -> Triple:
    """SP2's intermediate point z = α k₁ + β k₂ + γ (k₁ × k₂) projected normal to k₂: the target
    of the SP1 about k₂ that follows (`turn_parts`). Floats or arrays alike."""
    zx = alpha * k1[0] + beta * k2[0] + gamma * k12[0]
    zy = alpha * k1[1] + beta * k2[1] + gamma * k12[1]
    zz = alpha * k1[2] + beta * k2[2] + gamma * k12[2]
    kz = k2[0] * zx + k2[1] * zy + k2[2] * zz
    return zx - k2[0] * kz, zy - k2[1] * kz, zz - k2[2] * kz


def wrap(a: float) -> float:
    """One angle into (−π, π] (as `wrap_angles`)."""
    return a - TWO_PI * ceil((a - pi) / TWO_PI)


class PreparedSP2:
    """The target-independent part of SP2 about two fixed axes k₁, k₂ (`sp2`): kᵢᵀkⱼ, k₁ × k₂, …"""

    __slots__ = ("k1", "k2", "c", "k12", "den", "n12")

    def __init__(self, k1: Vec, k2: Vec) -> None:
        self.k1, self.k2 = k1, k2
        self.c = dot(k1, k2)
        self.k12 = cross(k1, k2)
        self.den = self.c * self.c - 1.0
        self.n12 = dot(self.k12, self.k12)

    def solve(
        self, p: Vec, q: Vec, default1: float, default2: float, eps: float
    ) -> list[tuple[float, float, bool]]:
        """`sp2(k1, k2, p, q, default1, default2, eps)` with this object's axes."""
        k1, k2, c, k12 = self.k1, self.k2, self.c, self.k12
        kp = k2[0] * p[0] + k2[1] * p[1] + k2[2] * p[2]
        kq = k1[0] * q[0] + k1[1] * q[1] + k1[2] * q[2]
        pp = p[0] * p[0] + p[1] * p[1] + p[2] * p[2]
        alpha, beta, g2 = sp2_parts(c, self.den, self.n12, kp, kq, pp)
        if g2 < -TANGENT_TOLERANCE * max(pp, eps * eps):
            return []
        gamma = sqrt(max(g2, 0.0))
        out = []
        for g in (gamma, -gamma):
            z = (
                alpha * k1[0] + beta * k2[0] + g * k12[0],
                alpha * k1[1] + beta * k2[1] + g * k12[1],
                alpha * k1[2] + beta * k2[2] + g * k12[2],
            )
            t2, f2 = sp1(k2, p, z, default2, eps)
            t1, f1 = sp1(k1, rotate(k2, t2, p), q, default1, eps)
            out.append((t1, t2, f1 or f2))
        return out


class PreparedSP3:
    """SP3 ‖R(k, θ) p − q‖ = δ with k, p and q fixed (`sp3`): only δ comes with the target."""

    __slots__ = ("a", "b", "pq", "dk2")

    def __init__(self, k: Vec, p: Vec, q: Vec) -> None:
        pp, qp = project_out(k, p), project_out(k, q)
        dk = dot(k, sub(p, q))
        self.a, self.b = dot(pp, qp), dot(k, cross(pp, qp))
        self.pq, self.dk2 = dot(pp, pp) + dot(qp, qp), dk * dk

    def solve(
        self, delta2: float, default: float, eps: float
    ) -> tuple[tuple[float, float], bool, bool]:
        """`sp3(k, p, q, δ, default, eps)` given δ² (the same up to the rounding of √ then ²)."""
        return solve_trig(self.a, self.b, 0.5 * (self.pq - (delta2 - self.dk2)), default, eps)


def reasons_of(*flags: tuple[bool, str]) -> tuple[str, ...]:
    return tuple(text for flag, text in flags if flag)


@dataclass(frozen=True)
class LaneGeometry:
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

    def passed(self, L: int, B: int) -> BoolArray:
        """(L, B): the branches that passed every stage recorded in `fails`."""
        ok = np.ones((L, B), dtype=bool)
        for _, f in self.fails:
            ok &= f
        return ok


def spread_branches(a: NDArray, n: int) -> NDArray:
    """Repeat the branch axis (axis 1) of a (L, B, …) array for n sub-branches: (L, B·n, …)."""
    return np.repeat(a, n, axis=1)


def per_lane(a: FloatArray) -> FloatArray:
    """A per-lane vector (L, 3) → (L, 1, 3), to broadcast over branches."""
    return a[:, None, :]


def apply_rotation(R: FloatArray, x: FloatArray) -> FloatArray:
    """R x for per-lane R (L, 3, 3) and x (L, B, 3) or (L, 3)."""
    if x.ndim == 3:
        R = R[:, None]
    x0, x1, x2 = x[..., 0], x[..., 1], x[..., 2]
    return np.stack(
        [R[..., i, 0] * x0 + R[..., i, 1] * x1 + R[..., i, 2] * x2 for i in range(3)], axis=-1
    )  # written out: faster than einsum or stacked matmul for 3-vectors


def branch_flag(a: NDArray, L: int, n: int) -> BoolArray:
    """Per-branch flags in any branch layout ((Lg,), (Lg, b), (Lg, b, b′)) → (L, n)."""
    a = np.asarray(a, dtype=bool)
    a = a.reshape(a.shape[0], -1)
    a = np.broadcast_to(a, (L, a.shape[1]))
    return np.repeat(a, n // a.shape[1], axis=1)


def grow_branches(a: NDArray, n: int) -> NDArray:
    """Branch layout (L,), (L, b) or (L, b, 3) → (L, n[, 3]): each branch repeated n/b times."""
    L = a.shape[0]
    if a.ndim == 1:
        a = a[:, None]
    return np.repeat(a, n // a.shape[1], axis=1).reshape((L, n) + a.shape[2:])


def turn_components(
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
