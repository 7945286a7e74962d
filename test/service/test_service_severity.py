"""How loudly each joint_states problem is reported: the severity travels with the problem."""

from __future__ import annotations

import math

from service_testing import chain_of, js

from kinematics_node.service.kinematics import Severity


def test_each_problem_carries_its_severity_into_the_logs_and_diagnostics(ros, ur5, clock):
    S = ros.cls("diagnostic_msgs/msg/DiagnosticStatus")
    names = chain_of(ur5).joint_names
    q = [0.0, -1.0, 1.0, 0.0, 0.5, 0.0]  # away from singularities (they WARN in diagnostics)
    clock.now = 1.0
    out = ur5.on_joint_state(js(ros, names[:3], [0.1, 0.2, 0.3], t=1.0))
    assert out.severity == Severity.WARN and "waiting for joint_states" in out.problem
    out = ur5.on_joint_state(js(ros, names, q, t=1.1))
    assert out.pose is not None and out.twist is None  # positions only: no velocity yet
    assert out.severity == Severity.NOTE and out.problem == "velocity unknown"
    assert ur5.diagnostics().status[0].level == S.OK  # an unknown velocity is no fault
    out = ur5.on_joint_state(js(ros, names, q, t=0.5))
    assert out.severity == Severity.WARN and "stale" in out.problem
    out = ur5.on_joint_state(js(ros, names, [0.0, math.nan, 0, 0, 0, 0], t=1.2))
    assert out.severity == Severity.ERROR and out.pose is None
    diag = ur5.diagnostics().status[0]
    assert diag.level == S.ERROR and "rejected" in diag.message
    # a good sample clears the last problem
    ur5.on_joint_state(js(ros, names, q, t=1.3, velocity=[0.0] * 6))
    assert ur5.diagnostics().status[0].level == S.OK


def test_severities_are_diagnostic_levels(ros):
    S = ros.cls("diagnostic_msgs/msg/DiagnosticStatus")
    assert list(Severity) == [Severity.NOTE, Severity.WARN, Severity.ERROR]
    assert (Severity.NOTE, Severity.WARN, Severity.ERROR) == (S.OK, S.WARN, S.ERROR)


def test_one_sample_stamped_far_ahead_does_not_stop_the_poses(ros, ur5, clock):
    names, q = ur5.model.chain.joint_names, [0.3, -1.1, 1.4, -0.6, 0.8, 0.2]
    assert ur5.on_joint_state(js(ros, names, q, t=100.0)).pose is not None
    assert ur5.on_joint_state(js(ros, names, q, t=(2**31 - 1, 0))).pose is not None  # a glitch
    out = ur5.on_joint_state(js(ros, names, q, t=100.01))  # the real clock again
    assert out.pose is not None and out.severity == Severity.WARN and "jumped back" in out.problem
    diag = ur5.diagnostics().status[0]
    assert diag.level == 1 and "jumped back" in diag.message
    out = ur5.on_joint_state(js(ros, names, q, t=100.02))
    assert out.pose is not None and out.twist is not None and out.problem is None
    assert ur5.diagnostics().status[0].level == 0


def test_a_stale_sample_shows_in_diagnostics(ros, ur5, clock):
    names, q = ur5.model.chain.joint_names, [0.3, -1.1, 1.4, -0.6, 0.8, 0.2]
    ur5.on_joint_state(js(ros, names, q, t=100.0))
    out = ur5.on_joint_state(js(ros, names, q, t=99.9))
    assert out.pose is None and "stale" in out.problem
    diag = ur5.diagnostics().status[0]
    assert diag.level == 1 and "stale" in diag.message


def test_joint_states_naming_none_of_the_chain_show_as_missing(ros, ur5, clock):
    names, q = ur5.model.chain.joint_names, [0.3, -1.1, 1.4, -0.6, 0.8, 0.2]
    ur5.on_joint_state(js(ros, names, q, t=clock.now))
    for _ in range(5):  # a gripper's joint_states, say: no chain joint in them
        clock.now += 0.5
        assert ur5.on_joint_state(js(ros, ["finger"], [0.01], t=clock.now)).pose is None
    diag = ur5.diagnostics().status[0]
    assert diag.level == 1 and "no recent joint_states naming the chain's joints" in diag.message
