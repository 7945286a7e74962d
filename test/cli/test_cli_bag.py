"""`kinematics record-demo` and `kinematics bag` as a user runs them: a recording of the simulated
arm, its kinematics with a report, a picture and a table; several recordings on the local cores
give what one at a time gives; each refusal is one line, exit status 1."""

from __future__ import annotations

import csv
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rosbags.rosbag2", reason="pip install rosbags")
from rosbags.rosbag2 import Reader  # noqa: E402

from kinematics_node.cli.main import main  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]


def _messages(path: Path) -> list[tuple[str, int, bytes]]:
    with Reader(path) as reader:
        return sorted((c.topic, t, bytes(d)) for c, t, d in reader.messages())


@pytest.fixture(scope="module")
def demo(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("rec") / "demo_run"
    assert main(["record-demo", str(path), "--duration", "3", "--rate", "500"]) == 0
    return path


def test_the_readme_lines_record_and_process_a_run(demo, tmp_path, capsys):
    out, picture, table = tmp_path / "kin", tmp_path / "run.png", tmp_path / "run.csv"
    code = main(["bag", str(demo), "--out", str(out), "--plot", str(picture), "--csv", str(table)])
    text = capsys.readouterr().out
    assert code == 0
    assert "1500 on /ee_pose, 1500 on /ee_twist, 1500 on /tf, 1 on /tf_static" in text
    assert "chain base_link -> tool0 (6 joints)" in text and "(500.0 Hz)" in text
    assert "near a singularity" in text and "tool peak speed" in text
    assert picture.stat().st_size > 10_000
    with table.open() as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 1500
    # the table's pose is the recording's ee_pose
    poses = [m for m in _messages(out) if m[0] == "/ee_pose"]
    last = np.frombuffer(poses[-1][2][-56:], "<f8")
    np.testing.assert_array_equal(
        last, [float(rows[-1][k]) for k in ("x", "y", "z", "qx", "qy", "qz", "qw")]
    )


def test_a_folder_of_recordings_runs_each_and_gives_what_one_at_a_time_gives(demo, tmp_path):
    runs = tmp_path / "runs"
    runs.mkdir()
    for name in ("a", "b"):
        os.symlink(demo, runs / name)
    assert main(["bag", str(runs), "--out", str(tmp_path / "outs"), "--jobs", "2"]) == 0
    assert main(["bag", str(demo), "--out", str(tmp_path / "one")]) == 0
    one = _messages(tmp_path / "one")
    assert _messages(tmp_path / "outs" / "a") == one == _messages(tmp_path / "outs" / "b")


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["bag", "nowhere", "--out", "x"], "nowhere: no such file or directory"),
        (["bag", "{demo}", "--out", "{demo}"], "exists: give --force"),
        (["bag", "{demo}", "--out", "{tmp}/o", "--joint-states", "js"], "no /js of type"),
        (["bag", "{demo}", "--out", "{tmp}/o", "--tip", "nope"], "was refused: .*nope"),
        (["bag", "{demo}", "--out", "{tmp}/o", "--urdf", "{tmp}/none.urdf"], "no such file"),
        (["bag", "{demo}", "--out", "{tmp}/o", "--singular-condition", "nan"], "finite number"),
        (["record-demo", "{tmp}/r", "--robot", "nope"], "unknown robot 'nope'"),
        (["record-demo", "{tmp}/r", "--duration", "0"], "expected 0 < duration"),
    ],
)
def test_refusals_are_one_line_with_status_1(demo, tmp_path, capsys, args, message):
    import re

    code = main([a.format(demo=demo, tmp=tmp_path) for a in args])
    err = capsys.readouterr().err
    assert code == 1
    assert err.count("\n") == 1 and err.startswith("kinematics: error: ")
    assert re.search(message, err), err
    assert not (tmp_path / "o").exists()


def test_without_rosbags_it_says_how_to_install_it(tmp_path):
    code = (
        "import sys; sys.modules['rosbags'] = None; from kinematics_node.cli.main import main; "
        f"sys.exit(main(['bag', {str(tmp_path)!r}, '--out', {str(tmp_path / 'o')!r}]))"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert run.returncode == 1
    assert run.stderr.strip() == (
        "kinematics: error: kinematics bag needs rosbags: pip install 'kinematics_service[bags]'"
    )
