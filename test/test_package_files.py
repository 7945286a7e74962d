"""The ROS package files are consistent with the code: package.xml declares what the code imports,
CMakeLists.txt builds every srv and installs what the launch files use, the parameter file matches
the declared parameters, the executables and setup.py's console script name existing entry points
(test_import_graph.py keeps the core free of rclpy)."""

from __future__ import annotations

import ast
import re
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CMAKE = (ROOT / "CMakeLists.txt").read_text(encoding="utf-8")

# Imports that are not ROS packages: the standard library, our own packages, pip-only packages.
OWN = {"kinematics_node", "msg_adapters", "kinematics_service"}
# imports without a rosdep key: ruckig, the servo's smoothing (pip install ruckig)
PIP_ONLY: set[str] = {"ruckig"}
ROSDEP_KEY = {
    "yourdfpy": "python3-yourdfpy-pip",  # rosdep's pip key (ros/rosdistro rosdep/python.yaml)
    "numpy": "python3-numpy",
    "scipy": "python3-scipy",
    "pytest": "python3-pytest",
    "yaml": "python3-yaml",
    "matplotlib": "python3-matplotlib",
    "tqdm": "python3-tqdm",
    "h5py": "python3-h5py",
}


def _package():
    catkin_pkg = pytest.importorskip("catkin_pkg.package", reason="pip install catkin_pkg")
    return catkin_pkg.parse_package(str(ROOT / "package.xml"))


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
    return names


def _declared(pkg, *kinds: str) -> set[str]:
    return {d.name for kind in kinds for d in getattr(pkg, kind)}


def test_package_xml_identity():
    pkg = _package()
    pkg.validate()
    assert pkg.name == "kinematics_service"
    assert pkg.package_format == 3
    assert pkg.get_build_type() == "ament_cmake"
    assert "rosidl_interface_packages" in {g.name for g in pkg.member_of_groups}
    assert "rosidl_default_generators" in _declared(pkg, "buildtool_depends")
    assert "rosidl_default_runtime" in _declared(pkg, "exec_depends")
    assert "yourdfpy" in (ROOT / "package.xml").read_text(encoding="utf-8")  # the pip note


def test_package_xml_declares_every_ros_package_the_code_imports():
    pkg = _package()
    run = _declared(pkg, "exec_depends", "run_depends")
    tests = _declared(pkg, "test_depends") | run
    stdlib = set(sys.stdlib_module_names)
    sources = [
        (p, run) for d in ("kinematics_node", "msg_adapters") for p in (ROOT / d).rglob("*.py")
    ]
    sources += [(p, run) for p in (ROOT / "launch").glob("*.py")]
    sources += [(ROOT / "test/launch/test_launch_integration.py", tests)]
    missing = []
    for path, declared in sources:
        for name in _imports(path) - stdlib - OWN - PIP_ONLY - {"__future__"}:
            key = ROSDEP_KEY.get(name, name)
            # pip-only optional extras of the ROS-free jobs (package.xml says so), and test tools
            optional = ("pytest", "catkin_pkg", "rosbags", "pinocchio", "distributed")
            if name in optional and declared is run:
                continue
            if key not in declared:
                missing.append(f"{path.relative_to(ROOT)} imports {name} (rosdep key {key})")
    # Message packages imported dynamically by MessageTypes.from_rclpy().
    from msg_adapters.types import MESSAGE_NAMES

    for full in MESSAGE_NAMES.values():
        if full.split("/")[0] not in run:
            missing.append(f"msg_adapters.types uses {full}")
    assert missing == []


def test_every_srv_file_is_generated_and_depends_on_its_packages():
    listed = set(re.findall(r'"(srv/\w+\.srv)"', CMAKE))
    on_disk = {f"srv/{p.name}" for p in (ROOT / "srv").glob("*.srv")}
    assert (
        listed == on_disk == {"srv/ComputeFK.srv", "srv/ComputeJacobian.srv", "srv/ComputeIK.srv"}
    )
    used = set()
    for p in (ROOT / "srv").glob("*.srv"):
        used |= set(re.findall(r"^(\w+)/\w+", p.read_text(encoding="utf-8"), re.MULTILINE))
    deps = set(re.search(r"DEPENDENCIES([\w\s]+)\)", CMAKE).group(1).split())
    assert used <= deps, used - deps
    pkg = _package()
    assert used <= _declared(pkg, "build_depends") & _declared(pkg, "exec_depends")


def _installed_dirs() -> set[str]:
    dirs = set()
    for block in re.findall(r"install\(DIRECTORY([^)]*)DESTINATION", CMAKE):
        dirs |= set(block.split())
    return dirs


def _installed_programs() -> set[str]:
    """scripts/<name> of every program installed (CMake installs their copies in the build
    directory, ${CMAKE_CURRENT_BINARY_DIR}/scripts/<name>, whose shebang it sets)."""
    progs = set()
    for block in re.findall(r"install\(PROGRAMS([^)]*)DESTINATION", CMAKE):
        progs |= {p.strip('"').replace("${CMAKE_CURRENT_BINARY_DIR}/", "") for p in block.split()}
    return progs


