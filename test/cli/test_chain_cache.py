"""The CLI's parsed-description cache: same answers, no yourdfpy/scipy import on a hit, no stale
entries after an edit."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np

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


def test_a_warm_fk_call_imports_neither_yourdfpy_nor_scipy(tmp_path):
    env = dict(os.environ, KINEMATICS_CACHE_DIR=str(tmp_path))
    code = (
        "import sys\n"
        "from kinematics_node.cli.main import main\n"
        "assert main(['fk', '--robot', 'ur5e', '--q', '0,0,0,0,0,0']) == 0\n"
        "print(sorted(m for m in ('scipy', 'yourdfpy', 'trimesh', 'xacro') if m in sys.modules))\n"
    )
    cold = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    warm = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert "yourdfpy" in cold.stdout.splitlines()[-1]
    assert warm.stdout.splitlines()[-1] == "[]", warm.stderr
