"""Inverse kinematics: the closed form where the arm has one, a numeric search elsewhere.

* `solver`: `solve` and `solve_batch`, which pick the method (`IKOptions.method`) and combine
  them; `SerialChain.ik` and `ik_batch` call these.
* `closed_form/`: every solution of the arms whose axes form a known family (detection, one module
  per family, the general 6R solver, the solution set); docs/closed_form.md.
* the numeric search: `problem` (the residual and its weights), `single` and `batch` (damped least
  squares, one target or many at once), `pose_error` (SE(3) and SO(3) logs), `joint_space` (limits
  and whole-turn equivalents).
* `subproblems`: the Paden–Kahan subproblems that the closed forms are built from.
* `options`, `result`: `IKOptions`, `IKResult`, `IKBatchResult`.

Importing this package costs only NumPy: the solvers (and SciPy) load with `solver`.
"""

from __future__ import annotations

from .options import IKOptions
from .result import IKBatchResult, IKResult

__all__ = ["IKBatchResult", "IKOptions", "IKResult"]
