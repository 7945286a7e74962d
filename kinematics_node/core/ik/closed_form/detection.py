"""Detection of a chain's closed-form family, once per chain, and why a chain has none.

A structure allowed by the axis relations (`structure._candidates`) is confirmed before it is
used: random configurations must come back from their own forward kinematics, which rejects
degenerate cases (e.g. an iiwa with its elbow held). A 7R arm is tried with each joint held.
"""

from __future__ import annotations

import math
import weakref

import numpy as np

from ...exceptions import InvalidInputError, NoClosedFormError
from ...model import KinematicChain
from .. import subproblems as sp
from .chain_solver import ChainSolver, solve_arrays, solve_branches
from .geometry import axis_lines, exp_rotation, meet_point, wrap_angles
from .structure import (
    ANGLE_TOLERANCE,
    CASE_LABEL,
    DISTANCE_TOLERANCE,
    EXACT_RELATION,
    ClosedFormFamily,
    Structure,
    collinear_axes,
    structure_candidates,
    structure_residual,
)


def _confirm(solver: ChainSolver) -> bool:
    """True if random configurations come back from their own FK (rejects degenerate structures)."""
    rng = np.random.default_rng(12345)
    q = rng.uniform(-math.pi, math.pi, size=(24, solver.chain.dof))
    T = solver.chain.fk(q)
    held = None if solver.held is None else q[:, solver.held]
    seeds = rng.uniform(-math.pi, math.pi, size=q.shape)  # not q: a free angle must not be guessed
    sol = solve_arrays(
        solver, T, seeds, None if held is None else held[:, None], 1e-9, use_limits=False
    )
    if not np.all(sol.count > 0):
        return False
    for i in range(q.shape[0]):
        d = np.abs(wrap_angles(sol.solutions_of(i) - q[i])).max(axis=1)
        if d.min() > 1e-6:
            return False
    return True


def _why_not(chain: KinematicChain) -> str:
    """Why a chain has no closed form, in a sentence (for NoClosedFormError)."""
    if any(t == "prismatic" for t in chain.joint_types):
        return "it has prismatic joints (only all-revolute arms have a closed form here)"
    if chain.dof not in (6, 7):
        return f"it has {chain.dof} joints (closed forms here are for 6R and 7R arms)"
    if chain.solver_model.G is not None:
        return "it has mimic joints (closed forms here are for arms whose joints move alone)"
    w, r = axis_lines(np.asarray(chain.S))
    pair = collinear_axes(w, r) if chain.dof == 6 else None
    if pair is not None:
        a, b = (chain.joint_names[k] for k in pair)
        return (
            f"joints {a!r} and {b!r} turn about one line (collinear axes), so the tip moves "
            "with their sum (or difference) alone: every reachable pose has infinitely many "
            "solutions, which no closed form lists"
        )
    parts = []
    for rev, label in ((False, "last"), (True, "first")):
        ww, rr = (w[::-1], r[::-1]) if rev else (w, r)
        _, miss = meet_point(ww[3:6], rr[3:6])
        parts.append(f"the {label} three axes miss a common point by {float(miss):.3g} m")
    return (
        "no structure was found: "
        + "; ".join(parts)
        + f" (tolerances {DISTANCE_TOLERANCE:g} m, {ANGLE_TOLERANCE:g} rad), and no three "
        "consecutive parallel axes are followed by two that meet"
    )


def no_closed_form_reason(chain: KinematicChain) -> str:
    """Why `chain` has no closed-form family, in a sentence ("" if it has one)."""
    return "" if solver_of(chain) is not None else _why_not(chain)


