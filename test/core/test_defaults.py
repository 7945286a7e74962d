"""One set of defaults: an empty base/tip link means the default (as in the node and the CLI),
`jacobian` defaults to the world frame (as `fk_jacobian`, the node and the CLI), `from_dh` takes
the list rows the README shows, and the README's library example runs as written."""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from kin_testing import erd_path

from kinematics_node.core import RobotDescriptionError, SerialChain
from kinematics_node.core.urdf import RobotDescription

REPO = Path(__file__).resolve().parents[2]
UR5 = "ur_description/urdf/ur5_robot.urdf"
Z1 = "z1_description/urdf/z1.urdf"


def test_empty_base_and_tip_mean_the_defaults() -> None:
    z1 = erd_path(Z1)  # one leaf: both links can default
    ref = SerialChain.from_urdf(z1)
    for base, tip in (("", ""), (None, ""), ("", None)):
        chain = SerialChain.from_urdf(z1, base_link=base, tip_link=tip)
        assert (chain.base_link, chain.tip_link) == (ref.base_link, ref.tip_link)
        np.testing.assert_array_equal(chain.S, ref.S)
    ur5 = erd_path(UR5)
    assert SerialChain.from_urdf(ur5, "", "tool0").base_link == "world"  # the root
    spec = RobotDescription(ur5).chain_spec("", "tool0")
    assert (spec.base_link, spec.tip_link) == ("world", "tool0")
    with pytest.raises(RobotDescriptionError, match="several leaf links"):
        SerialChain.from_urdf(ur5, "", "")  # the default tip is still ambiguous there


def test_jacobian_defaults_to_the_world_frame() -> None:
    chain = SerialChain.from_urdf(erd_path(UR5), tip_link="tool0")
    q = np.array([0.3, -1.1, 1.4, -0.6, 0.8, 0.2])
    J = chain.jacobian(q)
    np.testing.assert_array_equal(J, chain.jacobian(q, "world"))
    np.testing.assert_array_equal(J, chain.fk_jacobian(q)[1])
    assert not np.allclose(J, chain.jacobian(q, "space"))  # the default used to be "space"
    Q = np.stack((q, -q))
    np.testing.assert_array_equal(chain.jacobian(Q), chain.jacobian(Q, "world"))


def _scara_rows() -> tuple[list[dict], list[list]]:
    table = json.loads((REPO / "config/robots/scara_dh.json").read_text())["joints"]
    lists = [[r["a"], r["alpha"], r["d"], r["theta"], r["type"]] for r in table]
    return table, lists


def test_from_dh_takes_list_rows_a_alpha_d_theta_type() -> None:
    table, lists = _scara_rows()
    ref = SerialChain.from_dh(table)
    chain = SerialChain.from_dh(lists)
    # (list rows carry no limits: revolute joints are continuous, unlike the table's)
    assert chain.joint_types == ("continuous", "continuous", "prismatic", "continuous")
    assert chain.joint_names == ("joint1", "joint2", "joint3", "joint4")
    Q = np.random.default_rng(3).uniform(-1, 1, size=(20, 4))
    np.testing.assert_allclose(chain.fk(Q), ref.fk(Q), atol=1e-15)
    as_tuples = SerialChain.from_dh(tuple(tuple(r) for r in lists))
    np.testing.assert_allclose(as_tuples.fk(Q), ref.fk(Q), atol=1e-15)


def test_from_dh_takes_an_array_of_revolute_rows() -> None:
    # UR5e's published standard DH parameters (a, alpha, d, theta); the 5th value is optional
    rows = np.array(
        [
            [0.0, math.pi / 2, 0.1625, 0.0],
            [-0.425, 0.0, 0.0, 0.0],
            [-0.3922, 0.0, 0.0, 0.0],
            [0.0, math.pi / 2, 0.1333, 0.0],
            [0.0, -math.pi / 2, 0.0997, 0.0],
            [0.0, 0.0, 0.0996, 0.0],
        ]
    )
    from_array = SerialChain.from_dh(rows)
    from_lists = SerialChain.from_dh(rows.tolist())
    from_maps = SerialChain.from_dh(
        [dict(zip(("a", "alpha", "d", "theta"), r, strict=True)) for r in rows]
    )
    assert from_array.joint_types == ("continuous",) * 6
    Q = np.random.default_rng(4).uniform(-3, 3, size=(20, 6))
    for chain in (from_array, from_lists):
        np.testing.assert_allclose(chain.fk(Q), from_maps.fk(Q), atol=1e-15)
    # the arm's reach at home: a2 + a3 along x, d1 up, (d4, d5, d6) offsets
    np.testing.assert_allclose(from_array.fk(np.zeros(6))[:3, 3], [-0.8172, -0.2329, 0.0628])


@pytest.mark.parametrize(
    ("rows", "match"),
    [
        ([[0.1, 0.0, 0.2]], r"row 1 has 3 values.*a, alpha, d, theta\[, type\]"),
        ([[0.1, 0.0, 0.2, 0.0, "R", "extra"]], r"row 1 has 6 values"),
        ([[0.1, 0.0, 0.2, 0.0, "Q"]], r"row 1: type must be revolute/R or prismatic/P"),
        ([[0.1, "x", 0.2, 0.0]], r"row 1: 'alpha' must be a number"),
        (["abc"], r"row 1 must be a list a, alpha, d, theta\[, type\] or a mapping"),
        (np.zeros(4), r"must be 2-D"),
    ],
)
def test_bad_list_rows_are_refused_naming_the_row(rows, match) -> None:
    with pytest.raises(RobotDescriptionError, match=match):
        SerialChain.from_dh(rows)


def _readme_library_blocks() -> list[str]:
    text = (REPO / "README.md").read_text()
    section = re.search(r"^## Library\n(.*?)(?=^## )", text, re.S | re.M)
    assert section, "README.md has no '## Library' section"
    return re.findall(r"```python\n(.*?)```", section.group(1), re.S)


def test_readme_library_example_runs_as_written() -> None:
    """The Python of the README's Library section, verbatim, from the repository root (where
    its paths are), in a fresh interpreter."""
    blocks = _readme_library_blocks()
    assert blocks, "README.md's Library section has no python block"
    for code in blocks:
        run = subprocess.run(
            [sys.executable, "-c", code],
            cwd=REPO,
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert run.returncode == 0, f"README example failed:\n{code}\n{run.stderr[-2000:]}"
