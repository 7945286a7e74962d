"""Single-target twin of the vectorised closed-form solvers in `closed_form`, in plain Python floats.

For one target NumPy's per-call overhead (about 1 µs per operation on tiny arrays) dominates the
vectorised solvers; the same equations on Python floats take a tenth of the time. Every function
here mirrors one in `subproblems` or `closed_form` line by line (same equations, same branch
order, same tolerances), and the tests check that both paths return the same solutions.

Vectors are 3-tuples of floats. Angles [rad], lengths [m].
"""

from __future__ import annotations

from collections.abc import Sequence
from math import acos, atan2, cos, hypot, sin, sqrt

from .subproblems import TANGENT_TOLERANCE

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
    """A unit vector normal to the unit vector a (the same choice as `closed_form._perpendicular`)."""
    x = cross(a, (1.0, 0.0, 0.0) if abs(a[0]) < 0.9 else (0.0, 1.0, 0.0))
    n = norm(x)
    return (x[0] / n, x[1] / n, x[2] / n)


def _project(k: Vec, p: Vec) -> Vec:
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
    y = k0 * (a1 * b2 - a2 * b1) + k1 * (a2 * b0 - a0 * b2) + k2 * (a0 * b1 - a1 * b0)
    return atan2(y, a0 * b0 + a1 * b1 + a2 * b2), False


def sp2(
    k1: Vec, k2: Vec, p: Vec, q: Vec, default1: float, default2: float, eps: float
) -> list[tuple[float, float, bool]]:
    """(θ₁, θ₂, free) for both signs of γ with R(k₁, θ₁) R(k₂, θ₂) p = q, or [] (see `subproblems.sp2`)."""
    c = dot(k1, k2)
    k12 = cross(k1, k2)
    den = c * c - 1.0
    kp, kq = dot(k2, p), dot(k1, q)
    alpha = (c * kp - kq) / den
    beta = (c * kq - kp) / den
    pp = dot(p, p)
    g2 = (pp - alpha * alpha - beta * beta - 2.0 * alpha * beta * c) / dot(k12, k12)
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


def sp3(
    k: Vec, p: Vec, q: Vec, delta: float, default: float, eps: float
) -> tuple[tuple[float, float], bool, bool]:
    """θ with ‖R(k, θ) p − q‖ = δ (see `subproblems.sp3`): (θ₊, θ₋), ok, free."""
    pp, qp = _project(k, p), _project(k, q)
    dk = dot(k, sub(p, q))
    c = 0.5 * (dot(pp, pp) + dot(qp, qp) - (delta * delta - dk * dk))
    return solve_trig(dot(pp, qp), dot(k, cross(pp, qp)), c, default, eps)


def sp4(
    k: Vec, p: Vec, h: Vec, d: float, default: float, eps: float
) -> tuple[tuple[float, float], bool, bool]:
    """θ with hᵀ R(k, θ) p = d (see `subproblems.sp4`): (θ₊, θ₋), ok, free."""
    kp = dot(k, p)
    a = dot(h, _project(k, p))
    b = dot(h, cross(k, p))
    return solve_trig(a, b, d - dot(h, k) * kp, default, eps)


class Geometry:
    """The lane-0 `closed_form._Geometry` as tuples of floats."""

    def __init__(self, w: Sequence[Vec], r: Sequence[Vec], c: Vec, b: Vec, h: Vec, x: Vec,
                 s: Vec, scale: float) -> None:  # fmt: skip
        self.w, self.r, self.c, self.b, self.h, self.x, self.s = list(w), list(r), c, b, h, x, s
        self.eL, self.eL2 = 1e-9 * scale, 1e-12 * scale * scale
        # Constants of the three-parallel elbow SP3 (k = ω₃, p = r₄ − r₃, q = r₂ − r₃).
        k, p, q = self.w[2], sub(self.r[3], self.r[2]), sub(self.r[1], self.r[2])
        pp, qp = _project(k, p), _project(k, q)
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


