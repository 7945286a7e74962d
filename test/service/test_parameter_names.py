"""Parameters a node does not know (`service.parameter_names`): which overrides are reported at
start-up, and the closest known name each suggests (the issue's own typos, then every single-key
slip of every parameter of our three nodes)."""

from __future__ import annotations

import pytest

from kinematics_node.ros.executables import SIM_ARM_PARAMETERS
from kinematics_node.service.parameter_names import (
    closest_name,
    override_warnings,
    refusal_text,
    unknown_overrides,
    unknown_parameter_text,
)
from kinematics_node.service.parameters import SPECS
from kinematics_node.service.servo_parameters import SERVO_SPECS

TABLES = {
    "kinematics_node": sorted(SPECS),
    "servo": sorted(SERVO_SPECS),
    "sim_arm": sorted(spec.name for spec in SIM_ARM_PARAMETERS),
}
#: What rclpy declares on every node besides ours.
ROS_DECLARED = ["use_sim_time", "start_type_description_service"]


def test_the_issue_s_typos_name_the_parameters_meant():
    known = TABLES["kinematics_node"]
    assert override_warnings(["tip_lnk", "ik.timout"], known + ROS_DECLARED) == [
        "unknown parameter 'ik.timout' (did you mean 'ik.timeout'?): ignored",
        "unknown parameter 'tip_lnk' (did you mean 'tip_link'?): ignored",
    ]


def _slips(name: str) -> list[str]:
    """One key wrong: each letter dropped, doubled, or swapped with the next (dots kept)."""
    out = set()
    for i, c in enumerate(name):
        if c == ".":
            continue
        out.add(name[:i] + name[i + 1 :])
        out.add(name[:i] + c + name[i:])
        if i + 1 < len(name) and name[i + 1] not in (".", c):
            out.add(name[:i] + name[i + 1] + c + name[i + 2 :])
    return sorted(out - {name})


@pytest.mark.parametrize("node", sorted(TABLES))
def test_every_single_key_slip_of_every_parameter_suggests_that_parameter(node):
    known = TABLES[node]
    wrong = {
        slip: name for name in known for slip in _slips(name) if slip not in known and len(name) > 3
    }
    misses = {s: (closest_name(s, known), meant) for s, meant in wrong.items()}
    misses = {s: got for s, got in misses.items() if got[0] != got[1]}
    assert not misses, f"{len(misses)} of {len(wrong)} slips suggest another name: {misses}"


def test_case_and_a_missing_group_are_forgiven_and_a_stranger_gets_no_guess():
    known = TABLES["kinematics_node"]
    assert closest_name("Tip_Link", known) == "tip_link"
    assert closest_name("timeout", known) == "ik.timeout"
    assert closest_name("workers", known) == "ik.workers"
    assert closest_name("frobnicate", known) is None
    assert unknown_parameter_text("frobnicate", known) == "unknown parameter 'frobnicate'"


def test_declared_parameters_and_ros_s_own_are_never_reported():
    known = TABLES["servo"] + ROS_DECLARED
    given = [
        *known,
        "qos_overrides./parameter_events.publisher.depth",
        "use_sim_time",
        "period_ss",
    ]
    assert unknown_overrides(given, known) == ["period_ss"]
    assert unknown_overrides([], known) == []
    # a slip of a name ROS declares is still suggested
    assert closest_name("use_sim_tme", known) == "use_sim_time"


def test_a_run_time_refusal_names_each_parameter_and_says_it_was_not_set():
    text = refusal_text(["ik.timout", "zzz"], TABLES["kinematics_node"])
    assert text == (
        "unknown parameter 'ik.timout' (did you mean 'ik.timeout'?): not set; "
        "unknown parameter 'zzz': not set"
    )
