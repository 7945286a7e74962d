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

from .core import SerialChain
from .core.exceptions import InvalidInputError

FloatArray = NDArray[np.float64]


#: A sample stamped this much before a joint's last one starts a new timeline instead of being
#: ignored as stale: reordering in transit is far shorter, and a single sample stamped far ahead
#: would otherwise stop every later one [s].
JUMP_BACK = 1.0


class JointStateTracker:
    """Latest position and velocity of each tracked joint, fed by (possibly partial) samples.

    `required` joints (default: all) must be valid in every sample that names them: a NaN or
    infinite position of one rejects the sample. Other tracked joints (e.g. a gripper next to the
    arm's chain) are skipped when invalid, so they never block the required ones.

    Not thread-safe: feed it from one callback (or guard it with a lock).
    """

    def __init__(
        self,
        joint_names: Sequence[str],
        continuous: Sequence[bool] | None = None,
        required: Sequence[str] | None = None,
    ) -> None:
        self.joint_names = tuple(joint_names)
        self._index = {name: i for i, name in enumerate(self.joint_names)}
        n = len(self.joint_names)
        self._continuous = [False] * n if continuous is None else [bool(c) for c in continuous]
        if len(self._continuous) != n:
            raise InvalidInputError(f"{len(self._continuous)} continuous flags for {n} joints")
        self._required = (
            [True] * n if required is None else [name in set(required) for name in self.joint_names]
        )
        self._q = [math.nan] * n
        self._qdot = [math.nan] * n
        self._stamp = [-math.inf] * n  # per joint: stamp of its last accepted sample [s]
        self.latest_stamp = -math.inf
        self.stale_samples = 0
        self.jumps_back = 0  #: samples that started a new timeline (`JUMP_BACK`)

    @property
    def complete(self) -> bool:
        """True once every joint has a position."""
        return all(math.isfinite(v) for v in self._q)

    @property
    def q(self) -> FloatArray:
        return np.array(self._q)

    @property
    def qdot(self) -> FloatArray | None:
        """Joint velocities, or None while any of them is unknown."""
        return np.array(self._qdot) if all(math.isfinite(v) for v in self._qdot) else None

    def positions(self, index: Sequence[int]) -> list[float]:
        """Positions of the joints at `index` (NaN where not yet received)."""
        q = self._q
        return [q[i] for i in index]

    def velocities(self, index: Sequence[int]) -> list[float] | None:
        """Velocities of the joints at `index`, or None while any of them is unknown."""
        qdot = self._qdot
        v = [qdot[i] for i in index]
        return v if all(math.isfinite(x) for x in v) else None

    def update(
        self,
        names: Sequence[str],
        positions: Sequence[float],
        velocities: Sequence[float] | None,
        stamp: float,
    ) -> bool:
        """Merge one sample; return True if it changed at least one tracked joint.

        Untracked joints are ignored. A sample whose stamp is older than the last accepted sample
        of a joint it names is ignored for that joint (counted in `stale_samples`), unless it is
        older by more than `JUMP_BACK`: then the stamps jumped back (a bag or simulation restarted,
        or the last sample carried a wrong stamp far ahead), and it is taken as the start of a new
        timeline, its velocity not estimated across the jump (counted in `jumps_back`).

        Raises:
            InvalidInputError: lengths disagree, a tracked joint is named twice, the stamp is not
                finite, or a required joint's position is NaN or infinite or its velocity is
                infinite (a NaN velocity means "unknown"). Nothing is merged then.
        """
        n_names = len(names)
        if len(positions) != n_names:
            raise InvalidInputError(
                f"joint state has {n_names} names but {len(positions)} positions"
            )
        have_vel = velocities is not None and len(velocities) > 0
        if have_vel and velocities is not None and len(velocities) != n_names:
            raise InvalidInputError(
                f"joint state has {n_names} names but {len(velocities)} velocities"
            )
        if not math.isfinite(stamp):
            raise InvalidInputError(f"joint state stamp must be finite, got {stamp}")
        index = self._index
        updates = []
        for j, name in enumerate(names):
            i = index.get(name)
            if i is None:
                continue
            p = float(positions[j])
            v = float(velocities[j]) if have_vel and velocities is not None else math.nan
            if not math.isfinite(p) or v in (math.inf, -math.inf):
                if self._required[i]:
                    what = "position" if not math.isfinite(p) else "velocity"
                    raise InvalidInputError(
                        f"joint state {what} of {name!r} is {p if what == 'position' else v}"
                    )
                continue
            updates.append((i, p, v))
        hit = [i for i, _, _ in updates]
        if len(set(hit)) != len(hit):
            dup = next(self.joint_names[i] for k, i in enumerate(hit) if i in hit[:k])
            raise InvalidInputError(f"joint state names {dup!r} more than once")
        changed = False
        q, qdot, stamps = self._q, self._qdot, self._stamp
        jumped = False
        for i, p, v in updates:
            last = stamps[i]
            fresh = False  # the first sample of a new timeline: no estimate across the jump
            if stamp < last:
                if last - stamp <= JUMP_BACK:
                    self.stale_samples += 1
                    continue
                jumped = fresh = True
            if not math.isfinite(v) and not fresh:  # missing or NaN (ros2_control fills absent
                # interfaces so): estimated from the last sample
                dt = stamp - last
                if math.isfinite(q[i]) and dt > 0:
                    dq = p - q[i]
                    if self._continuous[i]:
                        dq = math.remainder(dq, 2 * math.pi)
                    v = dq / dt
                elif dt == 0 and math.isfinite(qdot[i]):
                    v = qdot[i]  # duplicate stamp: keep the previous estimate
            q[i], qdot[i], stamps[i] = p, v, stamp
            changed = True
        if jumped:
            self.jumps_back += 1
            self.latest_stamp = stamp
        elif changed:
            self.latest_stamp = max(self.latest_stamp, stamp)
        return changed


@dataclass(frozen=True)
class EndEffectorState:
    """End-effector quantities at one instant: what the node publishes per joint state.

    Attributes:
        stamp: time of the joint state [s].
        q, qdot: joint values and velocities (qdot None when unknown).
        T_base_tip: pose of the tip in the base (4×4).
        twist: (ω, v) of the tip: angular velocity and velocity of the tip origin, in base axes for
            frame "world", in tip axes for frame "body"; None when qdot is unknown.
    """

    stamp: float
    q: FloatArray
    qdot: FloatArray | None
    T_base_tip: FloatArray
    twist: FloatArray | None


def compute_ee_state(
    chain: SerialChain,
    q: FloatArray,
    qdot: FloatArray | None,
    stamp: float,
    twist_frame: Literal["world", "body"] = "world",
) -> EndEffectorState:
    """Pose and twist of the tip for one configuration (one FK/Jacobian pass, no decomposition:
    this runs once per joint state)."""
    T, J = chain.fk_jacobian(q, "world")
    twist = None
    if qdot is not None:
        twist = J @ qdot
        if twist_frame == "body":
            Rt = T[:3, :3].T
            twist = np.concatenate((Rt @ twist[:3], Rt @ twist[3:]))
    return EndEffectorState(
        stamp=stamp, q=np.asarray(q, dtype=np.float64), qdot=qdot, T_base_tip=T, twist=twist
    )
