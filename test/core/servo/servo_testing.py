"""Helpers of the servo tests: run a servo in closed loop with a simulated arm, check the limits.

The arm is simulated as a perfect integrator of the commanded positions (the measured positions of
the next cycle are the commanded ones), or as a first-order lag with time constant `lag_s`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from kinematics_node.core import SerialChain, so3
from kinematics_node.core.servo import (
    Command,
    JointJogCommand,
    PoseCommand,
    Servo,
    ServoLimits,
    ServoStatus,
    TwistCommand,
)

Script = Callable[[int, float], Sequence[Command]]

_CHAINS: dict[str, SerialChain] = {}
ROBOTS = Path(__file__).resolve().parents[3] / "config" / "robots"
#: the bundled robots' default chains (base link, tip link), as the package's robot table has them
LINKS = {
    "ur5e": ("base_link", "tool0"),
    "panda": ("panda_link0", "panda_hand_tcp"),
    "iiwa14": ("iiwa_link_0", "iiwa_link_ee"),
    "scara": ("base_link", "tool0"),
    "planar3r": ("base_link", "tool0"),
}


def robot(name: str) -> SerialChain:
    """A bundled robot's default chain, read from config/robots."""
    if name not in _CHAINS:
        _CHAINS[name] = SerialChain.from_urdf(ROBOTS / f"{name}.urdf", *LINKS[name])
    return _CHAINS[name]


@dataclass
class Trace:
    """What a run produced, one row per cycle (k = 0 … N−1), plus the state before it."""

    t: np.ndarray  # (N,) now_s of each step
    q: np.ndarray  # (N, n) commanded positions (for t + dt)
    v: np.ndarray  # (N, n)
    a: np.ndarray  # (N, n)
    measured: np.ndarray  # (N, n) measured positions passed to each step
    statuses: list[ServoStatus]
    q_start: np.ndarray  # (n,) at rest before the first step
    dt: float

    @property
    def codes(self) -> list[str]:
        return [s.code.name for s in self.statuses]


def run(
    servo: Servo,
    script: Script,
    seconds: float,
    t0: float = 100.0,
    lag_s: float | None = None,
    blocked: bool = False,
    corrupt: Callable[[int, np.ndarray], object] | None = None,
    held_up: bool = False,
) -> Trace:
    """Step `servo` for `seconds`; before each step, submit the commands `script(k, t)` returns.

    The arm: perfect integrator (lag_s None), first-order lag, or blocked (never moves).
    `corrupt(k, measured)` may replace what the step is told was measured; `held_up` is passed
    to every step (periods a held-up caller makes up).
    """
    dt = servo.config.period_s
    n = servo.chain.dof
    N = int(round(seconds / dt))
    measured = np.array(servo.positions, dtype=float)
    q_start = measured.copy()
    out_q, out_v, out_a, meas = (np.empty((N, n)) for _ in range(4))
    statuses = []
    times = t0 + dt * np.arange(N)
    alpha = None if lag_s is None else 1.0 - np.exp(-dt / lag_s)
    for k in range(N):
        t = float(times[k])
        for cmd in script(k, t):
            servo.submit(cmd, t)
        meas[k] = measured
        out = servo.step(t, measured if corrupt is None else corrupt(k, measured), held_up)
        out_q[k], out_v[k], out_a[k] = out.positions, out.velocities, out.accelerations
        statuses.append(out.status)
        if blocked:
            pass
        elif alpha is None:
            measured = out.positions.copy()
        else:
            measured = measured + alpha * (out.positions - measured)
    return Trace(times, out_q, out_v, out_a, meas, statuses, q_start, dt)


