"""The servo against moveit_servo's documented scheme, on the same scripted commands, in one run.

    python benchmarks/servo_benchmark.py [--arms ur5e,panda,iiwa14,scara] [--json out.json]
                                         [--baseline REV] [--repeats 5]

Scripts (issue 23, part 4), each on UR5e, Panda, iiwa14 and SCARA, the arm simulated as a perfect
integrator of the commanded positions (period 10 ms):

* singular_line: 0.1 m/s along a straight line, orientation held, through the configuration where
  the wrist axes align (UR5e: q5 = 0, a singularity; Panda/iiwa: q6 = 0, where a 7R arm keeps its
  rank; the SCARA has no wrist: skipped);
* pure_rotation: 10 s at 0.5 rad/s about a tilted axis through the tool point, reversing every
  2 s (the first time after 1 s), then 1 s without commands (SCARA: about z);
* wrist_spin+, wrist_spin-: 10 s at 0.5 rad/s about the same tilted axis of the tool, one way
  (then the other), from the home with the wrist joint 0.05 rad (2.9°) from where the wrist axes
  align (UR5e only: its wrist singularity, which the spin passes), then 1 s without commands;
  the end error is the drift of the tool point;
* edge_and_back: 0.2 m/s radially outward for 3 s, past the edge of the workspace, then back
  inward for 3 s (its path error is the tool's largest distance from that line);
* joint_limit: joint 2 (the SCARA's prismatic joint 3) jogged at half its speed limit toward its
  upper limit for 3 s, then back for 2 s;
* steps: a new random twist every 0.5 s for 4 s (|ω| ≈ 1 rad/s, |v| ≈ 0.25 m/s), each a step.

Schemes:

* ours: `kinematics_node.core.servo.Servo` with its defaults (Ruckig's jerk-limited smoothing,
  where Ruckig is installed);
* ours (accel): the same with `smoothing="acceleration"`, the smoothing it uses where Ruckig is
  not installed: the same position, velocity and acceleration limits, no jerk limit (its peak
  jerk against the same jerk limit says what the jerk limit buys);
* moveit_servo: its documented scheme, re-implemented here (no code copied): from the current
  state, Δq = J⁺ (V dt) with the undamped pseudo-inverse, scaled by 1 − (κ − 17)/(κ_u − 17) for a
  condition number κ between 17 and κ_u (κ_u = 30 when moving toward the singularity, 43 away from
  it: leaving_singularity_threshold_multiplier 2; the direction from a small step along the last
  left singular vector) and halted at κ ≥ 30; its default smoothing, the first-order Butterworth
  low-pass (filter coefficient 1.5), applied here to the joint velocities so that its steady
  gain is 1 (filtering the positions, as the plugin does, inside this closed loop would also
  slow every motion to 57 %); velocities scaled uniformly into their
  limits; every joint halted (halt_all_joints_*_mode: true) when one would pass its limit less
  the 0.1 rad margin; halted on a command timeout. It has no acceleration or jerk limit: its peaks
  are reported against the same limits as ours (URDF velocity; acceleration = velocity / 0.25 s;
  jerk = acceleration / 0.1 s).

* ours@REV (with --baseline REV): our servo as it was at git revision REV (its package read
  from git into a temporary folder and imported beside the current one), for a before/after
  comparison of the step cost in one process, under the same load; the same rows show whether
  its behaviour differs (the largest difference of the commanded positions is printed too).

Reported per script and scheme: time stopped [s] (a command asks for motion, the joints move
slower than 1e-3 rad/s), path error [mm] (largest distance of the tool point from the path the
commands describe), end error [mm] (tool point after the script vs where the commands put it:
for pure_rotation this is the drift), peak joint velocity, acceleration and jerk as fractions of
the limits (finite differences of the commanded positions), cycles with a limit violation, and
the median cost of one step [µs] (the whole script's steps, a command's `submit` included).
The machine may be shared, so the cost of one step is also measured on a steady twist (300
steps from the arm's home, the median of the last 250), `--repeats` times per scheme, the
schemes taking turns; reported: the smallest, the median and the largest of those medians.
"""