def detect(chain: KinematicChain) -> ChainSolver | None:
    """The closed-form solver of `chain`, or None. Geometry only: the lines of the screw axes S."""
    if any(t == "prismatic" for t in chain.joint_types) or chain.dof not in (6, 7):
        return None
    if chain.solver_model.G is not None:
        return None  # mimic joints: S has a column per moving joint, θ = G q + offset ≠ q
    S = np.asarray(chain.S)
    w, r = axis_lines(S)
    if not np.allclose(sp.norm(w), 1.0, atol=1e-9) or np.abs(sp.dot(w, S[3:].T)).max() > 1e-9:
        return None  # not pure revolute screws
    if chain.dof == 6:
        if collinear_axes(w, r) is not None:
            return None  # a redundant arm: infinitely many solutions (`_why_not`)
        scale = float(max(1e-3, np.abs(r).max(), np.abs(np.asarray(chain.M)[:3, 3]).max()))
        for st in structure_candidates(w, r):
            if structure_residual(st, w, r, scale) > EXACT_RELATION:
                continue  # a family only to rounding: the general solver needs no Newton steps
            solver = ChainSolver(chain, st, None)
            if _confirm(solver):
                return solver
        # The general solver (then the families to rounding): of the orders of the loop that
        # confirm, the first that misses nothing on a larger sample and finds its roots to
        # `WELL_CONDITIONED`, else the one missing least, then the most accurate (near-degenerate
        # eliminations, e.g. a wrist that nearly meets, lose near-double roots; one that misses
        # none of 256 may still miss a few in 10,000 where some roots are found only to ~1e-6).
        chosen: tuple[tuple[int, float], ChainSolver] | None = None
        for st in _GENERAL + structure_candidates(w, r):
            solver = ChainSolver(chain, st, None)
            if not _confirm(solver):
                continue
            score = _missed(solver)
            if score[0] == 0 and score[1] <= WELL_CONDITIONED:
                return solver
            if chosen is None or score < chosen[0]:
                chosen = (score, solver)
        return None if chosen is None else chosen[1]
    # 7R: hold joint j; the structure must hold whatever its value.
    probe = np.array([0.0, 1.1, -2.3])
    found_solvers: list[ChainSolver] = []
    for j in range(7):
        keep = [i for i in range(7) if i != j]
        common: list[Structure] | None = None
        for theta in probe:
            E = exp_rotation(w[j], r[j], np.array([theta]))[0]
            wj, rj = w.copy(), r.copy()
            wj[j + 1 :] = wj[j + 1 :] @ E[:3, :3].T
            rj[j + 1 :] = rj[j + 1 :] @ E[:3, :3].T + E[:3, 3]
            found = structure_candidates(wj[keep], rj[keep])
            common = found if common is None else [s for s in common if s in found]
        for st in common or []:
            solver = ChainSolver(chain, st, j)
            if _confirm(solver):
                found_solvers.append(solver)
                break
    if not found_solvers:  # no named family with any joint held: the general 6R solver
        for j in range(7):
            for st in _GENERAL:
                solver = ChainSolver(chain, st, j)
                if _confirm(solver):
                    found_solvers.append(solver)
                    break
    if not found_solvers:
        return None
    # Prefer the held joint whose values least often make a target unreachable (Panda: joint 7,
    # not the elbow), then the one nearest the middle of the chain (iiwa: joint 3).
    scored = [(_held_coverage(s), s) for s in found_solvers]
    best = max(c for c, _ in scored)
    ties = [s for c, s in scored if c >= best - 0.1]
    return min(ties, key=lambda s: (abs((s.held or 0) - 3), s.held))


#: The general 6R solver read from the base, then from the tip (a geometry that degenerates one
#: elimination may not degenerate the other).
#: Then with the loop read from another joint (`general_6r.solve_general_6r_shifted`): first
#: from joint 6, then 5 (the target then moves only the loop's first joints, so that every
#: target takes the arm prepared once and only its right-hand side moves: `general_6r.MovedFirst`),
#: then from joints 2, 3 and 4 (the arm then built per target on the joints it does not move).
_GENERAL = [
    Structure("general_6r", "" if k == 0 else str(k), rev)
    for k in (0, 5, 4, 1, 2, 3)
    for rev in (False, True)
]


#: The 99th percentile of the error [rad] of the unrefined root nearest each sampled
#: configuration below which a general 6R order of the loop is taken at once (random arms, IRB 140,
#: xArm 6: 1e-12 to 1e-10; an order that degenerates near double roots, as a Puma read from the
#: tip when its wrist misses by 1 mm, ~1e-6, and misses about one target in a thousand).
WELL_CONDITIONED = 1e-8