def limit_violations(
    limits: ServoLimits, trace: Trace, rel: float = 1e-9, jerk: bool = True
) -> list[str]:
    """Every cycle on which a joint leaves its position bounds (with margin) or its velocity,
    acceleration or jerk limit (`jerk` False: not the jerk limit, which only Ruckig's smoothing
    keeps), judged on the commanded positions' finite differences (the arm rests at q_start
    before the first cycle) and on the reported velocities and accelerations."""
    dt = trace.dt
    q = np.vstack([np.repeat(trace.q_start[None], 3, axis=0), trace.q])
    problems = []
    if not (np.all(np.isfinite(trace.q)) and np.all(np.isfinite(trace.v))):
        problems.append("non-finite output")
        return problems
    lo = np.minimum(limits.lower, trace.q_start)
    hi = np.maximum(limits.upper, trace.q_start)
    v_fd = np.diff(q, axis=0) / dt
    a_fd = np.diff(v_fd, axis=0) / dt
    j_fd = np.diff(a_fd, axis=0) / dt
    a_rep = np.vstack([np.zeros((1, q.shape[1])), trace.a])
    j_rep = np.diff(a_rep, axis=0) / dt
    checks = [
        ("position above upper bound", trace.q - hi, 1e-9),
        ("position below lower bound", lo - trace.q, 1e-9),
        ("finite-difference velocity", np.abs(v_fd) - limits.velocity * (1 + rel), 1e-9),
        ("reported velocity", np.abs(trace.v) - limits.velocity * (1 + rel), 1e-9),
        ("finite-difference acceleration", np.abs(a_fd) - limits.acceleration * (1 + rel), 1e-6),
        ("reported acceleration", np.abs(trace.a) - limits.acceleration * (1 + rel), 1e-9),
        ("finite-difference jerk", np.abs(j_fd) - limits.jerk * (1 + rel), 1e-3),
        ("reported-acceleration jerk", np.abs(j_rep) - limits.jerk * (1 + rel), 1e-6),
    ]
    if not jerk:
        checks = [c for c in checks if "jerk" not in c[0]]
    for what, excess, tol in checks:
        bad = np.argwhere(excess > tol)
        if bad.size:
            row, joint = bad[0]
            problems.append(
                f"{what}: joint {limits.joint_names[joint]} on row {row} by {excess[row, joint]:.3g}"
            )
    return problems


def tool_poses(chain: SerialChain, q: np.ndarray) -> np.ndarray:
    return chain.fk(q)


def rotation_angle(R_a: np.ndarray, R_b: np.ndarray) -> np.ndarray:
    """Angle [rad] of R_aᵀ R_b (batched)."""
    return np.linalg.norm(so3.log(np.swapaxes(R_a, -1, -2) @ R_b), axis=-1)


def ur5e_wrist_line() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(q_start, direction, T_middle): a 0.2 m straight line at constant orientation along which
    the UR5e's exact solution passes q5 = 0 halfway (the wrist singularity, joints 4 and 6
    aligned); it starts 0.1 m before the singular pose T_middle."""
    chain = robot("ur5e")
    q_mid = np.array([0.3, -1.3, 1.6, -1.9, 0.0, 0.4])
    T_mid = chain.fk(q_mid)
    d = T_mid[:3, 2].copy()  # the tool axis, which lies along joint 4's axis here
    T0 = T_mid.copy()
    T0[:3, 3] -= 0.1 * d
    q0 = chain.ik(T0, q_mid + np.array([0, 0, 0, 0, 0.05, 0])).q
    return q0, d, T_mid


def joined(first: Trace, second: Trace) -> Trace:
    """Two runs one after the other as one trace (for the limit checks across the seam)."""
    return Trace(
        np.r_[first.t, second.t],
        np.vstack([first.q, second.q]),
        np.vstack([first.v, second.v]),
        np.vstack([first.a, second.a]),
        np.vstack([first.measured, second.measured]),
        first.statuses + second.statuses,
        first.q_start,
        first.dt,
    )


def random_script(chain: SerialChain, servo: Servo, seed: int) -> tuple[Callable, int]:
    """(script, periods): twists, jogs, pose targets, nothing, NaN and pause in a random order,
    each for 5-40 periods, from the servo's start."""
    rng = np.random.default_rng(seed)
    T0 = chain.fk(servo.positions)
    plan = []
    for _ in range(30):
        kind = rng.choice(["twist", "jog", "pose", "nothing", "nan", "pause"])
        plan.append((kind, rng.normal(size=6), rng.integers(5, 40)))
    schedule = [p for p in plan for _ in range(p[2])]

    def script(k, t):
        kind, r, _ = schedule[min(k, len(schedule) - 1)]
        if kind == "twist":
            return [TwistCommand(tuple(r[:3]), tuple(0.3 * r[3:]), chain.tip_link, t)]
        if kind == "jog":
            return [JointJogCommand(list(chain.joint_names), list(r[: chain.dof] * 2), t)]
        if kind == "pose":
            goal = T0.copy()
            goal[:3, 3] += 0.05 * r[:3]
            return [PoseCommand(goal, chain.base_link, t)]
        if kind == "nan":
            return [TwistCommand((np.nan, 0, 0), (0, 0, 0), chain.base_link, t)]
        if kind == "pause":
            servo.pause() if r[0] > 0 else servo.resume()
        return []

    return script, len(schedule)
