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

from ..core import IKOptions, SerialChain
from ..core.analysis import singular_values
from ..core.model import middle_of_limits
from ..service.ee_state import JointStateTracker, compute_ee_state


@dataclass
class DemoRun:
    """Everything the demo computed (also what the tests inspect)."""

    chain: SerialChain
    t: np.ndarray  # (K,) [s]
    q: np.ndarray  # (K, n)
    p_tip: np.ndarray  # (K, 3) [m]
    speed_tip: np.ndarray  # (K,) [m/s], from the published-style twist
    manipulability: np.ndarray  # (K,) linear manipulability of the movable directions, see below
    manipulability_rank: (
        int  # r: how many translation directions the arm can move in (3, or 2 if planar)
    )
    ik_rows: list[tuple[float, bool, float, float, float]]  # (t, success, pos err, ori err, ms)
    ik_targets: np.ndarray  # (k, 3) [m] target positions of the IK calls


class Progress:
    """A one-line text progress bar on `stream`, drawn only on a terminal (a log file gets no
    carriage returns) and only when the run is long enough to need it."""

    def __init__(self, total: int, stream: TextIO, label: str) -> None:
        self.total, self.stream, self.label = total, stream, label
        self.start = time.perf_counter()
        self.drawn = False
        isatty = getattr(stream, "isatty", None)
        self.enabled = bool(isatty and isatty())

    def update(self, done: int) -> None:
        if not self.enabled:
            return
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
    from .arm import ArmSimulator
    from .robots import load_robot

    chain = load_robot(robot)
    sim = ArmSimulator.from_chain(chain, dt=1.0 / rate)
    tracker = JointStateTracker(chain.joint_names, chain.continuous.tolist())
    steps = int(round(duration * rate))
    if steps < 2:
        raise ValueError(f"duration × rate gives {steps} steps; need at least 2")
    t_log, q_log, p_log, v_log = [], [], [], []
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
        bar.update(k + 1)
    bar.close()

    q_arr = np.array(q_log)
    w, rank = movable_manipulability(chain, q_arr)
    ik_rows = []
    options = IKOptions(timeout=0.05, rng_seed=0)
    seed = middle_of_limits(chain.lower, chain.upper)
    ik_targets = []
    for k in np.linspace(0, steps - 1, n_ik).astype(int):
        target = chain.fk(q_arr[k])
        ik_targets.append(target[:3, 3])
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
        manipulability=w,
        manipulability_rank=rank,
        ik_rows=ik_rows,
        ik_targets=np.array(ik_targets).reshape(-1, 3),
    )


def movable_manipulability(chain: SerialChain, q: np.ndarray) -> tuple[np.ndarray, int]:
    """(w, r): the product of the r largest singular values of the linear rows of the world
    Jacobian, r = how many translation directions the arm can move in at all (its rank at
    generic configurations). Yoshikawa's √det(Jv Jvᵀ) when r = 3; for a planar arm (r = 2) it
    is the area measure of the plane, where the 3-row measure would be identically zero.
    Units: [m^r/rad^r] for revolute joints."""
    sv = singular_values(chain.jacobian(q, "world"), "linear")  # (K, k)
    tol = 1e-9 * max(float(sv.max()), 1e-300)
    rank = max(1, int((sv > tol).sum(axis=1).max()))
    return np.prod(sv[:, :rank], axis=1), rank


def summary(run: DemoRun, robot: str) -> str:
    c = run.chain
    span = run.p_tip.max(axis=0) - run.p_tip.min(axis=0)
    lines = [
        f"robot {robot}: {c.dof} joints, chain {c.base_link} → {c.tip_link}",
        f"simulated {run.t[-1] - run.t[0] + (run.t[1] - run.t[0]):.1f} s at "
        f"{1.0 / (run.t[1] - run.t[0]):.0f} Hz ({len(run.t)} joint states)",
        f"tip path spans {span[0]:.3f} × {span[1]:.3f} × {span[2]:.3f} m; "
        f"peak tip speed {np.nanmax(run.speed_tip):.3f} m/s",
        f"manipulability (linear, {run.manipulability_rank} movable directions) "
        f"min {run.manipulability.min():.4f}, max {run.manipulability.max():.4f} "
        f"{_unit(run.manipulability_rank)}",
        "IK for poses along the path (seed: middle of the joint limits):",
    ]
    for t, ok, pe, oe, ms in run.ik_rows:
        lines.append(
            f"  t = {t:5.2f} s  {'solved' if ok else 'FAILED'}  position error {pe:.1e} m  "
            f"orientation error {oe:.1e} rad  {ms:.2f} ms"
        )
    return "\n".join(lines)


