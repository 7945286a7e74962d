"""The CLI's parsed-description cache: same answers, no yourdfpy/scipy import on a hit, no stale
entries after an edit."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from kinematics_node.cli.chain_cache import chain_from_urdf_file
from kinematics_node.core import SerialChain
from kinematics_node.sim.robots import robot_path


def test_hit_equals_parse_and_an_edit_is_a_new_entry(tmp_path, monkeypatch):
    monkeypatch.setenv("KINEMATICS_CACHE_DIR", str(tmp_path / "cache"))
    f = tmp_path / "arm.urdf"
    f.write_text(robot_path("planar3r").read_text(encoding="utf-8"), encoding="utf-8")
    q = np.array([0.2, -0.3, 0.4])
    first = chain_from_urdf_file(f, None, None)
    assert len(list((tmp_path / "cache").glob("*.json"))) == 1
    again = chain_from_urdf_file(f, None, None)
    np.testing.assert_array_equal(again.fk(q), SerialChain.from_urdf(f).fk(q))
    assert again.joint_names == first.joint_names and again.link_names == first.link_names
    np.testing.assert_array_equal(again.lower, first.lower)
    f.write_text(f.read_text().replace('xyz="0.5 0 0"', 'xyz="0.6 0 0"', 1), encoding="utf-8")
    edited = chain_from_urdf_file(f, None, None)
    np.testing.assert_array_equal(edited.fk(q), SerialChain.from_urdf(f).fk(q))
    assert not np.array_equal(edited.fk(q), first.fk(q))


_FK_IMPORTS = (
    "import sys\n"
    "from kinematics_node.cli.main import main\n"
    "assert main(['fk', '--robot', 'ur5e', '--q', '0,0,0,0,0,0']) == 0\n"
    "print(sorted(m for m in ('scipy', 'yourdfpy', 'trimesh', 'xacro') if m in sys.modules))\n"
)


def _heavy_imports_of_fk(env: dict[str, str]) -> str:
    """The heavy modules a `kinematics fk` run in a new process imported, as it prints them."""
    run = subprocess.run(
        [sys.executable, "-c", _FK_IMPORTS], env=env, capture_output=True, text=True
    )
    assert run.stdout, run.stderr
    return run.stdout.splitlines()[-1]


def test_a_warm_fk_call_imports_neither_yourdfpy_nor_scipy(tmp_path):
    env = dict(os.environ, KINEMATICS_CACHE_DIR=str(tmp_path))
    assert "yourdfpy" in _heavy_imports_of_fk(env)  # cold
    assert _heavy_imports_of_fk(env) == "[]"  # warm


def test_the_family_detected_by_ik_is_kept_and_taken_back_only_by_the_same_detector(
    tmp_path, monkeypatch
):
    """`detect_family` keeps the detected closed-form family in the chain's entry; on the next
    load it installs that without detecting (a UR5e here; Baxter's run of `kinematics ik` went
    from 0.78 to ~0.55 s), and not when the detection's source differs."""
    from kinematics_node.cli import chain_cache
    from kinematics_node.core.ik.closed_form import detection, family_of

    monkeypatch.setenv("KINEMATICS_CACHE_DIR", str(tmp_path / "cache"))
    path = robot_path("ur5e")
    first = chain_from_urdf_file(path, None, None)
    chain_cache.detect_family(first)
    (entry,) = (tmp_path / "cache").glob("*.json")
    kept = json.loads(entry.read_text())["family"]
    assert kept["value"][0] == "three_parallel" and kept["detector"]

    def no_detection(chain):
        raise AssertionError("detected again")

    monkeypatch.setattr(detection, "detect", no_detection)
    again = chain_from_urdf_file(path, None, None)
    chain_cache.detect_family(again)
    assert family_of(again).name == "three_parallel"
    q = np.array([0.3, -1.1, 1.2, -0.4, 0.9, 0.2])
    assert again.ik_all(again.fk(q)).success

    monkeypatch.setattr(chain_cache, "_detector_fingerprint", lambda: "another detector")
    other = chain_from_urdf_file(path, None, None)
    with pytest.raises(AssertionError, match="detected again"):
        chain_cache.detect_family(other)


def test_a_chain_without_a_closed_form_keeps_that_too(tmp_path, monkeypatch):
    from kinematics_node.cli import chain_cache
    from kinematics_node.core.ik.closed_form import detection, family_of

    monkeypatch.setenv("KINEMATICS_CACHE_DIR", str(tmp_path / "cache"))
    path = robot_path("planar3r")
    chain_cache.detect_family(chain_from_urdf_file(path, None, None))
    monkeypatch.setattr(detection, "detect", lambda chain: 1 / 0)
    again = chain_from_urdf_file(path, None, None)
    chain_cache.detect_family(again)
    assert family_of(again) is None


def test_a_kept_family_does_not_make_a_warm_fk_call_import_scipy(tmp_path):
    """The family that `ik` kept is installed by `ik` alone (the closed form imports SciPy)."""
    env = dict(os.environ, KINEMATICS_CACHE_DIR=str(tmp_path))
    ik = "from kinematics_node.cli.main import main\nmain(['ik', '--robot', 'ur5e', '--target', '0.3,0.2,0.4,0,1,0,0'])\n"
    subprocess.run([sys.executable, "-c", ik], env=env, capture_output=True, text=True, check=True)
    (entry,) = tmp_path.glob("*.json")
    assert json.loads(entry.read_text())["family"]["value"][0] == "three_parallel"
    assert _heavy_imports_of_fk(env) == "[]"
