"""What the node tells its users names things as they named them (issue 22): ComputeIK failures
say once the request's own timeout and the time the answer really took, keep the reason, and name
the request's fields and the node's parameters, never the library's options; /diagnostics does not
turn the zero stamp of unstamped joint_states into a latency of 55 years.

The IK answers here run real solves (a UR5 cut at wrist_2_link cannot take most orientations, a
target beyond the reach sphere, a Panda wrist out of reach), then `finish_ik` at a chosen `now`:
the time a message states is compared with that, not with a clock.
"""

from __future__ import annotations

import math
import re
import time

import numpy as np
import pytest
from service_testing import check_message, ik_target, js

from kinematics_node.core import se3
from kinematics_node.core.ik.solver import beyond_reach
from kinematics_node.service.ik_pool import solve_job
from kinematics_node.service.kinematics import KinematicsService

#: Names of the library (IKOptions fields, its API, its argument names) that a ComputeIK user never
#: typed: the srv's fields are timeout, max_solutions, position_only, axis_tolerances, seed, target.
LIBRARY_WORDS = re.compile(
    r"IKOptions|chain\.|ik_all|q_seed|T_target|num_solutions|max_restarts=|\bmode\b|ωx|vx|"
    r"\bIK failed\b|timeout:"
)
Q5 = np.array([0.3, -1.1, 1.4, -0.6, 0.8])


@pytest.fixture
def ur5_wrist(ros, ur5_path, clock) -> KinematicsService:
    """A UR5 cut at wrist_2_link (5 joints): it cannot spin its tip about the tip's y axis."""
    params = {"robot_description": ur5_path.read_text(), "tip_link": "wrist_2_link"}
    return KinematicsService(ros.types, params, clock=clock)


def spun_target(svc: KinematicsService) -> np.ndarray:
    """A pose the 5-joint arm cannot take: a reachable one spun 0.8 rad about the tip's y."""
    assert svc.model is not None
    T = svc.model.chain.fk(Q5 + 0.1)
    return T @ se3.exp(np.array([0.0, 0.8, 0.0, 0.0, 0.0, 0.0]))


def answer(ros, svc, req, *, waited=0.0, after=None, sent_ago=0.0):
    """prepare_ik (the request arrived `sent_ago` s ago, `waited` s after its send; a `waited`
    below the timeout), a real solve of its job (`solve_job`, as a worker runs it), then
    finish_ik `after` seconds after the send (default: now). Returns the response, checked to be
    a failure that names no library option."""
    now = time.monotonic()
    arrival = now - sent_ago
    pending = svc.prepare_ik(ros.roundtrip(req), ros.response("ComputeIK"), arrival, waited)
    assert pending is not None
    outcome = solve_job(pending.job)
    sent = arrival - waited
    finished = None if after is None else sent + after
    resp = svc.finish_ik(pending, outcome, ros.response("ComputeIK"), finished)
    check_message(ros, resp)
    assert resp.success is False
    assert not LIBRARY_WORDS.search(resp.message), resp.message
    assert resp.message.startswith("no solution: ") and resp.message.count("no solution") == 1
    return resp


def residual_is_the_response_errors(message: str, resp) -> None:
    m = re.search(r"best residual (\S+) m / (\S+) rad", message)
    assert m is not None, message
    assert m[1] == f"{resp.position_error:.3g}" and m[2] == f"{resp.orientation_error:.3g}"


# =========================================================================== the timeout ran out
def test_a_search_that_runs_out_states_the_request_timeout_and_the_time_taken(ros, ur5_wrist):
    """The request waited 12 ms before the node took it, so the worker had 38 ms of its 50: the
    message says the request's 50 ms and the 53.7 ms the answer took since it was sent (before:
    'in 0.05 s', with the worker's '38 ms timeout' nested inside)."""
    req = ros.request("ComputeIK", target=ik_target(ros, spun_target(ur5_wrist)), timeout=0.05)
    resp = answer(ros, ur5_wrist, req, waited=0.012, after=0.0537)
    text = resp.message
    assert text.startswith("no solution: the timeout of 50 ms ran out after 53.7 ms, "), text
    assert re.search(r", \d+ restarts?; best residual", text), text
    assert text.count("timeout") == 1 and text.count(" ms") == 2, text  # said once
    assert "(position_tolerance 1e-05 m, orientation_tolerance 0.0001 rad)" in text, text
    residual_is_the_response_errors(text, resp)


