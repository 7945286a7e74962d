"""`jobs.tasks.run_tasks` on the local cores and on real Dask clusters: a LocalCluster of
worker processes, and a scheduler and a worker started as the commands users start
(`dask scheduler`, `dask worker`); `kinematics bag --scheduler` gives, byte for byte, what it
gives on the local cores; a worker that dies mid-task has its task run again; an unreachable
scheduler is one line."""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent / "recordings"))
from recording_testing import write_recording  # noqa: E402

from kinematics_node.jobs.tasks import TaskError, run_tasks  # noqa: E402

distributed = pytest.importorskip("distributed", reason="pip install 'kinematics_service[dask]'")
HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]


def square(x: int) -> int:
    if x == 3:
        raise ValueError("three is refused")
    return x * x


def die_once(marker: str) -> int:
    """Kills its worker process the first time it runs (the marker file says it did)."""
    if not os.path.exists(marker):
        Path(marker).write_text("died")
        os._exit(1)
    return os.getpid()


def batch_faults(arrays: int) -> int:
    """Page faults of a batch's working arrays (2 MB each, made and freed `arrays` times)."""
    import resource

    import numpy as np

    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    for _ in range(arrays):
        np.ones(250_000).sum()
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before


def test_a_worker_under_dasks_malloc_trim_setting_reuses_its_batches_memory():
    """A Dask nanny starts its workers with MALLOC_TRIM_THRESHOLD_=65536, which maps every array
    over 128 KiB afresh: each 2 MB array then faults in its 512 pages again (about 100,000 faults
    for 200 arrays; a map's chunk ran at half speed). The task runner's workers keep them."""
    code = (
        "from kinematics_node.jobs.tasks import run_tasks\n"
        "from test_tasks import batch_faults\n"
        "print(next(iter(run_tasks(batch_faults, [200], processes=1))).result)\n"
    )
    env = dict(os.environ, MALLOC_TRIM_THRESHOLD_="65536")
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), str(HERE), env.get("PYTHONPATH", "")])
    done = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr
    assert int(done.stdout) < 10_000, done.stdout


def _outcomes(**kwargs):
    got = {o.item: o for o in run_tasks(square, [1, 2, 3, 4], **kwargs)}
    assert {k: o.result for k, o in got.items() if o.error is None} == {1: 1, 2: 4, 4: 16}
    assert str(got[3].error) == "three is refused"


def test_local_cores_give_every_outcome():
    _outcomes(processes=2)


@pytest.fixture(scope="module")
def cluster():
    """A LocalCluster of two worker processes on loopback; the tests' modules importable."""
    os.environ["PYTHONPATH"] = os.pathsep.join(
        [str(HERE), str(ROOT), os.environ.get("PYTHONPATH", "")]
    )
    with distributed.LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        host="127.0.0.1",
        dashboard_address=None,
    ) as c:
        yield c


def test_a_local_cluster_gives_the_same_outcomes(cluster):
    _outcomes(scheduler=cluster.scheduler_address)


def test_a_worker_that_dies_has_its_task_run_again(cluster, tmp_path):
    (outcome,) = run_tasks(
        die_once, [str(tmp_path / "marker")], scheduler=cluster.scheduler_address
    )
    assert outcome.error is None and isinstance(outcome.result, int)
    assert (tmp_path / "marker").read_text() == "died"


def test_an_unreachable_scheduler_is_one_line():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # nobody listens here once the socket is closed
    with pytest.raises(
        TaskError, match=rf"cannot reach the Dask scheduler at tcp://127.0.0.1:{port}"
    ):
        list(run_tasks(square, [1], scheduler=f"tcp://127.0.0.1:{port}", connect_timeout_s=1.0))


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _dask() -> list[str]:
    found = shutil.which("dask", path=str(Path(sys.executable).parent))
    if found is None:
        pytest.skip("the dask command is not installed next to this Python")
    return [found]


def test_kinematics_bag_on_a_scheduler_and_worker_started_as_commands(tmp_path):
    runs = tmp_path / "runs"
    runs.mkdir()
    for name, count in (("morning", 120), ("evening", 80)):
        write_recording(runs / name, count=count)
    tip = ["--tip", "panda_hand_tcp"]
    kinematics = [sys.executable, "-m", "kinematics_node.cli", "bag", str(runs), *tip]
    local = subprocess.run(
        [*kinematics, "--out", str(tmp_path / "local")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert local.returncode == 0, local.stderr
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    env = dict(
        os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])
    )
    common = ["--no-dashboard"]
    scheduler = subprocess.Popen(
        [*_dask(), "scheduler", "--host", "127.0.0.1", "--port", str(port), *common],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    worker = subprocess.Popen(
        [
            *_dask(),
            "worker",
            address,
            "--host",
            "127.0.0.1",
            "--nworkers",
            "1",
            "--nthreads",
            "1",
            *common,
        ],
        env=env,
        cwd=tmp_path,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        deadline = time.monotonic() + 60
        with distributed.Client(address, timeout="30s") as client:
            while not client.scheduler_info()["workers"]:
                assert time.monotonic() < deadline, "the worker never joined the scheduler"
                time.sleep(0.2)
        remote = subprocess.run(
            [*kinematics, "--out", str(tmp_path / "dask"), "--scheduler", address],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=300,
            env=env,
        )
        assert remote.returncode == 0, remote.stderr
    finally:
        for process in (worker, scheduler):
            process.terminate()
            process.wait(timeout=30)
    for name in ("morning", "evening"):
        assert (tmp_path / "dask" / name / f"{name}.mcap").read_bytes() == (
            tmp_path / "local" / name / f"{name}.mcap"
        ).read_bytes()
    reports = remote.stdout.replace(str(tmp_path / "dask"), str(tmp_path / "local"))
    assert sorted(reports.splitlines()) == sorted(local.stdout.splitlines())
