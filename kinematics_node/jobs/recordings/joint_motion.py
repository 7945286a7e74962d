"""A recording's joint_states → the chain's joint positions and velocities, a batch at a time.

What the kinematics node's `JointStateTracker` does for one message at a time, done for a whole
batch of decoded messages with numpy, and carried from one batch to the next:

* a message may name a subset of the chain's joints, in any order, and joints of other chains; a
  joint it does not name keeps its last value (and its last velocity);
* a message whose chain joints include a NaN or infinite position (or an infinite velocity), or
  that names one twice, is skipped, as the node rejects it, and counted (`Counts.rejected`);
* a row has a pose once every chain joint has been named (as the node publishes only then);
* velocities come from the message where it carries a finite one; otherwise they are estimated
  from successive positions of the joint: over the header stamps when the stamp advances (the
  node's arithmetic: seconds = sec + nanosec · 1e-9, so the two agree to the last bit), else —
  stamps unset, repeated or going back — over the recording's log times (the node, live, uses
  arrival times there; a recording's log times are its arrival times). Continuous joints' steps
  are taken modulo 2π. A step over no time leaves the velocity unknown.

The output header stamp of a row is its joint_states stamp, or its log time where the stamp is
unset (0).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from msg_adapters.cdr import JointStateGroup

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]


@dataclass
class Counts:
    """What a recording's joint_states gave, so far.

    Attributes:
        messages: joint_states read.
        rejected: skipped for a NaN/infinite chain position or velocity, or a name given twice.
        foreign: naming no joint of the chain (another robot's joint_states).
        waiting: before every chain joint had been named (no pose yet).
        log_time_steps: velocities estimated over log times (stamps unset, repeated or back).
        unset_stamps: rows stamped 0 (their outputs carry the log time).
        unknown_velocity: rows with a pose but no velocity (no twist written).
    """

    messages: int = 0
    rejected: int = 0
    foreign: int = 0
    waiting: int = 0
    log_time_steps: int = 0
    unset_stamps: int = 0
    unknown_velocity: int = 0


@dataclass(frozen=True)
class Motion:
    """The rows of one batch that have a pose, in log-time order.

    Attributes:
        rows: indices into the batch (m,).
        log_time_ns: their log times (m,) [ns]; stamp_ns: their output stamps (m,) [ns].
        q: (m, n) joint values; qdot: (m, n) velocities (a NaN row: unknown).
    """

    rows: IntArray
    log_time_ns: IntArray
    stamp_ns: IntArray
    q: FloatArray
    qdot: FloatArray


@dataclass
class _Carry:
    """Per joint, what the last row that named it left (NaN / -1: nothing yet)."""

    q: FloatArray
    qdot: FloatArray
    stamp_ns: IntArray
    log_ns: IntArray
    seconds: FloatArray


@dataclass
class JointMotion:
    """Turns batches of decoded joint_states into `Motion`, carrying state between batches.

    Args:
        joint_names: the chain's actuated joints, in chain order.
        continuous: which of them have no limits (steps taken modulo 2π).
    """

    joint_names: Sequence[str]
    continuous: Sequence[bool]
    counts: Counts = field(default_factory=Counts)

    def __post_init__(self) -> None:
        n = len(self.joint_names)
        self._index = {name: i for i, name in enumerate(self.joint_names)}
        self._continuous = np.asarray(self.continuous, dtype=bool)
        nan = np.full(n, math.nan)
        self._carry = _Carry(nan.copy(), nan.copy(), np.full(n, -1), np.full(n, -1), nan.copy())

    @property
    def last_q(self) -> FloatArray:
        """Each joint's last position (NaN: never named yet)."""
        return self._carry.q.copy()

    def advance(self, groups: Sequence[JointStateGroup], log_time_ns: IntArray) -> Motion:
        """The rows of a batch (its decoded groups and the log time of every message, in the
        order read) that have a pose, with their positions and velocities."""
        k, n = len(log_time_ns), len(self.joint_names)
        log_ns = np.asarray(log_time_ns, dtype=np.int64)
        Q = np.full((k, n), math.nan)
        V = np.full((k, n), math.nan)
        named = np.zeros((k, n), dtype=bool)
        stamp = np.zeros(k, dtype=np.int64)
        rejected = np.zeros(k, dtype=bool)
        for g in groups:
            stamp[g.rows] = g.stamp_ns
            pairs = [
                (j, self._index[name]) for j, name in enumerate(g.names) if name in self._index
            ]
            if not pairs:
                continue
            src, dst = (list(x) for x in zip(*pairs, strict=True))
            if len(set(dst)) != len(dst):
                rejected[g.rows] = True
                continue
            P = g.position[:, src]
            bad = ~np.isfinite(P).all(axis=1)
            if g.velocity.shape[1]:
                Vg = g.velocity[:, src]
                bad |= np.isinf(Vg).any(axis=1)
                V[np.ix_(g.rows, dst)] = Vg
            rejected[g.rows[bad]] = True
            Q[np.ix_(g.rows, dst)] = P
            named[np.ix_(g.rows, dst)] = True
        named &= ~rejected[:, None]
        taken = named.any(axis=1)
        self.counts.messages += k
        self.counts.rejected += int(rejected.sum())
        self.counts.foreign += int((~taken & ~rejected).sum())

        # each row's output stamp and the seconds the node would read from it
        unset = stamp == 0
        out_stamp = np.where(unset, log_ns, stamp)
        sec, nanosec = np.divmod(stamp, 1_000_000_000)
        seconds = sec.astype(np.float64) + nanosec.astype(np.float64) * 1e-9

        c = self._carry
        Qf = np.empty((k, n))
        Vf = np.empty((k, n))
        ordinal = np.arange(k)
        for j in range(n):
            rows_j = np.flatnonzero(named[:, j])
            # the last row up to each row that named joint j (-1: before this batch)
            last = np.maximum.accumulate(np.where(named[:, j], ordinal, -1))
            before = last < 0
            Qf[:, j] = np.where(before, c.q[j], Q[np.maximum(last, 0), j])
            if rows_j.size == 0:
                Vf[:, j] = c.qdot[j]
                continue
            # velocity at each row that names j: the message's, else a step from the row before
            q_now, v_now = Q[rows_j, j], V[rows_j, j]
            q_prev = np.concatenate(([c.q[j]], q_now[:-1]))
            s_now, s_prev = stamp[rows_j], np.concatenate(([c.stamp_ns[j]], stamp[rows_j][:-1]))
            t_now = seconds[rows_j]
            t_prev = np.concatenate(([c.seconds[j]], t_now[:-1]))
            l_now = log_ns[rows_j]
            l_prev = np.concatenate(([c.log_ns[j]], l_now[:-1]))
            by_stamp = (s_now != 0) & (s_prev > 0) & (s_now > s_prev)
            dt = np.where(by_stamp, t_now - t_prev, (l_now - l_prev) * 1e-9)
            dq = q_now - q_prev
            if self._continuous[j]:  # the node's math.remainder: exact, and dq itself within π
                wraps = np.flatnonzero(np.abs(dq) > math.pi)
                dq[wraps] = [math.remainder(float(x), 2 * math.pi) for x in dq[wraps]]
            with np.errstate(divide="ignore", invalid="ignore"):
                estimate = np.where((dt > 0) & (l_prev >= 0), dq / dt, math.nan)
            estimated = np.isnan(v_now)
            self.counts.log_time_steps += int((estimated & ~by_stamp & (l_prev >= 0)).sum())
            v_rows = np.where(estimated, estimate, v_now)
            V_named = np.full(k, math.nan)
            V_named[rows_j] = v_rows
            Vf[:, j] = np.where(before, c.qdot[j], V_named[np.maximum(last, 0)])
            end = rows_j[-1]
            c.q[j], c.qdot[j], c.stamp_ns[j] = Q[end, j], v_rows[-1], stamp[end]
            c.log_ns[j], c.seconds[j] = log_ns[end], seconds[end]

        posed = taken & np.isfinite(Qf).all(axis=1)
        self.counts.waiting += int((taken & ~posed).sum())
        rows = np.flatnonzero(posed)
        self.counts.unset_stamps += int(unset[rows].sum())
        qdot = Vf[rows]
        self.counts.unknown_velocity += int((~np.isfinite(qdot).all(axis=1)).sum())
        return Motion(rows, log_ns[rows], out_stamp[rows], Qf[rows], qdot)
