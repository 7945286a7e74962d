"""Single-target twin of the vectorised closed-form solvers in `closed_form`, in plain Python floats.

For one target NumPy's per-call overhead (about 1 µs per operation on tiny arrays) dominates the
vectorised solvers; the same equations on Python floats take a tenth of the time. Every function
here mirrors one in `subproblems` or `closed_form` line by line (same equations, same branch
order, same tolerances), and the tests check that both paths return the same solutions.

Vectors are 3-tuples of floats. Angles [rad], lengths [m].
"""

from __future__ import annotations

from collections.abc import Sequence
from math import acos, atan2, ceil, cos, hypot, pi, sin, sqrt

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
    return _SP2(k1, k2).solve(p, q, default1, default2, eps)


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


class ThreeParallel:
    """`three_parallel` for one fixed geometry (a 6R arm read from its base), with every quantity
    that does not depend on the target computed once here.

    Hand-written for speed: one `ik_all` call on a UR5 spent about 85 µs in `three_parallel`,
    mostly in small function calls and in rotating constant vectors; here the subproblems are
    written out on local floats and the rotations of constant vectors reduce to
    v cos θ + (ω × v) sin θ + ω (ωᵀv)(1 − cos θ) with ω × v and ωᵀv stored. Same equations,
    branch order, tolerances, stages and reasons as `three_parallel` (the tests compare the two);
    results agree to round-off (a few products are regrouped, e.g. xᵀ(M z) as (Mᵀx)ᵀz).
    """

    def __init__(self, g: Geometry) -> None:
        W, P, h, c, x = g.w, g.r, g.h, g.c, g.x
        self.eL, self.eL2 = g.eL, g.eL2
        self.eLsq = g.eL * g.eL  # SP1 tests ‖x‖ ≤ eL as ‖x‖² ≤ eL²
        self.s = g.s
        self.a3, self.b3, self.pq3, self.dk3 = g.a3, g.b3, g.pq3, g.dk3
        self.c, self.h, self.x = c, h, x
        self.w0, self.p0, self.w1, self.p1, self.w4, self.w5, self.p5 = (
            W[0], P[0], W[1], P[1], W[4], W[5], P[5]
        )  # fmt: skip
        # q₁ (SP4 about ω₁ of pc − r₁ against h): a = hᵀx − (hᵀω₁)(ω₁ᵀx), b = (h × ω₁)ᵀx.
        self.hw0 = dot(h, W[0])
        self.hxw0 = cross(h, W[0])
        self.d1 = dot(h, sub(c, P[0]))
        # R(ω₁, q₁) h = h cos + (ω₁ × h) sin + ω₁ (ω₁ᵀh)(1 − cos); likewise for x and h × x.
        self.w0xh = cross(W[0], h)
        hx = cross(h, x)
        self.hx = hx
        self.w0xx, self.w0x = cross(W[0], x), dot(W[0], x)
        self.w0xhx, self.w0hx = cross(W[0], hx), dot(W[0], hx)
        # SP2 (ω₅, ω₆) of u onto h.
        self.c45 = dot(W[4], W[5])
        self.k12 = cross(W[4], W[5])
        self.den = self.c45 * self.c45 - 1.0
        self.n12 = dot(self.k12, self.k12)
        self.kq = dot(W[4], h)
        self.hp4 = _project(W[4], h)  # h projected normal to ω₅ (the second SP1's q′)
        self.hp4n = dot(self.hp4, self.hp4)
        # The point r₄ turned by −q₅ about axis 5: r₅ + R(ω₅, −q₅)(r₄ − r₅).
        v = sub(P[3], P[4])
        self.p4, self.v43, self.w4xv, self.w4v = P[4], v, cross(W[4], v), dot(W[4], v)
        self.w4xx, self.w4x = cross(W[4], x), dot(W[4], x)  # x turned about axis 5
        # The elbow point e₃ r₄ − r₂ = (r₃ − r₂) + R(ω₃, q₃)(r₄ − r₃).
        v = sub(P[3], P[2])
        self.v21, self.v32, self.w2xv, self.w2v = sub(P[2], P[1]), v, cross(W[2], v), dot(W[2], v)
        self.w2 = W[2]

    def _turned(self, R: Mat, c: float, s: float, v: Vec, wxv: Vec, wv: float) -> Vec:
        """Rᵀ R(ω₁, θ) v for a constant v, with ω₁ × v and ω₁ᵀv given, c = cos θ, s = sin θ."""
        w0x, w0y, w0z = self.w0
        f = wv * (1.0 - c)
        vx = v[0] * c + wxv[0] * s + w0x * f
        vy = v[1] * c + wxv[1] * s + w0y * f
        vz = v[2] * c + wxv[2] * s + w0z * f
        return (
            R[0][0] * vx + R[1][0] * vy + R[2][0] * vz,
            R[0][1] * vx + R[1][1] * vy + R[2][1] * vz,
            R[0][2] * vx + R[1][2] * vy + R[2][2] * vz,
        )

    def solve(self, R: Mat, p: Vec, d: Sequence[float], stages: Stages) -> list[Candidate]:
        """The candidates of `three_parallel(g, R, p, d, stages)`, with the angles already wrapped
        into (−π, π] (as `closed_form` wraps the others)."""
        (R00, R01, R02), (R10, R11, R12), (R20, R21, R22) = R
        p0x, p0y, p0z = p
        w0x, w0y, w0z = self.w0
        r0x, r0y, r0z = self.p0
        hx_, hy_, hz_ = self.h
        out: list[Candidate] = []
        # q₁: hᵀ e₁⁻¹(G c) = hᵀc (SP4 in φ = −q₁).
        cx, cy, cz = self.c
        ax = R00 * cx + R01 * cy + R02 * cz + p0x - r0x
        ay = R10 * cx + R11 * cy + R12 * cz + p0y - r0y
        az = R20 * cx + R21 * cy + R22 * cz + p0z - r0z
        kp = w0x * ax + w0y * ay + w0z * az
        hxw = self.hxw0
        th1, ok1, fr1 = solve_trig(
            hx_ * ax + hy_ * ay + hz_ * az - self.hw0 * kp,
            hxw[0] * ax + hxw[1] * ay + hxw[2] * az,
            self.d1 - self.hw0 * kp,
            -d[0],
            self.eL,
        )
        if not ok1:
            return out
        stages.passed["shoulder"] += 2
        why1 = ("the wrist point lies on joint 1's axis",) if fr1 else ()
        s2, s3, s4 = self.s
        w4x, w4y, w4z = self.w4
        w5x, w5y, w5z = self.w5
        c45, den, kq, n12 = self.c45, self.den, self.kq, self.n12
        k12x, k12y, k12z = self.k12
        hpx, hpy, hpz = self.hp4
        hpn = self.hp4n
        e2 = 1e-18  # (1e-9)², the SP1 tolerance of the wrist angles
        # Constants as locals (attribute look-ups cost as much as the arithmetic here).
        x0, x1, x2 = self.x
        w4xx, w4x_, w4xv, w4v, v43 = self.w4xx, self.w4x, self.w4xv, self.w4v, self.v43
        o5 = self.p5
        o45 = (self.p4[0] - o5[0], self.p4[1] - o5[1], self.p4[2] - o5[2])
        r1 = self.p1
        r01x, r01y, r01z = r0x - r1[0], r0y - r1[1], r0z - r1[2]
        a3, b3, pq3, dk3sq, eL2, eLsq = self.a3, self.b3, self.pq3, self.dk3**2, self.eL2, self.eLsq
        w1x, w1y, w1z = self.w1
        v32, w2xv, v21, w2d, w2v = self.v32, self.w2xv, self.v21, self.w2, self.w2v
        n_wrist = n_elbow = 0
        for phi in th1:
            q1 = -phi
            c1, s1 = cos(q1), sin(q1)
            q1w = q1 if -pi < q1 <= pi else wrap(q1)
            f1 = 1.0 - c1
            # u = Rᵀ R(ω₁, q₁) h
            a, b = self.w0xh, self.hw0 * f1
            vx = hx_ * c1 + a[0] * s1 + w0x * b
            vy = hy_ * c1 + a[1] * s1 + w0y * b
            vz = hz_ * c1 + a[2] * s1 + w0z * b
            ux = R00 * vx + R10 * vy + R20 * vz
            uy = R01 * vx + R11 * vy + R21 * vz
            uz = R02 * vx + R12 * vy + R22 * vz
            # X1 = Rᵀ R(ω₁, q₁) x and H1 = Rᵀ R(ω₁, q₁)(h × x): θ₂₃₄ = atan2(H1ᵀz, X1ᵀz) below.
            # X1 = Rᵀ R(ω₁, q₁) x and H1 = Rᵀ R(ω₁, q₁)(h × x): θ₂₃₄ = atan2(H1ᵀz, X1ᵀz) below.
            X1 = self._turned(R, c1, s1, self.x, self.w0xx, self.w0x)
            H1 = self._turned(R, c1, s1, self.hx, self.w0xhx, self.w0hx)
            # (q₅, q₆): SP2 R(ω₅, q₅) R(ω₆, q₆) u = h.
            kpu = w5x * ux + w5y * uy + w5z * uz
            alpha = (c45 * kpu - kq) / den
            beta = (c45 * kq - kpu) / den
            pp = ux * ux + uy * uy + uz * uz
            g2 = (pp - alpha * alpha - beta * beta - 2.0 * alpha * beta * c45) / n12
            if g2 < -TANGENT_TOLERANCE * max(pp, e2):
                continue
            gamma = sqrt(max(g2, 0.0))
            upx, upy, upz = ux - w5x * kpu, uy - w5y * kpu, uz - w5z * kpu  # u′ normal to ω₆
            up_small = upx * upx + upy * upy + upz * upz <= e2
            for gs in (gamma, -gamma):
                # q₆ = SP1(ω₆, u → z), z = α ω₅ + β ω₆ + γ (ω₅ × ω₆)
                zx = alpha * w4x + beta * w5x + gs * k12x
                zy = alpha * w4y + beta * w5y + gs * k12y
                zz = alpha * w4z + beta * w5z + gs * k12z
                kz = w5x * zx + w5y * zy + w5z * zz
                bx, by, bz = zx - w5x * kz, zy - w5y * kz, zz - w5z * kz
                if up_small or bx * bx + by * by + bz * bz <= e2:
                    q6, fr6 = wrap(d[5]), True
                else:
                    q6 = atan2(
                        w5x * (upy * bz - upz * by)
                        + w5y * (upz * bx - upx * bz)
                        + w5z * (upx * by - upy * bx),
                        upx * bx + upy * by + upz * bz,
                    )
                    fr6 = False
                    if q6 <= -pi:  # atan2 gives [−π, π]; candidates are in (−π, π]
                        q6 += TWO_PI
                # q₅ = SP1(ω₅, R(ω₆, q₆) u → h)
                c6, s6 = cos(q6), sin(q6)
                f6 = kpu * (1.0 - c6)
                yx = ux * c6 + (w5y * uz - w5z * uy) * s6 + w5x * f6
                yy = uy * c6 + (w5z * ux - w5x * uz) * s6 + w5y * f6
                yz = uz * c6 + (w5x * uy - w5y * ux) * s6 + w5z * f6
                ky = w4x * yx + w4y * yy + w4z * yz
                ax, ay, az = yx - w4x * ky, yy - w4y * ky, yz - w4z * ky
                if ax * ax + ay * ay + az * az <= e2 or hpn <= e2:
                    q5, fr5 = wrap(d[4]), True
                else:
                    q5 = atan2(
                        w4x * (ay * hpz - az * hpy)
                        + w4y * (az * hpx - ax * hpz)
                        + w4z * (ax * hpy - ay * hpx),
                        ax * hpx + ay * hpy + az * hpz,
                    )
                    fr5 = False
                    if q5 <= -pi:
                        q5 += TWO_PI
                n_wrist += 1
                why2 = why1 + (_WHY_WRIST,) if fr5 or fr6 else why1
                # θ₂₃₄ from z = R(ω₆, −q₆) R(ω₅, −q₅) x (x and ω₅ × x constant).
                c5, s5 = cos(q5), sin(q5)
                f = w4x_ * (1.0 - c5)
                zx = x0 * c5 - w4xx[0] * s5 + w4x * f
                zy = x1 * c5 - w4xx[1] * s5 + w4y * f
                zz = x2 * c5 - w4xx[2] * s5 + w4z * f
                f = (w5x * zx + w5y * zy + w5z * zz) * (1.0 - c6)
                zx, zy, zz = (
                    zx * c6 - (w5y * zz - w5z * zy) * s6 + w5x * f,
                    zy * c6 - (w5z * zx - w5x * zz) * s6 + w5y * f,
                    zz * c6 - (w5x * zy - w5y * zx) * s6 + w5z * f,
                )
                t234 = atan2(
                    H1[0] * zx + H1[1] * zy + H1[2] * zz, X1[0] * zx + X1[1] * zy + X1[2] * zz
                )
                # K r₄ = e₁⁻¹ G e₆⁻¹ e₅⁻¹ r₄: m = r₅ + R(ω₅, −q₅)(r₄ − r₅) − r₆, then about axis 6.
                f = w4v * (1.0 - c5)
                mx = o45[0] + v43[0] * c5 - w4xv[0] * s5 + w4x * f
                my = o45[1] + v43[1] * c5 - w4xv[1] * s5 + w4y * f
                mz = o45[2] + v43[2] * c5 - w4xv[2] * s5 + w4z * f
                f = (w5x * mx + w5y * my + w5z * mz) * (1.0 - c6)
                mx, my, mz = (
                    mx * c6 - (w5y * mz - w5z * my) * s6 + w5x * f + o5[0],
                    my * c6 - (w5z * mx - w5x * mz) * s6 + w5y * f + o5[1],
                    mz * c6 - (w5x * my - w5y * mx) * s6 + w5z * f + o5[2],
                )
                nx = R00 * mx + R01 * my + R02 * mz + p0x - r0x
                ny = R10 * mx + R11 * my + R12 * mz + p0y - r0y
                nz = R20 * mx + R21 * my + R22 * mz + p0z - r0z
                f = (w0x * nx + w0y * ny + w0z * nz) * f1
                krx = nx * c1 - (w0y * nz - w0z * ny) * s1 + w0x * f + r01x
                kry = ny * c1 - (w0z * nx - w0x * nz) * s1 + w0y * f + r01y
                krz = nz * c1 - (w0x * ny - w0y * nx) * s1 + w0z * f + r01z
                # q₃: SP3 with constant p = r₄ − r₃, q = r₂ − r₃.
                delta2 = krx * krx + kry * kry + krz * krz - dk3sq
                th3, ok3, fr3 = solve_trig(a3, b3, 0.5 * (pq3 - delta2), d[2], eL2)
                if not ok3:
                    continue
                n_elbow += 2
                why3 = why2 + (_WHY_ELBOW,) if fr3 else why2
                # q₂ = SP1(ω₂, e₃ r₄ − r₂ → K r₄ − r₂); the projection of the latter is shared.
                kk = w1x * krx + w1y * kry + w1z * krz
                bx, by, bz = krx - w1x * kk, kry - w1y * kk, krz - w1z * kk
                b_small = bx * bx + by * by + bz * bz <= eLsq
                for q3 in th3:
                    c3, s3_ = cos(q3), sin(q3)
                    f = w2v * (1.0 - c3)
                    ex = v21[0] + v32[0] * c3 + w2xv[0] * s3_ + w2d[0] * f
                    ey = v21[1] + v32[1] * c3 + w2xv[1] * s3_ + w2d[1] * f
                    ez = v21[2] + v32[2] * c3 + w2xv[2] * s3_ + w2d[2] * f
                    ke = w1x * ex + w1y * ey + w1z * ez
                    ax, ay, az = ex - w1x * ke, ey - w1y * ke, ez - w1z * ke
                    if b_small or ax * ax + ay * ay + az * az <= eLsq:
                        q2, fr4 = wrap(d[1]), True
                    else:
                        q2 = atan2(
                            w1x * (ay * bz - az * by)
                            + w1y * (az * bx - ax * bz)
                            + w1z * (ax * by - ay * bx),
                            ax * bx + ay * by + az * bz,
                        )
                        fr4 = False
                    if q2 <= -pi:
                        q2 += TWO_PI
                    q4 = s4 * (t234 - s2 * q2 - s3 * q3)
                    if not -pi < q4 <= pi:
                        q4 = wrap(q4)
                    q3w = q3 if -pi < q3 <= pi else wrap(q3)
                    out.append(
                        ([q1w, q2, q3w, q4, q5, q6], why3 + (_WHY_ELBOW_POINT,) if fr4 else why3)
                    )
        stages.passed["wrist"] += n_wrist
        stages.passed["elbow"] += n_elbow
        return out


