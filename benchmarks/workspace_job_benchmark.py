"""The whole `kinematics reach` job on the bundled UR5e: wall time, IK problems per second and
peak memory, and Dask's scale-out on this machine.

Each run is `kinematics reach ... --out MAP.h5` in a process of its own, timed whole (start-up,
grid, chunks, HDF5 and .npz included), its peak memory the largest ru_maxrss among it and its
worker processes (getrusage of the children):

* 5 cm, 50 orientations, one process (`--processes 1`): the issue's target is under 30 s;
* 2.5 cm, 50 orientations, the local cores: under 5 minutes and under 1 GB;
* Dask: a `dask scheduler` and `dask worker --nworkers 1 --nthreads 1` commands, the 5 cm map on
  one worker, then on two (a second worker joined): the issue's target is at least 1.7x.

    python -W ignore benchmarks/workspace_job_benchmark.py [--skip-fine] [--skip-dask]
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ENV = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))


def reach(out: Path, *args: str) -> tuple[float, float, str]:
    """(seconds, peak MB of the largest process, the summary) of one `kinematics reach`."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    t0 = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "kinematics_node.cli", "reach", "--robot", "ur5e", *args]
        + ["--out", str(out), "--force"],
        cwd=ROOT,
        env=ENV,
        capture_output=True,
        text=True,
    )
    seconds = time.perf_counter() - t0
    if done.returncode:
        raise SystemExit(done.stderr)
    peak = max(before, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss) / 1024
    return seconds, peak, done.stdout


def _problems(summary: str) -> int:
    for line in summary.splitlines():
        if line.startswith("solved "):
            return int(line.split()[1])
    return 0


def _row(name: str, seconds: float, peak: float, summary: str, cores: int) -> None:
    n = _problems(summary)
    print(
        f"{name:<34} {seconds:7.1f} s  {n / 1e6:6.2f} M problems  "
        f"{n / seconds / cores:9,.0f} /s/core  peak {peak:5.0f} MB"
    )


def dask_speedup(folder: Path) -> None:
    dask = shutil.which("dask", path=str(Path(sys.executable).parent))
    if dask is None:
        print("dask: the dask command is not installed next to this Python")
        return
    import distributed

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    quiet = {"env": ENV, "stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL}
    worker = [dask, "worker", address, "--host", "127.0.0.1", "--nworkers", "1"]
    worker += ["--nthreads", "1", "--no-dashboard"]
    procs = [
        subprocess.Popen(
            [dask, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
            **quiet,
        )
    ]

    def wait_for(n: int) -> None:
        with distributed.Client(address, timeout="60s") as client:
            while len(client.scheduler_info()["workers"]) < n:
                time.sleep(0.2)

    try:
        procs.append(subprocess.Popen(worker, cwd=folder, **quiet))
        wait_for(1)
        args = ("--resolution", "0.05", "--scheduler", address)
        one, _, summary = reach(folder / "dask1.h5", *args)
        _row("Dask, 1 worker, 5 cm", one, 0, summary, 1)
        procs.append(subprocess.Popen(worker, cwd=folder, **quiet))
        wait_for(2)
        two, _, summary = reach(folder / "dask2.h5", *args)
        _row("Dask, 2 workers, 5 cm", two, 0, summary, 2)
        print(f"Dask speed-up, 2 workers against 1: {one / two:.2f}x (target >= 1.7x)")
    finally:
        for p in reversed(procs):
            p.terminate()
            p.wait(timeout=30)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--skip-fine", action="store_true", help="no 2.5 cm map")
    parser.add_argument("--skip-dask", action="store_true", help="no Dask cluster")
    args = parser.parse_args()
    cores = os.cpu_count() or 1
    print(f"UR5e, 50 orientations per voxel; {cores} cores; load {os.getloadavg()[0]:.1f}")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        s, peak, summary = reach(folder / "m5.h5", "--resolution", "0.05", "--processes", "1")
        _row("5 cm, one process", s, peak, summary, 1)
        if not args.skip_fine:
            s, peak, summary = reach(folder / "m25.h5", "--resolution", "0.025")
            _row(f"2.5 cm, {cores} processes", s, peak, summary, cores)
            print(
                f"  files: {(folder / 'm25.h5').stat().st_size / 1e6:.0f} MB .h5, "
                f"{(folder / 'm25.npz').stat().st_size / 1e6:.0f} MB .npz"
            )
        if not args.skip_dask:
            dask_speedup(folder)
        print(f"load after: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
