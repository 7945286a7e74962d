"""Starting ROS 2 processes from tests, benchmarks and the demo (no rclpy import here).

* DDS discovery stays on this machine: by default Fast DDS announces itself by multicast on every
  network interface. `local_ros_env` sets ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST (Jazzy and later;
  on Humble, ROS_LOCALHOST_ONLY=1) and a ROS_DOMAIN_ID of the run's own, so parallel runs do not
  see each other. Call `keep_discovery_local` before `rclpy.init` in the calling process too.
* Fast DDS's profile: `local_ros_env` also names config/fastdds_profile.xml (unless a profile
  is named already), whose short shared-memory health check keeps writes from stalling ~333 ms,
  in the variable that this ROS 2's Fast DDS reads (`fastdds_major`: 2 on Humble and Jazzy, 3 from
  Kilted on).
* Shared memory left by dead processes: `clean_dead_shared_memory` runs Fast DDS's own
  `fastdds shm clean` before a benchmark or a live test session (see its docstring for why).
* The package's executables: from `tools/ros-from-pypi`'s environment (`KINEMATICS_*_EXECUTABLE`,
  set by `make`), else from a sourced ROS 2 workspace (the ament index on AMENT_PREFIX_PATH).
"""

from __future__ import annotations

import functools
import os
import re
import shutil
import subprocess
import sys
from collections.abc import Mapping
from pathlib import Path

PACKAGE = "kinematics_service"
_EXECUTABLE_VARIABLES = {
    "kinematics_node": "KINEMATICS_NODE_EXECUTABLE",
    "sim_arm": "KINEMATICS_SIM_ARM_EXECUTABLE",
}


#: Fast DDS profile for every process that talks to the node (why: in the file). Where the
#: source tree is not at hand (an installed package), share/kinematics_service/config has it.
FASTDDS_PROFILE = (  # <repo>/config: this module is <repo>/kinematics_node/ros/env.py
    Path(__file__).resolve().parents[2] / "config" / "fastdds_profile.xml"
)
#: The variables that name a Fast DDS profile file: Fast DDS 2.x (Humble, Jazzy) reads the first
#: only; 3.x (Kilted on) reads the second, and still takes the first, with a warning from every
#: participant that it is deprecated.
FASTDDS_PROFILE_VARIABLES = ("FASTRTPS_DEFAULT_PROFILES_FILE", "FASTDDS_DEFAULT_PROFILES_FILE")
#: Fast DDS major version -> (its library, the profile variable it reads, the prefix of its
#: shared-memory files in /dev/shm: ports, segments and their locks and semaphores)
FASTDDS_VERSIONS = {
    2: ("libfastrtps.so", "FASTRTPS_DEFAULT_PROFILES_FILE", "fastrtps_"),
    3: ("libfastdds.so", "FASTDDS_DEFAULT_PROFILES_FILE", "fastdds_"),
}


def run_domain_id() -> int:
    """A ROS_DOMAIN_ID for this run: from the process id, in 100..199 (valid for Fast DDS's port
    mapping, and away from the default 0 that other ROS users on the machine share)."""
    return 100 + os.getpid() % 100


def local_ros_env(
    domain_id: int | None = None, base: Mapping[str, str] | None = None
) -> dict[str, str]:
    """A copy of `base` (default: this process's environment) with discovery on loopback and the
    given (default: `run_domain_id()`) ROS_DOMAIN_ID."""
    env = dict(os.environ if base is None else base)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    if env.get("ROS_DISTRO", "").lower() == "humble":  # Humble predates the discovery range
        env["ROS_LOCALHOST_ONLY"] = "1"
    env["ROS_DOMAIN_ID"] = str(run_domain_id() if domain_id is None else domain_id)
    env.update(fastdds_profile_env(FASTDDS_PROFILE, env))
    return env


