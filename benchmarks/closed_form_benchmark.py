"""Closed-form IK (`chain.ik_all`): single-call time, batched throughput, and peers in one run.

    python benchmarks/closed_form_benchmark.py [--targets 1000] [--batch 20000] [--repeat 3]
                                               [--peer-targets 300] [--arms ur5,ur5-limited,panda]
                                               [--seed 777] [--json out.json]

Targets are FK of configurations drawn uniformly within the joint limits (continuous joints in
[−π, π]); the seed is the middle of the limits, as in `ik_benchmark.py`. For each arm:

* single call: median and 95th percentile of one `ik_all(T)` call (all solutions, sorted);
  "recall" is the share of targets whose own configuration is among the solutions (to 1e-6 rad;
  7R arms: with the held joint at the target's own value), and every solution of the first 100
  targets is checked by FK;
* batch: best of `--repeat` runs of one `ik_all_batch` call on `--batch` targets (7R arms: at
  most 1000, as each sweeps 36 held values), in targets/s and solutions/s;
* peers on the same targets (`--peer-targets`): our `chain.ik` (TRAC-IK protocol options), as
  used ("auto": the closed form, then the numeric search) and with the numeric search alone,
  and roboticstoolbox-python's `ik_LM` (C++; the bench extra), each returning one solution.
  Ratios are peer median / our closed-form median (> 1: the closed form is faster).

Arms: "ur5" is example-robot-data's ur5_robot.urdf (the UR5 of `ik_benchmark.py`; limits ±2π on
five joints, so each pose has up to 8 × 2⁵ = 256 solutions within the limits), "ur5-limited" its
ur5_joint_limited_robot.urdf (±π: at most 8), "panda" (7R: 36 values of joint 7 swept),
"iiwa14" (bundled; 7R, joint 3 swept). The issue's targets are for the UR5: a single call within
150 µs and a batch of at least 100k targets/s. Times are wall-clock on a possibly shared machine.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))
from ik_benchmark import ERD, TOL, peer_rtb, run_solver  # noqa: E402

from kinematics_node.core import IKOptions, SerialChain  # noqa: E402
from kinematics_node.core.ik.closed_form import family_of  # noqa: E402
from kinematics_node.sim.robots import load_robot  # noqa: E402

ARMS = {
    "ur5": lambda: SerialChain.from_urdf(ERD / "ur_description/urdf/ur5_robot.urdf", None, "tool0"),
    "ur5-limited": lambda: SerialChain.from_urdf(
        ERD / "ur_description/urdf/ur5_joint_limited_robot.urdf", None, "tool0"
    ),
    "panda": lambda: SerialChain.from_urdf(
        ERD / "panda_description/urdf/panda.urdf", None, "panda_hand"
    ),
    "iiwa14": lambda: load_robot("iiwa14"),
}


def random_q(chain: SerialChain, rng: np.random.Generator, n: int) -> np.ndarray:
    lo = np.where(np.isfinite(chain.lower), chain.lower, -np.pi)
    hi = np.where(np.isfinite(chain.upper), chain.upper, np.pi)
    return rng.uniform(lo, hi, size=(n, chain.dof))


def single_calls(chain: SerialChain, q: np.ndarray, T: np.ndarray) -> dict[str, float]:
    """Timed `ik_all` calls (7R: the default sweep of the held joint); recall is measured apart,
    for 7R arms with the held joint at the target's own value (a sweep grid rarely contains it)."""
    times, counts = [], []
    for k, Tk in enumerate(T):
        t0 = time.perf_counter()
        res = chain.ik_all(Tk)
        times.append(time.perf_counter() - t0)
        sols = np.array(res.solutions).reshape(-1, chain.dof)
        counts.append(len(sols))
        if k < 100 and len(sols):
            Tq = chain.fk(sols)
            assert np.abs(Tq - Tk).max() < 2e-9, "a returned solution misses its target"
    family = family_of(chain)
    assert family is not None
    held = None
    if family.held_joint is not None:
        j = chain.joint_index(family.held_joint)
        held = q[:, j : j + 1]
    res_b = chain.ik_all_batch(T, held=held)
    owner = np.repeat(np.arange(len(q)), res_b.count)
    best = np.full(len(q), np.inf)
    np.minimum.at(best, owner, np.abs(res_b.solutions - q[owner]).max(axis=1))
    t = np.array(times) * 1e6
    return {
        "median_us": float(np.median(t)),
        "p95_us": float(np.percentile(t, 95)),
        "recall_pct": 100.0 * float(np.mean(best < 1e-6)),
        "solutions_per_target": float(np.mean(counts)),
    }


