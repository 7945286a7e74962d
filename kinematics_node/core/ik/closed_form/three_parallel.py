"""The "three_parallel" family (UR arms): axes 2, 3, 4 parallel (direction h), 5 and 6 meet at c.

hᵀ e₁⁻¹(G c) = hᵀc gives q₁ (SP4); hᵀR₁ᵀR_G = hᵀR₅R₆ gives (q₅, q₆) (SP2); then e₂e₃e₄ =
e₁⁻¹ G e₆⁻¹ e₅⁻¹ gives q₃ (SP3, distance from axis 2), q₂ (SP1) and q₄ from the sum angle.

Single-target forms on floats (`three_parallel`, and `ThreeParallel` with the constants of one
geometry prepared) beside the vectorised forms over lanes (`solve_three_parallel`,
`solve_three_parallel_prepared`): same equations, same branch order (branch = 4·i₁ + 2·i₂ + i₃),
and the tests compare them. Angles [rad], lengths [m].
"""

from __future__ import annotations

from collections.abc import Sequence
from math import atan2, cos, pi, sin, sqrt

import numpy as np

from ...model import TWO_PI
from .. import subproblems as sp
from ..subproblems import TANGENT_TOLERANCE
from .geometry import (
    BoolArray,
    Candidate,
    FloatArray,
    Geometry,
    LaneGeometry,
    Mat,
    Stages,
    Trace,
    Vec,
    apply_rotation,
    branch_flag,
    cross,
    dot,
    per_lane,
    project_out,
    solve_trig,
    sp2_between,
    sp2_parts,
    spread_branches,
    sub,
    turn_components,
    turn_parts,
    wrap,
)


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
        self.hp4 = project_out(W[4], h)  # h projected normal to ω₅ (the second SP1's q′)
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
        k12 = self.k12
        w1, w4, w5, hp4, hpn = self.w1, self.w4, self.w5, self.hp4, self.hp4n
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
            X1 = self._turned(R, c1, s1, self.x, self.w0xx, self.w0x)
            H1 = self._turned(R, c1, s1, self.hx, self.w0xhx, self.w0hx)
            # (q₅, q₆): SP2 R(ω₅, q₅) R(ω₆, q₆) u = h.
            kpu = w5x * ux + w5y * uy + w5z * uz
            pp = ux * ux + uy * uy + uz * uz
            alpha, beta, g2 = sp2_parts(c45, den, n12, kpu, kq, pp)
            if g2 < -TANGENT_TOLERANCE * max(pp, e2):
                continue
            gamma = sqrt(max(g2, 0.0))
            upx, upy, upz = ux - w5x * kpu, uy - w5y * kpu, uz - w5z * kpu  # u′ normal to ω₆
            up_small = upx * upx + upy * upy + upz * upz <= e2
            for gs in (gamma, -gamma):
                # q₆ = SP1(ω₆, u → z), z = α ω₅ + β ω₆ + γ (ω₅ × ω₆)
                bx, by, bz = sp2_between(w4, w5, k12, alpha, beta, gs)
                if up_small or bx * bx + by * by + bz * bz <= e2:
                    q6, fr6 = wrap(d[5]), True
                else:
                    q6 = atan2(*turn_parts(w5, (upx, upy, upz), (bx, by, bz)))
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
                    q5 = atan2(*turn_parts(w4, (ax, ay, az), hp4))
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
                        q2 = atan2(*turn_parts(w1, (ax, ay, az), (bx, by, bz)))
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


