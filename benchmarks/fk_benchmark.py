"""FK and Jacobian speed, side by side with installed peers, in one run.

    python benchmarks/fk_benchmark.py [--batch 100000] [--json out.json]

Compares this package with Pinocchio (Python bindings), and where installed roboticstoolbox-python
and the `modern-robotics` package, on a 6-DOF (UR5) and a 7-DOF (Panda) arm from
example-robot-data. Times are the best of several repeats (the machine is shared and noisy);
ratios are peer time / our time, so > 1 means we are faster. Correctness is checked before timing.
"""

from __future__ import annotations

import argparse
import json
import sys
import sysconfig
import timeit
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from kinematics_node.core import SerialChain  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _pinocchio import chain_setup  # noqa: E402

ERD = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix/share/example-robot-data/robots"
ARMS = {
    "ur5 (6R)": ("ur_description/urdf/ur5_robot.urdf", "tool0"),
    "panda (7R)": ("panda_description/urdf/panda.urdf", "panda_hand"),
}


def best(fn, number: int, repeat: int = 5) -> float:
    """Best-of-`repeat` seconds per call."""
    return min(timeit.repeat(fn, number=number, repeat=repeat)) / number


def bench_ours(chain: SerialChain, q: np.ndarray, Q: np.ndarray) -> dict[str, float]:
    r = {
        "fk": best(lambda: chain.fk(q), 5000),
        "jacobian": best(lambda: chain.jacobian(q, "space"), 5000),
        "fk+world_jacobian": best(lambda: chain.fk_jacobian(q, "world"), 5000),
    }
    t = best(lambda: chain.fk(Q), 1, repeat=3)
    r["batch_fk_per_s"] = len(Q) / t
    return r


def bench_pinocchio(
    path: Path, chain: SerialChain, q: np.ndarray, Q: np.ndarray
) -> dict[str, float] | str:
    try:
        import pinocchio as pin
    except ImportError:
        return "not installed (pip install pin)"
    model, data, fid, idx = chain_setup(pin, path, chain)
    if model.nq != chain.dof:
        return f"skipped: model has {model.nq} coordinates, chain {chain.dof}"
    order = np.argsort(idx)
    qp = q[order]
    Qp = Q[:, order]

    def fk(x=qp):
        pin.framesForwardKinematics(model, data, x)
        return data.oMf[fid]

    ref = fk().homogeneous
    if not np.allclose(ref, chain.fk(q), atol=1e-9):
        return "disagrees with our FK; not timed"
    LWA = pin.LOCAL_WORLD_ALIGNED

    def fk_jac():
        fk()
        return pin.computeFrameJacobian(model, data, qp, fid, LWA)

    r = {
        "fk": best(fk, 5000),
        "jacobian": best(lambda: pin.computeFrameJacobian(model, data, qp, fid, pin.WORLD), 5000),
        "fk+world_jacobian": best(fk_jac, 5000),
    }

    def loop():
        for x in Qp:
            pin.framesForwardKinematics(model, data, x)
            data.oMf[fid].homogeneous  # noqa: B018 - the copy out is part of a user's loop

    n = min(len(Q), 100_000)
    Qp = Qp[:n]
    r["batch_fk_per_s"] = n / best(loop, 1, repeat=3)
    return r


def bench_modern_robotics(chain: SerialChain, q: np.ndarray) -> dict[str, float] | str:
    try:
        import modern_robotics as mr
    except ImportError:
        return "not installed (pip install modern-robotics)"
    S, M = np.array(chain.S), np.array(chain.M)
    if not np.allclose(mr.FKinSpace(M, S, q), chain.fk(q), atol=1e-9):
        return "disagrees with our FK; not timed"
    return {
        "fk": best(lambda: mr.FKinSpace(M, S, q), 500),
        "jacobian": best(lambda: mr.JacobianSpace(S, q), 500),
        "fk+world_jacobian": best(lambda: (mr.FKinSpace(M, S, q), mr.JacobianSpace(S, q)), 500),
    }