def batch(chain: SerialChain, T: np.ndarray, repeat: int) -> dict[str, float]:
    chain.ik_all_batch(T[:64])  # warm-up
    best, n_sol = np.inf, 0
    for _ in range(repeat):
        t0 = time.perf_counter()
        res = chain.ik_all_batch(T)
        best = min(best, time.perf_counter() - t0)
        n_sol = res.solutions.shape[0]
    return {"targets_per_s": len(T) / best, "solutions_per_s": n_sol / best}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--targets", type=int, default=1000, help="single-call targets per arm")
    ap.add_argument("--batch", type=int, default=20000, help="targets of the batched call")
    ap.add_argument("--repeat", type=int, default=3, help="batched runs (best is reported)")
    ap.add_argument("--peer-targets", type=int, default=300, help="targets for the peers")
    ap.add_argument("--arms", default="ur5,ur5-limited,panda")
    ap.add_argument("--seed", type=int, default=777)
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args(argv)
    report: dict[str, dict[str, object]] = {}
    for name in args.arms.split(","):
        if name not in ARMS:
            ap.error(f"unknown arm {name!r}; choose from {', '.join(ARMS)}")
        chain = ARMS[name]()
        rng = np.random.default_rng(args.seed)
        q = random_q(chain, rng, max(args.targets, args.batch))
        T = chain.fk(q)
        row: dict[str, object] = {"family": chain.ik_family}
        chain.ik_all(T[0])  # detection and warm-up outside the timing
        row["single"] = single_calls(chain, q[: args.targets], T[: args.targets])
        # 7R arms sweep 36 held values per target: 36× the lanes, so a smaller batch.
        n_batch = args.batch if chain.dof == 6 else min(args.batch, 1000)
        row["batch"] = batch(chain, T[:n_batch], args.repeat)
        peers: dict[str, object] = {}
        Tp = T[: args.peer_targets]
        opts = IKOptions(position_tolerance=TOL, orientation_tolerance=TOL, timeout=0.005)
        for label, method in (("ours ik (auto)", "auto"), ("ours ik (numeric)", "numeric")):
            o = replace(opts, method=method)
            peers[label] = run_solver(
                chain, lambda Tk, c=chain, o=o: np.asarray(c.ik(Tk, options=o).q), Tp
            )
        rtb = peer_rtb(chain)
        peers["rtb ik_LM"] = rtb if isinstance(rtb, str) else run_solver(chain, rtb, Tp)
        row["peers"] = peers
        report[name] = row
        print_row(name, row)
    if args.json is not None:
        args.json.write_text(json.dumps(report, indent=2))
    return 0


def print_row(name: str, row: dict[str, object]) -> None:
    s, b = row["single"], row["batch"]
    assert isinstance(s, dict) and isinstance(b, dict)
    print(f"\n{name}: family {row['family']}")
    print(
        f"  ik_all single call   median {s['median_us']:8.1f} µs  p95 {s['p95_us']:8.1f} µs  "
        f"recall {s['recall_pct']:.2f} %  {s['solutions_per_target']:.1f} solutions/target"
    )
    print(
        f"  ik_all_batch         {b['targets_per_s']:10.0f} targets/s  "
        f"{b['solutions_per_s']:12.0f} solutions/s"
    )
    peers = row["peers"]
    assert isinstance(peers, dict)
    for peer, r in peers.items():
        if isinstance(r, str):
            print(f"  {peer:<20} skipped: {r}")
            continue
        med_us = 1e3 * r["median_ms"]
        print(
            f"  {peer:<20} median {med_us:8.1f} µs  success {r['success_pct']:.1f} %  "
            f"(one solution; {med_us / s['median_us']:.2f}× our closed-form median)"
        )


if __name__ == "__main__":
    sys.exit(main())