def solve_three_parallel(
    g: LaneGeometry, R: FloatArray, p: FloatArray, dflt: FloatArray, trace: Trace
) -> tuple[FloatArray, BoolArray]:
    w, r, h, c = g.w, g.r, g.h, g.c
    eL, eL2, e1 = 1e-9 * g.scale, 1e-12 * g.scale**2, 1e-9
    W = [w[:, i] for i in range(6)]
    P = [r[:, i] for i in range(6)]
    L = R.shape[0]
    # q₁: hᵀ e₁⁻¹(G c) = hᵀc, with e₁⁻¹x = r₁ + R(ω₁, −q₁)(x − r₁)  (SP4 in φ = −q₁).
    pc = apply_rotation(R, np.broadcast_to(c, (L, 3))) + p
    phi, ok1, fr1 = sp.sp4(W[0], pc - P[0], h, sp.dot(h, c - P[0]), -dflt[:, 0], eL)
    q1 = -phi  # (L, 2)
    trace.fails.append(("shoulder", branch_flag(ok1, L, 8)))
    trace.frees.append(("the wrist point lies on joint 1's axis", branch_flag(fr1, L, 8)))
    # (q₅, q₆): R₅ R₆ (R_Gᵀ R₁ h) = h  (SP2).
    u = apply_rotation(R.swapaxes(1, 2), sp.rotate(per_lane(W[0]), q1, per_lane(h)))  # R_Gᵀ R₁ h
    d5 = np.broadcast_to(dflt[:, 4:5], q1.shape)
    d6 = np.broadcast_to(dflt[:, 5:6], q1.shape)
    t5, t6, ok2, fr2 = sp.sp2(
        per_lane(W[4]), per_lane(W[5]), u, np.broadcast_to(per_lane(h), u.shape), d5, d6, e1
    )
    q1 = spread_branches(q1, 2)
    q5, q6 = t5.reshape(L, 4), t6.reshape(L, 4)
    trace.fails.append(("wrist", branch_flag(ok2, L, 8)))
    trace.frees.append(
        ("wrist axes aligned (joint 6 parallel to joints 2-4)", branch_flag(fr2, L, 8))
    )
    # Sum angle θ₂₃₄ of R_K = R₁ᵀ R_G R₆ᵀ R₅ᵀ = R(h, θ₂₃₄), from a vector x normal to h.
    x = np.broadcast_to(per_lane(g.x), (L, 4, 3))
    y = sp.rotate(per_lane(W[4]), -q5, x)
    y = sp.rotate(per_lane(W[5]), -q6, y)
    y = sp.rotate(per_lane(W[0]), -q1, apply_rotation(R, y))
    t234 = np.arctan2(sp.dot(per_lane(h), sp.cross(x, y)), sp.dot(x, y))
    # Point K r₄ with K = e₁⁻¹ G e₆⁻¹ e₅⁻¹ = e₂ e₃ e₄ (r₄ on axis 4 is fixed by e₄).
    k = sp.rotate_about(
        per_lane(W[4]), per_lane(P[4]), -q5, np.broadcast_to(per_lane(P[3]), (L, 4, 3))
    )
    k = sp.rotate_about(per_lane(W[5]), per_lane(P[5]), -q6, k)
    k = sp.rotate_about(per_lane(W[0]), per_lane(P[0]), -q1, apply_rotation(R, k) + per_lane(p))
    # q₃: ‖e₃ r₄ − r₂‖ = ‖K r₄ − r₂‖  (SP3; r₂ on axis 2 is fixed by e₂).
    d3 = np.broadcast_to(dflt[:, 2:3], (L, 4))
    q3, ok3, fr3 = sp.sp3(
        per_lane(W[2]),
        per_lane(P[3] - P[2]),
        per_lane(P[1] - P[2]),
        sp.norm(k - per_lane(P[1])),
        d3,
        eL2,
    )
    trace.fails.append(("elbow", branch_flag(ok3, L, 8)))
    trace.frees.append(("joint 4's axis passes through joint 3's axis", branch_flag(fr3, L, 8)))
    q3 = q3.reshape(L, 8)
    q1, q5, q6, t234, k = (spread_branches(a, 2) for a in (q1, q5, q6, t234, k))
    # q₂: e₂ (e₃ r₄) = K r₄  (SP1).
    x3 = sp.rotate_about(
        per_lane(W[2]), per_lane(P[2]), q3, np.broadcast_to(per_lane(P[3]), (L, 8, 3))
    )
    d2 = np.broadcast_to(dflt[:, 1:2], (L, 8))
    q2, fr4 = sp.sp1(per_lane(W[1]), x3 - per_lane(P[1]), k - per_lane(P[1]), d2, eL)
    trace.frees.append(("the elbow point lies on joint 2's axis", branch_flag(fr4, L, 8)))
    s = g.s[:, None, :]
    q4 = s[..., 2] * (t234 - s[..., 0] * q2 - s[..., 1] * q3)
    Q = np.stack((q1, q2, q3, q4, q5, q6), axis=-1)
    return Q, trace.passed(L, 8)