from __future__ import annotations

import argparse
import atexit
import importlib.util
import json
import math
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from kinematics_node.core import SerialChain, so3  # noqa: E402
from kinematics_node.core.servo import (  # noqa: E402
    JointJogCommand,
    Servo,
    ServoConfig,
    ServoLimits,
    TwistCommand,
)

DT = 0.01
ROOT = Path(__file__).resolve().parents[1]
ROBOTS = ROOT / "config" / "robots"
LINKS = {  # the bundled robots' default chains (base link, tip link)
    "ur5e": ("base_link", "tool0"),
    "panda": ("panda_link0", "panda_hand_tcp"),
    "iiwa14": ("iiwa_link_0", "iiwa_link_ee"),
    "scara": ("base_link", "tool0"),
}


def load_robot(name: str) -> SerialChain:
    return SerialChain.from_urdf(ROBOTS / f"{name}.urdf", *LINKS[name])


HOMES = {
    "ur5e": np.array([0.3, -1.3, 1.6, -1.9, 1.2, 0.4]),
    "panda": np.array([0.0, -0.4, 0.0, -2.2, 0.0, 1.9, 0.8]),
    "iiwa14": np.array([0.0, 0.5, 0.0, -1.2, 0.0, 0.8, 0.0]),
    "scara": np.array([0.3, 1.2, -0.1, 0.2]),
}

# A command for one cycle: ("twist", (ω, v) in base axes) | ("jog", q̇) | None (no command).
Command = tuple[str, np.ndarray] | None
Script = Callable[[int, np.ndarray], Command]  # (cycle, current tool pose) -> command


