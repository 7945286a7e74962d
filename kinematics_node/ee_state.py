"""Joint-state tracking and end-effector state, with no ROS and no message types.

This is the numeric half of the node's `joint_states` handling, shared by the ROS node, the
message-level service logic and the ROS-free demo:

* `JointStateTracker` merges joint-state samples (names may be a subset, in any order, and may
  contain joints of other chains) into the chain's joint vector, rejects stale samples, and takes
  velocities from the sample or, when they are missing or NaN, estimates them from successive
  positions and stamps.
* `compute_ee_state` turns (q, q̇) into the end-effector pose, twist and conditioning figures.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from .core import SerialChain, condition_number, manipulability
from .core.exceptions import InvalidInputError

FloatArray = NDArray[np.float64]


class JointStateTracker:
    """Latest position and velocity of each chain joint, fed by (possibly partial) samples.

    Not thread-safe: feed it from one callback (or guard it with a lock).
    """

    def __init__(
        self, joint_names: Sequence[str], continuous: Sequence[bool] | None = None
    ) -> None:
        self.joint_names = tuple(joint_names)
        self._index = {name: i for i, name in enumerate(self.joint_names)}
        n = len(self.joint_names)
        self._continuous = np.zeros(n, bool) if continuous is None else np.asarray(continuous, bool)
        self._q = np.full(n, np.nan)
        self._qdot = np.full(n, np.nan)
        self._stamp = np.full(n, -np.inf)  # per joint: stamp of its last accepted sample [s]
        self.latest_stamp = -math.inf
        self.stale_samples = 0

    @property
    def complete(self) -> bool:
        """True once every chain joint has a position."""
        return bool(np.all(np.isfinite(self._q)))

    @property
    def q(self) -> FloatArray:
        return self._q.copy()

    @property
    def qdot(self) -> FloatArray | None:
        """Joint velocities, or None while any of them is unknown."""
        return self._qdot.copy() if np.all(np.isfinite(self._qdot)) else None

    def update(
        self,
        names: Sequence[str],
        positions: Sequence[float],
        velocities: Sequence[float] | None,
        stamp: float,
    ) -> bool:
        """Merge one sample; return True if it changed at least one chain joint.

        Joints not in the chain are ignored. A sample whose stamp is older than the last accepted
        sample of a joint it names is ignored for that joint (counted in `stale_samples`).

        Raises:
            InvalidInputError: lengths disagree, or a chain joint's position is NaN or infinite.
        """
        if len(positions) != len(names):
            raise InvalidInputError(
                f"joint state has {len(names)} names but {len(positions)} positions"
            )
        have_vel = velocities is not None and len(velocities) > 0
        if have_vel and velocities is not None and len(velocities) != len(names):
            raise InvalidInputError(
                f"joint state has {len(names)} names but {len(velocities)} velocities"
            )
        if not math.isfinite(stamp):
            raise InvalidInputError(f"joint state stamp must be finite, got {stamp}")
        updates = []
        for j, name in enumerate(names):
            i = self._index.get(name)
            if i is None:
                continue
            p = float(positions[j])
            if not math.isfinite(p):
                raise InvalidInputError(f"joint state position of {name!r} is {p}")
            v = float(velocities[j]) if have_vel and velocities is not None else math.nan
            updates.append((i, p, v))
        changed = False
        for i, p, v in updates:
            last = self._stamp[i]
            if stamp < last:
                self.stale_samples += 1
                continue
            if not math.isfinite(
                v
            ):  # missing or NaN (ros2_control fills absent interfaces with NaN)
                dt = stamp - last
                if math.isfinite(self._q[i]) and dt > 0:
                    dq = p - self._q[i]
                    if self._continuous[i]:
                        dq = math.remainder(dq, 2 * math.pi)
                    v = dq / dt
                elif dt == 0 and math.isfinite(self._qdot[i]):
                    v = self._qdot[i]  # duplicate stamp: keep the previous estimate
            self._q[i], self._qdot[i], self._stamp[i] = p, v, stamp
            changed = True
        if changed:
            self.latest_stamp = max(self.latest_stamp, stamp)
        return changed


@dataclass(frozen=True)
class EndEffectorState:
    """End-effector quantities at one instant.

    Attributes:
        stamp: time of the joint state [s].
        q, qdot: joint values and velocities (qdot None when unknown).
        T_base_tip: pose of the tip in the base (4×4).
        twist: (ω, v) of the tip: angular velocity and velocity of the tip origin, in base axes for
            frame "world", in tip axes for frame "body"; None when qdot is unknown.
        manipulability: Yoshikawa measure of the linear rows of the world Jacobian [m].
        condition_number: of the full world Jacobian (∞ at a singularity).
        near_singular: smallest singular value of the full Jacobian below the threshold.
    """

    stamp: float
    q: FloatArray
    qdot: FloatArray | None
    T_base_tip: FloatArray
    twist: FloatArray | None
    manipulability: float
    condition_number: float
    near_singular: bool


def compute_ee_state(
    chain: SerialChain,
    q: FloatArray,
    qdot: FloatArray | None,
    stamp: float,
    twist_frame: Literal["world", "body"] = "world",
    singular_threshold: float = 1e-3,
) -> EndEffectorState:
    """Pose, twist and conditioning of the tip for one configuration (one FK/Jacobian pass)."""
    T, J = chain.fk_jacobian(q, "world")
    twist = None
    if qdot is not None:
        twist = J @ qdot
        if twist_frame == "body":
            Rt = T[:3, :3].T
            twist = np.concatenate((Rt @ twist[:3], Rt @ twist[3:]))
    sv = np.linalg.svd(J, compute_uv=False)
    return EndEffectorState(
        stamp=stamp,
        q=np.asarray(q, dtype=np.float64),
        qdot=qdot,
        T_base_tip=T,
        twist=twist,
        manipulability=float(manipulability(J, "linear")),
        condition_number=float(condition_number(J, "full")),
        near_singular=bool(sv[-1] < singular_threshold),
    )