def test_the_time_taken_is_in_seconds_from_one_second(ros, ur5_wrist):
    """An answer handed back 1.03 s after the send (the node's thread was held up): said so."""
    req = ros.request("ComputeIK", target=ik_target(ros, spun_target(ur5_wrist)), timeout=0.02)
    resp = answer(ros, ur5_wrist, req, after=1.0254)
    assert "the timeout of 20 ms ran out after 1.03 s" in resp.message, resp.message


@pytest.mark.parametrize(
    ("fields", "what"),
    [
        ({"position_only": False, "max_solutions": 3}, "(position_tolerance 1e-05 m, orientation"),
        (
            {"axis_tolerances": np.array([1e-4, 1e-4, 1e-4, 1e-5, 1e-5, math.inf])},
            "(axis_tolerances [0.0001, 0.0001, 0.0001, 1e-05, 1e-05, inf])",
        ),
    ],
    ids=["max_solutions", "axis_tolerances"],
)
def test_sets_and_axis_bounds_are_named_as_the_request_names_them(ros, ur5_wrist, fields, what):
    req = ros.request(
        "ComputeIK", target=ik_target(ros, spun_target(ur5_wrist)), timeout=0.03, **fields
    )
    resp = answer(ros, ur5_wrist, req, after=0.0312)
    assert "the timeout of 30 ms ran out after 31.2 ms" in resp.message, resp.message
    assert what in resp.message, resp.message
    residual_is_the_response_errors(resp.message, resp)


def test_a_position_only_search_names_position_only(ros, ur5_wrist):
    """wrist_2_link stays 0.109 m from the base's z axis (the arm's sideways offsets): a point on
    that axis is inside the reach sphere, but no position reaches it."""
    T = spun_target(ur5_wrist)
    T[:3, 3] = [0.0, 0.0, 0.3]
    req = ros.request("ComputeIK", target=ik_target(ros, T), timeout=0.03, position_only=True)
    resp = answer(ros, ur5_wrist, req, after=0.0301)
    assert resp.message.startswith("no solution: the timeout of 30 ms ran out after 30.1 ms, ")
    assert resp.message.endswith("(position_tolerance 1e-05 m, position_only)"), resp.message
    assert resp.position_error >= 0.109 - 1e-6


def test_restarts_used_up_name_the_node_parameter_that_set_them(ros, ur5_path, clock):
    params = {
        "robot_description": ur5_path.read_text(),
        "tip_link": "wrist_2_link",
        "ik.max_restarts": 2,
    }
    svc = KinematicsService(ros.types, params, clock=clock)
    req = ros.request("ComputeIK", target=ik_target(ros, spun_target(svc)), timeout=5.0)
    resp = answer(ros, svc, req, after=0.0042)
    text = resp.message
    assert text.startswith(
        "no solution: all 2 restarts that the node's parameter ik.max_restarts allows were made "
        "in 4.20 ms; best residual"
    ), text
    assert "timeout" not in text, text  # it did not run out: not mentioned
    residual_is_the_response_errors(text, resp)


# =========================================================================== other reasons
@pytest.mark.parametrize("max_solutions", [1, 4])
def test_a_target_beyond_reach_keeps_its_distance_and_the_reach(ros, ur5, max_solutions):
    T = np.eye(4)
    T[:3, 3] = [5.0, 0.0, 0.0]
    req = ros.request(
        "ComputeIK", target=ik_target(ros, T), timeout=0.05, max_solutions=max_solutions
    )
    resp = answer(ros, ur5, req, after=0.0013)
    assert ur5.model is not None
    pending = ur5.prepare_ik(ros.roundtrip(req), ros.response("ComputeIK"))
    assert pending is not None
    why = beyond_reach(ur5.model.chain, pending.job.T_base_target, pending.options)
    assert why and "reaches at most" in why  # (the distance and the reach, from the core)
    assert resp.message == (
        f"no solution: unreachable: {why}; best effort from the seed in 1.30 ms: position error "
        f"{resp.position_error:.3g} m, orientation error {resp.orientation_error:.3g} rad"
    )


