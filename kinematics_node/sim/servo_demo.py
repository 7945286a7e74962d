"""`kinematics servo-demo`: the servo drives the UR5e's tool around a square through a wrist
singularity, then spins it in place; the ROS-free run, the figures and the picture.

The script (`SquarePlan`): a 0.2 m square in a vertical plane, the tool's orientation held, whose
first side passes through the configuration where the UR5e's wrist_2 joint is 0 (the axes of
wrist 1 and wrist 3 align: a singularity, where moveit_servo halts); then the tool turns 0.8 rad
about a tilted axis through its origin and back. It is streamed as twists (ω, v) in the base
frame, about the tool's origin, with a speed that rises and falls smoothly on each side (so the
commanded path is the square itself, corners included), as a joystick would send them.

`run_offline` runs it through the core servo (`kinematics_node.core.servo.Servo`) and the
simulated arm (`ArmSimulator`, following the servo's joint positions), one servo period per
simulator step. `kinematics_node.ros.servo_live_demo` runs the same script on the real nodes over
DDS. Both fill a `ServoDemoRun`; `figures` computes what the demo prints from it (`summary`), and
`plot` draws it.
"""

from __future__ import annotations

import math
import sys
from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TextIO

import numpy as np
from numpy.typing import NDArray

from ..core import IKOptions, SerialChain, so3
from ..core.analysis import condition_number
from ..core.servo import ServoConfig, ServoLimits

FloatArray = NDArray[np.float64]

ROBOT = "ur5e"
#: The configuration at the middle of the square's first side: wrist_2 = 0 [rad].
SINGULAR_Q = (0.3, -1.3, 1.6, -1.9, 0.0, 0.4)
SINGULAR_JOINT = 4  # wrist_2_joint
SIDE_M = 0.2  # [m]
SIDE_S = 2.5  # [s] per side
SPIN_RAD = 0.8  # [rad] each way
SPIN_S = 1.5  # [s] each way
SETTLE_S = 1.0  # [s] after the last command

#: A command asks for motion when it asks at least this tool speed [m/s] or turn rate [rad/s];
#: the tool stops when it moves slower than STILL_* over STOP_WINDOW_S [s] or longer (a single
#: step of the arm without a new joint command is not a stop: `ServoDemoFigures.held_steps`).
MOVING_M_S, MOVING_RAD_S = 0.005, 0.05
STILL_M_S, STILL_RAD_S = 0.001, 0.01
STOP_WINDOW_S = 0.05
#: moveit_servo's documented defaults: it slows from this condition number and halts at that one.
MOVEIT_SLOWDOWN, MOVEIT_HALT = 17.0, 30.0


