"""`kinematics demo`: the simulated arm, the node's joint-state logic and IK, without ROS.

Runs a bundled robot through the simulator's built-in demo motion, feeds every step through the
same joint-state tracking and end-effector computation the ROS node uses (`ee_state`), solves IK
for a few poses along the path, prints a short summary and writes a picture (tip path in 3-D,
manipulability and joint angles over time).
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

import numpy as np

from .core import IKOptions, SerialChain
from .ee_state import JointStateTracker, compute_ee_state, conditioning


@dataclass
class DemoRun:
    """Everything the demo computed (also what the tests inspect)."""

    chain: SerialChain
    t: np.ndarray  # (K,) [s]
    q: np.ndarray  # (K, n)
    p_tip: np.ndarray  # (K, 3) [m]
    speed_tip: np.ndarray  # (K,) [m/s], from the published-style twist
    manipulability: np.ndarray  # (K,)
    ik_rows: list[tuple[float, bool, float, float, float]]  # (t, success, pos err, ori err, ms)


class Progress:
    """A one-line text progress bar on `stream` (only drawn when the run is long enough)."""

    def __init__(self, total: int, stream: TextIO, label: str) -> None:
        self.total, self.stream, self.label = total, stream, label
        self.start = time.perf_counter()
        self.drawn = False

    def update(self, done: int) -> None:
        elapsed = time.perf_counter() - self.start
        if elapsed < 0.5 and not self.drawn:  # short runs stay quiet
            return
        if done != self.total and done % max(1, self.total // 50):
            return
        width = 30
        filled = int(width * done / self.total)
        eta = elapsed / max(done, 1) * (self.total - done)
        self.stream.write(
            f"\r{self.label} [{'#' * filled}{'.' * (width - filled)}] {done}/{self.total} "
            f"eta {eta:4.1f} s"
        )
        self.stream.flush()
        self.drawn = True

    def close(self) -> None:
        if self.drawn:
            self.stream.write("\n")


def run_demo(robot: str, duration: float, rate: float, n_ik: int, stream: TextIO) -> DemoRun:
    from .robots import load_robot
    from .simulator import ArmSimulator

    chain = load_robot(robot)
    sim = ArmSimulator.from_chain(chain, dt=1.0 / rate)
    tracker = JointStateTracker(chain.joint_names, chain.continuous)
    steps = int(round(duration * rate))
    t_log, q_log, p_log, v_log, w_log = [], [], [], [], []
    bar = Progress(steps, stream, "simulating")
    for k in range(steps):
        t, q, qdot = sim.step()
        # As the node does: positions only on odd steps, so velocity is estimated from stamps.
        vel = list(qdot) if k % 2 == 0 else []
        tracker.update(chain.joint_names, list(q), vel, t)
        state = compute_ee_state(chain, tracker.q, tracker.qdot, t)
        t_log.append(t)
        q_log.append(state.q)
        p_log.append(state.T_base_tip[:3, 3])
        v_log.append(np.nan if state.twist is None else float(np.linalg.norm(state.twist[3:])))
        w_log.append(conditioning(chain, state.q).manipulability)
        bar.update(k + 1)
    bar.close()

    q_arr = np.array(q_log)
    ik_rows = []
    options = IKOptions(timeout=0.05, rng_seed=0)
    limited = np.isfinite(chain.lower) & np.isfinite(chain.upper)
    seed = np.where(
        limited, 0.5 * (np.where(limited, chain.lower, 0) + np.where(limited, chain.upper, 0)), 0.0
    )
    for k in np.linspace(0, steps - 1, n_ik).astype(int):
        target = chain.fk(q_arr[k])
        t0 = time.perf_counter()
        res = chain.ik(target, q_seed=seed, options=options)
        ms = (time.perf_counter() - t0) * 1e3
        ik_rows.append((t_log[k], bool(res.success), res.position_error, res.orientation_error, ms))
    return DemoRun(
        chain=chain,
        t=np.array(t_log),
        q=q_arr,
        p_tip=np.array(p_log),
        speed_tip=np.array(v_log),
        manipulability=np.array(w_log),
        ik_rows=ik_rows,
    )


def summary(run: DemoRun, robot: str) -> str:
    c = run.chain
    span = run.p_tip.max(axis=0) - run.p_tip.min(axis=0)
    lines = [
        f"robot {robot}: {c.dof} joints, chain {c.base_link} → {c.tip_link}",
        f"simulated {run.t[-1] - run.t[0] + (run.t[1] - run.t[0]):.1f} s at "
        f"{1.0 / (run.t[1] - run.t[0]):.0f} Hz ({len(run.t)} joint states)",
        f"tip path spans {span[0]:.3f} × {span[1]:.3f} × {span[2]:.3f} m; "
        f"peak tip speed {np.nanmax(run.speed_tip):.3f} m/s",
        f"manipulability (linear) min {run.manipulability.min():.4f}, "
        f"max {run.manipulability.max():.4f}",
        "IK for poses along the path (seed: middle of the joint limits):",
    ]
    for t, ok, pe, oe, ms in run.ik_rows:
        lines.append(
            f"  t = {t:5.2f} s  {'solved' if ok else 'FAILED'}  position error {pe:.1e} m  "
            f"orientation error {oe:.1e} rad  {ms:.2f} ms"
        )
    return "\n".join(lines)


def plot(run: DemoRun, out: Path, robot: str) -> None:
    import matplotlib

    matplotlib.use("Agg")  # headless
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(13, 4.5))
    ax = fig.add_subplot(1, 3, 1, projection="3d")
    ax.plot(*run.p_tip.T, lw=1.5)
    ax.scatter(*run.p_tip[0], color="green", label="start")
    ax.set_title(f"{robot}: tip path in {run.chain.base_link}")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.legend(loc="upper left")
    ax2 = fig.add_subplot(1, 3, 2)
    ax2.plot(run.t, run.manipulability)
    ax2.set_title("manipulability (linear)")
    ax2.set_xlabel("t [s]")
    ax3 = fig.add_subplot(1, 3, 3)
    for i, name in enumerate(run.chain.joint_names):
        ax3.plot(run.t, run.q[:, i], label=name)
    ax3.set_title("joint values")
    ax3.set_xlabel("t [s]")
    ax3.set_ylabel("[rad] / [m]")
    ax3.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def main(robot: str, out: str, duration: float, rate: float, stream: TextIO | None = None) -> int:
    stream = sys.stdout if stream is None else stream
    run = run_demo(robot, duration, rate, n_ik=5, stream=sys.stderr)
    print(summary(run, robot), file=stream)
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        print(
            "kinematics: the picture needs matplotlib: pip install 'kinematics_service[demo]' "
            "(or run `make demo`, which installs it)",
            file=sys.stderr,
        )
        return 1
    path = Path(out)
    plot(run, path, robot)
    print(f"picture written to {path.resolve()}", file=stream)
    return 0