_WHY_WRIST = "wrist axes aligned (joint 6 parallel to joints 2-4)"
_WHY_ELBOW = "joint 4's axis passes through joint 3's axis"
_WHY_ELBOW_POINT = "the elbow point lies on joint 2's axis"


def _rot(k: Vec, c: float, s: float, x: Vec) -> Vec:
    """R(k, θ) x with c = cos θ, s = sin θ given (Rodrigues, written out)."""
    k0, k1, k2 = k
    x0, x1, x2 = x
    f = (k0 * x0 + k1 * x1 + k2 * x2) * (1.0 - c)
    return (
        x0 * c + (k1 * x2 - k2 * x1) * s + k0 * f,
        x1 * c + (k2 * x0 - k0 * x2) * s + k1 * f,
        x2 * c + (k0 * x1 - k1 * x0) * s + k2 * f,
    )


TWO_PI = 2.0 * pi


def wrap(a: float) -> float:
    """One angle into (−π, π] (as `closed_form._wrap`)."""
    return a - TWO_PI * ceil((a - pi) / TWO_PI)


class _SP2:
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
        alpha = (c * kp - kq) / self.den
        beta = (c * kq - kp) / self.den
        pp = p[0] * p[0] + p[1] * p[1] + p[2] * p[2]
        g2 = (pp - alpha * alpha - beta * beta - 2.0 * alpha * beta * c) / self.n12
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