def test_the_closed_form_reason_is_kept_before_the_search(ros, panda_path, clock):
    svc = KinematicsService(
        ros.types,
        {"robot_description": panda_path.read_text(), "tip_link": "panda_link8"},
        clock=clock,
    )
    assert svc.model is not None
    T = svc.model.chain.fk(np.zeros(7))
    T[:3, 3] = [0.0, 0.0, 1.2]  # above the shoulder, inside the reach sphere: the wrist is not
    req = ros.request("ComputeIK", target=ik_target(ros, T), timeout=0.04)
    resp = answer(ros, svc, req, after=0.0405)
    text = resp.message
    assert re.match(
        r"no solution: closed form: unreachable: .*panda_joint7.*; numeric search: the timeout "
        r"of 40 ms ran out after 40.5 ms, \d+ restarts; best residual",
        text,
    ), text
    assert text.count("timeout") == 1, text


def test_a_request_that_no_worker_started_says_how_long_it_took(ros, ur5_wrist):
    """Its deadline passed before a solve could start (here: sent 1.2 s ago with a 50 ms
    timeout, as after a long queue): no solve, and the message says so with the real time."""
    req = ros.request("ComputeIK", target=ik_target(ros, spun_target(ur5_wrist)), timeout=0.05)
    resp = answer(ros, ur5_wrist, req, sent_ago=1.2, after=1.2)
    assert resp.message == (
        "no solution: the timeout of 50 ms ran out after 1.20 s before an IK worker could start "
        "on the job"
    )
    assert resp.position_error == -1.0  # no solve ran


def test_a_timeout_too_short_to_solve_is_named_once(ros, ur5_wrist):
    req = ros.request("ComputeIK", target=ik_target(ros, spun_target(ur5_wrist)), timeout=1e-5)
    resp = answer(ros, ur5_wrist, req, after=0.0002)
    assert resp.message == (
        "no solution: the timeout of 0.01 ms is shorter than the 0.5 ms a solve needs at least"
    )


# =========================================================================== refused requests
def _ik_request(ros, **fields):
    req = ros.request("ComputeIK", **fields)
    req.target.pose.position.x = 0.4
    req.target.pose.orientation.w = 1.0
    return req


REFUSED = [
    ({"axis_tolerances": np.array([1e-3] * 5)}, "axis_tolerances must be empty or 6 values "
     "(wx, wy, wz, x, y, z) [rad, m], got 5 values"),
    ({"axis_tolerances": np.array([0.0] + [1e-3] * 5)}, "axis_tolerances must be > 0"),
    ({"axis_tolerances": np.array([math.inf] * 6)}, "axis_tolerances must bound at least one"),
    ({"axis_tolerances": np.array([math.inf] * 3 + [1e-3] * 3), "position_only": True},
     "axis_tolerances and position_only cannot be combined"),
    ({"timeout": -1.0}, "timeout must be >= 0 [s] (0 = the node's parameter ik.timeout)"),
    ({"position_tolerance": math.nan}, "(0 = the node's parameter ik.position_tolerance)"),
    ({"orientation_tolerance": -1.0}, "(0 = the node's parameter ik.orientation_tolerance)"),
    ({"tip_link": "nope"}, "tip_link: unknown link 'nope'; valid links are: "),
]  # fmt: skip


@pytest.mark.parametrize(("fields", "needle"), REFUSED, ids=[n for _, n in REFUSED])
def test_refused_ik_requests_name_the_request_fields(ros, ur5, fields, needle):
    resp = ur5.compute_ik(ros.roundtrip(_ik_request(ros, **fields)), ros.response("ComputeIK"))
    assert resp.success is False and needle in resp.message, resp.message
    assert not LIBRARY_WORDS.search(resp.message), resp.message
    check_message(ros, resp)


