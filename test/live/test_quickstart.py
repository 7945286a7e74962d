"""The README's quick start, run exactly as written.

The recipe is the bash block between ``<!-- quickstart -->`` and ``<!-- /quickstart -->`` in
README.md. It runs in one `bash -c`, as a user's shell would run it: PATH=/usr/bin:/bin (nothing of
ours on it until the recipe sources build/ros/env.sh) behind one directory whose `python3` is the
interpreter of this run's venv (so `make` picks this run's ROS 2 distribution, as for a user whose
`python3` that is), in a directory that looks like the clone (links to its Makefile and tools/,
and .venv and build/ros to this run's venv and build) and holds the robot description under the name
the recipe uses: a copy of example-robot-data's UR5, a description nobody here wrote, whose
several leaves (tool0, ee_link) need the recipe's tip_link. DDS stays on loopback, in this run's
domain. What it prints is checked against the core:

* the pose `kinematics ros pose` prints is FK of a joint state that the recipe's sim_arm
  published, in the chain's base frame. sim_arm's states are replayed here, with the simulator
  and the parameter defaults sim_arm uses (its motion depends on its step count only): a
  subscription of this process can miss sim_arm's first messages, since discovery takes a second
  or more and races them. The replay is checked against every joint_states message that does
  arrive here, and the pose against the one with its stamp where that one arrived;
* the joint values `kinematics ros ik` prints reach the recipe's target (FK of them).

Every process the recipe leaves in the background is stopped at the end (its process group).
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from kin_testing import erd_path
from live_node import DOMAIN_ID, ROOT, Client

from kinematics_node.core import SerialChain
from kinematics_node.core.rotations import matrix_from_quaternion
from kinematics_node.ros.env import FASTDDS_PROFILE_VARIABLES, local_ros_env
from kinematics_node.ros.executables import SIM_ARM_PARAMETERS
from kinematics_node.sim.arm import ArmSimulator

README = ROOT / "README.md"
#: What the user's description stands for here (a real arm with a gripper-less flange, tool0).
ROBOT = "ur_description/urdf/ur5_robot.urdf"
#: The recipe's whole run, `make ros` included (a rebuild takes ~30 s where sources changed).
RECIPE_TIMEOUT = 180.0
#: The links the temporary directory gets, so that `make ros` and `. build/ros/env.sh` work there.
CLONE_ENTRIES = ("Makefile", "tools")


def this_runs_build() -> Path:
    """The build directory of this run's ROS 2 (build/ros, or build/ros-<distro> for a second
    distribution, as in CI): where the env.sh that make sourced lies (it names itself)."""
    env_sh = os.environ.get("KINEMATICS_ROS_ENV")
    return Path(env_sh).parent if env_sh else ROOT / "build" / "ros"


POSE = re.compile(
    r"^(?P<topic>\S+): pose in '(?P<frame>[^']*)' at stamp (?P<sec>\d+)\.(?P<nsec>\d{9})\n"
    r"position \[m\] +(?P<p>\S+ +\S+ +\S+)\n"
    r"quaternion \(x,y,z,w\) +(?P<q>\S+ +\S+ +\S+ +\S+)$",
    re.MULTILINE,
)
IK = re.compile(r"^solved by (?P<service>\S+)\n(?P<rows>(?:  \S+ +\S+\n)+)position error", re.M)


def quickstart_recipe(readme: str) -> str:
    """The bash block of the README's quick-start section."""
    section = readme.split("<!-- quickstart -->", 1)[1].split("<!-- /quickstart -->", 1)[0]
    blocks = re.findall(r"^```bash\n(.*?)^```", section, re.MULTILINE | re.DOTALL)
    assert len(blocks) == 1, "the quick start holds one bash block, the recipe"
    return str(blocks[0])


def _one(pattern: str, recipe: str, what: str) -> str:
    found = set(re.findall(pattern, recipe))
    assert len(found) == 1, f"the recipe names one {what}, found {sorted(found)}"
    return found.pop()


def _stop_group(process: subprocess.Popen[bytes]) -> None:
    """SIGINT to the recipe's process group (bash, its background nodes, their IK workers),
    then SIGKILL to whatever is left after 10 s."""
    for sig, grace in ((signal.SIGINT, 10.0), (signal.SIGKILL, 5.0)):
        try:
            os.killpg(process.pid, sig)
        except ProcessLookupError:
            return
        end = time.monotonic() + grace
        while time.monotonic() < end:
            try:
                os.killpg(process.pid, 0)
            except ProcessLookupError:
                return
            time.sleep(0.05)


def _sim_arm_defaults() -> dict[str, Any]:
    return {spec.name: spec.default for spec in SIM_ARM_PARAMETERS}


def replay_sim_arm(description: Path, steps: int) -> tuple[tuple[str, ...], np.ndarray]:
    """(joint names, (steps, n) positions) that sim_arm publishes for `description` with its
    default parameters, as the recipe starts it (ros/sim_arm.py builds the same simulator)."""
    p = _sim_arm_defaults()
    assert not p["tip_link"] and p["demo"]  # every moving joint, in the demo motion
    sim = ArmSimulator.from_urdf(
        description,
        1.0 / p["rate"],
        command_timeout=p["command_timeout"],
        demo=p["demo"],
        demo_resume_after=p["demo_resume_after"],
    )
    return sim.joint_names, np.array([sim.step().q for _ in range(steps)])


def test_the_readme_recipe_has_five_lines_or_fewer_and_names_a_robot_file():
    lines = [line for line in quickstart_recipe(README.read_text("utf-8")).splitlines() if line]
    assert 1 <= len(lines) <= 5, lines
    recipe = "\n".join(lines)
    assert _one(r"robot_description_file:=(\S+)", recipe, "robot file")
    assert "kinematics ros pose" in recipe and "kinematics ros ik" in recipe