def test_cmake_installs_everything_the_launch_files_reference():
    launch_files = sorted((ROOT / "launch").glob("*.launch.py"))
    assert launch_files
    assert "launch" in _installed_dirs()
    for lf in launch_files:
        text = lf.read_text(encoding="utf-8")
        compile(text, str(lf), "exec")
        # Share files: [FindPackageShare("kinematics_service"), "dir", "file"]
        for parts in re.findall(
            r'FindPackageShare\("kinematics_service"\),\s*((?:"[^"]+",?\s*)+)', text
        ):
            rel = Path(*re.findall(r'"([^"]+)"', parts))
            assert rel.parts[0] in _installed_dirs(), f"{lf.name}: {rel} not installed"
            assert (ROOT / rel).exists(), f"{lf.name}: {rel} missing"
        for exe in re.findall(r'executable="([^"]+)"', text):
            pkg_block = text[: text.index(f'executable="{exe}"')]
            if pkg_block.rstrip().endswith('package="kinematics_service",'):
                assert f"scripts/{exe}" in _installed_programs(), exe


def test_executable_wrappers_call_existing_entry_points():
    for script in sorted(_installed_programs()):
        path = ROOT / script
        assert path.exists() and path.stat().st_mode & 0o111, script
        text = path.read_text(encoding="utf-8")
        assert text.startswith("#!/usr/bin/env python3")
        found = re.search(r"from ([\w.]+) import main", text) or re.search(
            r'run\("\w+", "([\w.]+)"\)', text
        )
        module = found.group(1)
        module_file = ROOT / (module.replace(".", "/") + ".py")
        assert module_file.exists(), module
        assert re.search(r"^def main\(", module_file.read_text(encoding="utf-8"), re.MULTILINE)


def test_setup_py_console_script_is_the_installed_kinematics_command():
    """pip's `kinematics` (setup.py) and colcon's (scripts/kinematics) run the same main()."""
    setup = (ROOT / "setup.py").read_text(encoding="utf-8")
    (entry,) = re.findall(r'"kinematics = ([\w.]+):(\w+)"', setup)
    module, function = entry
    module_file = ROOT / (module.replace(".", "/") + ".py")
    assert module_file.exists(), module
    assert re.search(rf"^def {function}\(", module_file.read_text(encoding="utf-8"), re.MULTILINE)
    script = (ROOT / "scripts" / "kinematics").read_text(encoding="utf-8")
    assert re.search(rf"from {re.escape(module)} import {function}\b", script)


def test_cmake_test_paths_exist():
    """The tests CMakeLists.txt hands to ament (BUILD_TESTING) are where it says."""
    listed = CMAKE[CMAKE.index("foreach(path") :].split(")")[0]
    paths = re.findall(r"\btest/[\w/.]+", listed)
    tests = [*paths, *re.findall(r"add_launch_test\((\S+)", CMAKE)]
    assert len(tests) >= 5
    assert [t for t in tests if not (ROOT / t).exists()] == []


def test_cmake_installs_the_python_packages_and_exports_the_runtime():
    for pkg in ("kinematics_node", "msg_adapters"):
        assert f"ament_python_install_package({pkg})" in CMAKE
    assert "ament_export_dependencies(rosidl_default_runtime)" in CMAKE
    assert "config" in _installed_dirs()


def test_parameter_file_matches_the_declared_parameters():
    yaml = pytest.importorskip("yaml")
    from kinematics_node.service.parameters import SPECS, validate_parameters

    doc = yaml.safe_load((ROOT / "config/kinematics.yaml").read_text(encoding="utf-8"))
    (node_key,) = doc
    assert node_key.split("/")[-1] == "kinematics_node"
    flat = {}

    def walk(d, prefix=""):
        for k, v in d.items():
            if isinstance(v, dict):
                walk(v, f"{prefix}{k}.")
            else:
                flat[prefix + k] = v

    walk(doc[node_key]["ros__parameters"])
    assert set(flat) == set(SPECS)
    assert validate_parameters(flat) is None
    for name, value in flat.items():  # ROS refuses an int for a double parameter
        assert type(value) is type(SPECS[name].default), name
        assert value == SPECS[name].default, name


@pytest.mark.parametrize("message", ["TFMessage", "TF2Error"])
def test_the_tf2_msgs_built_for_ros_from_pypi_is_ros2s(message):
    """tools/interfaces/tf2_msgs (built where no wheel has tf2_msgs) defines its messages as
    ROS 2 does, field for field and constant for constant: rosbags' Jazzy definitions, so the
    type hash the node announces on /tf is the real one (test/live/test_node_markers.py checks
    the hash on the wire)."""
    typesys = pytest.importorskip("rosbags.typesys", reason="rosbags has ROS 2's definitions")
    name = f"tf2_msgs/msg/{message}"
    text = (ROOT / "tools" / "interfaces" / "tf2_msgs" / "msg" / f"{message}.msg").read_text(
        encoding="utf-8"
    )
    ours = typesys.get_types_from_msg(text, name)[name]
    real = typesys.get_typestore(typesys.Stores.ROS2_JAZZY).fielddefs[name]
    assert ours == real
    cmake = (ROOT / "tools" / "interfaces" / "tf2_msgs" / "CMakeLists.txt").read_text()
    assert f'"msg/{message}.msg"' in cmake
