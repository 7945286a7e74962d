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
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from ..core import SerialChain
from ..core.exceptions import InvalidInputError

FloatArray = NDArray[np.float64]


#: A sample stamped this much before a joint's last one starts a new timeline instead of being
#: ignored as stale: reordering in transit is far shorter, and a single sample stamped far ahead
#: would otherwise stop every later one [s].
JUMP_BACK = 1.0

#: Shortest interval a velocity is estimated over from arrival times [s]. Arrival times carry
#: jitter: a publisher's delay between sampling and sending, and when they are taken at the
#: callback, the transport's and the executor's too (0.1–5 ms on a busy machine); and a burst
#: of samples that waited in a queue arrives within microseconds. Over this long, 0.5 ms of
#: jitter is 2 % of the velocity at most, and a burst cannot produce a huge one. The estimate
#: spans 1–2 of these at rates above 1 / ARRIVAL_SPAN (so it lags by 25–50 ms), one sample
#: interval below.
ARRIVAL_SPAN = 0.05

#: After the last estimate from arrival times, the velocity source stays reported as arrival
#: times this long, so a stream whose stamps advance only now and then reads as one source [s].
SOURCE_HOLD = 1.0

#: Where the velocities come from (`JointStateTracker.velocity_source`).
NO_VELOCITY_YET = "none yet"
FROM_MESSAGE = "from the message"
FROM_STAMPS = "estimated from stamps"
FROM_ARRIVAL_UNSTAMPED = "estimated from arrival times (joint_states are unstamped)"
FROM_ARRIVAL_REPEATED = "estimated from arrival times (joint_states stamps do not advance)"
ARRIVAL_SOURCES = frozenset({FROM_ARRIVAL_UNSTAMPED, FROM_ARRIVAL_REPEATED})


