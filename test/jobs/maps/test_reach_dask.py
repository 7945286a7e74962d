"""The map on a real Dask cluster: `dask scheduler` and two `dask worker` processes started as
the commands users start; the map equals the local one bit for bit (every dataset and
attribute), through the library and through `kinematics reach --scheduler`, and a worker killed
mid-map (SIGKILL to its process) has its chunks run again: the map is still whole and equal."""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from maps_testing import CLI_SMALL, ROOT, SMALL, assert_same_file, ur5e

from kinematics_node.jobs.maps.build import build_map

distributed = pytest.importorskip("distributed", reason="pip install 'kinematics_service[dask]'")
pytest.importorskip("h5py", reason="pip install 'kinematics_service[maps]'")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """A scheduler and two single-threaded workers, as commands, on loopback."""
    dask = shutil.which("dask", path=str(Path(sys.executable).parent))
    if dask is None:
        pytest.skip("the dask command is not installed next to this Python")
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    env = dict(
        os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])
    )
    quiet = {"env": env, "stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL}
    where = tmp_path_factory.mktemp("dask")
    processes = [
        subprocess.Popen(
            [dask, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
            **quiet,
        )
    ]
    worker = [dask, "worker", address, "--host", "127.0.0.1", "--nworkers", "1", "--nthreads"]
    for _ in range(2):
        processes.append(subprocess.Popen([*worker, "1", "--no-dashboard"], cwd=where, **quiet))
    try:
        deadline = time.monotonic() + 60
        with distributed.Client(address, timeout="30s") as client:
            while len(client.scheduler_info()["workers"]) < 2:
                assert time.monotonic() < deadline, "the workers never joined the scheduler"
                time.sleep(0.2)
        yield address
    finally:
        for process in reversed(processes):
            process.terminate()
            process.wait(timeout=30)


@pytest.fixture(scope="module")
def local_map(tmp_path_factory):
    out = tmp_path_factory.mktemp("local") / "ur5e.h5"
    build_map(ur5e(), out, processes=2, **SMALL)
    return out


def test_the_cluster_makes_the_local_map_bit_for_bit(cluster, local_map, tmp_path):
    out = tmp_path / "ur5e.h5"
    run = build_map(ur5e(), out, scheduler=cluster, **SMALL)
    assert run.kept == 0 and run.chunks == 26
    assert_same_file(out, local_map)


def test_kinematics_reach_on_the_cluster(cluster, local_map, tmp_path):
    out = tmp_path / "ur5e.h5"
    env = dict(
        os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])
    )
    done = subprocess.run(
        [sys.executable, "-m", "kinematics_node.cli", "reach", "--robot", "ur5e", *CLI_SMALL]
        + ["--out", str(out), "--scheduler", cluster],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[-1] == f"wrote {out} and {out.with_suffix('.npz')}"
    assert_same_file(out, local_map)


def test_a_worker_killed_mid_map_has_its_chunks_run_again(cluster, local_map, tmp_path):
    with distributed.Client(cluster, timeout="30s") as client:
        pids = client.run(os.getpid)  # the worker processes (each under its nanny)
    victim = sorted(pids.values())[0]
    killed = []

    def kill_once(done: int, total: int) -> None:
        if done == 1 and not killed:
            os.kill(victim, signal.SIGKILL)
            killed.append(victim)

    out = tmp_path / "ur5e.h5"
    # chunks of 4 voxels: 104 tasks, so the victim still has some when it dies
    settings = {**SMALL, "chunk_voxels": 4}
    run = build_map(ur5e(), out, scheduler=cluster, progress=kill_once, **settings)
    assert killed == [victim] and run.chunks == 104
    reference = tmp_path / "local.h5"
    build_map(ur5e(), reference, processes=2, **settings)
    assert_same_file(out, reference)
    with distributed.Client(cluster, timeout="30s") as client:
        assert victim not in client.run(os.getpid).values()  # it did die (its nanny restarted it)
