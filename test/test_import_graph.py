"""The packages' import graph, read from the source with `ast` (nothing is imported).

Every import counts: at module level, inside functions, and under ``if TYPE_CHECKING``. The graph
has no circle, and imports only run down the layers of DESIGN.md: node and service code →
msg_adapters → kinematics_node.core, which imports nothing of ours above it. Nothing outside
core/chain.py touches a private member of `SerialChain`, and no module imports another module's
private name.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("kinematics_node", "msg_adapters")


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _sources() -> dict[str, Path]:
    return {_module_name(p): p for pkg in PACKAGES for p in sorted((ROOT / pkg).rglob("*.py"))}


def _imports(module: str, path: Path, known: set[str]) -> list[tuple[str, list[str], int]]:
    """(imported module, names imported from it, line) for every import statement in `path`."""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out += [(alias.name, [], node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            names = [alias.name for alias in node.names]
            # `from . import so3` imports the module kinematics_node.core.so3
            subs = [f"{target}.{n}" for n in names if f"{target}.{n}" in known]
            out += [(s, [], node.lineno) for s in subs]
            rest = [n for n in names if f"{target}.{n}" not in known]
            if rest or not subs:
                out.append((target, rest, node.lineno))
    return out


def _graph() -> dict[str, set[str]]:
    sources = _sources()
    known = set(sources)
    graph: dict[str, set[str]] = {m: set() for m in sources}
    for module, path in sources.items():
        for target, _, _ in _imports(module, path, known):
            while target and target not in known:  # an attribute-style name: its module
                target = target.rpartition(".")[0]
            if target and target != module:
                graph[module].add(target)
    return graph


def _layer(module: str) -> int:
    if module.startswith("kinematics_node.core"):
        return 0
    if module.startswith("msg_adapters"):
        return 1
    return 2


def test_the_graph_is_read_from_every_module():
    graph = _graph()
    assert "kinematics_node.core.chain" in graph["kinematics_node.core"]
    assert "kinematics_node.core.model" in graph["kinematics_node.core.urdf"]
    assert "kinematics_node.core.so3" in graph["msg_adapters.geometry"]
    assert len(graph) >= 40


def test_the_import_graph_has_no_circle():
    graph = _graph()
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    cycles: list[list[str]] = []

    def visit(m: str, path: list[str]) -> None:
        state[m] = 1
        for t in sorted(graph[m]):
            if state.get(t) == 1:
                cycles.append(path[path.index(t) :] + [t] if t in path else [m, t])
            elif t not in state:
                visit(t, path + [t])
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m, [m])
    assert cycles == []


def test_imports_only_run_down_the_layers():
    """core → nothing of ours above it; msg_adapters → core only; package __init__ files aside,
    a package's parent is never imported by its children."""
    graph = _graph()
    upward = [
        (m, t)
        for m, targets in graph.items()
        for t in targets
        if _layer(t) > _layer(m) or (t in PACKAGES and m.startswith(t + ".") and _layer(m) == 0)
    ]
    assert upward == []
    # the core imports no package's __init__ above itself either (kinematics_node.__init__)
    assert all("kinematics_node" not in graph[m] for m in graph if _layer(m) == 0)


def _chain_privates() -> set[str]:
    tree = ast.parse((ROOT / "kinematics_node/core/chain.py").read_text(encoding="utf-8"))
    (cls,) = [n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == "SerialChain"]
    names = set()
    for node in cls.body:
        if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names.add(node.target.id)
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            names.add(node.name)
    return {n for n in names if n.startswith("_") and not n.startswith("__")}


def _python_files() -> list[Path]:
    dirs = [*PACKAGES, "benchmarks", "test"]
    return [p for d in dirs for p in sorted((ROOT / d).rglob("*.py"))]


def test_nothing_outside_chain_py_touches_a_private_member_of_the_chain():
    privates = _chain_privates()
    assert {"_kernel", "_G"} <= privates  # the check looks at the real members
    chain_py = ROOT / "kinematics_node/core/chain.py"
    hits = []
    for path in _python_files():
        if path == chain_py:
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Attribute) and node.attr in privates:
                owner = node.value
                if not (isinstance(owner, ast.Name) and owner.id in ("self", "cls")):
                    hits.append(f"{path.relative_to(ROOT)}:{node.lineno} .{node.attr}")
    assert hits == []


@pytest.mark.parametrize("top", [*PACKAGES, "benchmarks"])
def test_no_module_imports_a_private_name_of_another(top):
    sources = _sources()
    known = set(sources)
    hits = []
    for path in sorted((ROOT / top).rglob("*.py")):
        module = _module_name(path)
        for target, names, line in _imports(module, path, known):
            private = [n for n in names if n.startswith("_") and not n.startswith("__")]
            if private:
                hits.append(f"{path.relative_to(ROOT)}:{line} {target}: {private}")
    assert hits == []


#: Modules that must import without ROS, by layer: the core, the adapters, the node's plain logic.
WITHOUT_ROS = {
    "core": ("kinematics_node.core",),
    "msg_adapters": ("msg_adapters", "msg_adapters.joint_commands"),
    "node_logic": (
        "kinematics_node.service",
        "kinematics_node.ee_state",
        "kinematics_node.simulator",
        "kinematics_node.robots",
    ),
    # the `kinematics` command line (its `ros` command imports rclpy only when it runs) and what
    # the installed executables do before ROS starts (--help)
    "command_lines": (
        "kinematics_node.cli",
        "kinematics_node.ros_cli",
        "kinematics_node.ros_client",
        "kinematics_node.executables",
    ),
}
ROS_PACKAGES = ("rclpy", "rosidl_runtime_py", "geometry_msgs", "sensor_msgs")


@pytest.mark.parametrize("layer", list(WITHOUT_ROS))
def test_the_pure_modules_import_without_rclpy_or_ros_messages(layer: str) -> None:
    """Imported for real in a fresh interpreter, one layer at a time (so a failure names the
    layer that pulled ROS in): no ROS Python package is loaded on the way."""
    code = (
        f"import sys, {', '.join(WITHOUT_ROS[layer])}; "
        f"print(sorted(m for m in sys.modules if m.split('.')[0] in {ROS_PACKAGES!r}))"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"
