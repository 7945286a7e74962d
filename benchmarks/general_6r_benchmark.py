"""The general 6R closed form (issue 24): completeness on many arms, and speed beside rtb's ik_LM.

    python -W ignore benchmarks/general_6r_benchmark.py [--complete 10000] [--targets 1000]
                                                        [--arms random0,irb140,puma560,...]

Completeness (the "slow" check of test/core/test_closed_form_general.py): for every arm of that
test (20 random DH arms and the degenerate ones), `ik_all_batch(fk(q))` must contain q for
`--complete` random q, and every solution must reproduce its target to 1e-9. Printed per arm:
family, misses, the largest error, targets/s.

Speed, TRAC-IK's protocol (Beeson & Ames 2015): targets are FK of configurations drawn uniformly
within the limits, every solver starts from the middle of the limits and is asked for the full
pose within 1e-5 (m, rad); success means that pose by our FK and every joint within its limits,
5 ms per call. In the same run: `ik` with method "numeric" (the search alone: no success rate may
fall below it) and roboticstoolbox-python's `ik_LM` (C++, its own restarts) on an ETS built from
our parsed model. Printed: success and median of `ik`, of the numeric search and of rtb; median of
`ik_all` (every solution) for one target; `ik_all_batch` targets/s; and the ratios to rtb's
median. Every solver is timed with the heap exempt from the cyclic GC (as `ik_benchmark.py`).
Wall-clock on a possibly shared machine: rerun for stable figures.
"""

from __future__ import annotations

import argparse
import gc
import os
import sys
import sysconfig
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "test" / "core")]
from kinematics_node.core import IKOptions, SerialChain, so3  # noqa: E402
from kinematics_node.core.ik.closed_form import family_of  # noqa: E402
from kinematics_node.core.ik.closed_form.geometry import pose_errors  # noqa: E402
from kinematics_node.core.model import middle_of_limits  # noqa: E402

TOL = 1e-5
BUDGET = 0.005
PURELIB = Path(sysconfig.get_paths()["purelib"])
ERD = PURELIB / "cmeel.prefix/share/example-robot-data/robots"
RTBDATA = PURELIB / "rtbdata/xacro"


def arms() -> dict[str, SerialChain | str]:
    """name → chain, or the reason it is not available."""
    from test_closed_form_general import ARMS, dh_chain

    out: dict[str, SerialChain | str] = {
        "random0": dh_chain(ARMS["random 0"]),
        "offset-puma": dh_chain(ARMS["offset Puma"]),
    }
    files = {
        "xarm6": (pybullet_data() / "xarm/xarm6_robot.urdf", None, None),
        "irb140": (RTBDATA / "abb_irb140_description/urdf/irb140.urdf", None, "tool0"),
        "puma560": (RTBDATA / "unimation_puma560_description/urdf/puma560_robot.urdf", None, None),
        "kr16": (RTBDATA / "kuka_description/kuka_kr16/urdf/kr16_2.urdf", None, "tool0"),
        "ur5": (ERD / "ur_description/urdf/ur5_robot.urdf", None, "tool0"),
        "baxter": (ERD / "baxter_description/urdf/baxter.urdf", "torso", "left_gripper"),
        "xarm7": (ERD / "xarm_description/urdf/xarm7.urdf", None, "link_eef"),
    }
    for name, (path, base, tip) in files.items():
        if not path.exists():
            out[name] = f"{path} not found (pip install -e '.[bench]')"
            continue
        try:
            out[name] = SerialChain.from_urdf(path, base, tip)
        except Exception as exc:  # noqa: BLE001 - report and go on
            out[name] = f"{type(exc).__name__}: {exc}"
    return out


def pybullet_data() -> Path:
    """pybullet_data's folder (xArm 6's URDF), or a path that does not exist."""
    try:
        import pybullet_data as pd
    except ImportError:
        return Path("/nonexistent/pybullet_data")
    return Path(pd.getDataPath())


def rtb_solver(chain: SerialChain):  # noqa: ANN201 - a callable or the reason
    try:
        import roboticstoolbox as rtb
        from roboticstoolbox import ET
    except Exception as exc:  # noqa: BLE001
        return f"roboticstoolbox not importable ({type(exc).__name__})"
    A = chain.solver_model.kernel.A
    ets = ET.SE3(A[0])
    for k in range(chain.dof):
        lo, hi = float(chain.lower[k]), float(chain.upper[k])
        lim = [lo if np.isfinite(lo) else -np.pi, hi if np.isfinite(hi) else np.pi]
        ets = ets * ET.Rz(qlim=lim) * ET.SE3(A[k + 1])
    robot = rtb.Robot(ets)
    mid = middle_of_limits(chain.lower, chain.upper)

    def solve(T: np.ndarray) -> np.ndarray:
        sol = robot.ik_LM(T, q0=mid, ilimit=30, slimit=100, tol=0.5 * TOL**2, joint_limits=True)
        return np.asarray(sol.q, dtype=float)

    return solve


def verify(chain: SerialChain, q: np.ndarray | None, T: np.ndarray) -> bool:
    if q is None or not np.all(np.isfinite(q)):
        return False
    if np.any(q < chain.lower - 1e-12) or np.any(q > chain.upper + 1e-12):
        return False
    Tq = chain.fk(q)
    dr = float(np.linalg.norm(so3.log(Tq[:3, :3].T @ T[:3, :3])))
    return float(np.linalg.norm(Tq[:3, 3] - T[:3, 3])) <= TOL and dr <= TOL