def three_parallel(
    g: Geometry, R: Mat, p: Vec, d: Sequence[float], stages: Stages
) -> list[Candidate]:
    """Mirror of `closed_form._solve_three_parallel` (same equations, same branch order)."""
    W, P, h, c = g.w, g.r, g.h, g.c
    Rt: Mat = (
        (R[0][0], R[1][0], R[2][0]),
        (R[0][1], R[1][1], R[2][1]),
        (R[0][2], R[1][2], R[2][2]),
    )
    out: list[Candidate] = []
    pc = add(matvec(R, c), p)
    th1, ok1, fr1 = sp4(W[0], sub(pc, P[0]), h, dot(h, sub(c, P[0])), -d[0], g.eL)
    if not ok1:
        return out
    stages.passed["shoulder"] += 2
    why1 = ("the wrist point lies on joint 1's axis",) if fr1 else ()
    s2, s3, s4 = g.s
    for phi in th1:
        q1 = -phi
        u = matvec(Rt, rotate(W[0], q1, h))
        for q5, q6, fr2 in sp2(W[4], W[5], u, h, d[4], d[5], 1e-9):
            stages.passed["wrist"] += 1
            why2 = why1 + (("wrist axes aligned (joint 6 parallel to joints 2-4)",) if fr2 else ())
            y = rotate(W[0], -q1, matvec(R, rotate(W[5], -q6, rotate(W[4], -q5, g.x))))
            t234 = atan2(dot(h, cross(g.x, y)), dot(g.x, y))
            k = rotate_about(W[4], P[4], -q5, P[3])
            k = rotate_about(W[0], P[0], -q1, add(matvec(R, rotate_about(W[5], P[5], -q6, k)), p))
            # SP3 with constant p = r₄ − r₃, q = r₂ − r₃ (a, b and ‖p′‖² + ‖q′‖² precomputed).
            kr = sub(k, P[1])
            delta2 = dot(kr, kr) - g.dk3 * g.dk3
            th3, ok3, fr3 = solve_trig(g.a3, g.b3, 0.5 * (g.pq3 - delta2), d[2], g.eL2)
            if not ok3:
                continue
            stages.passed["elbow"] += 2
            why3 = why2 + (("joint 4's axis passes through joint 3's axis",) if fr3 else ())
            for q3 in th3:
                x3 = rotate_about(W[2], P[2], q3, P[3])
                q2, fr4 = sp1(W[1], sub(x3, P[1]), sub(k, P[1]), d[1], g.eL)
                q4 = s4 * (t234 - s2 * q2 - s3 * q3)
                why = why3 + (("the elbow point lies on joint 2's axis",) if fr4 else ())
                out.append(([q1, q2, q3, q4, q5, q6], why))
    return out


