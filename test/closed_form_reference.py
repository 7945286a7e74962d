"""Reference forms of the closed-form families for the tests: the single-target solvers written
as plain chains of subproblem calls, without prepared constants.

`ThreeParallel` and `Spherical` (kinematics_node.core.ik.closed_form) must give the same candidates,
in the same order, with the same stages and reasons (test_closed_form_single.py,
test_closed_form_spherical.py). Angles [rad], lengths [m].
"""

from __future__ import annotations

from collections.abc import Sequence
from math import atan2

from kinematics_node.core.ik.closed_form.geometry import (
    Candidate,
    Geometry,
    Mat,
    Stages,
    Vec,
    add,
    cross,
    dot,
    matvec,
    norm,
    reasons_of,
    rotate,
    rotate_about,
    solve_trig,
    sp1,
    sp2,
    sp3,
    sp4,
    sub,
)


def three_parallel(
    g: Geometry, R: Mat, p: Vec, d: Sequence[float], stages: Stages
) -> list[Candidate]:
    """Mirror of `closed_form.three_parallel.solve_three_parallel` (same equations, same branch order)."""
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
    """Mirror of `closed_form.spherical_wrist.solve_spherical` (same equations, same branch order)."""
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
                    why = reasons_of((frA, "the wrist centre lies on joint 1's axis"),
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
                    why = reasons_of((frA, "the wrist centre lies on joint 3's axis"),
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
                    why = reasons_of((frA, "the wrist centre lies on joint 1's axis"),
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
                    why = reasons_of((frA, "the wrist centre lies on joint 3's axis"),
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