def completeness(n: int) -> None:
    from test_closed_form_general import ARMS, dh_chain

    print(f"completeness: ik_all_batch(fk(q)) contains q, {n} random q per arm")
    print(f"{'arm':<16}{'family':<14}{'missed':>8}{'max err':>10}{'mean #':>8}{'targets/s':>11}")
    total_missed = 0
    for name, rows in ARMS.items():
        chain = dh_chain(rows)
        rng = np.random.default_rng(2024)
        q = rng.uniform(-np.pi, np.pi, size=(n, 6))
        T = chain.fk(q)
        t0 = time.perf_counter()
        out = chain.ik_all_batch(T)
        rate = n / (time.perf_counter() - t0)
        missed, worst = 0, 0.0
        for i in range(n):
            sols = out.solutions_of(i)
            d = (
                np.abs((sols - q[i] + np.pi) % (2 * np.pi) - np.pi).max(axis=1)
                if len(sols)
                else [1]
            )
            missed += bool(np.min(d) > 1e-6)
        ep, er = pose_errors(chain.fk(out.solutions), T[np.repeat(np.arange(n), out.count)])
        worst = float(max(ep.max(initial=0.0), er.max(initial=0.0)))
        total_missed += missed
        fam = chain.ik_family or "-"
        print(f"{name:<16}{fam:<14}{missed:>8}{worst:>10.1e}{out.count.mean():>8.2f}{rate:>11.0f}")
    print(f"total missed: {total_missed}")


def _timed(solve, T: np.ndarray, chain: SerialChain) -> tuple[list[float], int]:  # noqa: ANN001
    """Wall-clock seconds per call and verified successes of `solve` (T → q or None) on T."""
    gc.collect()
    gc.freeze()
    times, ok = [], 0
    for t in T:
        t0 = time.perf_counter()
        q = solve(t)
        times.append(time.perf_counter() - t0)
        ok += verify(chain, q, t)
    return times, ok


def speed(names: list[str], n: int) -> None:
    available = arms()
    print(f"\nspeed, TRAC-IK protocol: {n} targets, 5 ms, 1e-5; rtb ik_LM in the same run")
    head = (
        f"{'arm':<13}{'family':<20}{'ik %':>7}{'ik med':>9}{'num %':>7}{'num med':>9}{'rtb %':>7}"
        f"{'rtb med':>9}{'ik/rtb':>8}{'all med':>9}{'all/rtb':>9}{'batch/s':>9}"
    )
    print(head)
    for name in names:
        chain = available.get(name, "unknown arm")
        if isinstance(chain, str):
            print(f"{name:<13}skipped: {chain}")
            continue
        fam = family_of(chain)
        rng = np.random.default_rng(12345)
        lo = np.where(np.isfinite(chain.lower), chain.lower, -np.pi)  # continuous: [−π, π]
        hi = np.where(np.isfinite(chain.upper), chain.upper, np.pi)
        q = rng.uniform(lo, hi, size=(n, chain.dof))
        T = chain.fk(q)
        opts = IKOptions(
            position_tolerance=TOL, orientation_tolerance=TOL, timeout=BUDGET, rng_seed=0
        )
        numeric = replace(opts, method="numeric")
        for o in (opts, numeric):
            chain.ik(T[0], options=o)  # detection and first-call costs outside the timing

        def ours(t: np.ndarray, o: IKOptions = opts, c: SerialChain = chain) -> np.ndarray | None:
            res = c.ik(t, options=o)
            return res.q if res.success else None

        ours_t, ok = _timed(ours, T, chain)
        num_t, num_ok = _timed(lambda t, o=numeric: ours(t, o), T, chain)
        peer = rtb_solver(chain)
        rtb_t, rtb_ok = ([], 0) if isinstance(peer, str) else _timed(peer, T, chain)
        all_t: list[float] = []
        batch = float("nan")
        if fam is not None:
            all_t, _ = _timed(lambda t, c=chain: c.ik_all(t).q, T[: min(n, 300)], chain)
            t0 = time.perf_counter()
            chain.ik_all_batch(T)
            batch = n / (time.perf_counter() - t0)
        m = float(np.median(ours_t)) * 1e3
        mn = float(np.median(num_t)) * 1e3
        r = float(np.median(rtb_t)) * 1e3 if rtb_t else float("nan")
        a = float(np.median(all_t)) * 1e3 if all_t else float("nan")
        print(
            f"{name:<13}{(fam.name if fam else '-'):<20}{100 * ok / n:>6.1f}%{m:>7.2f}ms"
            f"{100 * num_ok / n:>6.1f}%{mn:>7.2f}ms"
            f"{100 * rtb_ok / n if rtb_t else float('nan'):>6.1f}%{r:>7.2f}ms{m / r:>8.2f}"
            f"{a:>7.2f}ms{a / r:>9.2f}{batch:>9.0f}"
        )
    print(f"\nmachine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--complete", type=int, default=10_000, help="random q per arm (0: skip)")
    ap.add_argument("--targets", type=int, default=1000)
    ap.add_argument(
        "--arms", default="random0,offset-puma,xarm6,irb140,puma560,kr16,ur5,baxter,xarm7"
    )
    args = ap.parse_args()
    if args.complete:
        completeness(args.complete)
    if args.targets:
        speed(args.arms.split(","), args.targets)
    return 0


if __name__ == "__main__":
    sys.exit(main())