def solve_three_parallel_prepared(
    c: ThreeParallel, R: FloatArray, p: FloatArray, dflt: FloatArray, trace: Trace
) -> tuple[FloatArray, BoolArray]:
    """`solve_three_parallel` for one fixed geometry whose constants `c` were prepared once
    (`ThreeParallel`: the same equations as its `solve`, on arrays).

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
    trace.fails.append(("shoulder", branch_flag(ok1, L, 8)))
    trace.frees.append(("the wrist point lies on joint 1's axis", branch_flag(fr1, L, 8)))
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
    pp = ux * ux + uy * uy + uz * uz
    alpha, beta, g2 = sp2_parts(c.c45, c.den, c.n12, kpu, c.kq, pp)
    ok2 = g2 >= -TANGENT_TOLERANCE * np.maximum(pp, e2)
    gamma = np.sqrt(np.maximum(g2, 0.0))
    upx, upy, upz = ux - w5x * kpu, uy - w5y * kpu, uz - w5z * kpu  # u′ normal to ω₆
    up_small = upx * upx + upy * upy + upz * upz <= e2
    gs = (gamma[:, :, None] * np.array((1.0, -1.0))).reshape(L, 4)
    alpha, beta, kpu, ux, uy, uz, upx, upy, upz, up_small = (
        spread_branches(a, 2) for a in (alpha, beta, kpu, ux, uy, uz, upx, upy, upz, up_small)
    )
    bx, by, bz = sp2_between(c.w4, c.w5, c.k12, alpha, beta, gs)
    fr6 = up_small | (bx * bx + by * by + bz * bz <= e2)
    q6 = np.arctan2(*turn_parts(c.w5, (upx, upy, upz), (bx, by, bz)))
    q6 = np.where(fr6, dflt[:, 5:6], q6)
    c6, s6 = np.cos(q6), np.sin(q6)
    f6 = kpu * (1.0 - c6)
    yx = ux * c6 + (w5y * uz - w5z * uy) * s6 + w5x * f6
    yy = uy * c6 + (w5z * ux - w5x * uz) * s6 + w5y * f6
    yz = uz * c6 + (w5x * uy - w5y * ux) * s6 + w5z * f6
    ky = w4x * yx + w4y * yy + w4z * yz
    ax, ay, az = yx - w4x * ky, yy - w4y * ky, yz - w4z * ky
    fr5 = (ax * ax + ay * ay + az * az <= e2) | (c.hp4n <= e2)
    q5 = np.arctan2(*turn_parts(c.w4, (ax, ay, az), c.hp4))
    q5 = np.where(fr5, dflt[:, 4:5], q5)
    trace.fails.append(("wrist", branch_flag(ok2, L, 8)))
    trace.frees.append(
        ("wrist axes aligned (joint 6 parallel to joints 2-4)", branch_flag(fr5 | fr6, L, 8))
    )
    # θ₂₃₄ from z₁ = R(ω₆, −q₆) R(ω₅, −q₅) x.
    c5, s5 = np.cos(q5), np.sin(q5)
    f = c.w4x * (1.0 - c5)
    x0 = c.x
    zx = x0[0] * c5 - c.w4xx[0] * s5 + w4x * f
    zy = x0[1] * c5 - c.w4xx[1] * s5 + w4y * f
    zz = x0[2] * c5 - c.w4xx[2] * s5 + w4z * f
    zx, zy, zz = turn_components(c.w5, c6, -s6, zx, zy, zz)
    X4 = [spread_branches(a, 2) for a in X1]
    H4 = [spread_branches(a, 2) for a in H1]
    t234 = np.arctan2(H4[0] * zx + H4[1] * zy + H4[2] * zz, X4[0] * zx + X4[1] * zy + X4[2] * zz)
    # K r₄ = e₁⁻¹ G e₆⁻¹ e₅⁻¹ r₄
    v, wxv, f = c.v43, c.w4xv, c.w4v * (1.0 - c5)
    o = c.p4
    o5 = c.p5
    mx = (o[0] - o5[0]) + v[0] * c5 - wxv[0] * s5 + w4x * f
    my = (o[1] - o5[1]) + v[1] * c5 - wxv[1] * s5 + w4y * f
    mz = (o[2] - o5[2]) + v[2] * c5 - wxv[2] * s5 + w4z * f
    mx, my, mz = turn_components(c.w5, c6, -s6, mx, my, mz)
    mx, my, mz = mx + o5[0], my + o5[1], mz + o5[2]
    nx = R00 * mx + R01 * my + R02 * mz + (px - r0x)
    ny = R10 * mx + R11 * my + R12 * mz + (py - r0y)
    nz = R20 * mx + R21 * my + R22 * mz + (pz - r0z)
    kx, ky, kz = turn_components(c.w0, spread_branches(c1, 2), -spread_branches(s1, 2), nx, ny, nz)
    r1 = c.p1
    krx, kry, krz = kx + (r0x - r1[0]), ky + (r0y - r1[1]), kz + (r0z - r1[2])
    # q₃: SP3 with constant p = r₄ − r₃, q = r₂ − r₃: (L, 4) → (L, 8).
    delta2 = krx * krx + kry * kry + krz * krz - c.dk3 * c.dk3
    q3, ok3, fr3 = sp.solve_trig(
        np.float64(c.a3), np.float64(c.b3), 0.5 * (c.pq3 - delta2), dflt[:, 2:3], c.eL2
    )
    trace.fails.append(("elbow", branch_flag(ok3, L, 8)))
    fr3 = np.broadcast_to(fr3, (L, 4))  # (a constant: a and b of this SP3 do not vary)
    trace.frees.append(("joint 4's axis passes through joint 3's axis", branch_flag(fr3, L, 8)))
    q3 = q3.reshape(L, 8)
    # q₂ = SP1(ω₂, e₃ r₄ − r₂ → K r₄ − r₂); the projection of the latter is shared.
    w1x, w1y, w1z = c.w1
    kk = w1x * krx + w1y * kry + w1z * krz
    bx, by, bz = krx - w1x * kk, kry - w1y * kk, krz - w1z * kk
    b_small = bx * bx + by * by + bz * bz <= c.eLsq
    bx, by, bz, b_small = (spread_branches(a, 2) for a in (bx, by, bz, b_small))
    c3, s3_ = np.cos(q3), np.sin(q3)
    v, wxv, v21, w2d = c.v32, c.w2xv, c.v21, c.w2
    f = c.w2v * (1.0 - c3)
    ex = v21[0] + v[0] * c3 + wxv[0] * s3_ + w2d[0] * f
    ey = v21[1] + v[1] * c3 + wxv[1] * s3_ + w2d[1] * f
    ez = v21[2] + v[2] * c3 + wxv[2] * s3_ + w2d[2] * f
    ke = w1x * ex + w1y * ey + w1z * ez
    ax, ay, az = ex - w1x * ke, ey - w1y * ke, ez - w1z * ke
    fr4 = b_small | (ax * ax + ay * ay + az * az <= c.eLsq)
    q2 = np.arctan2(*turn_parts(c.w1, (ax, ay, az), (bx, by, bz)))
    q2 = np.where(fr4, dflt[:, 1:2], q2)
    trace.frees.append(("the elbow point lies on joint 2's axis", fr4))
    s2, s3, s4 = c.s
    q4 = s4 * (spread_branches(t234, 2) - s2 * q2 - s3 * q3)
    Q = np.stack(
        (spread_branches(q1, 4), q2, q3, q4, spread_branches(q5, 2), spread_branches(q6, 2)),
        axis=-1,
    )
    return Q, trace.passed(L, 8)