# ---------------------------------------------------------------------- moveit_servo's scheme
class MoveItServoScheme:
    """moveit_servo's documented per-cycle scheme (see the module docstring)."""

    LOWER, HARD, LEAVING = 17.0, 30.0, 2.0
    MARGIN = 0.1
    FILTER = 1.5

    def __init__(self, chain: SerialChain, q0: np.ndarray, limits: ServoLimits) -> None:
        self.chain = chain
        self.q = q0.copy()
        self.vmax = limits.velocity
        self.lower = np.asarray(chain.lower) + self.MARGIN
        self.upper = np.asarray(chain.upper) - self.MARGIN
        self._x_prev = np.zeros_like(q0)
        self._y_prev = np.zeros_like(q0)

    def _reset_filter(self) -> None:
        self._x_prev = np.zeros_like(self.q)
        self._y_prev = np.zeros_like(self.q)

    def _condition(self, q: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        J = self.chain.jacobian(q, "world")
        U, s, Vt = np.linalg.svd(J, full_matrices=False)
        kappa = s[0] / s[-1] if s[-1] > 0 else math.inf
        with np.errstate(divide="ignore"):
            pinv = Vt.T @ np.diag(1.0 / s) @ U.T
        return kappa, pinv, U[:, -1]

    def step(self, command: Command) -> np.ndarray:
        if command is None:  # timeout: halt
            self._reset_filter()
            return self.q
        kind, value = command
        if kind == "jog":
            delta = value * DT
        else:
            kappa, pinv, u = self._condition(self.q)
            dx = value * DT
            if not math.isfinite(kappa) or kappa >= self.HARD:
                scale = 0.0
            else:
                k_next = self._condition(self.q + pinv @ (u / 100.0))[0]
                toward_vec = u if k_next > kappa else -u
                toward = float(toward_vec @ dx) > 0
                upper = (
                    self.HARD if toward else self.LOWER + (self.HARD - self.LOWER) * self.LEAVING
                )
                scale = (
                    1.0 - (kappa - self.LOWER) / (upper - self.LOWER) if kappa > self.LOWER else 1.0
                )
            delta = pinv @ dx * scale if scale > 0 else np.zeros_like(self.q)
        # first-order Butterworth low-pass, y = (x + x₋₁ − (1 − c) y₋₁) / (1 + c), on q̇
        c = self.FILTER
        x = delta / DT
        vel = (x + self._x_prev - (1.0 - c) * self._y_prev) / (1.0 + c)
        self._x_prev, self._y_prev = x, vel
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(np.abs(vel) > self.vmax, self.vmax / np.abs(vel), 1.0)
        vel = vel * float(ratio.min())
        target = self.q + vel * DT
        halt = ((vel > 0) & (target > self.upper)) | ((vel < 0) & (target < self.lower))
        if halt.any():
            self._reset_filter()
            return self.q
        self.q = target
        return self.q


class OurScheme:
    """Our servo with its defaults; `package`: the servo package to take it from (default: the
    current one; see `load_baseline`)."""

    def __init__(
        self,
        chain: SerialChain,
        q0: np.ndarray,
        package: ModuleType | None = None,
        smoothing: str = "auto",
    ) -> None:
        self._twist_command = TwistCommand if package is None else package.TwistCommand
        self._jog_command = JointJogCommand if package is None else package.JointJogCommand
        servo_class = Servo if package is None else package.Servo
        config = ServoConfig if package is None else package.ServoConfig
        settings = {} if smoothing == "auto" else {"smoothing": smoothing}
        self.servo = servo_class(chain, q0, config(period_s=DT, **settings))
        self.chain = chain
        self.t = 100.0

    def step(self, command: Command) -> np.ndarray:
        t = self.t
        if command is not None:
            kind, value = command
            if kind == "jog":
                self.servo.submit(self._jog_command(self.chain.joint_names, value.tolist(), t), t)
            else:
                w, v = value[:3].tolist(), value[3:].tolist()
                self.servo.submit(self._twist_command(w, v, self.chain.base_link, t), t)
        out = self.servo.step(t, self.servo.positions)
        self.t += DT
        return out.positions


def load_baseline(revision: str) -> ModuleType:
    """The servo package (kinematics_node/core/servo) as of git `revision`, imported beside the
    current one as `kinematics_node.core._servo_baseline` (its relative imports reach the
    current core: fine for a revision whose servo uses the same core API).

    Raises:
        SystemExit: git does not know the revision, or it has no servo package.
    """
    folder = "kinematics_node/core/servo"

    def git(*args: str) -> str:
        done = subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True)
        if done.returncode != 0:
            raise SystemExit(f"--baseline {revision}: git {' '.join(args)}: {done.stderr.strip()}")
        return done.stdout

    names = [n for n in git("ls-tree", "--name-only", f"{revision}:{folder}").split() if n]
    if "__init__.py" not in names:
        raise SystemExit(f"--baseline {revision}: no {folder}/__init__.py at that revision")
    target = Path(tempfile.mkdtemp(prefix="servo_baseline_"))
    atexit.register(shutil.rmtree, target, ignore_errors=True)
    for name in names:
        if name.endswith(".py"):
            (target / name).write_text(git("show", f"{revision}:{folder}/{name}"))
    name = "kinematics_node.core._servo_baseline"
    spec = importlib.util.spec_from_file_location(
        name, target / "__init__.py", submodule_search_locations=[str(target)]
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


# ---------------------------------------------------------------------- scripts
def _line_through_wrist(chain: SerialChain, name: str) -> tuple[np.ndarray, np.ndarray] | None:
    """(q_start, direction) of a 0.2 m constant-orientation line whose exact solution passes the
    wrist alignment halfway (found with the chain's IK along each axis direction)."""
    if name == "scara":
        return None
    joint = 4 if chain.dof == 6 else 5
    q_mid = HOMES[name].copy()
    q_mid[joint] = 0.0
    T_mid = chain.fk(q_mid)
    candidates = [T_mid[:3, 2]] + [np.eye(3)[i] for i in range(3)]
    for d in candidates:
        seed = q_mid + 0.05 * np.eye(chain.dof)[joint]
        values, qs = [], []
        for s in np.linspace(-0.1, 0.1, 11):
            T = T_mid.copy()
            T[:3, 3] += s * d
            result = chain.ik(T, seed)
            if not result.success:
                break
            seed = result.q
            values.append(result.q[joint])
            qs.append(result.q)
        if (
            len(values) == 11
            and np.all(np.diff(np.sign(values)) <= 0)
            and values[0] > 0 > values[-1]
        ):
            return qs[0], d
    return None


WRIST_START_RAD = 0.05  # the wrist_spin scripts start with the wrist joint this far from 0


def _near_wrist_alignment(chain: SerialChain, name: str) -> np.ndarray | None:
    """The UR5e's home with q5 at `WRIST_START_RAD`, 2.9° from its wrist singularity (joints 4
    and 6 aligned); None for the other arms (the 7R arms keep their rank where their wrist axes
    align, and the Panda's q6 = 0 lies outside its limit less the margin)."""
    if chain.dof != 6:
        return None
    q = HOMES[name].copy()
    q[4] = WRIST_START_RAD
    return q


def scripts(chain: SerialChain, name: str, limits: ServoLimits) -> dict[str, tuple]:
    """name -> (q_start, number of cycles, script, ideal path as a function of the cycle)."""
    home = HOMES[name]
    out: dict[str, tuple] = {}
    line = _line_through_wrist(chain, name)
    if line is not None:
        q0, d = line
        V = np.r_[0.0, 0.0, 0.0, 0.1 * d]
        out["singular_line"] = (q0, 250, lambda k, T: ("twist", V), d)
    axis = np.array([0.0, 0.0, 1.0]) if name == "scara" else np.ones(3) / math.sqrt(3)

    def rotation(k: int, T: np.ndarray) -> Command:
        if k >= 1000:
            return None
        sign = 1.0 if ((k * DT + 1.0) // 2.0) % 2 == 0 else -1.0
        return ("twist", np.r_[T[:3, :3] @ (0.5 * sign * axis), 0.0, 0.0, 0.0])

    out["pure_rotation"] = (home, 1100, rotation, None)
    near = _near_wrist_alignment(chain, name)
    if near is not None:
        for sign, label in ((1.0, "wrist_spin+"), (-1.0, "wrist_spin-")):

            def spin(k: int, T: np.ndarray, s: float = sign) -> Command:
                if k >= 1000:
                    return None
                return ("twist", np.r_[T[:3, :3] @ (0.5 * s * axis), 0.0, 0.0, 0.0])

            out[label] = (near, 1100, spin, None)
    p0 = chain.fk(home)[:3, 3]
    radial = np.r_[p0[:2], 0.0] / np.linalg.norm(p0[:2])

    def edge(k: int, T: np.ndarray) -> Command:
        return ("twist", np.r_[0.0, 0.0, 0.0, (0.2 if k < 300 else -0.2) * radial])

    out["edge_and_back"] = (home, 600, edge, radial)
    joint = 2 if name == "scara" else 1
    speed = 0.5 * limits.velocity[joint]

    def jog(k: int, T: np.ndarray) -> Command:
        qd = np.zeros(chain.dof)
        qd[joint] = speed if k < 300 else -speed
        return ("jog", qd)

    out["joint_limit"] = (home, 500, jog, None)
    rng = np.random.default_rng(23)
    steps = [np.r_[rng.normal(size=3) * 0.6, rng.normal(size=3) * 0.15] for _ in range(8)]
    out["steps"] = (home, 400, lambda k, T: ("twist", steps[(k // 50) % 8]), None)
    return out


# ---------------------------------------------------------------------- running and measuring
def run(scheme, chain: SerialChain, q0: np.ndarray, cycles: int, script: Script):
    """The script's commands and the pose they command (integrated exactly), then the scheme's
    steps on them: the scripts do not depend on the arm's state, so the timed loop does nothing
    but step (work between the steps would evict the step's data from the caches, which
    measured as a third more per step)."""
    commands, ideal_T = [], [chain.fk(q0)]
    for k in range(cycles):
        command = script(k, ideal_T[-1])
        commands.append(command)
        Ti = ideal_T[-1].copy()
        if command is not None and command[0] == "twist":
            w, v = command[1][:3], command[1][3:]
            Ti[:3, :3] = so3.exp(w * DT) @ Ti[:3, :3]
            Ti[:3, 3] += v * DT
        ideal_T.append(Ti)
    qs, costs = [q0.copy()], []
    for command in commands:
        t0 = time.perf_counter()
        q = scheme.step(command)
        costs.append(time.perf_counter() - t0)
        qs.append(np.array(q, dtype=float))  # a copy, in case a scheme reuses its array
    return np.array(qs, dtype=float), np.array(costs), commands, np.array(ideal_T)


def measure(
    chain, limits: ServoLimits, qs, costs, commands, ideal_T, kind: str, line: np.ndarray | None
) -> dict:
    T = chain.fk(qs)
    p, p_ideal = T[:, :3, 3], ideal_T[:, :3, 3]
    v = np.diff(qs, axis=0) / DT
    a = np.diff(v, axis=0) / DT
    j = np.diff(a, axis=0) / DT
    moving = np.array([c is not None and bool(np.any(c[1])) for c in commands])
    stopped = moving & (np.abs(v).max(axis=1) < 1e-3)
    # path error: distance of each tool point from the line (line scripts), else from the nearest
    # point of the commanded path
    if line is not None:
        rel = p - p[0]
        dists = np.linalg.norm(rel - np.outer(rel @ line, line), axis=1)
    else:
        dists = np.linalg.norm(p[:, None, :] - p_ideal[None, ::2, :], axis=2).min(axis=1)
    lo, hi = limits.lower, limits.upper
    bad = (
        (qs[1:] > hi + 1e-9).any(axis=1)
        | (qs[1:] < lo - 1e-9).any(axis=1)
        | (np.abs(v) > limits.velocity * (1 + 1e-9) + 1e-9).any(axis=1)
    )
    bad[1:] |= (np.abs(a) > limits.acceleration * (1 + 1e-9) + 1e-6).any(axis=1)
    bad[2:] |= (np.abs(j) > limits.jerk * (1 + 1e-9) + 1e-3).any(axis=1)
    return {
        "time_stopped_s": float(stopped.sum() * DT),
        "path_error_mm": None if kind == "joint_limit" else float(dists.max() * 1e3),
        # where the commands end the tool (not for the edge: its way out is cut short)
        "end_error_mm": None
        if kind in ("joint_limit", "edge_and_back")
        else float(np.linalg.norm(p[-1] - p_ideal[-1]) * 1e3),
        "peak_velocity": float((np.abs(v) / limits.velocity).max()),
        "peak_acceleration": float((np.abs(a) / limits.acceleration).max()),
        "peak_jerk": float((np.abs(j) / limits.jerk).max()),
        "violation_cycles": int(bad.sum()),
        "median_step_us": float(np.median(costs) * 1e6),
    }


def steady_step_cost(
    chain: SerialChain, name: str, schemes: dict[str, Callable], repeats: int
) -> dict[str, dict[str, float]]:
    """Cost of one step [µs] while streaming a constant twist from the arm's home: per scheme,
    the smallest, median and largest of `repeats` medians (each over steps 50-299 of a fresh
    run); the schemes take turns, so that they share the machine's load alike."""
    V = np.r_[0.0, 0.0, 0.2, 0.02, 0.0, 0.0]
    medians: dict[str, list[float]] = {label: [] for label in schemes}
    for _ in range(repeats):
        for label, make in schemes.items():
            scheme = make(HOMES[name])
            costs = []
            for _ in range(300):
                t0 = time.perf_counter()
                scheme.step(("twist", V))
                costs.append(time.perf_counter() - t0)
            medians[label].append(float(np.median(costs[50:])) * 1e6)
    return {
        label: {"min": min(m), "median": float(np.median(m)), "max": max(m)}
        for label, m in medians.items()
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--arms", default="ur5e,panda,iiwa14,scara")
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument(
        "--baseline",
        metavar="REV",
        default=None,
        help="also run our servo as of this git revision (e.g. HEAD~3), side by side",
    )
    parser.add_argument("--repeats", type=int, default=5, help="runs of the steady-twist cost")
    args = parser.parse_args(argv)
    baseline = load_baseline(args.baseline) if args.baseline else None
    report: dict = {}
    for name in args.arms.split(","):
        chain = load_robot(name)
        limits = ServoLimits.from_chain(chain, ServoConfig())
        schemes: dict[str, Callable] = {"ours": lambda q0, c=chain: OurScheme(c, q0)}
        schemes["ours (accel)"] = lambda q0, c=chain: OurScheme(c, q0, None, "acceleration")
        if baseline is not None:
            schemes[f"ours@{args.baseline}"] = lambda q0, c=chain: OurScheme(c, q0, baseline)
        schemes["moveit_servo"] = lambda q0, c=chain, lim=limits: MoveItServoScheme(c, q0, lim)
        report[name] = {
            "scripts": {},
            "steady_step_us": steady_step_cost(chain, name, schemes, args.repeats),
        }
        differences = []
        for script_name, (q0, cycles, script, line) in scripts(chain, name, limits).items():
            rows, positions = {}, {}
            for label, make in schemes.items():
                qs, costs, commands, ideal = run(make(q0), chain, q0, cycles, script)
                rows[label] = measure(chain, limits, qs, costs, commands, ideal, script_name, line)
                positions[label] = qs
            if baseline is not None:
                differences.append(
                    float(np.abs(positions["ours"] - positions[f"ours@{args.baseline}"]).max())
                )
            report[name]["scripts"][script_name] = rows
        if differences:
            report[name]["baseline_max_position_difference_rad"] = max(differences)
    _print(report)
    if args.json:
        args.json.write_text(json.dumps(report, indent=2))
    return 0


def _fmt(x) -> str:
    if x is None:
        return "-"
    if isinstance(x, int):
        return str(x)
    return f"{x:.3g}"


def _print(report: dict) -> None:
    cols = [
        ("time_stopped_s", "stopped s"),
        ("path_error_mm", "path mm"),
        ("end_error_mm", "end mm"),
        ("peak_velocity", "v/vmax"),
        ("peak_acceleration", "a/amax"),
        ("peak_jerk", "j/jmax"),
        ("violation_cycles", "viol."),
        ("median_step_us", "step µs"),
    ]
    header = f"{'arm':7} {'script':14} {'scheme':13} " + " ".join(f"{h:>9}" for _, h in cols)
    print(header)
    print("-" * len(header))
    for name, data in report.items():
        for script_name, rows in data["scripts"].items():
            for label, m in rows.items():
                cells = " ".join(f"{_fmt(m[k]):>9}" for k, _ in cols)
                print(f"{name:7} {script_name:14} {label:13} {cells}")
        steady = data["steady_step_us"]
        cells = ", ".join(
            f"{label} {c['median']:.0f} µs ({c['min']:.0f}-{c['max']:.0f})"
            for label, c in steady.items()
        )
        print(
            f"{name:7} {'steady twist':14} {'step cost':13} {cells} (median of the runs' medians)"
        )
        base = [label for label in steady if label.startswith("ours@")]
        if base:
            ratio = steady["ours"]["median"] / steady[base[0]]["median"]
            diff = data.get("baseline_max_position_difference_rad", math.nan)
            print(
                f"{name:7} {'':14} {'':13} ours / {base[0]}: {ratio:.2f}; commanded positions "
                f"differ by at most {diff:.3g} rad over the scripts"
            )
        print()


if __name__ == "__main__":
    raise SystemExit(main())