@pytest.mark.parametrize("srv", ["ComputeFK", "ComputeJacobian"])
@pytest.mark.parametrize(
    ("tip", "needle"),
    [("nope", "unknown link 'nope'"), ("base_link", "no moving joint")],
)
def test_a_bad_tip_link_in_fk_and_jacobian_requests_is_named(ros, ur5, q_ur5, srv, tip, needle):
    ur5.on_joint_state(js(ros, ur5.model.chain.joint_names, q_ur5, t=1.0))
    call = ur5.compute_fk if srv == "ComputeFK" else ur5.compute_jacobian
    resp = call(ros.request(srv, tip_link=tip), ros.response(srv))
    assert resp.success is False and resp.message.startswith("tip_link: "), resp.message
    assert needle in resp.message, resp.message


# =========================================================================== diagnostics
def _values(svc) -> dict[str, str]:
    return {kv.key: kv.value for kv in svc.diagnostics().status[0].values}


def test_unstamped_joint_states_have_an_unknown_latency_not_the_time_since_1970(ros, ur5, clock):
    names = ur5.model.chain.joint_names
    clock.now = 1.7e9  # a ROS clock: seconds since 1970
    assert _values(ur5)["joint_states_latency_s"] == "unknown (no joint_states received)"
    for k in range(11):  # unstamped, 100 Hz by their arrival times
        clock.now = 1.7e9 + 0.01 * k
        ur5.on_joint_state(js(ros, names, 0.3 + 0.01 * k * np.ones(6), t=(0, 0)), 0.01 * k)
    values = _values(ur5)
    assert values["joint_states_latency_s"] == "unknown (unstamped joint_states)"
    assert float(values["joint_states_rate_hz"]) == pytest.approx(100.0, rel=1e-6)
    for key, value in values.items():  # nothing computed from a zero stamp
        try:
            number = float(value)
        except ValueError:
            continue
        assert abs(number) < 1e6, (key, value)
    check_message(ros, ur5.diagnostics())
    # stamped samples (2 ms before they arrive) give a latency: theirs only, not a mean with the
    # unstamped ones still in the window
    for k in range(11, 14):
        clock.now = 1.7e9 + 0.01 * k
        t = clock.now - 0.002
        ur5.on_joint_state(js(ros, names, 0.3 + 0.01 * k * np.ones(6), t=t), 0.01 * k)
    assert float(_values(ur5)["joint_states_latency_s"]) == pytest.approx(0.002, abs=1e-6)
    clock.now += 0.01  # an unstamped one again: unknown again
    ur5.on_joint_state(js(ros, names, 0.5 * np.ones(6), t=(0, 0)), 0.2)
    assert _values(ur5)["joint_states_latency_s"] == "unknown (unstamped joint_states)"


def test_a_refused_ik_request_reports_its_errors_as_unknown(ros, ur5_path, clock) -> None:
    """A request refused before any solve (no tip chosen yet; a NaN target) answers
    position_error = orientation_error = -1, "unknown (no solve ran)" as ComputeIK.srv defines
    them, not 0, which a client reads as a pose reached exactly."""
    waiting = KinematicsService(ros.types, {"robot_description": ur5_path.read_text()}, clock=clock)
    loaded = KinematicsService(
        ros.types, {"robot_description": ur5_path.read_text(), "tip_link": "tool0"}, clock=clock
    )
    T_nan = np.eye(4)
    T_nan[0, 3] = math.nan
    for svc, T, reason in ((waiting, np.eye(4), "waiting for a tip"), (loaded, T_nan, "nan")):
        req = ros.request("ComputeIK")
        req.target = ik_target(ros, T)
        response = ros.response("ComputeIK")
        assert svc.prepare_ik(ros.roundtrip(req), response) is None
        assert not response.success and reason in response.message.lower()
        assert (response.position_error, response.orientation_error) == (-1.0, -1.0)
