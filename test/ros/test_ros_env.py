"""`kinematics_node.ros.env` without ROS: the environment every process that talks to the node
gets (discovery on loopback, a domain of the run's own, the package's Fast DDS profile)."""

from __future__ import annotations

import xml.etree.ElementTree as ET

from kinematics_node.ros import env as ros_env
from kinematics_node.ros.env import FASTDDS_PROFILE, FASTDDS_PROFILE_VARIABLES, local_ros_env

NS = {"dds": "http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles"}


def test_children_get_the_profile_unless_one_is_named_already():
    env = local_ros_env(123, base={"PATH": "/bin"})
    assert env["ROS_DOMAIN_ID"] == "123" and env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"
    for variable in FASTDDS_PROFILE_VARIABLES:
        assert env[variable] == str(FASTDDS_PROFILE)
    for variable in FASTDDS_PROFILE_VARIABLES:  # the user's own profile, by either name, is kept
        mine = local_ros_env(123, base={variable: "/etc/my_profile.xml"})
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
