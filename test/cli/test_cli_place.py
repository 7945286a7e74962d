"""`kinematics place MAP TASKS` end to end through main(): the ranking printed best first with
the verified counts, --json, --plot, and one-line refusals (bad task line, missing map, a robot
that is not the map's)."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "jobs" / "maps"))
from map_testing import save_npz, small_map  # noqa: E402

from kinematics_node.cli.main import main  # noqa: E402
from kinematics_node.core.rotations import quaternion_from_matrix  # noqa: E402
from kinematics_node.jobs.maps.placement import floor_pose  # noqa: E402
from kinematics_node.sim.robots import load_robot  # noqa: E402


@pytest.fixture
def files(tmp_path: Path) -> tuple[Path, Path]:
    m = small_map()
    map_path = tmp_path / "ur5e.npz"
    save_npz(m, map_path)
    chain = load_robot("ur5e")
    B = floor_pose(0.4, 0.2, math.radians(30.0))
    rng = np.random.default_rng(2)
    rows = ["x,y,z,qx,qy,qz,qw"]
    while len(rows) < 6:
        T = B @ chain.fk(rng.uniform(-math.pi, math.pi, 6))
        if T[2, 3] > 0.1:
            q = quaternion_from_matrix(T[:3, :3])
            rows.append(",".join(f"{v:.12g}" for v in (*T[:3, 3], *q)))
    tasks = tmp_path / "tasks.csv"
    tasks.write_text("\n".join(rows) + "\n")
    return map_path, tasks


def test_ranking_is_printed_with_verified_counts(files, capsys) -> None:
    map_path, tasks = files
    assert main(["place", str(map_path), str(tasks), "--top", "3"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert "floor placements scored against 5 task poses" in out[0]
    rows = out[2:5]
    assert len(rows) == 3 and rows[0].split()[0] == "1"
    assert "5/5 verified" in rows[0]


def test_json_and_plot(files, tmp_path, capsys) -> None:
    pytest.importorskip("matplotlib", reason="pip install 'kinematics_service[demo]'")
    map_path, tasks = files
    picture = tmp_path / "place.png"
    assert main(["place", str(map_path), str(tasks), "--json", "--plot", str(picture)]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["tasks"] == 5 and len(data["placements"]) == 10
    assert data["placements"][0]["verified"] == 5
    assert picture.read_bytes()[:4] == b"\x89PNG"


def test_refusals_are_one_line(files, tmp_path, capsys) -> None:
    map_path, tasks = files
    bad = tmp_path / "bad.csv"
    bad.write_text("0.4,0,0.3,0,0,0,1\n0.4,0,0.3,0,0,1\n")
    assert main(["place", str(map_path), str(bad)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "line 2: 6 values" in err
    assert main(["place", str(tmp_path / "none.h5"), str(tasks)]) == 1
    assert "no map at" in capsys.readouterr().err
    assert main(["place", str(map_path), str(tasks), "--robot", "panda"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "panda_link0" in err
    assert main(["place", str(map_path), str(tasks), "--top", "0"]) == 2
