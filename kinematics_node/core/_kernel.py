"""Evaluation kernels for a serial chain in factored product-of-exponentials form.

The PoE model T(θ) = e^{[S₁]θ₁} ⋯ e^{[Sₙ]θₙ} M (MR eq. 4.14) is evaluated in the equivalent form

    T(θ) = A₀ Z₁(θ₁) A₁ Z₂(θ₂) ⋯ Zₙ(θₙ) Aₙ,

where Hₖ is the home pose of joint k's frame (origin on the axis, z along it), e^{[Sₖ]θ} =
Hₖ Z(θ) Hₖ⁻¹, A₀ = H₁, Aₖ = Hₖ⁻¹Hₖ₊₁, Aₙ = Hₙ⁻¹M and Z(θ) is a rotation about, or translation
along, z. Each joint then costs one constant 3×3 product and a plane rotation of two columns,
instead of a Rodrigues exponential and a 4×4 product. The frame of joint k in the base, Fₖ, gives
the Jacobian columns directly: axis zₖ = third column of Fₖ, point oₖ = origin of Fₖ.

Two implementations of the same recursion:
* `fk_jacobian_scalar`: plain Python floats, for one configuration. NumPy's per-call overhead
  (~1 µs per tiny array operation) would dominate a 6- or 7-joint chain, so this path is
  hand-written for speed: `_generate_scalar` unrolls the recursion for the chain at hand into
  straight-line Python with the constant factors folded in. URDF joint frames are mostly signed
  permutations (rpy in multiples of π/2), so most of each constant 3×3 product becomes a
  renaming. On Panda, FK with joint axes takes ~2.7 µs, against ~7 µs for the same recursion
  written as a loop over the joints. Three variants are generated: pose only, pose and joint
  axes, and pose and world Jacobian columns (what IK's inner loop needs).
* `frames_batch`: NumPy in structure-of-arrays layout for N configurations: the three rotation
  columns are stacked into one (3, 3N) array so that each constant product is a single BLAS call.
Tests check that both agree with each other and with Pinocchio.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from math import cos, sin
from typing import Literal

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


#: Configurations per pass of `Kernel.frames_batch`. Its working arrays (a few times 9 × 8 bytes
#: per configuration) then stay in the CPU caches: on a UR5 with N = 160,000, FK took 159–172 ms in
#: one pass and 42–44 ms in passes of 16,384 (4,096: 43–55 ms; 1,024: 100–120 ms).
FRAMES_CHUNK = 8192


class Kernel:
    """Constants of the factored recursion. Immutable after construction; safe to share across threads."""

    __slots__ = ("n", "prismatic", "A", "_A_rot_T", "_A_pos", "fk_pose", "fk_axes", "fk_world")

    def __init__(self, A: FloatArray, prismatic: NDArray[np.bool_]) -> None:
        self.n = int(prismatic.shape[0])
        self.prismatic = tuple(bool(b) for b in prismatic)
        self.A = A  # (n + 1, 4, 4)
        # Generated scalar functions q → (tip pose as 12 floats, list), see `_generate_scalar`:
        # the list is empty, each joint's (z, o), or the world Jacobian's columns at the tip.
        self.fk_pose = _compile_scalar(A, self.prismatic, "pose")
        self.fk_axes = _compile_scalar(A, self.prismatic, "axes")
        self.fk_world = _compile_scalar(A, self.prismatic, "world")
        self._A_rot_T = np.ascontiguousarray(np.swapaxes(A[:, :3, :3], 1, 2))
        self._A_pos = np.ascontiguousarray(A[:, :3, 3])

    def __reduce__(self) -> tuple[type[Kernel], tuple[FloatArray, NDArray[np.bool_]]]:
        # the generated functions cannot be pickled; rebuild them from the constants
        return (Kernel, (self.A, np.array(self.prismatic)))

    # ------------------------------------------------------------------ scalar path
    def fk_jacobian_scalar(
        self, q: Sequence[float], want_jacobian: bool
    ) -> tuple[tuple[float, ...], list[tuple[float, float, float, float, float, float]]]:
        """Tip pose as 12 floats (row-major R, then p) and, if asked, each joint's (z, o) in the
        base: axis direction and a point on it (else an empty list). `q` holds n floats."""
        return (self.fk_axes if want_jacobian else self.fk_pose)(q)

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
        if N <= FRAMES_CHUNK:
            return self._frames(q, want_axes, want_joint_frames)
        parts = [
            self._frames(q[i : i + FRAMES_CHUNK], want_axes, want_joint_frames)
            for i in range(0, N, FRAMES_CHUNK)
        ]

        def joined(k: int, axis: int) -> FloatArray:
            return np.concatenate([part[k] for part in parts], axis=axis)  # type: ignore[misc]

        F = None
        if want_joint_frames:
            F = [np.concatenate([part[4][j] for part in parts], axis=2) for j in range(self.n)]  # type: ignore[index]
        if want_axes:
            return joined(0, 2), joined(1, 1), joined(2, 2), joined(3, 2), F
        return joined(0, 2), joined(1, 1), None, None, F

    def _frames(
        self, q: FloatArray, want_axes: bool, want_joint_frames: bool
    ) -> tuple[
        FloatArray, FloatArray, FloatArray | None, FloatArray | None, list[FloatArray] | None
    ]:
        """`frames_batch` in one pass."""
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


# ---------------------------------------------------------------------- scalar code generation
# A constant within this of 0 or ±1 is taken as exactly that (URDF rpy of π/2 gives cos = 6e-17);
# the change is below the rounding of the result.
_SNAP = 1e-15

Form = dict[str, float]  # Σ coefficient · monomial; the monomial "" is the constant 1
Axis = tuple[float, float, float, float, float, float]
ScalarFK = Callable[[Sequence[float]], tuple[tuple[float, ...], list[Axis]]]


def _term(key: str, coef: float) -> str:
    if key == "":
        return repr(coef)
    if coef == 1.0:
        return key
    if coef == -1.0:
        return f"-{key}"
    return f"{coef!r} * {key}"


def _render(form: Form) -> str:
    if not form:
        return "0.0"
    return " + ".join(_term(k, c) for k, c in form.items()).replace("+ -", "- ")


def _snap(x: float) -> float:
    if abs(x) < _SNAP:
        return 0.0
    if abs(abs(x) - 1.0) < _SNAP:
        return 1.0 if x > 0 else -1.0
    return float(x)


def _combine(terms: list[tuple[float, Form]]) -> Form:
    """Σ c · form for constants c (zero coefficients dropped)."""
    out: Form = {}
    for c, form in terms:
        c = _snap(c)
        if c == 0.0:
            continue
        for key, v in form.items():
            out[key] = out.get(key, 0.0) + c * v
    return {k: v for k, v in out.items() if v != 0.0}


def _times(var: str, form: Form) -> Form:
    """var · form, for a form whose monomials are plain names or constants."""
    return {(var if k == "" else f"{var} * {k}"): c for k, c in form.items()}


def _mul(f: Form, g: Form) -> Form:
    """Product of two forms of at most one monomial each."""
    if not f or not g:
        return {}
    (k1, c1), (k2, c2) = next(iter(f.items())), next(iter(g.items()))
    key = k2 if k1 == "" else k1 if k2 == "" else f"{k1} * {k2}"
    return {key: c1 * c2}


Output = Literal["pose", "axes", "world"]


def _generate_scalar(A: FloatArray, prismatic: tuple[bool, ...], output: Output) -> str:
    """Source of `fk(q)`: the recursion of this module's docstring, unrolled for one chain.

    It returns the tip pose as 12 floats and a list: empty for "pose"; each joint's axis and a
    point on it, (z, o), for "axes"; the world Jacobian's columns at the tip for "world"."""
    lines: list[str] = []
    counter = [0]

    def bind(form: Form) -> Form:
        """A form that is a constant or a single scaled name passes; anything else is assigned
        to a fresh variable (each is assigned once, so earlier frames stay readable)."""
        if len(form) == 0 or (len(form) == 1 and "*" not in next(iter(form))):
            return form
        name = f"v{counter[0]}"
        counter[0] += 1
        lines.append(f"{name} = {_render(form)}")
        return {name: 1.0}

    n = len(prismatic)
    if n:
        lines.append(", ".join(f"q{k}" for k in range(n)) + ", = q")
    R = [[_combine([(A[0, i, j], {"": 1.0})]) for j in range(3)] for i in range(3)]
    p = [_combine([(A[0, i, 3], {"": 1.0})]) for i in range(3)]
    axes: list[str] = []
    frames: list[tuple[list[Form], list[Form]]] = []
    for k, prism in enumerate(prismatic):
        if output == "axes":
            z_o = [bind(R[i][2]) for i in range(3)] + [bind(p[i]) for i in range(3)]
            axes.append("(" + ", ".join(_render(f) for f in z_o) + ")")
        elif output == "world":
            frames.append(([bind(R[i][2]) for i in range(3)], [bind(p[i]) for i in range(3)]))
        if prism:  # F ← F · Trans_z(q): p += q z
            p = [
                bind(_combine([(1.0, p[i]), (1.0, _times(f"q{k}", bind(R[i][2])))]))
                for i in range(3)
            ]
        else:  # F ← F · Rot_z(q): columns 0 and 1 turn by q
            lines.append(f"c{k} = cos(q{k})")
            lines.append(f"s{k} = sin(q{k})")
            for i in range(3):
                a, b = bind(R[i][0]), bind(R[i][1])
                R[i][0] = bind(_combine([(1.0, _times(f"c{k}", a)), (1.0, _times(f"s{k}", b))]))
                R[i][1] = bind(_combine([(1.0, _times(f"c{k}", b)), (-1.0, _times(f"s{k}", a))]))
        B = A[k + 1]  # F ← F · A_{k+1}
        p = [
            bind(_combine([(1.0, p[i])] + [(B[j, 3], R[i][j]) for j in range(3)])) for i in range(3)
        ]
        R = [
            [bind(_combine([(B[m, j], R[i][m]) for m in range(3)])) for j in range(3)]
            for i in range(3)
        ]
    p = [bind(x) for x in p]
    for (z, o), prism in zip(frames, prismatic, strict=False):  # "world" only; else no frames
        if prism:
            col = [{}, {}, {}, *z]
        else:
            d = [bind(_combine([(1.0, p[i]), (-1.0, o[i])])) for i in range(3)]
            v = [
                bind(_combine([(1.0, _mul(z[b], d[c])), (-1.0, _mul(z[c], d[b]))]))
                for b, c in ((1, 2), (2, 0), (0, 1))
            ]
            col = [*z, *v]
        axes.append("(" + ", ".join(_render(f) for f in col) + ")")
    pose = [_render(R[i][j]) for i in range(3) for j in range(3)] + [_render(x) for x in p]
    lines.append(f"return ({', '.join(pose)}), [{', '.join(axes)}]")
    return "def fk(q):\n" + "".join(f"    {line}\n" for line in lines)


def _compile_scalar(A: FloatArray, prismatic: tuple[bool, ...], output: Output) -> ScalarFK:
    source = _generate_scalar(A, prismatic, output)
    namespace: dict[str, object] = {"cos": cos, "sin": sin}
    exec(compile(source, f"<kinematics chain fk: {output}>", "exec"), namespace)
    return namespace["fk"]  # type: ignore[return-value]
