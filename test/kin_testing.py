"""Test helpers: real robot descriptions nobody here wrote, sampling within limits."""

from __future__ import annotations

import math
import sysconfig
from pathlib import Path

import numpy as np
import pytest

ERD = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix/share/example-robot-data/robots"

#: (name, file below ERD, base link or None, tip link) of real arms from `example-robot-data`.
REAL_ARMS = [
    ("ur5", "ur_description/urdf/ur5_robot.urdf", None, "tool0"),
    ("panda", "panda_description/urdf/panda.urdf", None, "panda_hand"),
    ("xarm7", "xarm_description/urdf/xarm7.urdf", None, "link_eef"),
    ("z1", "z1_description/urdf/z1.urdf", None, "gripperMover"),
]


def ur_hole_target() -> np.ndarray:
    """A pose inside a UR arm's reach sphere (UR5, UR5e: base_link -> tool0) that no
    configuration reaches: tool0 at (0, 0, 0.3) m with the base's orientation puts the wrist
    centre on joint 1's axis, nearer to it than the shoulder offset allows (`ik_all` confirms the
    set is empty). The reach-sphere test cannot rule it out, so a search uses its whole timeout."""
    T = np.eye(4)
    T[:3, 3] = (0.0, 0.0, 0.3)
    return T


def erd_path(relative: str) -> Path:
    path = ERD / relative
    if not path.exists():
        pytest.skip(f"example-robot-data not installed ({path} missing): pip install '.[test]'")
    return path


def wrapped_gap(a: list[float], b: list[float]) -> float:
    """Largest difference between two joint vectors with angles compared modulo 2π [rad]."""
    return max(abs((x - y + math.pi) % (2 * math.pi) - math.pi) for x, y in zip(a, b, strict=True))


def random_q(chain, rng, n=None):
    """Uniform samples within limits (continuous joints in [-π, π])."""
    lo = np.where(np.isfinite(chain.lower), chain.lower, -np.pi)
    hi = np.where(np.isfinite(chain.upper), chain.upper, np.pi)
    size = (chain.dof,) if n is None else (n, chain.dof)
    return rng.uniform(lo, hi, size=size)


def check_nearest_solutions(Q, every, seed, atol=1e-9):
    """Q (k, n) is the k solutions of `every` (K, n) nearest `seed`, each once, nearest first.
    Solutions at the same distance (whole turns of a joint either way) may come in either order,
    and a target read back from a message may reorder such ties, so rows are matched, not indexed.
    """
    Q, every = np.asarray(Q, dtype=float), np.asarray(every, dtype=float)
    matched = []
    for q in Q:
        diff = np.max(np.abs(every - q), axis=1)
        i = int(np.argmin(diff))
        assert diff[i] <= atol, f"{q} is not one of the expected solutions"
        matched.append(i)
    assert len(set(matched)) == len(matched), "a solution is returned twice"
    d = np.linalg.norm(Q - seed, axis=1)
    assert np.all(np.diff(d) >= -1e-9), "not sorted nearest the seed first"
    rest = np.delete(every, matched, axis=0)
    if len(rest):
        assert d.max() <= np.linalg.norm(rest - seed, axis=1).min() + 1e-9, (
            "a nearer one is left out"
        )