class JointStateTracker:
    """Latest position and velocity of each tracked joint, fed by (possibly partial) samples.

    `required` joints (default: all) must be valid in every sample that names them: a NaN or
    infinite position of one rejects the sample. Other tracked joints (e.g. a gripper next to the
    arm's chain) are skipped when invalid, so they never block the required ones.

    Velocities come from the sample when it carries them (a NaN entry means "unknown", as
    ros2_control fills absent interfaces); otherwise they are estimated from successive positions:

    * over the *stamps* when a joint's stamp advances: from the first sample with the joint's
      previous stamp, so a stamp that advances only every k-th sample still spans the motion of
      those k samples;
    * over the *arrival times* (`received`) when the stamp is unset (0) or repeats while a
      position changed: from the sample received at least `ARRIVAL_SPAN` before, so bursts and
      jitter do not produce huge or noisy velocities (arrival times off by up to e make the
      velocity off by at most 2e / ARRIVAL_SPAN of it; the first ARRIVAL_SPAN has no estimate);
    * not at all for a duplicate (a set stamp repeated with every position unchanged, received
      within `ARRIVAL_SPAN` of the original): the previous velocity stays. A repeat that comes
      later is a robot at rest reported again, and its velocity is estimated (it decays to 0).

    `velocity_source` says which of these the required joints' velocities came from lately.

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
        self._taken = [-math.inf] * n  # per joint: `taken_at` of its last accepted sample [s]
        self._q_at_stamp = [math.nan] * n  # position at the first sample with that stamp
        # Two anchors per joint for estimates over arrival times: a = the newest sample received
        # at least ARRIVAL_SPAN after b. Unknown anchors are (-inf, nan).
        self._t_a = [-math.inf] * n
        self._q_a = [math.nan] * n
        self._t_b = [-math.inf] * n
        self._q_b = [math.nan] * n
        self._moved_at = -math.inf  # arrival of the last sample that was not a duplicate
        self._arrival_at = -math.inf  # arrival of the last sample estimated from arrival times
        self.latest_stamp = -math.inf
        self.stale_samples = 0
        self.jumps_back = 0  #: samples that started a new timeline (`JUMP_BACK`)
        self.duplicates = 0  #: samples whose velocity was kept as a duplicate's
        #: Where the required joints' velocities came from: `FROM_MESSAGE`, `FROM_STAMPS`, one of
        #: `ARRIVAL_SOURCES` (held `SOURCE_HOLD` after the last such estimate), or
        #: `NO_VELOCITY_YET`.
        self.velocity_source = NO_VELOCITY_YET
        self.from_arrival_times = False  #: velocity_source is one of `ARRIVAL_SOURCES`
        self.arrival_episodes = 0  #: times estimates from arrival times began (after a hold)

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

    def taken_at(self) -> dict[str, float]:
        """{joint: when its last accepted sample was taken (`update`'s `taken_at`)} of the
        joints received so far."""
        return {
            name: t for name, t in zip(self.joint_names, self._taken, strict=True) if t > -math.inf
        }

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
        received: float | None = None,
        taken_at: float | None = None,
    ) -> bool:
        """Merge one sample; return True if it was taken for at least one tracked joint.

        Args:
            names, positions, velocities: as in sensor_msgs/JointState (velocities may be empty
                or None).
            stamp: the sample's stamp [s]; 0 means unset.
            received: its arrival time [s], on one clock for every sample (the node passes
                when its publisher sent it, the DDS source timestamp, which no transport or
                executor delay blurs; default: `time.monotonic()`); used only to estimate
                velocities the stamps cannot give.
            taken_at: when the sample is taken, on the clock the age of a joint's value is
                measured with (the node's clock; `taken_at()`); default: `received`.

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
        r = time.monotonic() if received is None else received
        t_taken = r if taken_at is None else taken_at
        index = self._index
        q = self._q
        updates = []
        moved = False
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
            if p != q[i]:
                moved = True
            updates.append((i, p, v))
        hit = [i for i, _, _ in updates]
        if len(set(hit)) != len(hit):
            dup = next(self.joint_names[i] for k, i in enumerate(hit) if i in hit[:k])
            raise InvalidInputError(f"joint state names {dup!r} more than once")
        # A set stamp repeated with no position changed, soon after the original: a duplicate.
        duplicate = not moved and stamp != 0.0 and r - self._moved_at < ARRIVAL_SPAN
        if not duplicate:
            self._moved_at = r
        changed = jumped = False
        by_message = by_stamps = False
        arrival: str | None = None
        qdot, stamps, q_at, required = self._qdot, self._stamp, self._q_at_stamp, self._required
        taken = self._taken
        t_a, q_a, t_b, q_b = self._t_a, self._q_a, self._t_b, self._q_b
        continuous, span = self._continuous, ARRIVAL_SPAN
        for i, p, v in updates:
            last = stamps[i]
            if stamp < last:
                if last - stamp <= JUMP_BACK:
                    self.stale_samples += 1
                    continue
                # a new timeline: no estimate across the jump, from stamps or arrival times
                changed = jumped = True
                taken[i] = t_taken
                q[i], qdot[i], stamps[i], q_at[i] = p, v, stamp, p
                t_a[i], q_a[i], t_b[i], q_b[i] = r, p, -math.inf, math.nan
                continue
            changed = True
            taken[i] = t_taken
            if v == v:  # from the message
                by_message = by_message or required[i]
                if stamp != last:
                    q_at[i] = p
            elif stamp > last and (last != 0.0 or stamp <= JUMP_BACK):
                # the stamp advances (from 0 only at the start of simulated time): over the
                # stamps, from the first sample with the previous one
                dq = p - q_at[i]
                if continuous[i]:
                    dq = math.remainder(dq, 2 * math.pi)
                v = dq / (stamp - last)
                q_at[i] = p
                by_stamps = by_stamps or (required[i] and v == v)
            elif duplicate:
                self.duplicates += 1
                continue  # the same sample again: velocity and anchors stay
            else:  # unset (0) or not advancing: over the arrival times
                if stamp != last:
                    q_at[i] = p
                ta = t_a[i]
                if r - ta >= span:
                    dq, dt = p - q_a[i], r - ta
                else:
                    dq, dt = p - q_b[i], r - t_b[i]
                if continuous[i]:
                    dq = math.remainder(dq, 2 * math.pi)
                v = dq / dt
                if required[i] and q[i] == q[i]:
                    arrival = (
                        FROM_ARRIVAL_UNSTAMPED
                        if stamp == 0.0 or last == 0.0
                        else FROM_ARRIVAL_REPEATED
                    )
            if r - t_a[i] >= span:  # the anchors follow every sample taken
                t_b[i], q_b[i], t_a[i], q_a[i] = t_a[i], q_a[i], r, p
            q[i], qdot[i], stamps[i] = p, v, stamp
        if arrival is not None:
            if r - self._arrival_at > SOURCE_HOLD:
                self.arrival_episodes += 1
            self._arrival_at = r
            self.velocity_source, self.from_arrival_times = arrival, True
        elif r - self._arrival_at > SOURCE_HOLD:
            if by_stamps:
                self.velocity_source, self.from_arrival_times = FROM_STAMPS, False
            elif by_message:
                self.velocity_source, self.from_arrival_times = FROM_MESSAGE, False
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
