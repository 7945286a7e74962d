"""Closed-form IK: every solution, from Paden–Kahan subproblems, where the geometry allows.

Problem. The PoE model T(q) = e^{[S₁]q₁} ⋯ e^{[Sₙ]qₙ} M (MR eq. 4.14). For a target T_t (tip pose in
the base frame) put G = T_t M⁻¹ = e^{[S₁]q₁} ⋯ e^{[Sₙ]qₙ}, a product of rotations about the home
axes (ωᵢ, a point rᵢ on each). A point x on an axis is fixed by that joint's exponential; the
component hᵀx along h is kept by rotations about axes parallel to h; the distance from a point on
an axis is kept by that joint. These three invariants split the 6R problem into subproblems
(`kinematics_node.core.ik.subproblems`), each with at most two solutions, so at most 8 in all.

Families, detected from the screw axes S alone (never from names or DH tables), with tolerances
`ANGLE_TOLERANCE` [rad] and `DISTANCE_TOLERANCE` [m] that absorb the rounding of real URDFs:

* ``"three_parallel"`` (UR family): axes 2, 3, 4 parallel (direction h), axes 5 and 6 meet at c.
  hᵀ e₁⁻¹(G c) = hᵀc gives q₁ (SP4); hᵀR₁ᵀR_G = hᵀR₅R₆ gives (q₅, q₆) (SP2); then e₂e₃e₄ =
  e₁⁻¹ G e₆⁻¹ e₅⁻¹ gives q₃ (SP3, distance from axis 2), q₂ (SP1) and q₄ from the sum angle.
* ``"spherical_wrist"`` (Puma, ABB IRB, KUKA KR, Fanuc: OPW arms): axes 4, 5, 6 meet at the wrist
  centre c, so e₁e₂e₃ c = G c. The position problem is solved when the first three axes have one of
  four relations: 2 ∥ 3 (SP4, SP3, SP1), 1 ∩ 2 (SP3, SP2), 2 ∩ 3 (SP3, SP2) or 1 ∥ 2 (SP4, SP3,
  SP1). Then R₄R₅R₆ = R₃ᵀR₂ᵀR₁ᵀR_G gives (q₄, q₅) by SP2 and q₆ by SP1.
* Either of them read from the tip: the same structure in the reversed chain G⁻¹ = e^{−[S₆]q₆} ⋯
  e^{−[S₁]q₁} (e.g. a spherical shoulder).
* ``"7r_three_parallel"``, ``"7r_spherical_wrist"``: a 7R arm that becomes one of the above when one
  joint j is held at θ (the later axes move to Ad_{e^{[S_j]θ}} Sₖ, M to e^{[S_j]θ} M). The held
  joint's values are swept, vectorised (Panda: q₇; iiwa: q₃).

A detected structure is confirmed before it is used: random configurations must come back from
their own forward kinematics, which rejects degenerate cases (e.g. an iiwa with its elbow held).

Every candidate is checked by forward kinematics against the target; candidates within 1e-2 are
first refined by two Gauss–Newton steps (this restores full precision near singularities and on
URDFs whose axes meet only to within the tolerances). Only those within `tolerance` are returned.

Units: lengths [m], angles [rad]. Frames: targets are tip poses in the base frame.

Layout (one concept per module):

* `geometry`: lines of the screw axes, points and vectors on floats and in lanes, the scalar
  twins of `kinematics_node.core.ik.subproblems`, pose errors.
* `three_parallel`, `spherical_wrist`: one family each, its single-target form on Python floats
  and its vectorised form over lanes side by side (same equations, same branch order).
* `structure`: which family the axis relations of six lines allow (not yet confirmed).
* `chain_solver`: a detected structure with everything precomputed for a chain, the held joint of
  a 7R arm, the candidates of one or many targets and their forward-kinematics check.
* `solution_set`: the result types, whole-turn equivalents within the limits, duplicates, ranking.
* `detection`: detection (with confirmation) and the per-chain cache, and why a chain has none.
* `held`: the swept values of a 7R arm's held joint.
* `api`: the entry points `solve_all`, `solve_all_batch`, `nearest`, `nearest_batch`,
  `branches_within_limits`.
"""

from .api import (
    Branches,
    Nearest,
    NearestBatch,
    branches_within_limits,
    nearest,
    nearest_batch,
    solve_all,
    solve_all_batch,
)
from .detection import (
    ExportedFamily,
    export_family,
    family_of,
    import_family,
    no_closed_form_reason,
)
from .geometry import pose_errors
from .held import DEFAULT_HELD_SAMPLES, held_order
from .solution_set import ClosedFormBatchResult, ClosedFormResult
from .structure import ANGLE_TOLERANCE, DISTANCE_TOLERANCE, ClosedFormFamily

__all__ = [
    "ANGLE_TOLERANCE",
    "DEFAULT_HELD_SAMPLES",
    "DISTANCE_TOLERANCE",
    "Branches",
    "ExportedFamily",
    "Nearest",
    "NearestBatch",
    "ClosedFormBatchResult",
    "ClosedFormFamily",
    "ClosedFormResult",
    "export_family",
    "family_of",
    "held_order",
    "import_family",
    "nearest",
    "nearest_batch",
    "pose_errors",
    "no_closed_form_reason",
    "branches_within_limits",
    "solve_all",
    "solve_all_batch",
]
