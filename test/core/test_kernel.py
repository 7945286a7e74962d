"""The generated scalar kernel: equal to the product of exponentials (MR eq. 4.14) evaluated with
`se3.exp`, and to the batched NumPy path, on random screw chains mixing revolute and prismatic
joints (so no constant happens to be a permutation) and on chains whose constants are permutations
up to rounding (the folding case); joint axes equal the columns of J_s and the world columns equal
(z, z × (p − o)); pickling rebuilds it."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from kinematics_node.core import SerialChain, se3
from kinematics_node.core._kernel import _generate_scalar


def _random_chain(rng: np.random.Generator, n: int, prismatic_every: int = 3) -> SerialChain:
    S = np.empty((6, n))
    for k in range(n):
        if k % prismatic_every == prismatic_every - 1:
            v = rng.normal(size=3)
            S[:, k] = np.r_[0.0, 0.0, 0.0, v / np.linalg.norm(v)]
        else:
            w = rng.normal(size=3)
            w /= np.linalg.norm(w)
            S[:, k] = np.r_[w, np.cross(rng.normal(size=3), w)]  # v = −ω × point
    M = se3.exp(rng.normal(size=6))
    return SerialChain.from_poe(S, M)


def _poe(chain: SerialChain, q: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    for k in range(chain.dof):
        T = T @ se3.exp(chain.S[:, k] * q[k])
    return T @ chain.M


@pytest.mark.parametrize("n", [1, 2, 6, 9])
def test_scalar_kernel_equals_product_of_exponentials(n: int) -> None:
    rng = np.random.default_rng(n)
    for _ in range(5):
        chain = _random_chain(rng, n)
        for q in rng.uniform(-3, 3, (10, n)):
            T = chain.fk(q)  # scalar path (one configuration)
            np.testing.assert_allclose(T, _poe(chain, q), rtol=0, atol=1e-12)
            np.testing.assert_allclose(T, chain.fk(q[None])[0], rtol=0, atol=1e-13)  # batch path


def test_joint_axes_are_the_space_jacobian_columns() -> None:
    rng = np.random.default_rng(7)
    chain = _random_chain(rng, 7)
    for q in rng.uniform(-3, 3, (10, 7)):
        _, axes = chain.solver_model.kernel.fk_jacobian_scalar(q.tolist(), True)
        Js = chain.jacobian(q, "space")
        for k, (zx, zy, zz, ox, oy, oz) in enumerate(axes):
            z, o = np.array([zx, zy, zz]), np.array([ox, oy, oz])
            if chain.joint_types[k] == "prismatic":
                np.testing.assert_allclose(Js[3:, k], z, atol=1e-12)
            else:
                np.testing.assert_allclose(Js[:, k], np.r_[z, np.cross(o, z)], atol=1e-12)
        assert chain.solver_model.kernel.fk_jacobian_scalar(q.tolist(), False)[1] == []


def test_world_columns_are_z_and_z_cross_tip_minus_o() -> None:
    rng = np.random.default_rng(8)
    chain = _random_chain(rng, 8)
    kernel = chain.solver_model.kernel
    for q in rng.uniform(-3, 3, (10, 8)).tolist():
        t, axes = kernel.fk_axes(q)
        t_w, cols = kernel.fk_world(q)
        assert t_w == pytest.approx(t, abs=1e-14)
        p = np.array(t[9:])
        for k, ((zx, zy, zz, ox, oy, oz), col) in enumerate(zip(axes, cols, strict=True)):
            z, o = np.array([zx, zy, zz]), np.array([ox, oy, oz])
            want = np.r_[0.0, 0.0, 0.0, z] if kernel.prismatic[k] else np.r_[z, np.cross(z, p - o)]
            np.testing.assert_allclose(col, want, rtol=0, atol=1e-12)


def test_folded_constants_stay_exact_to_rounding() -> None:
    """Joint frames rotated by multiples of π/2 (entries 0, ±1 up to ~1e-16, as URDF rpy gives
    them) are folded into renamings; the result must still agree with the batch path."""
    rng = np.random.default_rng(3)
    S = np.zeros((6, 5))
    axes = [(0, 0, 1), (0, 1, 0), (1, 0, 0), (0, -1, 0), (0, 0, 1)]
    points = rng.normal(size=(5, 3))
    for k, (w, pt) in enumerate(zip(axes, points, strict=True)):
        w = np.array(w, dtype=float)
        S[:, k] = np.r_[w, -np.cross(w, pt)]
    c = np.cos(np.pi / 2)  # 6e-17, not 0
    M = np.array([[c, -1.0, 0, 0.3], [1.0, c, 0, 0.1], [0, 0, 1.0, 0.5], [0, 0, 0, 1.0]])
    chain = SerialChain.from_poe(S, M)
    source = _generate_scalar(
        chain.solver_model.kernel.A, chain.solver_model.kernel.prismatic, "pose"
    )
    assert "e-1" not in source  # no ~1e-17 constants survive: they were folded to 0
    for q in rng.uniform(-3, 3, (20, 5)):
        np.testing.assert_allclose(chain.fk(q), _poe(chain, q), rtol=0, atol=1e-13)


def test_pickled_chain_rebuilds_its_generated_kernel() -> None:
    rng = np.random.default_rng(11)
    chain = _random_chain(rng, 6)
    clone = pickle.loads(pickle.dumps(chain))
    q = rng.uniform(-2, 2, 6)
    np.testing.assert_array_equal(clone.fk(q), chain.fk(q))


def test_batches_longer_than_one_pass_equal_the_rows_computed_alone() -> None:
    """`frames_batch` works in passes of FRAMES_CHUNK configurations: a batch that spans several
    passes (and ends in a partial one) gives every row, pose, Jacobian and joint frame, as if
    each configuration were computed on its own."""
    from kinematics_node.core._kernel import FRAMES_CHUNK

    rng = np.random.default_rng(11)
    chain = _random_chain(rng, 7)
    N = 2 * FRAMES_CHUNK + 5
    q = rng.uniform(-3, 3, (N, 7))
    T, J = chain.fk_jacobian(q, "world")
    rows = [0, FRAMES_CHUNK - 1, FRAMES_CHUNK, 2 * FRAMES_CHUNK, N - 1]
    for i in rows:
        Ti, Ji = chain.fk_jacobian(q[i : i + 1], "world")
        np.testing.assert_allclose(T[i], Ti[0], rtol=0, atol=1e-13)
        np.testing.assert_allclose(J[i], Ji[0], rtol=0, atol=1e-13)
        np.testing.assert_allclose(T[i], _poe(chain, q[i]), rtol=0, atol=1e-12)
    kernel = chain.solver_model.kernel
    _, _, _, _, F = kernel.frames_batch(q, want_axes=False, want_joint_frames=True)
    _, _, _, _, F_one = kernel.frames_batch(q[rows], want_axes=False, want_joint_frames=True)
    assert F is not None and F_one is not None and len(F) == len(F_one) == 7
    for frame, frame_one in zip(F, F_one, strict=True):
        assert frame.shape == (3, 4, N)
        np.testing.assert_allclose(frame[:, :, rows], frame_one, rtol=0, atol=1e-13)
