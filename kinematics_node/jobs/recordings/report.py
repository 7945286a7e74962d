"""What a recording shows about the arm, gathered a batch at a time and told on the terminal.

* the stream: duration, rate, gaps (log-time steps longer than `GAP_FACTOR` median steps);
* episodes near a singularity: spans where the Jacobian's condition number exceeds a threshold
  (start, end, worst), on the conditioning samples (`conditioning_rate_hz`, default 100 Hz);
* joints at or near their position limits (within `near_limit` of them), and joint speeds over
  the description's velocity limits;
* the tool's peak speed (the tip origin's, from the twist);
* the sampled series (tool position, speed, condition number) that `picture` draws;
* what the joint_states gave (`joint_motion.Counts`): skipped, waiting, log times used.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ...core import SerialChain
from .joint_motion import Counts, Motion
from .outputs import Computed, Conditioning

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: A log-time step longer than this many median steps is a gap in the stream.
GAP_FACTOR = 5.0


@dataclass
class Episode:
    """A span near a singularity: first and last sample [ns] and the worst condition number."""

    start_ns: int
    end_ns: int
    worst: float


@dataclass
class JointExtreme:
    """How close a joint came to its limits, and how fast it went against its velocity limit."""

    closest: float = math.inf  # [rad or m] to the nearer limit
    at_ns: int = 0
    over_speed_samples: int = 0
    peak_speed: float = 0.0


@dataclass
class Findings:
    """Accumulates the report over the batches of one recording."""

    chain: SerialChain
    singular_condition: float = 100.0
    near_limit: float = 0.05
    first_ns: int | None = None
    last_ns: int | None = None
    posed: int = 0
    steps: list[FloatArray] = field(default_factory=list)
    gaps: list[tuple[int, float]] = field(default_factory=list)  # (start ns, length s)
    episodes: list[Episode] = field(default_factory=list)
    joints: dict[str, JointExtreme] = field(default_factory=dict)
    peak_tool_speed: float = 0.0
    peak_tool_speed_ns: int = 0
    series: list[tuple[IntArray, FloatArray, FloatArray, FloatArray]] = field(default_factory=list)
    _open: Episode | None = None

    def __post_init__(self) -> None:
        self.joints = {name: JointExtreme() for name in self.chain.joint_names}

    def add(
        self, motion: Motion, computed: Computed, sampled: IntArray, cond: Conditioning
    ) -> None:
        """One batch: its posed rows, what was computed for them, and the rows sampled for the
        conditioning (`cond`), which also make the series the picture draws."""
        log = motion.log_time_ns
        if log.size:
            previous = self.last_ns
            times = log if previous is None else np.concatenate(([previous], log))
            self.steps.append(np.diff(times).astype(np.float64) * 1e-9)
            self.first_ns = int(log[0]) if self.first_ns is None else self.first_ns
            self.last_ns = int(log[-1])
            self.posed += int(log.size)
        chain = self.chain
        room = np.minimum(motion.q - chain.lower, chain.upper - motion.q)
        known = np.isfinite(motion.qdot).all(axis=1)
        for j, name in enumerate(chain.joint_names):
            ext = self.joints[name]
            if room.shape[0] and np.isfinite(room[:, j]).any():
                k = int(np.nanargmin(room[:, j]))
                if room[k, j] < ext.closest:
                    ext.closest, ext.at_ns = float(room[k, j]), int(log[k])
            speed = np.abs(motion.qdot[known, j])
            if speed.size:
                ext.peak_speed = max(ext.peak_speed, float(speed.max()))
                ext.over_speed_samples += int((speed > chain.velocity_limit[j]).sum())
        tool_speed = np.linalg.norm(computed.V[:, 3:], axis=1)  # NaN where q̇ is unknown
        if known.any():
            k = int(np.nanargmax(np.where(known, tool_speed, -1.0)))
            if tool_speed[k] > self.peak_tool_speed:
                self.peak_tool_speed, self.peak_tool_speed_ns = float(tool_speed[k]), int(log[k])
        self.series.append(
            (log[sampled], computed.T[sampled, :3, 3], tool_speed[sampled], cond.condition_number)
        )
        self._episodes(cond)

    def series_arrays(self) -> tuple[IntArray, FloatArray, FloatArray, FloatArray]:
        """The sampled series: log times [ns], tool positions (k, 3) [m], tool speeds [m/s]
        (NaN: unknown) and condition numbers."""
        if not self.series:
            return np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros(0), np.zeros(0)
        t, p, s, c = zip(*self.series, strict=True)
        return np.concatenate(t), np.concatenate(p), np.concatenate(s), np.concatenate(c)

    def _episodes(self, cond: Conditioning) -> None:
        near = cond.condition_number > self.singular_condition
        for t, is_near, c in zip(
            cond.log_time_ns.tolist(), near.tolist(), cond.condition_number.tolist(), strict=True
        ):
            if is_near:
                if self._open is None:
                    self._open = Episode(t, t, c)
                    self.episodes.append(self._open)
                self._open.end_ns, self._open.worst = t, max(self._open.worst, c)
            else:
                self._open = None

    def finish(self) -> None:
        """Find the gaps once every step is known (their threshold is the median step)."""
        if not self.steps:
            return
        steps = np.concatenate(self.steps)
        positive = steps[steps > 0]
        if not positive.size:
            return
        median = float(np.median(positive))
        long = np.flatnonzero(steps > GAP_FACTOR * median)
        starts = np.cumsum(np.concatenate(([0.0], steps)))[:-1]
        first = self.first_ns or 0
        self.gaps = [(first + int(starts[i] * 1e9), float(steps[i])) for i in long]
        self._median_step = median

    def text(self, counts: Counts, origin_ns: int | None = None) -> str:
        """The report, for the terminal (times in seconds from `origin_ns`, default: the first
        posed joint_states)."""
        o = self.first_ns if origin_ns is None else origin_ns
        lines = []
        if self.first_ns is None or self.last_ns is None or o is None:
            return "no joint_states with every chain joint: nothing computed"
        duration = (self.last_ns - self.first_ns) * 1e-9
        rate = (self.posed - 1) / duration if duration > 0 else math.nan
        lines.append(
            f"joint_states: {counts.messages} read, {self.posed} posed over {duration:.3f} s "
            f"({rate:.1f} Hz)"
        )
        skipped = [
            (counts.rejected, "skipped (NaN or infinite value, or a joint named twice)"),
            (counts.foreign, "naming no joint of the chain"),
            (counts.waiting, "before every chain joint was named"),
            (counts.unknown_velocity, "with no velocity (no ee_twist)"),
            (counts.log_time_steps, "velocities over log times (stamps unset, repeated or back)"),
            (counts.unset_stamps, "stamped 0 (outputs carry the log time)"),
        ]
        lines += [f"  {n} {what}" for n, what in skipped if n]

        def at(ns: int) -> str:
            return f"{(ns - o) * 1e-9:.3f} s"

        if self.gaps:
            longest = sorted(self.gaps, key=lambda g: -g[1])[:5]
            lines.append(
                f"gaps: {len(self.gaps)} (steps over {GAP_FACTOR:g}x the median "
                f"{self._median_step * 1e3:.3g} ms); longest: "
                + ", ".join(f"{length:.3f} s at {at(t)}" for t, length in longest)
            )
        else:
            lines.append("gaps: none")
        if self.episodes:
            lines.append(
                f"near a singularity (condition number > {self.singular_condition:g}): "
                f"{len(self.episodes)} episode(s)"
            )
            for e in sorted(self.episodes, key=lambda e: -e.worst)[:10]:
                lines.append(f"  {at(e.start_ns)} to {at(e.end_ns)}, worst {e.worst:.4g}")
        else:
            lines.append(
                f"near a singularity (condition number > {self.singular_condition:g}): never"
            )
        near = [(name, e) for name, e in self.joints.items() if e.closest <= self.near_limit]
        if near:
            lines.append(f"joints within {self.near_limit:g} of a position limit:")
            lines += [f"  {name}: {e.closest:.4g} at {at(e.at_ns)}" for name, e in near]
        else:
            lines.append(f"joints within {self.near_limit:g} of a position limit: none")
        fast = [(n, e) for n, e in self.joints.items() if e.over_speed_samples]
        limits = dict(zip(self.chain.joint_names, self.chain.velocity_limit, strict=True))
        if fast:
            lines.append("joint speeds over the description's velocity limits:")
            lines += [
                f"  {n}: {e.over_speed_samples} samples, peak {e.peak_speed:.4g} (limit "
                f"{limits[n]:.4g})"
                for n, e in fast
            ]
        else:
            lines.append("joint speeds over the description's velocity limits: none")
        lines.append(
            f"tool peak speed: {self.peak_tool_speed:.4g} m/s at {at(self.peak_tool_speed_ns)}"
        )
        return "\n".join(lines)
