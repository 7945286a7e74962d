"""How loudly each joint_states problem is reported: the severity travels with the problem."""

from __future__ import annotations

import math

from service_testing import chain_of, js

from kinematics_node.service import Severity


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
