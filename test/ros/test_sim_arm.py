"""The sim_arm node's module (its message handling: msg_adapters/test_joint_commands.py; its pure
modules import without rclpy: test_import_graph.py)."""

from __future__ import annotations

import ast
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def test_sim_arm_node_parses_and_has_a_main():
    source = (REPO / "kinematics_node" / "ros" / "sim_arm.py").read_text(encoding="utf-8")
    tree = ast.parse(source)
    assert any(isinstance(n, ast.FunctionDef) and n.name == "main" for n in tree.body)