def fastdds_major(base: Mapping[str, str] | None = None) -> int | None:
    """The major version of the Fast DDS that ROS 2 loads in the environment `base` (default:
    this process's): that of the first library of `FASTDDS_VERSIONS` found in lib/ of a prefix
    on its AMENT_PREFIX_PATH (a sourced ROS 2, or build/ros/env.sh, which names the venv of
    wheels), else of this Python's prefix (a venv of wheels); None where none has one."""
    env = os.environ if base is None else base
    prefixes = [p for p in env.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    return _fastdds_major((*prefixes, sys.prefix))


@functools.lru_cache(maxsize=8)
def _fastdds_major(prefixes: tuple[str, ...]) -> int | None:
    for prefix in prefixes:
        lib = Path(prefix) / "lib"
        for major, (library, _, _) in FASTDDS_VERSIONS.items():
            if next(lib.glob(library + "*"), None) is not None:
                return major
    return None


def fastdds_profile_env(
    profile: Path | str = FASTDDS_PROFILE, base: Mapping[str, str] | None = None
) -> dict[str, str]:
    """The variable that gives a child process the Fast DDS profile `profile` (the package's,
    config/fastdds_profile.xml, which says why): the one the Fast DDS of `base` (default: this
    process's environment) reads (`fastdds_major`), or both where that is not known. {} where
    `base` names a profile already (by either variable), or where the file is missing. The
    launch files use it with the installed package's copy."""
    env = os.environ if base is None else base
    if not Path(profile).is_file() or any(env.get(v) for v in FASTDDS_PROFILE_VARIABLES):
        return {}
    major = fastdds_major(env)
    variables = FASTDDS_PROFILE_VARIABLES if major is None else (FASTDDS_VERSIONS[major][1],)
    return {variable: str(profile) for variable in variables}


def keep_discovery_local(domain_id: int | None = None) -> int:
    """Apply `local_ros_env` to this process (before `rclpy.init`); returns the domain id."""
    env = local_ros_env(domain_id)
    for key in (
        "ROS_AUTOMATIC_DISCOVERY_RANGE",
        "ROS_LOCALHOST_ONLY",
        "ROS_DOMAIN_ID",
        *FASTDDS_PROFILE_VARIABLES,
    ):
        if key in env:
            os.environ[key] = env[key]
    return int(env["ROS_DOMAIN_ID"])


def fastdds_tool() -> str | None:
    """Fast DDS's `fastdds` command line: on PATH (a ROS 2 installation) or next to this Python
    (the Fast DDS wheels put it there); None when neither has it."""
    return shutil.which("fastdds") or shutil.which("fastdds", path=str(Path(sys.executable).parent))


def clean_dead_shared_memory() -> str:
    """Remove the shared-memory ports and segments (/dev/shm/fastrtps_* with Fast DDS 2,
    fastdds_* with Fast DDS 3) of Fast DDS participants whose process died without closing them
    (killed, crashed), with Fast DDS's own tool, `fastdds shm clean`, which removes only files
    whose owner's lock is gone (each version only its own). Returns one line saying what it
    removed, or why nothing was done. The tool is a shell script that runs its Python part with
    the first `python3` on PATH; it runs with this Python's directory first on PATH (a venv of
    wheels: there the tool's imports, psutil for Fast DDS 3, are installed).

    Why: such files pile up (140 here, from earlier sessions' killed runs), and a participant
    that meets one (its port number reused, or an announcement sent there) has to find out that
    it is dead and replace it while holding its send lock, so every run starts from a different
    state. Whether they add to the ~333 ms write stalls of issue #10 is not settled: with the
    140 files, 4 of 31 runs of the benchmark's IK phase had one; after this clean, none in 10;
    but the stalls' main cause, Fast DDS's health-check interval (config/fastdds_profile.xml),
    alone gave about one run in five.
    """
    tool = fastdds_tool()
    if tool is None:
        return "Fast DDS shared memory: not checked (no `fastdds` tool on PATH)"
    try:
        path = os.pathsep.join((str(Path(sys.executable).parent), os.environ.get("PATH", "")))
        done = subprocess.run(
            [tool, "shm", "clean"],
            env={**os.environ, "PATH": path},
            capture_output=True,
            text=True,
            timeout=30.0,
            check=False,
        )
    except (OSError, subprocess.TimeoutExpired) as exc:
        return f"Fast DDS shared memory: `fastdds shm clean` failed ({exc})"
    found = re.findall(r"(\d+) zombie (ports|segments) cleaned", done.stdout)
    counts = {what: int(n) for n, what in found}
    if done.returncode != 0 or len(counts) != 2:
        return f"Fast DDS shared memory: `fastdds shm clean` said: {(done.stdout + done.stderr).strip()!r}"
    return (
        f"Fast DDS shared memory: {counts['ports']} ports and {counts['segments']} segments of dead "
        "processes removed (`fastdds shm clean`)"
    )


def executable(name: str) -> list[str] | None:
    """argv prefix that runs the package's executable `name` (kinematics_node or sim_arm) with
    this environment's Python, or None when the package is not built here."""
    variable = _EXECUTABLE_VARIABLES.get(name)
    path = os.environ.get(variable, "") if variable else ""
    candidates = [Path(path)] if path else []
    for prefix in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep):
        if prefix:
            candidates.append(Path(prefix) / "lib" / PACKAGE / name)
    for candidate in candidates:
        if candidate.is_file():
            python = os.environ.get("KINEMATICS_ROS_PYTHON") or sys.executable
            return [python, str(candidate)]
    return None


def unavailable_reason() -> str | None:
    """Why the real node cannot be run from this process (None when it can)."""
    try:
        import rclpy  # noqa: F401
    except ImportError as exc:
        return f"rclpy is not importable ({exc}): run `make test`, or source a ROS 2 installation"
    try:
        import kinematics_service.srv  # noqa: F401
    except ImportError as exc:
        return (
            f"the kinematics_service interfaces are not built or not on the path ({exc}): run "
            "`make test` (or `make ros`, then `. build/ros/env.sh`), or colcon build and source "
            "install/setup.bash"
        )
    if executable("kinematics_node") is None:
        return (
            "the kinematics_node executable is not found: run `make ros`, then . build/ros/env.sh"
        )
    return None
