"""Input validation helpers used at the public boundary (never inside inner loops)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .exceptions import InvalidInputError


def as_float_array(value: Any, name: str) -> NDArray[np.float64]:
    """Convert `value` to a float64 array or raise `InvalidInputError` naming `name`."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(
            f"{name} must be numeric, got {type(value).__name__}: {exc}"
        ) from None
    return arr


def check_finite(arr: NDArray[np.float64], name: str) -> None:
    """Raise `InvalidInputError` if `arr` contains NaN or infinity, naming the first bad index."""
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0]
        idx = tuple(int(i) for i in bad)
        raise InvalidInputError(
            f"{name} contains a non-finite value {float(arr[idx])} at index {idx}"
        )


def check_trailing_shape(arr: NDArray[np.float64], shape: tuple[int, ...], name: str) -> None:
    """Raise `InvalidInputError` unless `arr.shape` ends with `shape`."""
    k = len(shape)
    if arr.ndim < k or arr.shape[arr.ndim - k :] != shape:
        want = "(..., " + ", ".join(str(s) for s in shape) + ")"
        raise InvalidInputError(f"{name} must have shape {want}, got shape {arr.shape}")


_LAST_ROW = np.array((0.0, 0.0, 0.0, 1.0))


def check_transform(value: Any, name: str = "transform") -> NDArray[np.float64]:
    """Validate a (..., 4, 4) homogeneous transform: finite, last row (0, 0, 0, 1), rotation in SO(3).

    The rotation is accepted when ||RᵀR − I|| ≤ 1e-6 and det R > 0; tighter data is common, looser
    data almost always means a bug (e.g. a scaled or transposed matrix).
    """
    if (
        isinstance(value, np.ndarray)
        and value.shape == (4, 4)
        and value.dtype == np.float64
        and rigid_on_floats(value.tolist(), 1e-6, 1e-9)
    ):
        return value  # the common case, one clean transform: checked on floats (~3 µs, not ~20)
    T = as_float_array(value, name)
    check_trailing_shape(T, (4, 4), name)
    check_finite(T, name)
    if not np.all(np.abs(T[..., 3, :] - _LAST_ROW) <= 1e-9):
        raise InvalidInputError(
            f"{name} must have last row (0, 0, 0, 1), got {T[..., 3, :].tolist()}"
        )
    R = T[..., :3, :3]
    err = np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(3)).max(axis=(-1, -2))
    if np.any(err > 1e-6) or np.any(np.linalg.det(R) <= 0):
        raise InvalidInputError(
            f"{name} rotation block is not a rotation matrix (max |RᵀR − I| = {float(np.max(err)):.3g})"
        )
    return T


def rigid_on_floats(T: list[list[float]], rotation_tolerance: float, row_tolerance: float) -> bool:
    """True if T (4 × 4 nested lists) is finite, has last row (0, 0, 0, 1) within `row_tolerance`
    and a rotation with |RᵀR − I| ≤ `rotation_tolerance` elementwise and det R > 0: the tests of
    `check_transform` (1e-6, 1e-9) on plain floats, a few µs for one transform instead of ~20 µs
    of NumPy. False means "let the array path decide" (it raises with the reason).

    Written out for speed: it runs on every single-target FK/IK call."""
    (a, b, c, p), (d, e, f, q), (g, h, i, r), (w, x, y, z) = T
    if not (-math.inf < a + b + c + d + e + f + g + h + i + p + q + r + w + x + y + z < math.inf):
        return False  # some value is not finite (or they are so large that the sum overflows)
    if max(abs(w), abs(x), abs(y), abs(z - 1.0)) > row_tolerance:
        return False
    tol = rotation_tolerance
    if (  # columns (a, d, g), (b, e, h), (c, f, i): unit length, pairwise orthogonal
        abs(a * a + d * d + g * g - 1.0) > tol
        or abs(a * b + d * e + g * h) > tol
        or abs(a * c + d * f + g * i) > tol
        or abs(b * b + e * e + h * h - 1.0) > tol
        or abs(b * c + e * f + h * i) > tol
        or abs(c * c + f * f + i * i - 1.0) > tol
    ):
        return False
    return (d * h - g * e) * c + (g * b - a * h) * f + (a * e - d * b) * i > 0
