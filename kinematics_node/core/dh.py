"""Denavit–Hartenberg tables and raw screw axes → `ChainSpec`.

Standard DH as in De Luca's slides: frame i−1 → i is
    ^{i−1}A_i = R_Z(θ_i) T_Z(d_i) T_X(a_i) R_X(α_i),
with θ_i = q_i + theta for a revolute joint and d_i = q_i + d for a prismatic one; the axis of joint
i is z_{i−1}.

A table is a sequence of rows, each a mapping with keys ``a`` [m], ``alpha`` [rad], ``d`` [m],
``theta`` [rad] (the constant part), ``type`` ("revolute"/"R" or "prismatic"/"P"), and optionally
``name``, ``lower``, ``upper`` (limits; ±inf when absent) and ``velocity``. A row may also be a
list (or tuple) of its values in the order ``a, alpha, d, theta[, type]``, and the whole table a
2-D array of ``a, alpha, d, theta`` rows (revolute joints); use mappings to give names and limits.
A mapping ``{"joints": [...], "base": 4×4, "tool": 4×4}`` is also accepted (the JSON file format
of the CLI).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._checks import as_float_array, check_finite, check_transform
from .exceptions import RobotDescriptionError
from .model import ChainSpec, JointModel, frame_aligned_with


def _rot_z(t: float) -> np.ndarray:
    c, s = np.cos(t), np.sin(t)
    T = np.eye(4)
    T[:2, :2] = ((c, -s), (s, c))
    return T


def _dh_fixed(d: float, a: float, alpha: float) -> np.ndarray:
    """T_Z(d) T_X(a) R_X(α)."""
    c, s = np.cos(alpha), np.sin(alpha)
    return np.array(((1.0, 0, 0, a), (0, c, -s, 0), (0, s, c, d), (0, 0, 0, 1.0)))


def _keys(table: Mapping[Any, Any]) -> str:
    keys = [repr(k)[:30] for k in list(table)[:8]]
    return "{" + ", ".join(keys) + (", …}" if len(table) > 8 else "}")


#: A DH table: rows as mappings or lists, a 2-D array, or {"joints": rows, "base", "tool"}.
DHTable = Sequence[Mapping[str, Any] | Sequence[Any]] | Mapping[str, Any] | NDArray[Any]

#: The keys a DH row may have (the module docstring says what each means).
ROW_KEYS = ("a", "alpha", "d", "theta", "type", "name", "lower", "upper", "velocity")
#: The values of a row given as a list, in this order (the last may be left out).
LIST_ROW_KEYS = ("a", "alpha", "d", "theta", "type")


def _row_mapping(row: Any, i: int) -> Mapping[str, Any]:
    """Row `i` as a mapping: a mapping as it is, a list or tuple ``a, alpha, d, theta[, type]``
    (a NumPy row included) keyed in that order.

    Raises:
        RobotDescriptionError: anything else, or a list of the wrong length.
    """
    if isinstance(row, Mapping):
        return row
    if isinstance(row, np.ndarray):
        row = row.tolist()
    if isinstance(row, (list, tuple)):
        if len(row) not in (4, 5):
            raise RobotDescriptionError(
                f"DH row {i} has {len(row)} values; a list row is a, alpha, d, theta[, type] "
                "(use a mapping for name, lower, upper, velocity)"
            )
        return dict(zip(LIST_ROW_KEYS, row, strict=False))
    raise RobotDescriptionError(
        f"DH row {i} must be a list a, alpha, d, theta[, type] or a mapping with those keys, "
        f"got {type(row).__name__}"
    )


def _number(row: Mapping[str, Any], key: str, i: int, default: float | None = None) -> float:
    if key not in row or row[key] is None:
        if default is None:
            raise RobotDescriptionError(f"DH row {i} has no {key!r}")
        return default
    if isinstance(row[key], bool):  # (float(True) is 1.0: a typo, not a length)
        raise RobotDescriptionError(f"DH row {i}: {key!r} must be a number, got {row[key]!r}")
    try:
        value = float(row[key])
    except (TypeError, ValueError, OverflowError):
        raise RobotDescriptionError(
            f"DH row {i}: {key!r} must be a number, got {repr(row[key])[:40]}"
        ) from None
    if np.isnan(value) or (np.isinf(value) and key not in ("lower", "upper", "velocity")):
        raise RobotDescriptionError(f"DH row {i}: {key!r} must be finite, got {value}")
    return value


def spec_from_dh(
    table: DHTable,
    *,
    base: ArrayLike | None = None,
    tool: ArrayLike | None = None,
) -> ChainSpec:
    """Build a chain spec from a standard DH table (see the module docstring for the format)."""
    if isinstance(table, Mapping):
        if "joints" not in table:
            raise RobotDescriptionError(
                f"a DH mapping needs a 'joints' list of rows; got keys {_keys(table)}"
            )
        base = table.get("base", base)
        tool = table.get("tool", tool)
        rows: Any = table["joints"]
        what = "the DH table's 'joints'"
    else:
        rows = table
        what = "a DH table"
    if isinstance(rows, np.ndarray):
        if rows.ndim != 2:
            raise RobotDescriptionError(
                f"{what} given as an array must be 2-D (one row a, alpha, d, theta per joint), "
                f"got shape {rows.shape}"
            )
        rows = rows.tolist()
    if isinstance(rows, (str, bytes)) or not isinstance(rows, Sequence):
        raise RobotDescriptionError(
            f"{what} must be a list of rows {{a, alpha, d, theta, type}}, got {type(rows).__name__}"
        )
    if not rows:
        raise RobotDescriptionError("the DH table has no rows")
    T = np.eye(4) if base is None else check_transform(base, "DH base transform")
    T_tool = np.eye(4) if tool is None else check_transform(tool, "DH tool transform")

    joints: list[JointModel] = []
    names, types, lower, upper, vel = [], [], [], [], []
    links: list[tuple[str, np.ndarray, int]] = [("link0", T.copy(), -1)]
    for i, raw_row in enumerate(rows, start=1):
        row = _row_mapping(raw_row, i)
        unknown = [k for k in row if k not in ROW_KEYS]
        if unknown:  # a misspelt limit would otherwise be silently absent (±inf)
            raise RobotDescriptionError(
                f"DH row {i} has unknown key {repr(unknown[0])[:40]}; the keys are "
                f"{', '.join(ROW_KEYS)}"
            )
        kind = str(row.get("type", "revolute"))[:40].lower()
        if kind in ("r", "revolute"):
            prismatic = False
        elif kind in ("p", "prismatic"):
            prismatic = True
        else:
            raise RobotDescriptionError(
                f"DH row {i}: type must be revolute/R or prismatic/P, got {kind!r}"
            )
        a, alpha = _number(row, "a", i), _number(row, "alpha", i)
        d, theta = _number(row, "d", i), _number(row, "theta", i, 0.0)
        name = row.get("name", f"joint{i}")
        if not isinstance(name, str) or not name:
            raise RobotDescriptionError(
                f"DH row {i}: 'name' must be a non-empty string, got {repr(name)[:40]}"
            )
        if name in names:
            raise RobotDescriptionError(f"DH row {i}: duplicate joint name {name!r}")
        lo, up = _number(row, "lower", i, -np.inf), _number(row, "upper", i, np.inf)
        if not lo <= up:
            raise RobotDescriptionError(
                f"DH row {i} ({name!r}): lower limit {lo} > upper limit {up}"
            )
        H = T @ _rot_z(theta)  # joint i turns (or slides) about z_{i−1}
        joints.append(JointModel(name, prismatic, H, lo, up))
        T = H @ _dh_fixed(d, a, alpha)
        names.append(name)
        types.append(
            "prismatic"
            if prismatic
            else ("continuous" if np.isinf(lo) and np.isinf(up) else "revolute")
        )
        lower.append(lo)
        upper.append(up)
        vel.append(_number(row, "velocity", i, np.inf))
        links.append((f"link{i}", T.copy(), i - 1))
    n = len(joints)
    M = T @ T_tool
    links.append(("tool", M.copy(), n - 1))
    return ChainSpec(
        base_link="link0",
        tip_link="tool",
        joints=joints,
        M=M,
        actuated_names=names,
        joint_types=types,
        lower=np.array(lower),
        upper=np.array(upper),
        velocity_limit=np.array(vel),
        G=np.eye(n),
        offset=np.zeros(n),
        links=links,
    )


def spec_from_poe(
    S: ArrayLike,
    M: ArrayLike,
    *,
    joint_names: Sequence[str] | None = None,
    lower: ArrayLike | None = None,
    upper: ArrayLike | None = None,
) -> ChainSpec:
    """Build a chain spec from space screw axes S (6, n), rows (ω, v), and home pose M."""
    Sa = as_float_array(S, "S")
    if Sa.ndim != 2 or Sa.shape[0] != 6 or Sa.shape[1] == 0:
        raise RobotDescriptionError(f"S must have shape (6, n) with n ≥ 1, got {Sa.shape}")
    check_finite(Sa, "S")
    Mm = check_transform(M, "M")
    n = Sa.shape[1]
    names = [f"joint{i + 1}" for i in range(n)] if joint_names is None else list(joint_names)
    if len(names) != n or len(set(names)) != n:
        raise RobotDescriptionError(f"joint_names must be {n} distinct names, got {names}")
    lo = np.full(n, -np.inf) if lower is None else as_float_array(lower, "lower")
    up = np.full(n, np.inf) if upper is None else as_float_array(upper, "upper")
    if lo.shape != (n,) or up.shape != (n,) or np.any(lo > up):
        raise RobotDescriptionError(f"lower/upper must be {n} values with lower ≤ upper")
    joints, types = [], []
    for k in range(n):
        w, v = Sa[:3, k], Sa[3:, k]
        nw, nv = np.linalg.norm(w), np.linalg.norm(v)
        H = np.eye(4)
        if abs(nw - 1.0) < 1e-6:
            if abs(w @ v) > 1e-9:
                raise RobotDescriptionError(
                    f"screw axis of {names[k]!r} has pitch {w @ v:.3g}; only revolute (pitch 0) "
                    "and prismatic axes are supported"
                )
            H[:3, :3] = frame_aligned_with(w)
            H[:3, 3] = np.cross(w, v)  # the point of the axis closest to the origin
            joints.append(JointModel(names[k], False, H, float(lo[k]), float(up[k])))
            types.append("continuous" if np.isinf(lo[k]) and np.isinf(up[k]) else "revolute")
        elif nw < 1e-9 and abs(nv - 1.0) < 1e-6:
            H[:3, :3] = frame_aligned_with(v)
            joints.append(JointModel(names[k], True, H, float(lo[k]), float(up[k])))
            types.append("prismatic")
        else:
            raise RobotDescriptionError(
                f"screw axis of {names[k]!r} is not normalised: need ‖ω‖ = 1, or ω = 0 and ‖v‖ = 1"
            )
    return ChainSpec(
        base_link="base",
        tip_link="tip",
        joints=joints,
        M=Mm,
        actuated_names=names,
        joint_types=types,
        lower=lo,
        upper=up,
        velocity_limit=np.full(n, np.inf),
        G=np.eye(n),
        offset=np.zeros(n),
        links=[("base", np.eye(4), -1), ("tip", Mm.copy(), n - 1)],
    )
