"""`kinematics_node.ros.env` without ROS: the environment every process that talks to the node
gets (discovery on loopback, a domain of the run's own, the package's Fast DDS profile)."""

from __future__ import annotations

import os
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

from kinematics_node.ros import env as ros_env
from kinematics_node.ros.env import FASTDDS_PROFILE, FASTDDS_PROFILE_VARIABLES, local_ros_env

NS = {"dds": "http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles"}


def _prefix(root: Path, *libraries: str) -> str:
    """A ROS prefix whose lib/ holds (empty stand-ins of) `libraries`."""
    (root / "lib").mkdir(parents=True)
    for library in libraries:
        (root / "lib" / library).touch()
    return str(root)


def test_children_get_the_profile_in_the_variable_their_fast_dds_reads(tmp_path, monkeypatch):
    """Fast DDS 2 (Jazzy) reads only FASTRTPS_DEFAULT_PROFILES_FILE; Fast DDS 3 (Kilted) reads
    FASTDDS_DEFAULT_PROFILES_FILE and warns in every process that the other is deprecated. Which
    one is installed: the library in the first prefix of AMENT_PREFIX_PATH that has one."""
    jazzy = _prefix(tmp_path / "jazzy", "libfastrtps.so.2.14.5", "librmw_fastrtps_cpp.so")
    kilted = _prefix(tmp_path / "kilted", "libfastdds.so", "libfastdds.so.3.2.2")
    workspace = _prefix(tmp_path / "workspace", "libkinematics_service__rosidl_generator_c.so")
    for prefixes, variable in (
        ([workspace, jazzy], "FASTRTPS_DEFAULT_PROFILES_FILE"),
        ([workspace, kilted], "FASTDDS_DEFAULT_PROFILES_FILE"),
        ([kilted, jazzy], "FASTDDS_DEFAULT_PROFILES_FILE"),  # the first one found
        ([jazzy, kilted], "FASTRTPS_DEFAULT_PROFILES_FILE"),
    ):
        env = local_ros_env(123, base={"AMENT_PREFIX_PATH": os.pathsep.join(prefixes)})
        assert env["ROS_DOMAIN_ID"] == "123"
        assert env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"
        assert [v for v in FASTDDS_PROFILE_VARIABLES if v in env] == [variable], prefixes
        assert env[variable] == str(FASTDDS_PROFILE)
    # nothing on AMENT_PREFIX_PATH: this Python's prefix (a venv of wheels) decides
    monkeypatch.setattr(sys, "prefix", kilted)
    assert ros_env.fastdds_major({}) == 3
    # no Fast DDS anywhere: both variables (each version reads its own)
    monkeypatch.setattr(sys, "prefix", workspace)
    assert ros_env.fastdds_major({"AMENT_PREFIX_PATH": workspace}) is None
    env = local_ros_env(123, base={"AMENT_PREFIX_PATH": workspace})
    assert all(env[v] == str(FASTDDS_PROFILE) for v in FASTDDS_PROFILE_VARIABLES)


def test_the_users_own_profile_is_kept_by_either_name(tmp_path):
    kilted = _prefix(tmp_path / "kilted", "libfastdds.so")
    for variable in FASTDDS_PROFILE_VARIABLES:
        base = {variable: "/etc/my_profile.xml", "AMENT_PREFIX_PATH": kilted}
        mine = local_ros_env(123, base=base)
        assert mine[variable] == "/etc/my_profile.xml"
        assert all(mine.get(v) in (None, "/etc/my_profile.xml") for v in FASTDDS_PROFILE_VARIABLES)
    assert ros_env.fastdds_profile_env("/no/such/profile.xml", base={}) == {}


def test_the_profile_shortens_the_shared_memory_health_check_and_keeps_both_transports():
    """What the profile is for (its comment says why): Fast DDS's default is 1000 ms, so a
    port's listener checks in every 333 ms and an opener can wait that long."""
    root = ET.parse(FASTDDS_PROFILE).getroot()
    descriptors = {
        d.findtext("dds:transport_id", namespaces=NS): d
        for d in root.iterfind(".//dds:transport_descriptor", NS)
    }
    kinds = {i: d.findtext("dds:type", namespaces=NS) for i, d in descriptors.items()}
    assert sorted(kinds.values()) == ["SHM", "UDPv4"]
    shm = next(d for d in descriptors.values() if d.findtext("dds:type", namespaces=NS) == "SHM")
    assert 0 < int(shm.findtext("dds:healthy_check_timeout_ms", namespaces=NS)) <= 100
    participant = root.find(".//dds:participant", NS)
    assert participant is not None and participant.get("is_default_profile") == "true"
    used = [t.text for t in participant.iterfind(".//dds:userTransports/dds:transport_id", NS)]
    assert sorted(used) == sorted(descriptors)  # both, and only what is described
    assert participant.findtext(".//dds:useBuiltinTransports", namespaces=NS) == "false"