class PinocchioOracle:
    """Pinocchio (an oracle nobody here wrote) for one description, in our joint order and our
    conventions: Jacobian rows (ω, v), poses in Pinocchio's world (the URDF root).

    Continuous joints have two configuration entries in Pinocchio, (cos θ, sin θ); revolute and
    prismatic joints one. Joints not in `joint_names` stay at Pinocchio's neutral configuration.
    """

    def __init__(self, model, joint_names) -> None:
        import pinocchio

        self.pin = pinocchio
        self.model = model
        self.data = model.createData()
        self.joint_names = tuple(joint_names)
        self.joints = [model.joints[model.getJointId(name)] for name in self.joint_names]
        #: Pinocchio velocity columns of our joints, in our order.
        self.cols = [joint.idx_v for joint in self.joints]

    @classmethod
    def from_urdf(cls, path, joint_names, *, mimic: bool = False) -> PinocchioOracle:
        pin = pytest.importorskip("pinocchio", reason="Pinocchio (pip install pin) is the oracle")
        model = (
            pin.buildModelFromUrdf(str(path), mimic=True)
            if mimic
            else pin.buildModelFromUrdf(str(path))
        )
        return cls(model, joint_names)

    @classmethod
    def from_xml(cls, urdf_text: str, joint_names) -> PinocchioOracle:
        pin = pytest.importorskip("pinocchio", reason="Pinocchio (pip install pin) is the oracle")
        return cls(pin.buildModelFromXML(urdf_text), joint_names)

    def q(self, q) -> np.ndarray:
        """Pinocchio's configuration for our q [rad or m]: continuous joints take (cos, sin)."""
        out = self.pin.neutral(self.model)
        for joint, value in zip(self.joints, q, strict=True):
            if joint.nq == 2:
                out[joint.idx_q : joint.idx_q + 2] = (np.cos(value), np.sin(value))
            else:
                out[joint.idx_q] = value
        return out

    def frame_id(self, frame: str) -> int:
        return self.model.getFrameId(frame)

    def pose(self, q, frame: str) -> np.ndarray:
        """T_world_frame (4×4) at our q."""
        return self.pose_of_configuration(self.q(q), frame)

    def pose_of_configuration(self, q_pin, frame: str) -> np.ndarray:
        """T_world_frame (4×4) at a Pinocchio configuration (for mimic joints set by hand)."""
        self.pin.framesForwardKinematics(self.model, self.data, q_pin)
        return self.data.oMf[self.frame_id(frame)].homogeneous

    def pose_and_jacobians(self, q, frame: str | int) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """(T_world_frame, {"world", "body", "space": 6×n Jacobian, rows (ω, v), our columns}).

        "world" is Pinocchio's LOCAL_WORLD_ALIGNED, "body" LOCAL and "space" WORLD; Pinocchio
        orders twists (v, ω), so its rows are swapped here.
        """
        pin = self.pin
        fid = frame if isinstance(frame, int) else self.frame_id(frame)
        pin.computeJointJacobians(self.model, self.data, self.q(q))
        pin.updateFramePlacements(self.model, self.data)
        J = {}
        for name, ref in (
            ("world", pin.LOCAL_WORLD_ALIGNED),
            ("body", pin.LOCAL),
            ("space", pin.WORLD),
        ):
            Jp = pin.getFrameJacobian(self.model, self.data, fid, ref)[:, self.cols]
            J[name] = np.vstack((Jp[3:], Jp[:3]))
        return self.data.oMf[fid].homogeneous, J


def moved_base(chain):
    """The same arm on a base turned and shifted off the coordinate axes: S′ = Ad(B) S, M′ = B M,
    so no axis direction or point has zero components."""
    from kinematics_node.core import SerialChain, se3

    rng = np.random.default_rng(11)
    B = se3.exp(rng.normal(size=6) * 0.7)
    S = se3.adjoint(B) @ np.asarray(chain.S)
    return SerialChain.from_poe(S, B @ np.asarray(chain.M), lower=chain.lower, upper=chain.upper)


def reversed_arm(chain):
    """The same arm read from the tip: T′(q′) = T(q)⁻¹ with q′ = −q reversed, so a family's
    structure is found reversed (a spherical wrist becomes a spherical shoulder).
    S′ₖ = Ad(M⁻¹) Sₙ₊₁₋ₖ, M′ = M⁻¹."""
    from kinematics_node.core import SerialChain, se3

    Mi = se3.inverse(chain.M)
    S = se3.adjoint(Mi) @ np.asarray(chain.S)[:, ::-1]
    return SerialChain.from_poe(S, Mi, lower=-chain.upper[::-1], upper=-chain.lower[::-1])


def assert_same_batched_solve(ref, fast, n_singular):
    """A prepared batched closed-form solver against the reference one, each given as (Q, ok,
    trace): the same branches succeed, every stage flags the same lanes with the same reason, and
    the angles of the successful branches agree to 1e-9 (to 1e-6 on the first `n_singular` rows,
    exactly singular ones, where a tangent leaves √ε)."""
    from kinematics_node.core.ik.closed_form import geometry as cf

    (Q_ref, ok_ref, ref_trace), (Q_fast, ok_fast, fast_trace) = ref, fast
    np.testing.assert_array_equal(ok_fast, ok_ref)
    for (name_r, f_r), (name_f, f_f) in zip(
        ref_trace.fails + ref_trace.frees, fast_trace.fails + fast_trace.frees, strict=True
    ):
        assert name_f == name_r
        np.testing.assert_array_equal(f_f, f_r, err_msg=name_r)
    gap = np.abs(cf.wrap_angles(Q_fast - Q_ref))
    gap = np.where(ok_ref[..., None], gap, 0.0).max(axis=(1, 2))
    assert gap[n_singular:].max() <= 1e-9
    assert gap[:n_singular].max() <= 1e-6
    assert np.isfinite(Q_fast).all()