def test_the_readme_recipe_runs_as_written(tmp_path: Path, client: Client) -> None:
    from sensor_msgs.msg import JointState

    recipe = quickstart_recipe(README.read_text("utf-8"))
    robot_file = _one(r"robot_description_file:=(\S+)", recipe, "robot file")
    tip = _one(r"tip_link:=(\S+)", recipe, "tip link")
    target = [float(v) for v in _one(r"--target (\S+)", recipe, "IK target").split(",")]
    for entry in CLONE_ENTRIES:
        (tmp_path / entry).symlink_to(ROOT / entry)
    (tmp_path / ".venv").symlink_to(sys.prefix)
    (tmp_path / "build").mkdir()
    (tmp_path / "build" / "ros").symlink_to(this_runs_build())
    (tmp_path / "bin").mkdir()
    (tmp_path / "bin" / "python3").symlink_to(sys._base_executable)  # type: ignore[attr-defined]
    shutil.copyfile(erd_path(ROBOT), tmp_path / robot_file)
    chain = SerialChain.from_urdf(tmp_path / robot_file, tip_link=tip)

    # sim_arm's joint_states, by stamp, as far as they arrive here
    states: dict[tuple[int, int], tuple[tuple[str, ...], np.ndarray]] = {}

    def keep(msg: JointState) -> None:
        stamp = (msg.header.stamp.sec, msg.header.stamp.nanosec)
        states[stamp] = (tuple(msg.name), np.array(msg.position))

    subscription = client.node.create_subscription(JointState, "joint_states", keep, 1000)
    env = {"PATH": f"{tmp_path / 'bin'}:/usr/bin:/bin", "HOME": str(tmp_path), "LANG": "C.UTF-8"}
    # DDS on loopback, in this run's domain; no Fast DDS profile, as in a user's shell
    local = local_ros_env(DOMAIN_ID, base={})
    env.update({k: v for k, v in local.items() if k not in FASTDDS_PROFILE_VARIABLES})
    out_path, err_path = tmp_path / "stdout.txt", tmp_path / "stderr.txt"
    started = time.monotonic()
    with out_path.open("wb") as out, err_path.open("wb") as err:
        process = subprocess.Popen(
            ["bash", "-c", recipe],
            cwd=tmp_path,
            env=env,
            stdout=out,
            stderr=err,
            start_new_session=True,  # its own process group: the background nodes are in it
        )
    try:
        status = process.wait(RECIPE_TIMEOUT)
    except subprocess.TimeoutExpired:
        status = None
    finally:
        elapsed = time.monotonic() - started
        _stop_group(process)
        client.node.destroy_subscription(subscription)
    stdout, stderr = out_path.read_text(errors="replace"), err_path.read_text(errors="replace")
    said = f"after {elapsed:.1f} s, stdout:\n{stdout}\nstderr:\n{stderr[-4000:]}"
    assert status == 0, f"the recipe ended with status {status} {said}"

    # sim_arm's states, replayed (more steps than it can have taken): each one that arrived here
    # is one of them, in the order of their stamps
    names, Q = replay_sim_arm(tmp_path / robot_file, round(elapsed * _sim_arm_defaults()["rate"]))
    steps = []
    for stamp in sorted(states):
        sent_names, q = states[stamp]
        assert sent_names == names
        (k,) = np.flatnonzero(np.all(np.abs(Q - q) <= 1e-12, axis=1))[:1].tolist() or [-1]
        assert k >= 0, f"sim_arm sent a state the replay lacks (its defaults changed?) {said}"
        steps.append(k)
    assert steps == sorted(set(steps))

    # the pose: FK of one of those states (printed to 6 decimals: 5e-7 of rounding), the one
    # with its stamp where that arrived, in the chain's base frame
    pose = POSE.search(stdout)
    assert pose is not None, f"no pose printed {said}"
    assert pose["topic"] == "/ee_pose" and pose["frame"] == chain.base_link
    position = np.array(pose["p"].split(), dtype=float)
    rotation = matrix_from_quaternion(np.array(pose["q"].split(), dtype=float))
    T = chain.fk(Q[:, [names.index(name) for name in chain.joint_names]])
    (matches,) = np.nonzero(
        np.all(np.abs(T[:, :3, 3] - position) <= 6e-7, axis=1)
        & np.all(np.abs(T[:, :3, :3] - rotation) <= 3e-6, axis=(1, 2))
    )
    assert matches.size == 1, f"the pose printed is FK of {matches.size} states sim_arm sent {said}"
    stamp = (int(pose["sec"]), int(pose["nsec"]))
    if stamp in states:
        np.testing.assert_array_equal(Q[matches[0]], states[stamp][1])

    # the IK answer reaches the target (printed to 6 decimals: ~1e-6 of rounding on top of the
    # node's default tolerances, 1e-5 m and 1e-4 rad)
    ik = IK.search(stdout)
    assert ik is not None, f"no IK answer printed {said}"
    assert ik["service"] == "/compute_ik"
    rows = [row.split() for row in ik["rows"].splitlines()]
    assert [name for name, _ in rows] == list(chain.joint_names)
    reached = chain.fk(np.array([value for _, value in rows], dtype=float))
    assert np.linalg.norm(reached[:3, 3] - target[:3]) < 2e-5
    R_error = reached[:3, :3].T @ matrix_from_quaternion(target[3:])
    angle = np.arccos(np.clip((np.trace(R_error) - 1.0) / 2.0, -1.0, 1.0))
    assert angle < 2e-4
