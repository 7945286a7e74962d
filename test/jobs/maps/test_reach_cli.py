"""`kinematics reach` as a user runs it, in a process of its own: the map and its summary, a real
Ctrl-C (SIGINT to the process) and a hard kill (SIGKILL) mid-map, each resumed by the same
command to the same file; its refusals, one line each without a traceback; without h5py."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest
from maps_testing import CLI_SMALL, ROOT, assert_same_file

from kinematics_node.jobs.maps.storage import read_map

pytest.importorskip("h5py", reason="pip install 'kinematics_service[maps]'")

REACH = [sys.executable, "-m", "kinematics_node.cli", "reach"]


def _run(args: list[str], code: str | None = None) -> subprocess.CompletedProcess[str]:
    env = dict(
        os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])
    )
    command = REACH + args if code is None else [sys.executable, "-c", code, *args]
    return subprocess.run(command, cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)


@pytest.fixture(scope="module")
def whole(tmp_path_factory):
    out = tmp_path_factory.mktemp("cli") / "ur5e.h5"
    done = _run(["--robot", "ur5e", *CLI_SMALL, "--processes", "2", "--out", str(out)])
    assert done.returncode == 0, done.stderr
    return out, done


def test_a_map_and_its_summary(whole):
    out, done = whole
    lines = done.stdout.splitlines()
    assert lines[0].startswith("ur5e base_link -> tool0: 413 voxels of 0.25 m x 12 orientations")
    m = read_map(out)
    share = 100.0 * m.reached.mean()
    assert f"reachable: {share:.1f} % of the 4956 poses" in lines[1]
    assert f"{int(m.reached.any(axis=1).sum())} voxels with D > 0" in lines[1]
    assert lines[2].startswith("solved 4956 IK problems in ")
    assert lines[3] == f"wrote {out} and {out.with_suffix('.npz')}"
    assert done.stderr == ""  # no progress bar off a terminal


def test_the_picture_and_the_markers_of_the_map_it_made(tmp_path):
    pytest.importorskip("matplotlib", reason="pip install 'kinematics_service[demo]'")
    reader = pytest.importorskip("mcap_ros2.reader", reason="mcap-ros2-support (test extra)")
    out, png, mcap = tmp_path / "m.npz", tmp_path / "m.png", tmp_path / "markers.mcap"
    done = _run(
        ["--robot", "ur5e", *CLI_SMALL, "--processes", "1", "--out", str(out)]
        + ["--plot", str(png), "--markers", str(mcap)]
    )
    assert done.returncode == 0, done.stderr
    assert png.stat().st_size > 10_000 and png.read_bytes()[:4] == b"\x89PNG"
    m = read_map(out)
    (msg,) = [d.ros_msg for d in reader.read_ros2_messages(str(mcap))]
    (cubes,) = msg.markers
    assert len(cubes.points) == int((m.index > 0).sum())
    assert cubes.header.frame_id == m.base_link
    # refused before any map is made: markers over an existing file
    again = _run(
        ["--robot", "ur5e", *CLI_SMALL, "--out", str(tmp_path / "n.npz")] + ["--markers", str(mcap)]
    )
    assert again.returncode == 1 and "exists" in again.stderr and "Traceback" not in again.stderr
    assert not (tmp_path / "n.npz").exists()


# The CLI's own process stops itself after its second chunk is written: a real signal, at a
# known point.
STOP_AFTER_TWO = """
import os, signal, sys
from kinematics_node.cli.main import main
from kinematics_node.jobs.maps import storage
write, calls = storage.MapWriter.write_chunk, []
def write_then_stop(self, *args):
    write(self, *args)
    calls.append(1)
    if len(calls) == 2:
        os.kill(os.getpid(), getattr(signal, sys.argv[1]))
storage.MapWriter.write_chunk = write_then_stop
sys.exit(main(["reach", *sys.argv[2:]]))
"""


@pytest.mark.parametrize("signal_name", ["SIGINT", "SIGKILL"])
def test_a_stopped_map_resumes_to_the_same_file(whole, tmp_path, signal_name):
    out = tmp_path / "ur5e.h5"
    args = ["--robot", "ur5e", *CLI_SMALL, "--processes", "2", "--out", str(out)]
    stopped = _run([signal_name, *args], code=STOP_AFTER_TWO)
    if signal_name == "SIGINT":
        assert stopped.returncode == 130
        assert stopped.stderr == (
            f"kinematics: interrupted: 2 of 26 chunks kept in {out}; run the same command again "
            "to finish\n"
        )
    else:
        assert stopped.returncode == -9
    assert not out.with_suffix(".npz").exists()
    again = _run(args)
    assert again.returncode == 0, again.stderr
    assert "(2 of 26 chunks kept from before)" in again.stdout
    assert_same_file(out, whole[0])


def test_without_h5py_h5_is_refused_and_npz_works(tmp_path):
    no_h5py = (
        "import sys; sys.modules['h5py'] = None\n"
        "from kinematics_node.cli.main import main\n"
        "sys.exit(main(['reach', *sys.argv[1:]]))\n"
    )
    base = ["--robot", "ur5e", *CLI_SMALL, "--processes", "1"]
    refused = _run([*base, "--out", str(tmp_path / "m.h5")], code=no_h5py)
    assert refused.returncode == 1
    assert refused.stderr == (
        "kinematics: error: HDF5 maps (.h5) need h5py: pip install 'kinematics_service[maps]' "
        "(or write .npz)\n"
    )
    assert list(tmp_path.iterdir()) == []
    done = _run([*base, "--out", str(tmp_path / "m.npz")], code=no_h5py)
    assert done.returncode == 0, done.stderr
    assert read_map(tmp_path / "m.npz").reached.shape == (413, 12)


@pytest.mark.parametrize(
    ("args", "status", "message"),
    [
        (["--resolution", "0"], 2, "argument --resolution: '0': expected a finite length > 0"),
        (["--resolution", "nan"], 2, "argument --resolution: 'nan': expected a finite length > 0"),
        (["--resolution", "-0.1"], 2, "expected a finite length > 0 [m]"),
        (["--directions", "0"], 2, "argument --directions: '0': expected a whole number ≥ 1"),
        (["--robot", "ur6"], 1, "kinematics: error: unknown robot 'ur6'"),
        (["--urdf", "missing.urdf"], 1, "kinematics: error: --urdf 'missing.urdf': no such file"),
        (["--tip", "nowhere"], 1, "kinematics: error: --tip: unknown link 'nowhere'"),
        (["--out", "map.txt"], 1, "the map file must end in .h5 or .npz"),
        (["--out", "no/such/folder/m.h5"], 1, "the folder no/such/folder does not exist"),
    ],
)
def test_bad_input_is_one_line(tmp_path, args, status, message):
    given = dict(zip(args[::2], args[1::2], strict=True))
    options = {"--robot": "ur5e", "--resolution": "0.3", "--out": str(tmp_path / "m.h5")}
    if "--urdf" in given:
        del options["--robot"]
    options.update(given)
    done = _run([x for pair in options.items() for x in pair])
    assert done.returncode == status
    assert message in done.stderr
    assert len(done.stderr.splitlines()) == 1, done.stderr
    assert "Traceback" not in done.stderr
    assert not (tmp_path / "m.h5").exists()


def test_the_help_names_the_options():
    done = _run(["--help"])
    assert done.returncode == 0
    for option in ("--resolution", "--directions", "--rolls", "--scheduler", "--chunk-voxels"):
        assert option in done.stdout
