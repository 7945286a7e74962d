"""The "spherical_wrist" family (Puma, ABB IRB, KUKA KR, Fanuc: OPW arms).

Axes 4, 5, 6 meet at the wrist centre c, so e₁e₂e₃ c = G c. The position problem is solved when
the first three axes have one of four relations: 2 ∥ 3 (SP4, SP3, SP1), 1 ∩ 2 (SP3, SP2), 2 ∩ 3
(SP3, SP2) or 1 ∥ 2 (SP4, SP3, SP1). Then R₄R₅R₆ = R₃ᵀR₂ᵀR₁ᵀR_G gives (q₄, q₅) by SP2 and q₆ by
SP1.

Single-target forms on floats (`spherical`, and `Spherical` with the constants of one geometry
prepared) beside the vectorised form over lanes (`solve_spherical`): same equations, same branch
order, and the tests compare them. Angles [rad], lengths [m].
"""

from __future__ import annotations

from collections.abc import Sequence
from math import atan2, cos, sin, sqrt

import numpy as np
from numpy.typing import NDArray

from .. import subproblems as sp
from ..subproblems import TANGENT_TOLERANCE
from .geometry import (
    BoolArray,
    Candidate,
    FloatArray,
    Geometry,
    LaneGeometry,
    Mat,
    PreparedSP2,
    PreparedSP3,
    Stages,
    Trace,
    Vec,
    add,
    apply_rotation,
    branch_flag,
    cross,
    dot,
    grow_branches,
    matvec,
    norm,
    per_lane,
    project_out,
    reasons_of,
    rotate_about,
    rotate_cs,
    solve_trig,
    sp1,
    sp2_between,
    sp2_parts,
    sp3,
    sp4,
    sub,
    turn_components,
    turn_parts,
)


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
            self.sp3 = PreparedSP3(W[2], sub(c, P[2]), sub(P[1], P[2]))
        elif case == "int12":
            self.sp3 = PreparedSP3(W[2], sub(c, P[2]), sub(b, P[2]))
            self.sp2 = PreparedSP2(W[0], W[1])
        elif case == "int23":
            self.delta2 = dot(sub(c, b), sub(c, b))
            self.cb = sub(c, b)
            self.sp2 = PreparedSP2(W[1], W[2])
        # x = R(ω₃, q₃)(c − r₃) + r₃ (par23, int12, par12): c − r₃, ω₃ × (c − r₃), ω₃ᵀ(c − r₃).
        v = sub(c, P[2])
        self.v3, self.w2xv, self.w2v = v, cross(W[2], v), dot(W[2], v)
        # The wrist: SP2 (ω₄, ω₅) of ω₆ onto v₆; then SP1 about ω₆ of x.
        self.wsp2 = PreparedSP2(W[3], W[4])
        w5 = W[5]
        self.kp_w = dot(W[4], w5)
        self.pp_w = dot(w5, w5)
        self.w5p4 = project_out(W[4], w5)  # ω₆ projected normal to ω₅ (the first SP1's p′)
        self.w4xw5, self.w4w5 = cross(W[4], w5), dot(W[4], w5)
        self.xp5 = project_out(w5, g.x)  # x projected normal to ω₆ (q₆'s SP1 p′)
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
                        why = reasons_of((frA, "the wrist centre lies on joint 1's axis"),
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
                        why = reasons_of((frA, "the wrist centre lies on joint 3's axis"),
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
                        why = reasons_of((frA, "the wrist centre lies on joint 1's axis"),
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
        w3x, w3y, w3z = w3
        w4x, w4y, w4z = w4
        kp, pp = self.kp_w, self.pp_w
        ap = self.w5p4
        a_small = dot(ap, ap) <= 1e-18
        uxw, uw = self.w4xw5, self.w4w5
        d3, d4, d5 = d[3], d[4], d[5]
        w5x, w5y, w5z = w5
        xp = self.xp5
        x_small = self.x_small
        last_q1 = None
        for q1, q2, q3, why in arms:
            # v₆ and y₀: Rω₆ and Rx turned by −q₁ about ω₁, −q₂ about ω₂, −q₃ about ω₃ (the
            # first turn shared by consecutive arms with the same q₁: par23, int23).
            if q1 != last_q1:
                c1, s1 = cos(q1), -sin(q1)
                v1, x1 = rotate_cs(w0, c1, s1, Rw5), rotate_cs(w0, c1, s1, Rx)
                last_q1 = q1
            c2, s2 = cos(q2), -sin(q2)
            c3, s3 = cos(q3), -sin(q3)
            v6 = rotate_cs(w2, c3, s3, rotate_cs(w1, c2, s2, v1))
            y0x, y0y, y0z = rotate_cs(w2, c3, s3, rotate_cs(w1, c2, s2, x1))
            v6x, v6y, v6z = v6
            # SP2 (ω₄, ω₅) of p = ω₆ onto q = v₆ (`sp2` written out, p fixed).
            kq = w3x * v6x + w3y * v6y + w3z * v6z
            alpha, beta, g2 = sp2_parts(c34, den, n12, kp, kq, pp)
            if g2 < -TANGENT_TOLERANCE * max(pp, 1e-18):
                continue
            gamma = sqrt(max(g2, 0.0))
            # v₆ projected normal to ω₄ (the target of q₄'s SP1), shared by both branches
            bvx, bvy, bvz = v6x - w3x * kq, v6y - w3y * kq, v6z - w3z * kq
            bv_small = bvx * bvx + bvy * bvy + bvz * bvz <= 1e-18
            for gs in (gamma, -gamma):
                # q₅ = SP1(ω₅, ω₆ → z), the projection of ω₆ stored
                bx, by, bz = sp2_between(w3, w4, sp2w.k12, alpha, beta, gs)
                if a_small or bx * bx + by * by + bz * bz <= 1e-18:
                    q5, f2 = d4, True
                else:
                    q5 = atan2(*turn_parts(w4, ap, (bx, by, bz)))
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
                    q4 = atan2(*turn_parts(w3, (ax, ay, az), (bvx, bvy, bvz)))
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
                    q6 = atan2(*turn_parts(w5, xp, (bx, by, bz)))
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
                why = reasons_of((frA, "the wrist centre lies on joint 3's axis"),
                           (frB, "the wrist centre lies on joint 2's axis"),
                           (frC, "the wrist centre lies on joint 1's axis"))  # fmt: skip
                arms.append((q1, q2, q3, why))
    return arms


def solve_spherical(
    case: str,
    g: LaneGeometry,
    R: FloatArray,
    p: FloatArray,
    dflt: FloatArray,
    trace: Trace,
    prepared: Spherical | None = None,
) -> tuple[FloatArray, BoolArray]:
    """All 8 branches of a spherical-wrist 6R arm. `prepared`: the constants of a geometry g that
    is the same for every lane (`Spherical`): the wrist then runs on them
    (`_wrist_prepared`)."""
    w, r, c, b, h = g.w, g.r, g.c, g.b, g.h
    eL, eL2 = 1e-9 * g.scale, 1e-12 * g.scale**2
    W = [per_lane(w[:, i]) for i in range(6)]  # (L, 1, 3): broadcast over branches
    P = [per_lane(r[:, i]) for i in range(6)]
    cv, bv, hv = per_lane(c), per_lane(b), per_lane(h)
    L = R.shape[0]
    pc = per_lane(
        apply_rotation(R, np.broadcast_to(c, (L, 3))) + p
    )  # wrist centre: e₁e₂e₃ c = G c, (L, 1, 3)
    d = [dflt[:, i : i + 1] for i in range(6)]  # (L, 1)
    fails: list[tuple[str, NDArray]] = []
    frees: list[tuple[str, NDArray]] = []
    if case == "par23":
        # hᵀ e₁⁻¹(G c) = hᵀc (SP4 in φ = −q₁); ‖e₃c − r₂‖ = ‖e₁⁻¹Gc − r₂‖ (SP3); e₂(e₃c) = e₁⁻¹Gc (SP1).
        phi, okA, frA = sp.sp4(W[0], pc - P[0], hv, sp.dot(hv, cv - P[0]), -d[0], eL)
        q1 = -phi.reshape(L, 2)
        wp = sp.rotate_about(W[0], P[0], -q1, pc)  # (L, 2, 3)
        q3, okB, frB = sp.sp3(W[2], cv - P[2], P[1] - P[2], sp.norm(wp - P[1]), d[2], eL2)
        q1, wp, q3 = grow_branches(q1, 4), grow_branches(wp, 4), q3.reshape(L, 4)
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
        q1, q2, q3 = t1.reshape(L, 4), t2.reshape(L, 4), grow_branches(q3, 4)
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
        q1, q2, q3 = grow_branches(q1, 4), t2.reshape(L, 4), t3.reshape(L, 4)
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
        q3, x, q2 = grow_branches(q3, 4), grow_branches(x, 4), q2.reshape(L, 4)
        y = sp.rotate_about(W[1], P[1], q2, x)
        q1, frC = sp.sp1(W[0], y - P[0], pc - P[0], d[0], eL)
        fails += [("shoulder", okA), ("elbow", okB)]
        frees += [
            ("the wrist centre lies on joint 3's axis", frA),
            ("the wrist centre lies on joint 2's axis", frB),
            ("the wrist centre lies on joint 1's axis", frC),
        ]

    if prepared is not None:
        q1, q2, q3 = (grow_branches(a, 8) for a in (q1, q2, q3))
        q4, q5, q6, okC, frD = _wrist_prepared(prepared, R, q1, q2, q3, dflt)
        return _finish(trace, fails, frees, okC, frD, L, (q1, q2, q3, q4, q5, q6))

    # Orientation R₄R₅R₆ = R_w = R₃ᵀR₂ᵀR₁ᵀR_G: R₄R₅ ω₆ = R_w ω₆ (SP2), R₆ x = (R₄R₅)ᵀR_w x (SP1).
    def to_wrist(v: FloatArray, q1: FloatArray, q2: FloatArray, q3: FloatArray) -> FloatArray:
        v = sp.rotate(W[0], -q1, v)
        v = sp.rotate(W[1], -q2, v)
        return sp.rotate(W[2], -q3, v)

    v6 = to_wrist(np.broadcast_to(per_lane(apply_rotation(R, w[:, 5])), (L, 4, 3)), q1, q2, q3)
    t4, t5, okC, frD = sp.sp2(W[3], W[4], np.broadcast_to(W[5], v6.shape), v6, d[3], d[4], 1e-9)
    q1, q2, q3 = (grow_branches(a, 8) for a in (q1, q2, q3))
    q4, q5 = t4.reshape(L, 8), t5.reshape(L, 8)
    x6 = np.broadcast_to(per_lane(g.x), (L, 8, 3))
    y = to_wrist(apply_rotation(R, x6), q1, q2, q3)
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
        trace.fails.append((name, branch_flag(f, L, 8)))
    for name, f in frees + [("wrist axes aligned (joints 4 and 6 coincide)", frD)]:
        trace.frees.append((name, branch_flag(f, L, 8)))
    return np.stack(angles, axis=-1), trace.passed(L, 8)


def _wrist_prepared(
    c: Spherical, R: FloatArray, q1: FloatArray, q2: FloatArray, q3: FloatArray, dflt: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray, BoolArray, BoolArray]:
    """The wrist of `solve_spherical` (q₄, q₅, q₆ (L, 8), ok (L, 4), free (L, 8)) for a geometry
    whose constants `c` were prepared once (`Spherical.solve`'s wrist, on
    arrays).

    Hand-written for speed (`ik_batch` on Panda runs it for every held value tried): vectors are
    three (L, b) component arrays and the axes floats, so a rotation costs a few scaled sums
    instead of cross products of stacked (L, b, 3) arrays. Same equations, branch layout, flags
    and tolerances as the general wrist (‖x‖ ≤ ε tested as ‖x‖² ≤ ε²; the tests compare them).
    """
    w0, w1, w2, w3, w4, w5 = c.W
    sp2w = c.wsp2
    c34, den, n12 = sp2w.c, sp2w.den, sp2w.n12
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
    v = turn_components(
        w2, cs3, sn3, *turn_components(w1, cs2, sn2, *turn_components(w0, cs1, sn1, *applied(w5)))
    )
    y = turn_components(
        w2, cs3, sn3, *turn_components(w1, cs2, sn2, *turn_components(w0, cs1, sn1, *applied(c.x)))
    )
    # SP2 (ω₄, ω₅) of p = ω₆ onto q = v₆.
    kp, pp = c.kp_w, c.pp_w
    kq = w3x * v[0] + w3y * v[1] + w3z * v[2]
    alpha, beta, g2 = sp2_parts(c34, den, n12, kp, kq, pp)
    ok = g2 >= -TANGENT_TOLERANCE * max(pp, 1e-18)
    gamma = np.sqrt(np.maximum(g2, 0.0))
    gs = np.stack((gamma, -gamma), axis=-1).reshape(L, 8)

    def two(a: FloatArray) -> FloatArray:
        return np.repeat(a, 2, axis=1)

    alpha, beta, kq = two(alpha), two(beta), two(kq)
    vx, vy, vz = (two(a) for a in v)
    y0x, y0y, y0z = (two(a) for a in y)
    # q₅ = SP1(ω₅, ω₆ → z), z = α ω₄ + β ω₅ + γ (ω₄ × ω₅)
    bx, by, bz = sp2_between(w3, w4, sp2w.k12, alpha, beta, gs)
    a_small = dot(c.w5p4, c.w5p4) <= 1e-18
    fr5 = (bx * bx + by * by + bz * bz <= 1e-18) | a_small
    q5 = np.arctan2(*turn_parts(w4, c.w5p4, (bx, by, bz)))
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
    q4 = np.arctan2(*turn_parts(w3, (ax, ay, az), (bvx, bvy, bvz)))
    q4 = np.where(fr4, dflt[:, 3:4], q4)
    # y = R(ω₅, −q₅) R(ω₄, −q₄) y₀; q₆ = SP1(ω₆, x → y)
    yx, yy, yz = turn_components(
        w4, cs5, -sn5, *turn_components(w3, np.cos(q4), -np.sin(q4), y0x, y0y, y0z)
    )
    ky = w5x * yx + w5y * yy + w5z * yz
    bx, by, bz = yx - w5x * ky, yy - w5y * ky, yz - w5z * ky
    fr6 = (bx * bx + by * by + bz * bz <= 1e-18) | c.x_small
    q6 = np.arctan2(*turn_parts(w5, c.xp5, (bx, by, bz)))
    q6 = np.where(fr6, dflt[:, 5:6], q6)
    return q4, q5, q6, ok, fr4 | fr5