class _SP3:
    """SP3 ‖R(k, θ) p − q‖ = δ with k, p and q fixed (`sp3`): only δ comes with the target."""

    __slots__ = ("a", "b", "pq", "dk2")

    def __init__(self, k: Vec, p: Vec, q: Vec) -> None:
        pp, qp = _project(k, p), _project(k, q)
        dk = dot(k, sub(p, q))
        self.a, self.b = dot(pp, qp), dot(k, cross(pp, qp))
        self.pq, self.dk2 = dot(pp, pp) + dot(qp, qp), dk * dk

    def solve(
        self, delta2: float, default: float, eps: float
    ) -> tuple[tuple[float, float], bool, bool]:
        """`sp3(k, p, q, δ, default, eps)` given δ² (the same up to the rounding of √ then ²)."""
        return solve_trig(self.a, self.b, 0.5 * (self.pq - (delta2 - self.dk2)), default, eps)


class Spherical:
    """`spherical` for one fixed geometry (a 6R arm, or a 7R arm with its held joint at one value),
    with every quantity that does not depend on the target computed once here.

    Hand-written for speed: an `ik` call on a 7R arm runs the 6R solve at up to four values of the
    held joint, and `spherical` spent most of its time in recomputing the constant parts of its
    subproblems (projections of fixed vectors, the SP2 basis of fixed axes) and in trigonometric
    functions of the same angle. Here those are stored, the three rotations that take the target's
    wrist axis and reference vector back to the wrist are applied with one cos/sin each, and the
    wrist SP2 (fixed p = ω₆) is written out. Same equations, branch order, tolerances, stages and
    reasons as `spherical` (the tests compare the two); results agree to round-off (δ² is used
    where `spherical` squares ‖·‖).
    """

    def __init__(self, case: str, g: Geometry) -> None:
        W, P, c, b, h = g.w, g.r, g.c, g.b, g.h
        self.case, self.g = case, g
        self.W, self.P, self.c, self.b, self.h, self.x = W, P, c, b, h, g.x
        self.eL, self.eL2 = g.eL, g.eL2
        if case == "par23":
            # q₁: SP4 about ω₁ of pc − r₁ against h (a = hᵀv − (hᵀω₁)(ω₁ᵀv), b = (h × ω₁)ᵀv).
            self.hw0, self.hxw0, self.d1 = dot(h, W[0]), cross(h, W[0]), dot(h, sub(c, P[0]))
            self.sp3 = _SP3(W[2], sub(c, P[2]), sub(P[1], P[2]))
        elif case == "int12":
            self.sp3 = _SP3(W[2], sub(c, P[2]), sub(b, P[2]))
            self.sp2 = _SP2(W[0], W[1])
        elif case == "int23":
            self.delta2 = dot(sub(c, b), sub(c, b))
            self.cb = sub(c, b)
            self.sp2 = _SP2(W[1], W[2])
        # x = R(ω₃, q₃)(c − r₃) + r₃ (par23, int12, par12): c − r₃, ω₃ × (c − r₃), ω₃ᵀ(c − r₃).
        v = sub(c, P[2])
        self.v3, self.w2xv, self.w2v = v, cross(W[2], v), dot(W[2], v)
        # The wrist: SP2 (ω₄, ω₅) of ω₆ onto v₆; then SP1 about ω₆ of x.
        self.wsp2 = _SP2(W[3], W[4])
        w5 = W[5]
        self.kp_w = dot(W[4], w5)
        self.pp_w = dot(w5, w5)
        self.w5p4 = _project(W[4], w5)  # ω₆ projected normal to ω₅ (the first SP1's p′)
        self.w4xw5, self.w4w5 = cross(W[4], w5), dot(W[4], w5)
        self.xp5 = _project(w5, g.x)  # x projected normal to ω₆ (q₆'s SP1 p′)
        self.x_small = dot(self.xp5, self.xp5) <= 1e-18

    def _arms(
        self, R: Mat, p: Vec, d: Sequence[float], stages: Stages
    ) -> list[tuple[float, float, float, tuple[str, ...]]]:
        """(q1, q2, q3, why) of the position part, as in `spherical`."""
        W, P, c, b = self.W, self.P, self.c, self.b
        eL, eL2 = self.eL, self.eL2
        pc = (
            R[0][0] * c[0] + R[0][1] * c[1] + R[0][2] * c[2] + p[0],
            R[1][0] * c[0] + R[1][1] * c[1] + R[1][2] * c[2] + p[1],
            R[2][0] * c[0] + R[2][1] * c[1] + R[2][2] * c[2] + p[2],
        )
        arms: list[tuple[float, float, float, tuple[str, ...]]] = []
        case = self.case
        if case == "par23":
            v = sub(pc, P[0])
            kp = dot(W[0], v)
            th1, okA, frA = solve_trig(
                dot(self.h, v) - self.hw0 * kp, dot(self.hxw0, v), self.d1 - self.hw0 * kp,
                -d[0], eL,
            )  # fmt: skip
            if okA:
                stages.passed["shoulder"] += 2
                for phi in th1:
                    q1 = -phi
                    wp = rotate_about(W[0], P[0], -q1, pc)
                    e = sub(wp, P[1])
                    th3, okB, frB = self.sp3.solve(dot(e, e), d[2], eL2)
                    if not okB:
                        continue
                    stages.passed["elbow"] += 2
                    for q3 in th3:
                        x = self._elbow(q3)
                        q2, frC = sp1(W[1], sub(x, P[1]), e, d[1], eL)
                        why = _why((frA, "the wrist centre lies on joint 1's axis"),
                                   (frB, "the wrist centre lies on joint 3's axis"),
                                   (frC, "the wrist centre lies on joint 2's axis"))  # fmt: skip
                        arms.append((q1, q2, q3, why))
        elif case == "int12":
            e = sub(pc, b)
            th3, okA, frA = self.sp3.solve(dot(e, e), d[2], eL2)
            if okA:
                stages.passed["elbow"] += 2
                for q3 in th3:
                    x = self._elbow(q3)
                    for q1, q2, frB in self.sp2.solve(sub(x, b), e, d[0], d[1], eL):
                        stages.passed["shoulder"] += 1
                        why = _why((frA, "the wrist centre lies on joint 3's axis"),
                                   (frB, "the wrist centre lies on joint 1's axis"))  # fmt: skip
                        arms.append((q1, q2, q3, why))
        elif case == "int23":
            # (p = pc − r₁ changes with the target: the general SP3)
            th1, okA, frA = sp3(W[0], sub(pc, P[0]), sub(b, P[0]), sqrt(self.delta2), -d[0], eL2)
            if okA:
                stages.passed["shoulder"] += 2
                for phi in th1:
                    q1 = -phi
                    wp = rotate_about(W[0], P[0], -q1, pc)
                    for q2, q3, frB in self.sp2.solve(self.cb, sub(wp, b), d[1], d[2], eL):
                        stages.passed["elbow"] += 1
                        why = _why((frA, "the wrist centre lies on joint 1's axis"),
                                   (frB, "the wrist centre lies on joint 2's axis"))  # fmt: skip
                        arms.append((q1, q2, q3, why))
        else:  # "par12": the general subproblems (no constant SP3 here)
            return _spherical_arms(case, self.g, R, p, d, stages)
        return arms

    def _elbow(self, q3: float) -> Vec:
        """x = r₃ + R(ω₃, q₃)(c − r₃)."""
        c3, s3 = cos(q3), sin(q3)
        v, u, k, r = self.v3, self.w2xv, self.W[2], self.P[2]
        f = self.w2v * (1.0 - c3)
        return (
            r[0] + v[0] * c3 + u[0] * s3 + k[0] * f,
            r[1] + v[1] * c3 + u[1] * s3 + k[1] * f,
            r[2] + v[2] * c3 + u[2] * s3 + k[2] * f,
        )

    def solve(self, R: Mat, p: Vec, d: Sequence[float], stages: Stages) -> list[Candidate]:
        """The candidates of `spherical(case, g, R, p, d, stages)` (angles not wrapped)."""
        arms = self._arms(R, p, d, stages)
        out: list[Candidate] = []
        if not arms:
            return out
        W, x = self.W, self.x
        w0, w1, w2, w3, w4, w5 = W
        Rw5, Rx = matvec(R, w5), matvec(R, x)
        sp2w = self.wsp2
        c34, den, n12 = sp2w.c, sp2w.den, sp2w.n12
        k12x, k12y, k12z = sp2w.k12
        w3x, w3y, w3z = w3
        w4x, w4y, w4z = w4
        kp, pp = self.kp_w, self.pp_w
        apx, apy, apz = self.w5p4
        a_small = apx * apx + apy * apy + apz * apz <= 1e-18
        uxw, uw = self.w4xw5, self.w4w5
        d3, d4, d5 = d[3], d[4], d[5]
        w5x, w5y, w5z = w5
        xpx, xpy, xpz = self.xp5
        x_small = self.x_small
        last_q1 = None
        for q1, q2, q3, why in arms:
            # v₆ and y₀: Rω₆ and Rx turned by −q₁ about ω₁, −q₂ about ω₂, −q₃ about ω₃ (the
            # first turn shared by consecutive arms with the same q₁: par23, int23).
            if q1 != last_q1:
                c1, s1 = cos(q1), -sin(q1)
                v1, x1 = _rot(w0, c1, s1, Rw5), _rot(w0, c1, s1, Rx)
                last_q1 = q1
            c2, s2 = cos(q2), -sin(q2)
            c3, s3 = cos(q3), -sin(q3)
            v6 = _rot(w2, c3, s3, _rot(w1, c2, s2, v1))
            y0x, y0y, y0z = _rot(w2, c3, s3, _rot(w1, c2, s2, x1))
            v6x, v6y, v6z = v6
            # SP2 (ω₄, ω₅) of p = ω₆ onto q = v₆ (`sp2` written out, p fixed).
            kq = w3x * v6x + w3y * v6y + w3z * v6z
            alpha = (c34 * kp - kq) / den
            beta = (c34 * kq - kp) / den
            g2 = (pp - alpha * alpha - beta * beta - 2.0 * alpha * beta * c34) / n12
            if g2 < -TANGENT_TOLERANCE * max(pp, 1e-18):
                continue
            gamma = sqrt(max(g2, 0.0))
            # v₆ projected normal to ω₄ (the target of q₄'s SP1), shared by both branches
            bvx, bvy, bvz = v6x - w3x * kq, v6y - w3y * kq, v6z - w3z * kq
            bv_small = bvx * bvx + bvy * bvy + bvz * bvz <= 1e-18
            for gs in (gamma, -gamma):
                zx = alpha * w3x + beta * w4x + gs * k12x
                zy = alpha * w3y + beta * w4y + gs * k12y
                zz = alpha * w3z + beta * w4z + gs * k12z
                # q₅ = SP1(ω₅, ω₆ → z), the projection of ω₆ stored
                kz = w4x * zx + w4y * zy + w4z * zz
                bx, by, bz = zx - w4x * kz, zy - w4y * kz, zz - w4z * kz
                if a_small or bx * bx + by * by + bz * bz <= 1e-18:
                    q5, f2 = d4, True
                else:
                    q5 = atan2(
                        w4x * (apy * bz - apz * by)
                        + w4y * (apz * bx - apx * bz)
                        + w4z * (apx * by - apy * bx),
                        apx * bx + apy * by + apz * bz,
                    )
                    f2 = False
                # q₄ = SP1(ω₄, R(ω₅, q₅) ω₆ → v₆)
                c5, s5 = cos(q5), sin(q5)
                f = uw * (1.0 - c5)
                rx = w5x * c5 + uxw[0] * s5 + w4x * f
                ry = w5y * c5 + uxw[1] * s5 + w4y * f
                rz = w5z * c5 + uxw[2] * s5 + w4z * f
                kr = w3x * rx + w3y * ry + w3z * rz
                ax, ay, az = rx - w3x * kr, ry - w3y * kr, rz - w3z * kr
                if ax * ax + ay * ay + az * az <= 1e-18 or bv_small:
                    q4, f1 = d3, True
                else:
                    q4 = atan2(
                        w3x * (ay * bvz - az * bvy)
                        + w3y * (az * bvx - ax * bvz)
                        + w3z * (ax * bvy - ay * bvx),
                        ax * bvx + ay * bvy + az * bvz,
                    )
                    f1 = False
                stages.passed["wrist"] += 1
                # y = R(ω₅, −q₅) R(ω₄, −q₄) y₀, then q₆ = SP1(ω₆, x → y) (x′ stored)
                c4, s4 = cos(q4), -sin(q4)
                f = (w3x * y0x + w3y * y0y + w3z * y0z) * (1.0 - c4)
                ux = y0x * c4 + (w3y * y0z - w3z * y0y) * s4 + w3x * f
                uy = y0y * c4 + (w3z * y0x - w3x * y0z) * s4 + w3y * f
                uz = y0z * c4 + (w3x * y0y - w3y * y0x) * s4 + w3z * f
                f = (w4x * ux + w4y * uy + w4z * uz) * (1.0 - c5)
                yx = ux * c5 - (w4y * uz - w4z * uy) * s5 + w4x * f
                yy = uy * c5 - (w4z * ux - w4x * uz) * s5 + w4y * f
                yz = uz * c5 - (w4x * uy - w4y * ux) * s5 + w4z * f
                ky = w5x * yx + w5y * yy + w5z * yz
                bx, by, bz = yx - w5x * ky, yy - w5y * ky, yz - w5z * ky
                if x_small or bx * bx + by * by + bz * bz <= 1e-18:
                    q6 = d5
                else:
                    q6 = atan2(
                        w5x * (xpy * bz - xpz * by)
                        + w5y * (xpz * bx - xpx * bz)
                        + w5z * (xpx * by - xpy * bx),
                        xpx * bx + xpy * by + xpz * bz,
                    )
                w = why + ("wrist axes aligned (joints 4 and 6 coincide)",) if f1 or f2 else why
                out.append(([q1, q2, q3, q4, q5, q6], w))
        return out


def _spherical_arms(
    case: str, g: Geometry, R: Mat, p: Vec, d: Sequence[float], stages: Stages
) -> list[tuple[float, float, float, tuple[str, ...]]]:
    """The position part of `spherical` (par12 only is used by `Spherical`)."""
    W, P, c, h = g.w, g.r, g.c, g.h
    eL, eL2 = g.eL, g.eL2
    pc = add(matvec(R, c), p)
    arms: list[tuple[float, float, float, tuple[str, ...]]] = []
    th3, okA, frA = sp4(W[2], sub(c, P[2]), h, dot(h, sub(pc, P[2])), d[2], eL)
    if okA:
        stages.passed["shoulder"] += 2
        for q3 in th3:
            x = rotate_about(W[2], P[2], q3, c)
            th2, okB, frB = sp3(W[1], sub(x, P[1]), sub(P[0], P[1]), norm(sub(pc, P[0])), d[1], eL2)
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
    return arms
