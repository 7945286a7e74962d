"""Evaluation kernels for a serial chain in factored product-of-exponentials form.

The PoE model T(θ) = e^{[S₁]θ₁} ⋯ e^{[Sₙ]θₙ} M (MR eq. 4.14) is evaluated in the equivalent form

    T(θ) = A₀ Z₁(θ₁) A₁ Z₂(θ₂) ⋯ Zₙ(θₙ) Aₙ,

where Hₖ is the home pose of joint k's frame (origin on the axis, z along it), e^{[Sₖ]θ} =
Hₖ Z(θ) Hₖ⁻¹, A₀ = H₁, Aₖ = Hₖ⁻¹Hₖ₊₁, Aₙ = Hₙ⁻¹M and Z(θ) is a rotation about, or translation
along, z. Each joint then costs one constant 3×3 product and a plane rotation of two columns,
instead of a Rodrigues exponential and a 4×4 product. The frame of joint k in the base, Fₖ, gives
the Jacobian columns directly: axis zₖ = third column of Fₖ, point oₖ = origin of Fₖ.

Two implementations of the same recursion:
* `fk_jacobian_scalar`: plain Python floats, for one configuration. Hand-written because NumPy's
  per-call overhead (~1 µs per tiny array operation) dominates a 6- or 7-joint chain; this path
  computes FK and a Jacobian in roughly 10–15 µs where chained small NumPy calls take 30–60 µs.
* `frames_batch`: NumPy in structure-of-arrays layout for N configurations: the three rotation
  columns are stacked into one (3, 3N) array so that each constant product is a single BLAS call.
Tests check that both agree with each other and with Pinocchio.
"""

from __future__ import annotations

from math import cos, sin

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


class Kernel:
    """Constants of the factored recursion. Immutable after construction; safe to share across threads."""

    __slots__ = ("n", "prismatic", "A", "_A_flat", "_A_rot_T", "_A_pos")

    def __init__(self, A: FloatArray, prismatic: NDArray[np.bool_]) -> None:
        self.n = int(prismatic.shape[0])
        self.prismatic = tuple(bool(b) for b in prismatic)
        self.A = A  # (n + 1, 4, 4)
        # Row-major rotation then position, as Python floats, for the scalar path.
        self._A_flat = tuple(
            tuple(float(x) for x in a[:3, :3].ravel()) + tuple(float(x) for x in a[:3, 3])
            for a in A
        )
        self._A_rot_T = np.ascontiguousarray(np.swapaxes(A[:, :3, :3], 1, 2))
        self._A_pos = np.ascontiguousarray(A[:, :3, 3])

    # ------------------------------------------------------------------ scalar path
    def fk_jacobian_scalar(
        self, q: list[float], want_jacobian: bool
    ) -> tuple[tuple[float, ...], list[tuple[float, float, float, float, float, float]]]:
        """Tip pose as 12 floats (row-major R, then p) and, if asked, each joint's (z, o) in the base."""
        r00, r01, r02, r10, r11, r12, r20, r21, r22, px, py, pz = self._A_flat[0]
        axes: list[tuple[float, float, float, float, float, float]] = []
        A = self._A_flat
        for k, prism in enumerate(self.prismatic):
            if want_jacobian:
                axes.append((r02, r12, r22, px, py, pz))
            t = q[k]
            if prism:  # F ← F · Trans_z(t)
                px += t * r02
                py += t * r12
                pz += t * r22
            else:  # F ← F · Rot_z(t): columns 0 and 1 turn by t
                c, s = cos(t), sin(t)
                r00, r01 = c * r00 + s * r01, c * r01 - s * r00
                r10, r11 = c * r10 + s * r11, c * r11 - s * r10
                r20, r21 = c * r20 + s * r21, c * r21 - s * r20
            b00, b01, b02, b10, b11, b12, b20, b21, b22, bx, by, bz = A[k + 1]
            px, py, pz = (
                px + r00 * bx + r01 * by + r02 * bz,
                py + r10 * bx + r11 * by + r12 * bz,
                pz + r20 * bx + r21 * by + r22 * bz,
            )
            r00, r01, r02 = (
                r00 * b00 + r01 * b10 + r02 * b20,
                r00 * b01 + r01 * b11 + r02 * b21,
                r00 * b02 + r01 * b12 + r02 * b22,
            )
            r10, r11, r12 = (
                r10 * b00 + r11 * b10 + r12 * b20,
                r10 * b01 + r11 * b11 + r12 * b21,
                r10 * b02 + r11 * b12 + r12 * b22,
            )
            r20, r21, r22 = (
                r20 * b00 + r21 * b10 + r22 * b20,
                r20 * b01 + r21 * b11 + r22 * b21,
                r20 * b02 + r21 * b12 + r22 * b22,
            )
        return (r00, r01, r02, r10, r11, r12, r20, r21, r22, px, py, pz), axes

    # ------------------------------------------------------------------ batched path
    def frames_batch(
        self, q: FloatArray, want_axes: bool, want_joint_frames: bool = False
    ) -> tuple[
        FloatArray, FloatArray, FloatArray | None, FloatArray | None, list[FloatArray] | None
    ]:
        """Recursion for q of shape (N, n).

        Returns (C, p, Z, O, F): C (3, 3, N) tip rotation columns (C[j] is column j), p (3, N) tip
        position, Z and O (n, 3, N) joint axes and points in the base if `want_axes`, and if
        `want_joint_frames` the list of (4, 4, N)-free frames after each joint as (3, 4, N) arrays.
        """
        N = q.shape[0]
        C = np.repeat(self._A_rot_T[0][:, :, None], N, axis=2)  # (3 columns, 3 rows, N)
        p = np.repeat(self._A_pos[0][:, None], N, axis=1)
        n = self.n
        Z = np.empty((n, 3, N)) if want_axes else None
        O = np.empty((n, 3, N)) if want_axes else None
        F: list[FloatArray] | None = [] if want_joint_frames else None
        for k, prism in enumerate(self.prismatic):
            if Z is not None and O is not None:
                Z[k] = C[2]
                O[k] = p
            t = q[:, k]
            if prism:
                p = p + t * C[2]
            else:
                c, s = np.cos(t), np.sin(t)
                c0, c1 = C[0], C[1]
                C = np.stack((c * c0 + s * c1, c * c1 - s * c0, C[2]))
            if F is not None:
                F.append(np.concatenate((np.swapaxes(C, 0, 1), p[:, None, :]), axis=1))
            # F ← F · A_{k+1}: new column j = Σ_i B[i, j] C[i]; position += Σ_i b[i] C[i]
            flat = C.reshape(3, -1)
            p = p + (self._A_pos[k + 1] @ flat).reshape(3, N)
            C = (self._A_rot_T[k + 1] @ flat).reshape(3, 3, N)
        return C, p, Z, O, F