@dataclass(frozen=True)
class SquarePlan:
    """The demo's script: where the arm starts, the square's corners, and the twist at any time.

    Attributes:
        q_start: (n,) joint positions at the first corner [rad].
        corners: (5, 3) the square's corners in the base frame, first repeated last [m].
        R: (3, 3) the tool's orientation, held along the square (base axes).
        spin_axis: (3,) unit axis of the spin, base axes, through the tool's origin.
        side_s: time per side [s]; spin_s: time per half of the spin [s]; settle_s: time after
            the last command [s].
    """

    q_start: FloatArray
    corners: FloatArray
    R: FloatArray
    spin_axis: FloatArray
    side_m: float = SIDE_M
    side_s: float = SIDE_S
    spin_rad: float = SPIN_RAD
    spin_s: float = SPIN_S
    settle_s: float = SETTLE_S

    @property
    def spin_start_s(self) -> float:
        """When the spin begins [s after the first command]."""
        return 4 * self.side_s

    @property
    def commands_s(self) -> float:
        """How long twists are sent [s]."""
        return self.spin_start_s + 2 * self.spin_s

    @property
    def duration_s(self) -> float:
        """The whole run, settling included [s]."""
        return self.commands_s + self.settle_s

    def twist(self, t: float) -> FloatArray | None:
        """The twist (ω [rad/s], v [m/s]) (6,) commanded at `t` [s], base axes, about the tool's
        origin; None once the script is over (no more commands). Each side and each half-spin
        has speed profile (D/T)(1 − cos 2πτ/T) over its time T: it covers its distance D, and
        starts and ends at rest."""
        if t < 0 or t >= self.commands_s:
            return None
        out = np.zeros(6)
        if t < self.spin_start_s:
            k = min(int(t // self.side_s), 3)
            tau = t - k * self.side_s
            d = self.corners[k + 1] - self.corners[k]
            out[3:] = d / self.side_s * (1.0 - math.cos(2.0 * math.pi * tau / self.side_s))
        else:
            t2 = t - self.spin_start_s
            sign = 1.0 if t2 < self.spin_s else -1.0
            tau = t2 % self.spin_s
            speed = (
                self.spin_rad / self.spin_s * (1.0 - math.cos(2.0 * math.pi * tau / self.spin_s))
            )
            out[:3] = sign * speed * self.spin_axis
        return out


def plan_square(chain: SerialChain) -> SquarePlan:
    """The square for the UR5e `chain`: its first side, along the tool's z axis at `SINGULAR_Q`,
    has that wrist singularity at its middle; the second side goes up. The start configuration
    is found by IK in small steps from the singular one, so it is on the branch the first side
    passes the singularity on.

    Raises:
        RuntimeError: the IK walk failed (a chain other than the UR5e's).
    """
    q_mid = np.array(SINGULAR_Q, dtype=np.float64)
    T_mid = chain.fk(q_mid)
    along = T_mid[:3, 2].copy()  # the tool's z axis (horizontal here)
    up = np.array([0.0, 0.0, 1.0])
    c0 = T_mid[:3, 3] - 0.5 * SIDE_M * along
    corners = np.array([c0, c0 + SIDE_M * along, c0 + SIDE_M * (along + up), c0 + SIDE_M * up, c0])
    options = IKOptions(rng_seed=0)
    seed = q_mid + 0.05 * np.eye(chain.dof)[SINGULAR_JOINT]  # off the singularity, on the branch
    for s in np.linspace(0.0, 1.0, 11):
        T = T_mid.copy()
        T[:3, 3] = T_mid[:3, 3] + s * (c0 - T_mid[:3, 3])
        result = chain.ik(T, seed, options=options)
        if not result.success:
            raise RuntimeError(f"no IK solution on the way to the square's first corner ({s:.1f})")
        seed = result.q
    # tilted in the tool's axes; this sense turns the wrist away from the singularity (turning
    # the other way would cross it again, which is not what this part shows)
    tilted = np.array([-1.0, 1.0, -1.0]) / math.sqrt(3.0)
    return SquarePlan(
        q_start=seed, corners=corners, R=T_mid[:3, :3].copy(), spin_axis=T_mid[:3, :3] @ tilted
    )


@dataclass(frozen=True)
class ServoDemoRun:
    """What a run of the demo recorded (in process or over DDS), time from the first twist [s].

    Attributes:
        chain, limits: the arm and the servo's joint limits (velocity, acceleration, jerk).
        plan: the script.
        period_s: the servo's period [s].
        q_command: (K, n) the servo's joint commands, one per period, in order.
        t_tool: (M,) when the arm's joint positions were measured [s].
        q_tool: (M, n) the measured joint positions.
        p_tool: (M, 3) the tool's position [m] (in process: FK; live: the kinematics node's
            ee_pose); R_tool: (M, 3, 3) its orientation.
        t_twist: (C,) when each twist was sent [s]; twist: (C, 6) the twists sent (ω, v).
        status_counts: {servo status code: cycles} (empty where the status was not received).
        where: how it ran, one phrase.
        notes: extra lines for the summary (live: transport figures, the processes' exit).
        command_sequence, command_time: (K,) the joint commands' publication sequence numbers
            and times [s] where known (live: DDS's); a command lost in transport, or one
            published more than 1.5 periods after the one before (likely a late cycle, see
            `command_gaps`), is a gap in the stream, and the derivatives that would span it are
            left out (`command_derivatives`).
    """

    chain: SerialChain
    limits: ServoLimits
    plan: SquarePlan
    period_s: float
    q_command: FloatArray
    t_tool: FloatArray
    q_tool: FloatArray
    p_tool: FloatArray
    R_tool: FloatArray
    t_twist: FloatArray
    twist: FloatArray
    status_counts: Mapping[str, int]
    where: str
    notes: tuple[str, ...] = ()
    command_sequence: NDArray[np.int64] | None = None
    command_time: FloatArray | None = None


@dataclass(frozen=True)
class Peak:
    """The largest |value| of one derivative over the run, on one joint, against its limit."""

    fraction: float  # of the limit
    joint: str
    value: float
    limit: float


@dataclass(frozen=True)
class ServoDemoFigures:
    """What the demo prints, computed from a `ServoDemoRun` (`figures`).

    Attributes:
        path_error_max_mm, path_error_rms_mm: distance of the tool's origin from the commanded
            square, while the square is driven [mm].
        spin_drift_mm: the farthest the tool's origin went from the square's first corner while
            it spun and settled [mm] (the commands keep it there).
        spin_angle_rad: the largest rotation from the square's orientation during the spin.
        end_error_mm, end_error_mrad: the tool after the run vs where the commands put it (the
            first corner, the square's orientation).
        time_asked_s: time the commands asked for motion (`MOVING_*`); time_stopped_s: of that,
            the time the tool stood still (`STILL_*`) for `STOP_WINDOW_S` or longer.
        held_steps, held_s: measured intervals, and their time, in which the commands asked for
            motion and the arm's joint positions did not change at all (its step found no new
            joint command: over DDS the servo's and the arm's loops are not synchronised).
        condition_max: the largest condition number σ_max/σ_min of the Jacobian (tool origin,
            base axes) at the measured positions; time_beyond_halt_s: time it was ≥ 30, where
            moveit_servo's documented scheme halts; singular_crossings: how often the wrist_2
            joint changed sign (passed the singularity).
        velocity, acceleration, jerk: peaks of the servo's joint commands (finite differences
            of its positions over its period; the servo starts at rest); command_gaps: how many
            commands did not follow the one before by one period (`command_gaps`; the
            derivatives across them are left out).
    """

    path_error_max_mm: float
    path_error_rms_mm: float
    spin_drift_mm: float
    spin_angle_rad: float
    end_error_mm: float
    end_error_mrad: float
    time_asked_s: float
    time_stopped_s: float
    held_steps: int
    held_s: float
    command_gaps: int
    condition_max: float
    time_beyond_halt_s: float
    singular_crossings: int
    velocity: Peak
    acceleration: Peak
    jerk: Peak
    condition: FloatArray = field(repr=False)  # (M,) per measured sample


def distance_to_polyline(points: FloatArray, corners: FloatArray) -> FloatArray:
    """(M,) distance of each point (M, 3) from the polyline through `corners` (k, 3) [m]."""
    a, b = corners[:-1], corners[1:]
    ab = b - a
    rel = points[:, None, :] - a[None]  # (M, k−1, 3)
    s = np.clip((rel * ab).sum(-1) / (ab * ab).sum(-1), 0.0, 1.0)
    nearest = a[None] + s[..., None] * ab[None]
    return np.asarray(np.linalg.norm(points[:, None, :] - nearest, axis=-1).min(axis=1))


def _peak(values: FloatArray, limit: FloatArray, names: tuple[str, ...]) -> Peak:
    ratio = np.abs(values) / limit
    k, j = np.unravel_index(int(np.nanargmax(ratio)), ratio.shape)
    return Peak(float(ratio[k, j]), names[j], float(abs(values[k, j])), float(limit[j]))


def command_gaps(
    period_s: float, sequence: NDArray[np.int64] | None, times: FloatArray | None
) -> NDArray[np.bool_] | None:
    """(K,) True where a joint command may not follow the one before it by one period: a
    missing publication `sequence` number, or a publication time more than 1.5 periods after
    the previous. None when neither is known.

    The times stand in for the node's late cycles, which it counts but does not mark on its
    commands: a cycle is late when its timer callback starts a period or more after its tick on
    the timer's grid; it then steps the servo for the periods it skipped too and publishes only
    the last (`ServoService.step`), so that command comes at least two periods, less the
    previous callback's delay within its own period, after the one before. 1.5 periods catches
    every late cycle whose previous callback was under half a period late, and also marks some
    pairs only jitter put that far apart (their derivatives are left out, not wrong)."""
    gap = None
    if sequence is not None:
        gap = np.r_[False, np.diff(np.asarray(sequence)) != 1]
    if times is not None:
        late = np.r_[False, np.diff(np.asarray(times)) > 1.5 * period_s]
        gap = late if gap is None else gap | late
    return gap


def command_derivatives(
    q: FloatArray, period_s: float, gaps: NDArray[np.bool_] | None = None
) -> tuple[FloatArray, ...]:
    """(velocity, acceleration, jerk), each (K, n), of the joint commands `q` (K, n), one per
    period, by backward finite differences; before the first command the arm was at rest there.
    Rows whose differences would span a gap (`command_gaps`, (K,): True where a command does
    not follow the one before by one period) are NaN: velocity the row of the gap,
    acceleration two rows, jerk three."""
    padded = np.vstack((q[:1], q[:1], q[:1], q))
    v = np.diff(padded, axis=0) / period_s
    a = np.diff(v, axis=0) / period_s
    j = np.diff(a, axis=0) / period_s
    k = len(q)
    v, a, j = v[-k:], a[-k:], j[-k:]
    if gaps is not None and k > 1:
        gap = np.asarray(gaps, dtype=bool)
        for values, rows in ((v, 1), (a, 2), (j, 3)):
            spans = gap.copy()
            for shift in range(1, rows):
                spans[shift:] |= gap[:-shift]
            values[spans] = np.nan
    return v, a, j


def stopped_intervals(t: FloatArray, p: FloatArray, R: FloatArray) -> NDArray[np.bool_]:
    """(M − 1,) which intervals [t_i, t_i+1] of the tool's samples lie in a stop: a window of at
    least `STOP_WINDOW_S` over which the tool moved less than `STILL_M_S` × its length and turned
    less than `STILL_RAD_S` × its length (every interval of every such window counts)."""
    n = len(t)
    end = np.minimum(np.searchsorted(t, t + STOP_WINDOW_S - 1e-9, side="left"), n - 1)
    span = t[end] - t
    moved = np.linalg.norm(p[end] - p, axis=1)
    turned = np.linalg.norm(so3.log(np.swapaxes(R, -1, -2) @ R[end]), axis=-1)
    still = (
        (span >= STOP_WINDOW_S - 1e-9) & (moved < STILL_M_S * span) & (turned < STILL_RAD_S * span)
    )
    out = np.zeros(max(n - 1, 0), dtype=bool)
    for i in np.flatnonzero(still):
        out[i : end[i]] = True
    return out


def figures(run: ServoDemoRun) -> ServoDemoFigures:
    """The demo's figures, from what the run recorded (see `ServoDemoFigures`)."""
    plan, t, p, R = run.plan, run.t_tool, run.p_tool, run.R_tool
    square = t < plan.spin_start_s
    dist = distance_to_polyline(p[square], plan.corners)
    spinning = ~square
    from_corner = np.linalg.norm(p[spinning] - plan.corners[0], axis=1)
    angle = np.linalg.norm(so3.log(np.swapaxes(R[spinning], -1, -2) @ plan.R), axis=-1)
    end_angle = float(np.linalg.norm(so3.log(R[-1].T @ plan.R)))
    # asked: the last twist sent before each measured interval began
    idx = np.searchsorted(run.t_twist, t[:-1], side="right") - 1
    sent = np.zeros((len(t) - 1, 6))
    sent[idx >= 0] = run.twist[idx[idx >= 0]]
    asked = (np.linalg.norm(sent[:, 3:], axis=1) >= MOVING_M_S) | (
        np.linalg.norm(sent[:, :3], axis=1) >= MOVING_RAD_S
    )
    dt = np.diff(t)
    stopped = stopped_intervals(t, p, R) & asked
    held = asked & np.all(run.q_tool[1:] == run.q_tool[:-1], axis=1)
    kappa = condition_number(run.chain.jacobian(run.q_tool), "full")
    beyond = kappa[:-1] >= MOVEIT_HALT
    wrist = run.q_tool[:, SINGULAR_JOINT]
    crossings = int(np.count_nonzero(np.diff(np.sign(wrist[wrist != 0.0]))))
    gaps = command_gaps(run.period_s, run.command_sequence, run.command_time)
    v, a, j = command_derivatives(run.q_command, run.period_s, gaps)
    names, lim = run.chain.joint_names, run.limits
    return ServoDemoFigures(
        path_error_max_mm=float(dist.max()) * 1e3,
        path_error_rms_mm=float(np.sqrt(np.mean(dist**2))) * 1e3,
        spin_drift_mm=float(from_corner.max()) * 1e3,
        spin_angle_rad=float(angle.max()),
        end_error_mm=float(np.linalg.norm(p[-1] - plan.corners[0])) * 1e3,
        end_error_mrad=end_angle * 1e3,
        time_asked_s=float(dt[asked].sum()),
        time_stopped_s=float(dt[stopped].sum()),
        held_steps=int(held.sum()),
        held_s=float(dt[held].sum()),
        command_gaps=0 if gaps is None else int(gaps.sum()),
        condition_max=float(kappa.max()),
        time_beyond_halt_s=float(dt[beyond].sum()),
        singular_crossings=crossings,
        velocity=_peak(v, lim.velocity, names),
        acceleration=_peak(a, lim.acceleration, names),
        jerk=_peak(j, lim.jerk, names),
        condition=kappa,
    )


# ---------------------------------------------------------------------------- the run
def servo_config(rate: float) -> ServoConfig:
    """The servo's settings in the demo: its defaults at period 1/`rate` [Hz]."""
    return ServoConfig(period_s=1.0 / rate)


def run_offline(rate: float = 100.0) -> ServoDemoRun:
    """The demo in this process: the core servo at `rate` [Hz] and the simulated arm stepping
    at the same rate, which moves to each joint command within one step (its velocity limits
    permitting). The servo gets the arm's measured positions every period.

    Raises:
        InvalidInputError: a rate whose period the servo does not accept (10 Hz to 2 kHz).
    """
    from ..core.servo import Servo, TwistCommand
    from .arm import ArmSimulator
    from .robots import load_robot

    chain = load_robot(ROBOT)
    config = servo_config(rate)
    plan = plan_square(chain)
    dt = config.period_s
    servo = Servo(chain, plan.q_start, config)
    sim = ArmSimulator.from_chain(chain, dt, q0=plan.q_start, demo=False)
    steps = int(round(plan.duration_s / dt))
    q_cmd = np.empty((steps, chain.dof))
    t_tool, q_tool = [0.0], [sim.q]
    t_twist, twists = [], []
    codes: Counter[str] = Counter()
    for k in range(steps):
        now = k * dt
        twist = plan.twist(now)
        if twist is not None:
            w, v = twist[:3].tolist(), twist[3:].tolist()
            servo.submit(TwistCommand(w, v, chain.base_link, now), now)
            t_twist.append(now)
            twists.append(twist)
        out = servo.step(now, sim.q)
        codes[out.status.code.name] += 1
        q_cmd[k] = out.positions
        sim.command_position(out.positions)  # as the servo node drives it
        state = sim.step()
        t_tool.append(state.time)
        q_tool.append(state.q)
    q_meas = np.array(q_tool)
    T = chain.fk(q_meas)
    return ServoDemoRun(
        chain=chain,
        limits=servo.limits,
        plan=plan,
        period_s=dt,
        q_command=q_cmd,
        t_tool=np.array(t_tool),
        q_tool=q_meas,
        p_tool=T[:, :3, 3],
        R_tool=T[:, :3, :3],
        t_twist=np.array(t_twist),
        twist=np.array(twists).reshape(-1, 6),
        status_counts=dict(codes),
        where=f"the core servo in this process at {rate:g} Hz, the simulated arm following "
        "its joint commands",
    )


# ---------------------------------------------------------------------------- output
def _peak_line(what: str, peak: Peak, unit: str) -> str:
    return (
        f"peak joint {what}: {peak.value:.3g} {unit} ({peak.joint}), {100 * peak.fraction:.0f} % "
        f"of its limit {peak.limit:.3g} {unit}"
    )


def summary(run: ServoDemoRun, fig: ServoDemoFigures) -> str:
    plan, c = run.plan, run.chain
    peak_speed = 2 * plan.side_m / plan.side_s
    lines = [
        f"servo demo: {ROBOT}, {c.dof} joints, {c.base_link} → {c.tip_link}; {run.where}",
        f"script: a {plan.side_m:.2f} m square, 4 × {plan.side_s:g} s (up to {peak_speed:.2f} m/s),"
        f" orientation held, through the wrist singularity ({c.joint_names[SINGULAR_JOINT]} = 0);"
        f" then a spin of {plan.spin_rad:g} rad about a tilted axis through the tool and back "
        f"(2 × {plan.spin_s:g} s); {plan.settle_s:g} s to settle",
        f"singularity: {c.joint_names[SINGULAR_JOINT]} passed 0 {fig.singular_crossings} times; "
        f"condition number up to {fig.condition_max:.3g} ({fig.time_beyond_halt_s:.2f} s at "
        f"≥ {MOVEIT_HALT:g}, where moveit_servo's documented scheme halts)",
        f"tracking error (tool from the commanded square): max {fig.path_error_max_mm:.2f} mm, "
        f"rms {fig.path_error_rms_mm:.3f} mm",
        f"spin in place: turned up to {fig.spin_angle_rad:.2f} rad; the tool stayed within "
        f"{fig.spin_drift_mm:.2f} mm of its corner",
        f"end: {fig.end_error_mm:.2f} mm and {fig.end_error_mrad:.2f} mrad from where the "
        "commands put the tool",
        f"time stopped while commanded to move: {fig.time_stopped_s:.2f} s of "
        f"{fig.time_asked_s:.2f} s (a stop: the tool still for {1e3 * STOP_WINDOW_S:.0f} ms or "
        f"more); the arm's step found no new joint command {fig.held_steps} times "
        f"({1e3 * fig.held_s:.0f} ms in all)",
        _peak_line("velocity", fig.velocity, "rad/s"),
        _peak_line("acceleration", fig.acceleration, "rad/s²"),
        _peak_line("jerk", fig.jerk, "rad/s³"),
    ]
    if fig.command_gaps:
        lines.append(
            f"  ({fig.command_gaps} of {len(run.q_command)} joint commands did not follow the "
            "one before by one period (lost, or published more than 1.5 periods after it: "
            "likely a late cycle, whose skipped periods the node made up): the derivatives "
            "across them are left out)"
        )
    if run.status_counts:
        counts = ", ".join(
            f"{code} {n}" for code, n in sorted(run.status_counts.items(), key=lambda kv: -kv[1])
        )
        lines.append(f"servo status over {sum(run.status_counts.values())} cycles: {counts}")
    lines.extend(run.notes)
    return "\n".join(lines)


def plot(run: ServoDemoRun, fig_data: ServoDemoFigures, out: Path) -> None:
    """The picture: the tool's path in the square's plane vs the commanded square; the
    condition number; the tracking error; joint velocity, acceleration and jerk as fractions of
    their limits, over time."""
    import matplotlib

    matplotlib.use("Agg")  # headless
    import matplotlib.pyplot as plt

    plan, chain = run.plan, run.chain
    e1 = plan.corners[1] - plan.corners[0]
    e1 /= np.linalg.norm(e1)
    e2 = plan.corners[3] - plan.corners[0]
    e2 /= np.linalg.norm(e2)

    def in_plane(p: FloatArray) -> tuple[FloatArray, FloatArray]:
        rel = p - plan.corners[0]
        return rel @ e1 * 1e3, rel @ e2 * 1e3

    fig, axes = plt.subplots(2, 3, figsize=(15, 8.5))
    ax = axes[0, 0]
    ax.plot(*in_plane(plan.corners), "k--", lw=1, label="commanded square")
    ax.plot(*in_plane(run.p_tool), lw=1.5, label="tool path")
    kappa = fig_data.condition
    x, y = in_plane(run.p_tool)
    halted = np.where(kappa >= MOVEIT_HALT, y, np.nan)
    ax.plot(x, halted, color="red", lw=3, label=f"κ ≥ {MOVEIT_HALT:g} (moveit_servo halts)")
    ax.scatter([0.0], [0.0], color="green", s=30, zorder=3, label="start, spin, end")
    ax.set_aspect("equal")
    ax.margins(0.12)
    ax.set_xlabel("along the first side [mm]")
    ax.set_ylabel("up [mm]")
    ax.set_title(
        f"tool path (error max {fig_data.path_error_max_mm:.2f} mm; spin drift "
        f"{fig_data.spin_drift_mm:.2f} mm)",
        fontsize=10,
    )
    ax.legend(fontsize=8, loc="center", frameon=False)

    t = run.t_tool

    def phases(a: object) -> None:
        for k in range(1, 5):
            a.axvline(k * plan.side_s, color="0.85", lw=0.8, zorder=0)  # type: ignore[attr-defined]
        a.axvline(plan.commands_s, color="0.85", lw=0.8, zorder=0)  # type: ignore[attr-defined]

    ax = axes[0, 1]
    ax.semilogy(t, kappa, label="condition number")
    ax.axhline(MOVEIT_SLOWDOWN, color="orange", ls=":", label="moveit_servo slows (17)")
    ax.axhline(MOVEIT_HALT, color="red", ls=":", label="moveit_servo halts (30)")
    phases(ax)
    ax.set_xlabel("t [s]")
    ax.set_title("condition number of the Jacobian", fontsize=10)
    for k, label in enumerate(("side 1", "side 2", "side 3", "side 4", "spin")):
        ax.text(
            (k + 0.5) * plan.side_s if k < 4 else plan.spin_start_s + plan.spin_s,
            0.97,
            label,
            transform=ax.get_xaxis_transform(),
            ha="center",
            va="top",
            fontsize=7,
        )
    ax.legend(fontsize=8)

    ax = axes[0, 2]
    square = t < plan.spin_start_s
    err = np.full(len(t), np.nan)
    err[square] = distance_to_polyline(run.p_tool[square], plan.corners) * 1e3
    err[~square] = np.linalg.norm(run.p_tool[~square] - plan.corners[0], axis=1) * 1e3
    ax.plot(t, err)
    phases(ax)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("[mm]")
    ax.set_title("tool from the commanded path (spin: from its corner)", fontsize=10)

    gaps = command_gaps(run.period_s, run.command_sequence, run.command_time)
    v, a, j = command_derivatives(run.q_command, run.period_s, gaps)
    t_cmd = (np.arange(len(v)) + 1) * run.period_s  # step k commands the time (k + 1) period
    lim = run.limits
    for ax, values, limit, what, peak in (
        (axes[1, 0], v, lim.velocity, "velocity", fig_data.velocity),
        (axes[1, 1], a, lim.acceleration, "acceleration", fig_data.acceleration),
        (axes[1, 2], j, lim.jerk, "jerk", fig_data.jerk),
    ):
        for i, name in enumerate(chain.joint_names):
            ax.plot(t_cmd, values[:, i] / limit[i], lw=1, label=name)
        ax.axhline(1.0, color="red", ls=":", lw=1)
        ax.axhline(-1.0, color="red", ls=":", lw=1)
        phases(ax)
        ax.set_ylim(-1.15, 1.15)
        ax.set_xlabel("t [s]")
        ax.set_ylabel("fraction of the limit")
        ax.set_title(
            f"joint {what} / limit (peak {100 * peak.fraction:.0f} %, {peak.joint})", fontsize=10
        )
    axes[1, 2].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), frameon=False)
    fig.suptitle(f"servo demo: {ROBOT}; {run.where}", fontsize=11)
    fig.subplots_adjust(left=0.05, right=0.88, bottom=0.07, top=0.91, wspace=0.28, hspace=0.32)
    fig.savefig(out, dpi=110)
    plt.close(fig)


def main(out: Path, rate: float, stream: TextIO | None = None) -> int:
    """The ROS-free demo: summary on `stream`, picture at `out` (checked by the caller)."""
    stream = sys.stdout if stream is None else stream
    run = run_offline(rate)
    fig = figures(run)
    print(summary(run, fig), file=stream)
    plot(run, fig, out)
    print(f"picture written to {out.resolve()}", file=stream)
    return 0