def bench_rtb(
    path: Path, chain: SerialChain, q: np.ndarray, Q: np.ndarray
) -> dict[str, float] | str:
    try:
        import roboticstoolbox as rtb
    except Exception as exc:  # import can fail in many ways (missing deps, numpy ABI)
        return f"not available ({type(exc).__name__})"
    try:
        robot = rtb.Robot.URDF(str(_without_geometry(path)))
        ee = robot.link_dict[chain.tip_link]
        base = robot.link_dict[chain.base_link]
        T = np.asarray(robot.fkine(q, end=ee, start=base))
    except Exception as exc:
        return f"could not load the URDF ({type(exc).__name__}: {exc})"
    if not np.allclose(T, chain.fk(q), atol=1e-9):
        return "disagrees with our FK; not timed"
    r = {
        "fk": best(lambda: robot.fkine(q, end=ee, start=base), 2000),
        "jacobian": best(lambda: robot.jacob0(q, end=ee, start=base), 2000),
    }
    r["fk+world_jacobian"] = r["fk"] + r["jacobian"]
    r["batch_fk_per_s"] = len(Q) / best(lambda: robot.fkine(Q, end=ee, start=base), 1, repeat=3)
    return r


def _without_geometry(path: Path) -> Path:
    """A copy of the URDF without <visual>/<collision> (rtb resolves package:// meshes eagerly)."""
    import tempfile
    import xml.etree.ElementTree as ET

    tree = ET.parse(path)
    for link in tree.getroot().iter("link"):
        for tag in ("visual", "collision"):
            for el in link.findall(tag):
                link.remove(el)
    out = Path(tempfile.mkdtemp()) / path.name
    tree.write(out)
    return out


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--batch", type=int, default=100_000, help="configurations in the batched FK"
    )
    parser.add_argument("--json", help="write the figures to this file")
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    results: dict[str, dict[str, object]] = {}
    for arm, (rel, tip) in ARMS.items():
        path = ERD / rel
        if not path.exists():
            print(f"{arm}: {path} missing (pip install example-robot-data)")
            continue
        chain = SerialChain.from_urdf(path, tip_link=tip)
        lo = np.where(np.isfinite(chain.lower), chain.lower, -np.pi)
        hi = np.where(np.isfinite(chain.upper), chain.upper, np.pi)
        q = rng.uniform(lo, hi)
        Q = rng.uniform(lo, hi, size=(args.batch, chain.dof))
        results[arm] = {
            "ours": bench_ours(chain, q, Q),
            "pinocchio": bench_pinocchio(path, chain, q, Q),
            "roboticstoolbox": bench_rtb(path, chain, q, Q),
            "modern_robotics": bench_modern_robotics(chain, q),
        }
    print_table(results, args.batch)
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=2))
    return 0


def print_table(results: dict[str, dict[str, object]], batch: int) -> None:
    metrics = [
        ("fk", "FK [µs]"),
        ("jacobian", "Jacobian [µs]"),
        ("fk+world_jacobian", "FK+world J [µs]"),
    ]
    print(
        f"{'arm':<12}{'library':<17}"
        + "".join(f"{label:>18}" for _, label in metrics)
        + f"{'batch FK [1/s]':>18}"
    )
    for arm, libs in results.items():
        ours = libs["ours"]
        assert isinstance(ours, dict)
        for lib, r in libs.items():
            if not isinstance(r, dict):
                print(f"{arm:<12}{lib:<17}{r}")
                continue
            cells = []
            for key, _ in metrics:
                if key in r:
                    ratio = "" if lib == "ours" else f" ({r[key] / ours[key]:.2g}x)"
                    cells.append(f"{r[key] * 1e6:.2f}{ratio}")
                else:
                    cells.append("—")
            if "batch_fk_per_s" in r:
                ratio = (
                    ""
                    if lib == "ours"
                    else f" ({ours['batch_fk_per_s'] / r['batch_fk_per_s']:.2g}x)"
                )
                cells.append(f"{r['batch_fk_per_s']:.3g}{ratio}")
            else:
                cells.append("—")
            print(f"{arm:<12}{lib:<17}" + "".join(f"{c:>18}" for c in cells))
    print(
        f"\nbatch = {batch} configurations; ratios in parentheses are (peer time / our time) for "
        "single calls and (our rate / peer rate) for batches: > 1 means we are faster."
    )


if __name__ == "__main__":
    sys.exit(main())