def spherical(
    case: str, g: Geometry, R: Mat, p: Vec, d: Sequence[float], stages: Stages
) -> list[Candidate]:
    """Mirror of `closed_form._solve_spherical` (same equations, same branch order)."""
    W, P, c, b, h = g.w, g.r, g.c, g.b, g.h
    eL, eL2 = g.eL, g.eL2
    pc = add(matvec(R, c), p)
    arms: list[tuple[float, float, float, tuple[str, ...]]] = []  # (q1, q2, q3, why)
    if case == "par23":
        th1, okA, frA = sp4(W[0], sub(pc, P[0]), h, dot(h, sub(c, P[0])), -d[0], eL)
        if okA:
            stages.passed["shoulder"] += 2
            for phi in th1:
                q1 = -phi
                wp = rotate_about(W[0], P[0], -q1, pc)
                th3, okB, frB = sp3(
                    W[2], sub(c, P[2]), sub(P[1], P[2]), norm(sub(wp, P[1])), d[2], eL2
                )
                if not okB:
                    continue
                stages.passed["elbow"] += 2
                for q3 in th3:
                    x = rotate_about(W[2], P[2], q3, c)
                    q2, frC = sp1(W[1], sub(x, P[1]), sub(wp, P[1]), d[1], eL)
                    why = _why((frA, "the wrist centre lies on joint 1's axis"),
                               (frB, "the wrist centre lies on joint 3's axis"),
                               (frC, "the wrist centre lies on joint 2's axis"))  # fmt: skip
                    arms.append((q1, q2, q3, why))
    elif case == "int12":
        th3, okA, frA = sp3(W[2], sub(c, P[2]), sub(b, P[2]), norm(sub(pc, b)), d[2], eL2)
        if okA:
            stages.passed["elbow"] += 2
            for q3 in th3:
                x = rotate_about(W[2], P[2], q3, c)
                for q1, q2, frB in sp2(W[0], W[1], sub(x, b), sub(pc, b), d[0], d[1], eL):
                    stages.passed["shoulder"] += 1
                    why = _why((frA, "the wrist centre lies on joint 3's axis"),
                               (frB, "the wrist centre lies on joint 1's axis"))  # fmt: skip
                    arms.append((q1, q2, q3, why))
    elif case == "int23":
        th1, okA, frA = sp3(W[0], sub(pc, P[0]), sub(b, P[0]), norm(sub(c, b)), -d[0], eL2)
        if okA:
            stages.passed["shoulder"] += 2
            for phi in th1:
                q1 = -phi
                wp = rotate_about(W[0], P[0], -q1, pc)
                for q2, q3, frB in sp2(W[1], W[2], sub(c, b), sub(wp, b), d[1], d[2], eL):
                    stages.passed["elbow"] += 1
                    why = _why((frA, "the wrist centre lies on joint 1's axis"),
                               (frB, "the wrist centre lies on joint 2's axis"))  # fmt: skip
                    arms.append((q1, q2, q3, why))
    else:  # "par12"
        th3, okA, frA = sp4(W[2], sub(c, P[2]), h, dot(h, sub(pc, P[2])), d[2], eL)
        if okA:
            stages.passed["shoulder"] += 2
            for q3 in th3:
                x = rotate_about(W[2], P[2], q3, c)
                th2, okB, frB = sp3(
                    W[1], sub(x, P[1]), sub(P[0], P[1]), norm(sub(pc, P[0])), d[1], eL2
                )
                if not okB:
                    continue
                stages.passed["elbow"] += 2
                for q2 in th2:
                    y = rotate_about(W[1], P[1], q2, x)
                    q1, frC = sp1(W[0], sub(y, P[0]), sub(pc, P[0]), d[0], eL)
                    why = _why((frA, "the wrist centre lies on joint 3's axis"),
                               (frB, "the wrist centre lies on joint 2's axis"),
                               (frC, "the wrist centre lies on joint 1's axis"))  # fmt: skip
                    arms.append((q1, q2, q3, why))
    out: list[Candidate] = []
    Rw5, Rx = matvec(R, W[5]), matvec(R, g.x)
    for q1, q2, q3, why in arms:
        v6 = rotate(W[2], -q3, rotate(W[1], -q2, rotate(W[0], -q1, Rw5)))
        y0 = rotate(W[2], -q3, rotate(W[1], -q2, rotate(W[0], -q1, Rx)))
        for q4, q5, frD in sp2(W[3], W[4], W[5], v6, d[3], d[4], 1e-9):
            stages.passed["wrist"] += 1
            y = rotate(W[4], -q5, rotate(W[3], -q4, y0))
            q6, _ = sp1(W[5], g.x, y, d[5], 1e-9)
            w = why + (("wrist axes aligned (joints 4 and 6 coincide)",) if frD else ())
            out.append(([q1, q2, q3, q4, q5, q6], w))
    return out


def _why(*flags: tuple[bool, str]) -> tuple[str, ...]:
    return tuple(text for flag, text in flags if flag)
