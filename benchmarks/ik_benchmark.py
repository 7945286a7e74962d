"""IK success rate and speed, side by side with installed peers, in one run (TRAC-IK protocol).

    python benchmarks/ik_benchmark.py [--targets 2000] [--peer-targets 500] [--slow-targets 100]
                                      [--arms ur5,panda,iiwa] [--seed 12345] [--json out.json]
                                      [--peers kdl,pinocchio,rtb,mr,ikpy] [--numeric]

`--arms repo-ur5e,repo-panda,repo-iiwa14,repo-scara,repo-planar3r` measures the repository's own
bundled arms (`load_robot`); scara and planar3r have no closed form, so their `ik` is the numeric
search. `--arms xarm6,irb140,puma560,baxter` measures arms in no named family (xArm 6 and ABB's
IRB 140: the general 6R solver; Baxter's left arm: a joint held, the general 6R solver for the
rest) and a Puma 560 whose wrist axes meet only to rounding (pybullet_data's xArm 6 URDF, the
rtbdata descriptions of roboticstoolbox-data, example-robot-data's Baxter). `--numeric` also
times `IKOptions(method="numeric")` on arms that have a closed form.

Protocol (Beeson & Ames, TRAC-IK, 2015): targets are FK of configurations drawn uniformly within
the joint limits; every solver starts from the middle of the limits; the full 6-D pose must match
to 1e-5 (m and rad); budget 5 ms per call. A result counts as a success only if *we* verify it:
every joint within its limits and ‖Δp‖ ≤ 1e-5 m and rotation angle ≤ 1e-5 rad by our FK (which
the core tests check against Pinocchio). "within limits %" is reported separately for solvers
that ignore limits.

Peers (each optional; skipped with the reason printed):
* KDL (Debian python3-pykdl, imported from /usr/lib/python3/dist-packages): ChainIkSolverPos_LMA
  and ChainIkSolverPos_NR_JL, wrapped in random restarts until the 5 ms budget as in the TRAC-IK
  paper's KDL baseline. The KDL chain is built from our parsed model (one RotZ/TransZ joint plus a
  constant frame per joint), i.e. the same kinematics.
* Pinocchio: the damped least-squares loop of Pinocchio's documented IK example (DT = 0.1,
  damping 1e-12, error log6 in the local frame), with the 5 ms budget; no restarts, no limits.
* roboticstoolbox-python `ik_LM` (C++; its own restarts via slimit; no timeout option), on an ETS
  built from our parsed model, tolerance E = ½‖e‖² ≤ ½(1e-5)².
* modern-robotics `IKinSpace` (pure Python Newton–Raphson, no limits, 20 iterations): slow, so it
  runs on `--slow-targets` targets only.
* ikpy `inverse_kinematics_frame` (scipy optimiser): slow, `--slow-targets` targets.

Ratios are peer median time / our median time (> 1: we are faster). The machine may be shared:
times are wall-clock per call, noisy; rerun for stable figures.
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import sys
import sysconfig
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from kinematics_node.core import IKOptions, SerialChain, so3  # noqa: E402
from kinematics_node.core.model import middle_of_limits  # noqa: E402
from kinematics_node.sim.robots import default_chain_links, load_robot, robot_path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _pinocchio import chain_setup  # noqa: E402

ERD = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix/share/example-robot-data/robots"
RTBDATA = Path(sysconfig.get_paths()["purelib"]) / "rtbdata/xacro"
#: The base link of arms whose chain does not start at the URDF's root.
BASES = {"baxter": "torso"}
TOL = 1e-5
BUDGET = 0.005
# The repository's bundled arms (config/robots), `--arms repo-<name>`; scara and planar3r have no
# closed form, so their `ik` is the numeric search.
REPO_ARMS = ("ur5e", "panda", "iiwa14", "scara", "planar3r")
ALL_PEERS = ("kdl", "pinocchio", "rtb", "mr", "ikpy")


def arm_paths() -> dict[str, tuple[Path | None, str | None, str]]:
    """name → (urdf path or None, tip link, note). ur5, panda and iiwa are the arms of the
    repository's tests (the issue's table); the others (example-robot-data) are arms nobody here
    tuned for: ur10, z1 (three parallel axes), kinova j2s6s200 (spherical wrist), xarm7 (7R)."""
    erd = "example-robot-data"
    out: dict[str, tuple[Path | None, str | None, str]] = {
        "ur5": (ERD / "ur_description/urdf/ur5_robot.urdf", "tool0", erd),
        "panda": (ERD / "panda_description/urdf/panda.urdf", "panda_hand", erd),
        "ur10": (ERD / "ur_description/urdf/ur10_robot.urdf", "tool0", erd),
        "z1": (ERD / "z1_description/urdf/z1.urdf", "link06", erd),
        "kinova": (ERD / "kinova_description/robots/kinova.urdf", "j2s6s200_end_effector", erd),
        "xarm7": (ERD / "xarm_description/urdf/xarm7.urdf", "link_eef", erd),
    }
    # Arms in no named family (issue 24): the general 6R solver, or a 7R arm holding a joint for it.
    out["irb140"] = (RTBDATA / "abb_irb140_description/urdf/irb140.urdf", "tool0", "rtbdata")
    out["puma560"] = (
        RTBDATA / "unimation_puma560_description/urdf/puma560_robot.urdf",
        None,
        "rtbdata",
    )
    out["baxter"] = (ERD / "baxter_description/urdf/baxter.urdf", "left_gripper", erd)
    try:
        import pybullet_data

        p = Path(pybullet_data.getDataPath()) / "kuka_iiwa/model.urdf"
        out["iiwa"] = (p, "lbr_iiwa_link_7", "pybullet_data kuka_iiwa/model.urdf")
        p = Path(pybullet_data.getDataPath()) / "xarm/xarm6_robot.urdf"
        out["xarm6"] = (p, "link6", "pybullet_data xarm/xarm6_robot.urdf")
    except ImportError:
        out["iiwa"] = (None, None, "pybullet not installed (pip install pybullet)")
        out["xarm6"] = out["iiwa"]
    for robot in REPO_ARMS:  # the repository's bundled arms, as `load_robot` builds them
        out[f"repo-{robot}"] = (robot_path(robot), default_chain_links(robot)[1], "load_robot")
    return out


def load_arm(name: str, path: Path, tip: str | None) -> SerialChain:
    """The chain of arm `name` (a bundled arm through `load_robot`, with its default base)."""
    if name.startswith("repo-"):
        return load_robot(name.removeprefix("repo-"))
    return SerialChain.from_urdf(path, base_link=BASES.get(name), tip_link=tip)


# ---------------------------------------------------------------------- verification
def verify(chain: SerialChain, q: np.ndarray | None, T: np.ndarray) -> tuple[bool, bool]:
    """(success, within limits) of a returned configuration, checked with our FK."""
    if q is None or q.shape != (chain.dof,) or not np.all(np.isfinite(q)):
        return False, False
    lim = bool(np.all(q >= chain.lower - 1e-12) and np.all(q <= chain.upper + 1e-12))
    Tq = chain.fk(q)
    dp = float(np.linalg.norm(Tq[:3, 3] - T[:3, 3]))
    dr = float(np.linalg.norm(so3.log(Tq[:3, :3].T @ T[:3, :3])))
    return lim and dp <= TOL and dr <= TOL, lim


def run_solver(
    chain: SerialChain, solve: Callable[[np.ndarray], np.ndarray | None], T: np.ndarray
) -> dict[str, float]:
    # Every solver is timed with the heap built so far exempt from the cyclic GC, as in the
    # node's IK workers (`ik_pool._init_worker`): a full collection of this process's heap
    # (Pinocchio, rtb, KDL loaded) took 12-28 ms and landed inside single timed calls.
    gc.collect()
    gc.freeze()
    times, ok, lim = [], 0, 0
    for Tk in T:
        t0 = time.perf_counter()
        q = solve(Tk)
        times.append(time.perf_counter() - t0)
        s, w = verify(chain, q, Tk)
        ok += s
        lim += w
    t = np.array(times) * 1e3
    return {
        "targets": len(T),
        "success_pct": 100.0 * ok / len(T),
        "within_limits_pct": 100.0 * lim / len(T),
        "median_ms": float(np.median(t)),
        "p95_ms": float(np.percentile(t, 95)),
        "max_ms": float(t.max()),
    }


# ---------------------------------------------------------------------- peers
def random_q(chain: SerialChain, rng: np.random.Generator) -> np.ndarray:
    """Uniform within the limits; continuous joints in [−π, π]."""
    lo = np.where(np.isfinite(chain.lower), chain.lower, -np.pi)
    hi = np.where(np.isfinite(chain.upper), chain.upper, np.pi)
    return rng.uniform(lo, hi)


def peer_kdl(chain: SerialChain) -> dict[str, Callable[[np.ndarray], np.ndarray | None]] | str:
    sys.path.append("/usr/lib/python3/dist-packages")
    try:
        import PyKDL as kdl
    except ImportError as exc:
        return f"PyKDL not importable ({exc}); apt-get install python3-pykdl"
    finally:
        sys.path.remove("/usr/lib/python3/dist-packages")

    def frame(A: np.ndarray) -> kdl.Frame:
        R = kdl.Rotation(*A[:3, :3].ravel().tolist())
        return kdl.Frame(R, kdl.Vector(*A[:3, 3].tolist()))

    A = chain.solver_model.kernel.A
    kchain = kdl.Chain()
    kchain.addSegment(kdl.Segment(kdl.Joint(kdl.Joint.Fixed), frame(A[0])))
    for k, prism in enumerate(chain.solver_model.kernel.prismatic):
        jt = kdl.Joint(kdl.Joint.TransZ if prism else kdl.Joint.RotZ)
        kchain.addSegment(kdl.Segment(jt, frame(A[k + 1])))
    n = chain.dof
    qmin, qmax = kdl.JntArray(n), kdl.JntArray(n)
    for i in range(n):
        qmin[i], qmax[i] = float(chain.lower[i]), float(chain.upper[i])
    fk = kdl.ChainFkSolverPos_recursive(kchain)
    vel = kdl.ChainIkSolverVel_pinv(kchain)
    nr_jl = kdl.ChainIkSolverPos_NR_JL(kchain, qmin, qmax, fk, vel, 100, TOL)
    # LMA's eps bounds the error weighted by its default L = (1, 1, 1, 0.01, 0.01, 0.01) on
    # (v, ω), so 1e-7 is needed for 1e-5 rad.
    lma = kdl.ChainIkSolverPos_LMA(kchain, 1e-2 * TOL, 500, 1e-15)
    mid = middle_of_limits(chain.lower, chain.upper)
    # KDL solvers keep C++ references to the chain and sub-solvers: keep the Python objects alive
    keep_alive = (kchain, qmin, qmax, fk, vel)

    def make(solver: object) -> Callable[[np.ndarray], np.ndarray | None]:
        def solve(T: np.ndarray, _keep: object = keep_alive) -> np.ndarray | None:
            rng = np.random.default_rng(0)
            target = frame(T)
            q0, out = kdl.JntArray(n), kdl.JntArray(n)
            seed = mid
            deadline = time.perf_counter() + BUDGET
            best = None
            while True:
                for i in range(n):
                    q0[i] = float(seed[i])
                rc = solver.CartToJnt(q0, target, out)  # type: ignore[attr-defined]
                q = np.array([out[i] for i in range(n)])
                if best is None:
                    best = q
                if rc >= 0 and verify(chain, q, T)[0]:
                    return q
                if time.perf_counter() > deadline:
                    return best
                seed = random_q(chain, rng)

        return solve

    return {"KDL LMA+restarts": make(lma), "KDL NR_JL+restarts": make(nr_jl)}


def peer_pinocchio(path: Path, chain: SerialChain) -> Callable[[np.ndarray], np.ndarray] | str:
    try:
        import pinocchio as pin
    except ImportError:
        return "pinocchio not installed (pip install pin)"
    model, data, fid, idx = chain_setup(pin, path, chain)
    mid = middle_of_limits(chain.lower, chain.upper)
    DT, damp = 1e-1, 1e-12

    def solve(T: np.ndarray) -> np.ndarray:
        oMdes = pin.SE3(T[:3, :3].copy(), T[:3, 3].copy())
        q = pin.neutral(model)
        q[idx] = mid
        deadline = time.perf_counter() + BUDGET
        while time.perf_counter() < deadline:
            pin.framesForwardKinematics(model, data, q)
            iMd = data.oMf[fid].actInv(oMdes)
            err = pin.log(iMd).vector
            if np.linalg.norm(err[:3]) < TOL and np.linalg.norm(err[3:]) < TOL:
                break
            J = pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL)
            J = -pin.Jlog6(iMd.inverse()) @ J
            v = -J.T @ np.linalg.solve(J @ J.T + damp * np.eye(6), err)
            q = pin.integrate(model, q, v * DT)
        return np.asarray(q)[idx]

    return solve


def peer_rtb(chain: SerialChain) -> Callable[[np.ndarray], np.ndarray | None] | str:
    try:
        import roboticstoolbox as rtb
        from roboticstoolbox import ET
    except Exception as exc:  # noqa: BLE001 - any import failure means "skip"
        return f"roboticstoolbox not importable ({type(exc).__name__}: {exc})"
    A = chain.solver_model.kernel.A
    ets = ET.SE3(A[0])
    for k, prism in enumerate(chain.solver_model.kernel.prismatic):
        # rtb draws its restarts within the limits and refuses infinite ones: a continuous
        # joint gets [−π, π], the range its targets are drawn from
        lo, hi = float(chain.lower[k]), float(chain.upper[k])
        lim = [lo if np.isfinite(lo) else -np.pi, hi if np.isfinite(hi) else np.pi]
        ets = ets * (ET.tz(qlim=lim) if prism else ET.Rz(qlim=lim)) * ET.SE3(A[k + 1])
    robot = rtb.Robot(ets)
    mid = middle_of_limits(chain.lower, chain.upper)

    def solve(T: np.ndarray) -> np.ndarray | None:
        sol = robot.ik_LM(T, q0=mid, ilimit=30, slimit=100, tol=0.5 * TOL**2, joint_limits=True)
        return np.asarray(sol.q, dtype=float)

    return solve


def peer_mr(chain: SerialChain) -> Callable[[np.ndarray], np.ndarray | None] | str:
    try:
        import modern_robotics as mr
    except ImportError:
        return "modern_robotics not installed (pip install modern-robotics)"
    S, M = np.array(chain.S), np.array(chain.M)
    mid = middle_of_limits(chain.lower, chain.upper)

    def solve(T: np.ndarray) -> np.ndarray:
        q, _ = mr.IKinSpace(S, M, T, mid.copy(), TOL, TOL)
        return np.asarray(q, dtype=float)

    return solve


def peer_ikpy(chain: SerialChain) -> Callable[[np.ndarray], np.ndarray | None] | str:
    try:
        from ikpy.chain import Chain
        from ikpy.link import OriginLink, URDFLink
    except ImportError:
        return "ikpy not installed (pip install ikpy)"
    from kinematics_node.core.rotations import rpy_from_matrix

    A = chain.solver_model.kernel.A
    links = [OriginLink()]
    for k, prism in enumerate(chain.solver_model.kernel.prismatic):
        axis = np.array([0.0, 0.0, 1.0])
        links.append(
            URDFLink(
                name=chain.joint_names[k],
                origin_translation=A[k][:3, 3],
                origin_orientation=rpy_from_matrix(A[k][:3, :3]),
                rotation=None if prism else axis,
                translation=axis if prism else None,
                bounds=(float(chain.lower[k]), float(chain.upper[k])),
                joint_type="prismatic" if prism else "revolute",
            )
        )
    links.append(
        URDFLink(
            name="tip",
            origin_translation=A[-1][:3, 3],
            origin_orientation=rpy_from_matrix(A[-1][:3, :3]),
            joint_type="fixed",
        )
    )
    mask = [False] + [True] * chain.dof + [False]
    ik_chain = Chain(links, active_links_mask=mask)
    mid = middle_of_limits(chain.lower, chain.upper)
    init = np.r_[0.0, mid, 0.0]
    # sanity: ikpy FK equals ours at a random configuration
    q = random_q(chain, np.random.default_rng(0))
    if not np.allclose(ik_chain.forward_kinematics(np.r_[0.0, q, 0.0]), chain.fk(q), atol=1e-9):
        return "ikpy chain conversion does not reproduce our FK (skipped)"

    def solve(T: np.ndarray) -> np.ndarray:
        sol = ik_chain.inverse_kinematics_frame(T, initial_position=init, orientation_mode="all")
        return np.asarray(sol[1:-1])

    return solve


# ---------------------------------------------------------------------- main
def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--targets", type=int, default=2000, help="targets per arm for our solver")
    ap.add_argument("--peer-targets", type=int, default=500, help="targets for KDL/Pinocchio/rtb")
    ap.add_argument("--slow-targets", type=int, default=100, help="targets for MR and ikpy")
    ap.add_argument(
        "--arms",
        default="ur5,panda,iiwa",
        help="any of ur5,panda,iiwa,ur10,z1,kinova,xarm7,xarm6,irb140,puma560,baxter and the "
        "bundled arms " + ",".join(f"repo-{a}" for a in REPO_ARMS),
    )
    ap.add_argument("--peers", default=",".join(ALL_PEERS), help=f"subset of {','.join(ALL_PEERS)}")
    ap.add_argument(
        "--numeric", action="store_true", help="also time method='numeric' on every arm"
    )
    ap.add_argument(
        "--seed", type=int, default=12345, help="seed of the random target configurations"
    )
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args(argv)

    paths = arm_paths()
    results: dict[str, dict[str, object]] = {}
    rows = []
    for name in args.arms.split(","):
        if name not in paths:
            print(f"unknown arm {name!r}; choose from {sorted(paths)}")
            return 2
        path, tip, note = paths[name]
        if path is None or not path.exists():
            print(f"[{name}] skipped: {note}")
            continue
        chain = load_arm(name, path, tip)
        rng = np.random.default_rng(args.seed)
        lo = np.where(np.isfinite(chain.lower), chain.lower, -np.pi)  # continuous: [−π, π]
        hi = np.where(np.isfinite(chain.upper), chain.upper, np.pi)
        Q = rng.uniform(lo, hi, (args.targets, chain.dof))
        T = chain.fk(Q)
        mid = middle_of_limits(chain.lower, chain.upper)  # 0 for continuous joints
        # The closed-form family is detected once per chain, on first use (like a peer building
        # its own model of the arm); done here so that it is not charged to the first target.
        t0 = time.perf_counter()
        family = chain.ik_family
        detect_ms = (time.perf_counter() - t0) * 1e3
        print(
            f"[{name}] {chain!r} from {note}; {args.targets} targets; closed-form family "
            f"{family} (detected in {detect_ms:.0f} ms)"
        )
        arm_res: dict[str, object] = {"family": family}
        opts = IKOptions(
            position_tolerance=TOL, orientation_tolerance=TOL, timeout=BUDGET, rng_seed=0
        )

        def ours_solve(
            Tk: np.ndarray, c: SerialChain = chain, s: np.ndarray = mid, o: IKOptions = opts
        ) -> np.ndarray:
            return np.asarray(c.ik(Tk, s, o).q)

        ours = run_solver(chain, ours_solve, T)
        with_numeric = family is not None or args.numeric
        if with_numeric:  # the numeric search alone, for comparison
            num = replace(opts, method="numeric")
            arm_res["ours numeric"] = res_num = run_solver(
                chain, lambda Tk, c=chain, s=mid, o=num: np.asarray(c.ik(Tk, s, o).q), T
            )
        # batch: whole set at once, verified afterwards
        t0 = time.perf_counter()
        b = chain.ik_batch(T, options=opts)
        dt = time.perf_counter() - t0
        n_ok = sum(verify(chain, b.q[k], T[k])[0] for k in range(len(T)))
        ours["batch_solutions_per_s"] = n_ok / dt
        ours["batch_success_pct"] = 100.0 * n_ok / len(T)
        arm_res["ours"] = ours
        rows.append((name, "ours (ik)", ours))
        if with_numeric:
            rows.append((name, "ours (ik, numeric)", res_num))

        peers: list[tuple[str, object, int]] = []
        chosen = set(args.peers.split(","))
        if "kdl" in chosen:
            kdl = peer_kdl(chain)
            if isinstance(kdl, str):
                peers.append(("KDL", kdl, 0))
            else:
                peers += [(k, v, args.peer_targets) for k, v in kdl.items()]
        if "pinocchio" in chosen:
            pin_peer = (
                "the arm's chain does not start at the URDF root"
                if name.startswith("repo-") or name in BASES
                else peer_pinocchio(path, chain)
            )
            peers.append(("Pinocchio DLS", pin_peer, args.peer_targets))
        if "rtb" in chosen:
            peers.append(("rtb ik_LM", peer_rtb(chain), args.peer_targets))
        if args.slow_targets > 0:
            if "mr" in chosen:
                peers.append(("MR IKinSpace", peer_mr(chain), args.slow_targets))
            if "ikpy" in chosen:
                peers.append(("ikpy", peer_ikpy(chain), args.slow_targets))
        for pname, solver, count in peers:
            if isinstance(solver, str):
                print(f"  {pname}: skipped: {solver}")
                arm_res[pname] = {"skipped": solver}
                continue
            try:
                res = run_solver(chain, solver, T[:count])  # type: ignore[arg-type]
            except Exception as exc:  # noqa: BLE001 - report and continue with other peers
                print(f"  {pname}: failed: {type(exc).__name__}: {exc}")
                arm_res[pname] = {"failed": str(exc)}
                continue
            arm_res[pname] = res
            rows.append((name, pname, res))
        results[name] = arm_res

    print()
    hdr = (
        f"{'arm':13} {'solver':22} {'targets':>7} {'success%':>9} {'limits%':>8} "
        f"{'median ms':>10} {'p95 ms':>8} {'max ms':>8} {'median/ours':>12}"
    )
    print(hdr)
    print("-" * len(hdr))
    for arm_name, pname, r in rows:
        ref = results[arm_name]["ours"]["median_ms"]  # type: ignore[index]
        ratio = r["median_ms"] / ref
        print(
            f"{arm_name:13} {pname:22} {r['targets']:7d} {r['success_pct']:9.2f} "
            f"{r['within_limits_pct']:8.2f} {r['median_ms']:10.3f} {r['p95_ms']:8.3f} "
            f"{r['max_ms']:8.2f} {ratio:12.2f}"
        )
    print()
    for arm_name, res in results.items():
        o = res["ours"]
        print(
            f"{arm_name:13} ours (ik_batch): {o['batch_solutions_per_s']:,.0f} verified "  # type: ignore[index]
            f"solutions/s, success {o['batch_success_pct']:.2f} %"  # type: ignore[index]
        )
    print(f"\nmachine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f}")
    if args.json:
        args.json.write_text(json.dumps(results, indent=2))
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