def _unit(rank: int) -> str:
    power = {1: "", 2: "²", 3: "³"}[rank]
    return f"m{power}/rad{power}"


def plot(run: DemoRun, out: Path, robot: str) -> None:
    import matplotlib

    matplotlib.use("Agg")  # headless
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator

    fig = plt.figure(figsize=(15, 4.8))
    grid = fig.add_gridspec(1, 3, width_ratios=(1.15, 1.0, 1.0), wspace=0.38)
    ax = fig.add_subplot(grid[0], projection="3d")
    ax.plot(*run.p_tip.T, lw=1.5, label="tip path")
    ax.scatter(*run.p_tip[0], color="green", s=30, label="start")
    ax.scatter(*run.p_tip[-1], color="red", marker="s", s=30, label="end")
    ok = np.array([row[1] for row in run.ik_rows], dtype=bool)
    if len(run.ik_targets):
        tgt = run.ik_targets
        ax.scatter(*tgt[ok].T, color="black", marker="x", s=40, label="IK target (solved)")
        if (~ok).any():
            ax.scatter(*tgt[~ok].T, color="orange", marker="x", s=40, label="IK target (failed)")
    ax.set_title(f"{robot}: tip path in {run.chain.base_link}", fontsize=10)
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_major_locator(MaxNLocator(4))  # fewer ticks: no overlapping labels
    ax.tick_params(labelsize=7)
    ax.set_xlabel("x [m]", labelpad=6)
    ax.set_ylabel("y [m]", labelpad=6)
    ax.set_zlabel("z [m]", labelpad=6)
    ax.set_box_aspect(None, zoom=0.82)  # room for the z label inside the panel
    ax.legend(loc="upper left", bbox_to_anchor=(0.0, -0.02), ncol=3, fontsize=7, frameon=False)
    ax2 = fig.add_subplot(grid[1])
    ax2.plot(run.t, run.manipulability)
    ax2.set_title(
        f"linear manipulability ({run.manipulability_rank} movable directions)", fontsize=10
    )
    ax2.set_xlabel("t [s]")
    ax2.set_ylabel(f"w = product of singular values [{_unit(run.manipulability_rank)}]")
    ax2.xaxis.set_major_locator(MaxNLocator(6))
    ax3 = fig.add_subplot(grid[2])
    for i, name in enumerate(run.chain.joint_names):
        ax3.plot(run.t, run.q[:, i], label=name)
    ax3.set_title("joint values", fontsize=10)
    ax3.set_xlabel("t [s]")
    ax3.set_ylabel("q [rad] (prismatic: [m])")
    ax3.xaxis.set_major_locator(MaxNLocator(6))
    ax3.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), frameon=False)
    fig.subplots_adjust(left=0.02, right=0.86, bottom=0.2, top=0.9)
    fig.savefig(out, dpi=110)
    plt.close(fig)


def check_matplotlib() -> None:
    """Raises ValueError, saying how to install it, when matplotlib is missing."""
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        raise ValueError(
            "the picture needs matplotlib: pip install 'kinematics_service[demo]' (or run "
            "`make demo`, which installs it)"
        ) from None


def check_picture_path(out: str) -> Path:
    """The picture's path, checked before the run: its directory exists and matplotlib can write
    its format (from the extension).

    Raises:
        ValueError: saying what is wrong.
    """
    from matplotlib.figure import Figure

    path = Path(out)
    formats = Figure().canvas.get_supported_filetypes()
    ext = path.suffix.lower().lstrip(".")
    if ext not in formats:
        raise ValueError(
            f"--out {str(out)[:60]!r}: unknown picture format {('.' + ext) if ext else '(no extension)'}; "
            f"use one of {', '.join('.' + f for f in sorted(formats))}"
        )
    parent = path.resolve().parent
    if not parent.is_dir():
        raise ValueError(f"--out {str(out)[:60]!r}: directory {str(parent)[:80]!r} does not exist")
    return path


def main(robot: str, out: str, duration: float, rate: float, stream: TextIO | None = None) -> int:
    stream = sys.stdout if stream is None else stream
    try:  # everything the user can get wrong is checked before the (long) run
        check_matplotlib()
        path = check_picture_path(out)
    except ValueError as exc:
        print(f"kinematics: error: {exc}", file=sys.stderr)
        return 1
    run = run_demo(robot, duration, rate, n_ik=5, stream=sys.stderr)
    print(summary(run, robot), file=stream)
    plot(run, path, robot)
    print(f"picture written to {path.resolve()}", file=stream)
    return 0