def _missed(solver: ChainSolver, n: int = 256) -> tuple[int, float]:
    """How many of n random configurations of a 6R arm are missing from their own solution sets
    (limits ignored), and the 99th percentile over them of the distance [rad] from each to the
    nearest unrefined root (how well conditioned the solver's elimination is)."""
    rng = np.random.default_rng(2468)
    q = rng.uniform(-math.pi, math.pi, size=(n, 6))
    T = solver.chain.fk(q)
    out = solve_arrays(solver, T, np.zeros_like(q), None, 1e-9, use_limits=False)
    missed = 0
    for i in range(n):
        sols = out.solutions_of(i)
        missed += not sols.shape[0] or bool(
            np.abs(wrap_angles(sols - q[i])).max(axis=1).min() > 1e-6
        )
    Q, ok, _, _, _ = solve_branches(solver, T, np.zeros_like(q), None)
    d = np.where(ok, np.abs(wrap_angles(Q - q[:, None])).max(axis=2), np.inf).min(axis=1)
    return missed, float(np.percentile(d, 99))


def _held_coverage(solver: ChainSolver) -> float:
    """Fraction of (random target, random held value) pairs with a solution, limits ignored."""
    rng = np.random.default_rng(54321)
    N, K = 32, 8
    q = rng.uniform(-math.pi, math.pi, size=(N, solver.chain.dof))
    held = rng.uniform(-math.pi, math.pi, size=K)
    out = solve_arrays(solver, solver.chain.fk(q), q, held, 1e-9, use_limits=False)
    # Lanes are target-major; count (target, held value) pairs with at least one solution.
    return float(np.count_nonzero(out.lane_count) / (N * K))


_SOLVERS: weakref.WeakKeyDictionary[KinematicChain, ChainSolver | None] = (
    weakref.WeakKeyDictionary()
)


def solver_of(chain: KinematicChain) -> ChainSolver | None:
    """The chain's detected solver, detected once per chain (the chain is immutable)."""
    try:
        return _SOLVERS[chain]
    except KeyError:
        solver = detect(chain)
        _SOLVERS[chain] = solver
        return solver


#: What `export_family` gives: the structure found and the held joint, or None (no family).
ExportedFamily = tuple[str, str, bool, int | None] | None


def export_family(chain: KinematicChain) -> ExportedFamily:
    """The chain's detected family (detecting it if needed) as a small picklable value, for a
    process that will solve IK on a copy of the same chain (`import_family` there skips the
    20–100 ms detection: the node's IK workers)."""
    solver = solver_of(chain)
    if solver is None:
        return None
    st = solver.structure
    return (st.kind, st.case, st.reversed, solver.held)


def import_family(chain: KinematicChain, exported: ExportedFamily) -> None:
    """Install what `export_family` gave for an equal chain (same screw axes, home pose and
    limits: e.g. an unpickled copy) without detecting it again. A chain whose family is already
    known keeps it.

    Raises:
        InvalidInputError: `exported` is not a value `export_family` gives for this chain's size.
    """
    if chain in _SOLVERS:
        return
    if exported is None:
        _SOLVERS[chain] = None
        return
    try:
        kind, case, rev, held = exported
        ok = (kind in ("three_parallel", "spherical_wrist") and case in CASE_LABEL) or (
            kind == "general_6r" and case in ("", "1", "2", "3", "4", "5")
        )
        ok = ok and (held is None if chain.dof == 6 else held in range(chain.dof))
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise InvalidInputError(f"not an exported closed-form family of this chain: {exported!r}")
    _SOLVERS[chain] = ChainSolver(chain, Structure(kind, case, bool(rev)), held)


def family_of(chain: KinematicChain) -> ClosedFormFamily | None:
    """The closed-form family of `chain` with its details, or None where none applies."""
    solver = solver_of(chain)
    return None if solver is None else solver.family()


def require_solver(chain: KinematicChain) -> ChainSolver:
    solver = solver_of(chain)
    if solver is None:
        raise NoClosedFormError(
            f"no closed-form IK for chain {chain.base_link!r} → {chain.tip_link!r}: "
            f"{_why_not(chain)}; use chain.ik (numeric) instead"
        )
    return solver
