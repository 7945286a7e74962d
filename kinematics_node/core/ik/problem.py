"""The IK problem: what one `ik` or `ik_batch` call solves, worked out once from the chain and
`IKOptions`, and used by both solvers (`_ik_single` on plain floats, `_ik_batch` vectorised).

It fixes the error being driven to zero (see `ik`'s docstring for the equations):

* ``coupled``: full pose, every weight > 0, no per-axis bounds: the body error twist
  V_b = log(T(q)⁻¹ T_target) (MR eq. 6.7's log) with the body Jacobian at the tip origin;
* otherwise the decoupled error e = (log(R_err), p_err), p_err = R(q)ᵀ(p_target − p(q)), with the
  body Jacobian of the target point attached to the tip, J_v + J_ω × p_err; only its position
  rows if ``position_only``.

The m components in use are weighted by `w` (r = W^½ e); a per-axis bound that is met zeroes its
component (``axis_tol``). Success means position and orientation errors within their tolerances,
or every component within its bound. The Levenberg–Marquardt tuning constants live here, once.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from .. import se3, so3
from ..exceptions import InvalidInputError
from ..model import KinematicChain, SolverModel
from .joint_space import pinnable_mask
from .options import IKOptions

FloatArray = NDArray[np.float64]

LAMBDA_INIT = 1e-2  # initial damping [same units as J J^T: m² or 1]
LAMBDA_MIN = 1e-12
LAMBDA_MAX = 1e6  # beyond this the attempt is stuck (steps rejected ~9 times in a row)
MAX_STEP = 1.0  # largest joint change per step [rad or m]; the step is scaled down to it
STALL_FRACTION = 0.05  # an accepted step that lowers the cost by less than 5 % ...
STALL_STEPS = 2  # ... this many times in a row ends the attempt (a local minimum or a limit)
# More joints pinned at a limit than the arm has spare degrees of freedom, max(n − m, 0), for this
# many accepted steps in a row ends the attempt: the free joints cannot span the task any more. On
# Panda this ends ~2/3 of the attempts that would fail, ~5 steps earlier, and ~5 % of attempts
# that would succeed; net, the share of targets needing > 80 iterations halves (1.8 % → 0.9 %).
PINNED_STEPS = 2


class ScalarView(NamedTuple):
    """`IKProblem`'s constants as plain Python values for `_ik_single` (shared by every call of
    the problem: read only). `unit_weights`, `base_axes`: see `IKProblem.scalar`."""

    lower: list[float]
    upper: list[float]
    periodic: list[bool]
    pinnable: list[bool]
    joint_weights: list[float]
    axis_tol: list[float] | None
    w: list[float]
    pos_mask: list[bool]
    ori_mask: list[bool]
    all_ori: bool
    unit_weights: bool
    base_axes: bool
    eye: FloatArray  # identity of the damped system's size, min(n, m)


@dataclass(frozen=True)
class IKProblem:
    """One IK call's constant data: the chain's joint space and the error definition.

    Attributes:
        chain: the robot model (its public interface, `model.KinematicChain`).
        model: `chain.solver_model` (scalar kernel, mimic map, periodic joints).
        opts: the call's `IKOptions`.
        lower, upper: (n,) joint limits. periodic: (n,) 2π-periodic joints. pinnable: (n,) joints
            that can sit pinned at a limit (`_joint_space.pinnable_mask`).
        joint_weights: (n,) weights of the joint-space distance to the seed.
        position_only: only the 3 position components are used (m = 3).
        coupled: the error is the body twist V_b (see the module docstring).
        w: (m,) weights of the components in use; an infinite axis bound counts as weight 0.
        sw: (m,) their square roots, W^½.
        axis_tol: None, or (6,) per-axis bounds (inf where the weight is 0).
        pos_mask, ori_mask: (3,) which position / rotation components count in the errors.
        m: rows of the error, 6 or 3. spare: redundant degrees of freedom, max(n − m, 0).
        all_weighted: every component of the pose counts (no zero weight, no infinite bound).
    """

    chain: KinematicChain
    model: SolverModel
    opts: IKOptions
    lower: FloatArray
    upper: FloatArray
    periodic: NDArray[np.bool_]
    pinnable: NDArray[np.bool_]
    joint_weights: FloatArray
    position_only: bool
    coupled: bool
    w: FloatArray
    sw: FloatArray
    axis_tol: FloatArray | None
    pos_mask: NDArray[np.bool_]
    ori_mask: NDArray[np.bool_]
    m: int
    spare: int
    all_weighted: bool

    @classmethod
    def build(cls, chain: KinematicChain, opts: IKOptions) -> IKProblem:
        """The problem of `chain` under `opts`.

        Raises:
            InvalidInputError: `opts.joint_weights` does not have one value per joint.
        """
        if opts.joint_weights is None:
            joint_weights = np.ones(chain.dof)
        elif len(opts.joint_weights) != chain.dof:
            raise InvalidInputError(
                f"IKOptions.joint_weights must have {chain.dof} values (one per joint "
                f"{list(chain.joint_names)}), got {len(opts.joint_weights)}"
            )
        else:
            joint_weights = np.array(opts.joint_weights)
        w = np.array(opts.weights if opts.weights is not None else (1.0,) * 6)
        position_only = bool(opts.position_only)
        # TRAC-IK-style per-axis bounds on the decoupled error. An infinite bound frees its axis
        # exactly like a zero weight (the row leaves the cost and the Jacobian); a finite bound
        # zeroes its component while it is met, so the step leaves it where it is.
        axis_tol = None
        if opts.axis_tolerances is not None:
            bounds = np.array(opts.axis_tolerances)
            w = np.where(np.isinf(bounds), 0.0, w)
            axis_tol = np.where(w > 0, bounds, np.inf)
        m = 3 if position_only else 6
        model = chain.solver_model
        lower, upper = np.asarray(chain.lower), np.asarray(chain.upper)
        return cls(
            chain=chain,
            model=model,
            opts=opts,
            lower=lower,
            upper=upper,
            periodic=model.periodic,
            pinnable=pinnable_mask(lower, upper, model.periodic),
            joint_weights=joint_weights,
            position_only=position_only,
            coupled=not position_only and bool(np.all(w > 0)) and axis_tol is None,
            w=w[3:] if position_only else w,
            sw=np.sqrt(w[3:] if position_only else w),
            axis_tol=axis_tol,
            pos_mask=w[3:] > 0,
            ori_mask=w[:3] > 0,
            m=m,
            spare=max(chain.dof - m, 0),
            all_weighted=bool(np.all(w > 0)),
        )

    @cached_property
    def scalar(self) -> ScalarView:
        """The constants of the scalar solver, made once per problem rather than once per call."""
        w: list[float] = self.w.tolist()
        # The LM step Δq = Jᵀ(JJᵀ + λI)⁻¹r is unchanged when J's rows and r are rotated together
        # (an orthogonal change of task-space axes). With weights that are equal within the
        # rotation block and within the translation block, J and r are therefore expressed in
        # base axes: J's columns need no rotation into the tip frame (7 × 18 multiplications
        # saved per Jacobian), only r is rotated (18).
        blocks = [w] if self.position_only else [w[:3], w[3:]]
        eye = np.eye(min(self.lower.shape[0], self.m))
        eye.flags.writeable = False
        ori_mask: list[bool] = self.ori_mask.tolist()
        return ScalarView(
            lower=self.lower.tolist(),
            upper=self.upper.tolist(),
            periodic=self.periodic.tolist(),
            pinnable=self.pinnable.tolist(),
            joint_weights=self.joint_weights.tolist(),
            axis_tol=None if self.axis_tol is None else self.axis_tol.tolist(),
            w=w,
            pos_mask=self.pos_mask.tolist(),
            ori_mask=ori_mask,
            all_ori=all(ori_mask),
            unit_weights=all(x == 1.0 for x in w),
            base_axes=all(len(set(b)) == 1 for b in blocks),
            eye=eye,
        )

    def evaluate_batch(
        self, Q: FloatArray, R_t: FloatArray, p_t: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, NDArray[np.bool_], FloatArray]:
        """At configurations Q (k, n) for targets (R_t (k, 3, 3), p_t (k, 3)): the weighted cost
        E = Σ wᵢ eᵢ² (k,), the error e (k, m), position error [m], orientation error [rad],
        within tolerance (k,), and the weighted Jacobian W^½ J (k, m, n)."""
        T_c, J = self.chain.fk_jacobian(Q, "body")
        R_c, p_c = T_c[:, :3, :3], T_c[:, :3, 3]
        R_cT = np.swapaxes(R_c, 1, 2)
        R_e = R_cT @ R_t  # T_err = T_c⁻¹ T_t
        p_e = (R_cT @ (p_t - p_c)[:, :, None])[:, :, 0]
        if self.coupled:
            e = se3.log(se3.make_transform(R_e, p_e))
            phi = e[:, :3]
        else:
            phi = so3.log(R_e)
            e = p_e if self.position_only else np.concatenate((phi, p_e), axis=1)
            # body Jacobian of the target point attached to the tip: J_v + J_ω × p_err
            Jw, Jv = J[:, :3, :], J[:, 3:, :]
            Jv = Jv + np.swapaxes(np.cross(np.swapaxes(Jw, 1, 2), p_e[:, None, :]), 1, 2)
            J = Jv if self.position_only else np.concatenate((Jw, Jv), axis=1)
        within: NDArray[np.bool_] | None = None
        if self.axis_tol is not None:  # a component within its bound is met and exerts no pull
            within = np.abs(e) <= self.axis_tol  # False for NaN
            e = np.where(within, 0.0, e)
        E = np.einsum("km,m->k", e * e, self.w)
        pos = np.sqrt(np.einsum("kj,j->k", p_e * p_e, self.pos_mask.astype(np.float64)))
        if self.position_only:
            ori = np.zeros(Q.shape[0])
        elif self.ori_mask.all():
            ori = np.linalg.norm(phi, axis=1)
        else:
            ori = np.sqrt(np.einsum("kj,j->k", phi * phi, self.ori_mask.astype(np.float64)))
        ok: NDArray[np.bool_]
        if within is not None:
            ok = np.all(within, axis=1)
        else:
            ok = (pos <= self.opts.position_tolerance) & (ori <= self.opts.orientation_tolerance)
        return E, e, pos, ori, ok, J * self.sw[None, :, None]
