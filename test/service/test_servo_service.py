"""ServoService (the servo node's logic) on a real UR5 description (example-robot-data) with real
message classes (rosbags), no rclpy: commands in, joint commands and status out.

Oracles: the chain's FK of the published joint positions (the tool must move as commanded), the
URDF's own fixed transforms (frames fixed to the base), and the properties the issue asks for:
bad input refused with a status, nothing non-finite published, a smooth stop on timeout."""

from __future__ import annotations

import math

import numpy as np
import pytest
from servo_node_testing import (
    Q_UR5,
    Loop,
    all_finite,
    joint_jog,
    joint_state,
    make_service,
    pose_msg,
    twist_msg,
    values,
)

from kinematics_node.core import SerialChain
from kinematics_node.core.exceptions import InvalidInputError, KinematicsError
from kinematics_node.core.servo import StatusCode
from kinematics_node.core.so3 import quaternion_from_rows
from kinematics_node.service.servo import MAX_CATCH_UP, NOT_READY, code_name

pytest.importorskip("ruckig", reason="the servo's smoothing needs ruckig (extra 'servo')")

UR5 = {"base_link": "base_link", "tip_link": "tool0"}


@pytest.fixture
def ur5_text(ur5_path) -> str:
    return ur5_path.read_text(encoding="utf-8")


@pytest.fixture
def service(ros, ur5_text):
    return make_service(ros, ur5_text, **UR5)


@pytest.fixture
def loop(ros, service):
    return Loop(ros, service)


def tool_positions(chain: SerialChain, qs: np.ndarray) -> np.ndarray:
    return chain.fk(qs)[:, :3, 3]


# ---------------------------------------------------------------------------- before it is ready
def test_without_a_description_commands_are_refused_saying_what_is_missing(ros):
    service = make_service(ros, "")  # the topic, which has sent nothing
    answer = service.on_twist(twist_msg(ros, linear=(0.1, 0, 0)), 1.0)
    assert values(answer)["code"] == str(NOT_READY) and answer.level == 1
    assert "TwistCommand refused" in answer.message
    assert "robot_description" in answer.message  # how to give one
    cycle = service.step(1.0)
    assert cycle.command is None and cycle.status.message.startswith("no robot description")


def test_until_joint_states_name_every_joint_commands_are_refused_naming_the_missing(ros, service):
    names = service.chain.joint_names
    assert service.on_joint_state(joint_state(ros, names[:4], Q_UR5[:4])) is None
    answer = service.on_twist(twist_msg(ros, linear=(0.1, 0, 0)), 1.0)
    assert "wrist_2_joint" in answer.message and "wrist_3_joint" in answer.message
    assert "shoulder_pan_joint" not in answer.message
    assert service.step(1.0).command is None
    # the rest arrives (with a joint of another chain): the servo starts where the arm is
    service.on_joint_state(joint_state(ros, [*names[4:], "gripper"], [*Q_UR5[4:], 0.3]))
    assert service.servo is not None
    assert np.allclose(service.servo.positions, Q_UR5)


def test_the_robot_description_topic_gives_the_robot(ros, ur5_text):
    service = make_service(ros, "", **UR5)
    assert service.chain is None and service.takes_description_topic
    service.on_description_message(ur5_text)
    assert service.chain is not None and service.chain.tip_link == "tool0"
    assert any("loaded 'ur5'" in text for _, text in service.take_log())


def test_bad_joint_states_are_reported_and_not_used(ros, service):
    names = service.chain.joint_names
    problem = service.on_joint_state(joint_state(ros, names, [0.1] * 5))
    assert "6 names but 5 positions" in problem
    q = Q_UR5.copy()
    q[2] = math.nan
    problem = service.on_joint_state(joint_state(ros, names, q))
    assert "'elbow_joint'" in problem and "nan" in problem
    assert service.servo is None  # nothing was taken


# ---------------------------------------------------------------------------- following commands
def test_a_twist_in_the_base_moves_the_tool_along_it_at_its_speed(ros, loop):
    chain = loop.service.chain
    v = np.array([0.03, -0.04, 0.02])  # 0.054 m/s
    loop.run(1.5, lambda now: loop.service.on_twist(twist_msg(ros, linear=v), now))
    p = tool_positions(chain, loop.positions())
    period = loop.service.period_s
    velocity = (p[-1] - p[-51]) / (50 * period)  # the last 0.5 s: the ramp is over
    assert np.allclose(velocity, v, atol=1e-3), velocity
    # the orientation was held (no rotation commanded)
    R0, R1 = chain.fk(Q_UR5)[:3, :3], chain.fk(loop.positions()[-1])[:3, :3]
    assert np.abs(R1 - R0).max() < 1e-3
    assert all_finite(loop.commands())


def test_empty_frame_id_is_the_base(ros, loop):
    v = np.array([0.0, 0.0, 0.05])
    loop.run(1.0, lambda now: loop.service.on_twist(twist_msg(ros, linear=v, frame=""), now))
    p = tool_positions(loop.service.chain, loop.positions())
    assert (p[-1] - p[0])[2] > 0.03 and np.abs((p[-1] - p[0])[:2]).max() < 1e-3


def test_a_twist_in_the_tool_frame_moves_along_the_tools_axes(ros, loop):
    chain = loop.service.chain
    R_base_tool = chain.fk(Q_UR5)[:3, :3]
    loop.run(
        1.0, lambda now: loop.service.on_twist(twist_msg(ros, (0, 0, 0.04), frame="tool0"), now)
    )
    p = tool_positions(chain, loop.positions())
    moved = p[-1] - p[0]
    assert np.linalg.norm(moved) > 0.02
    assert np.allclose(moved / np.linalg.norm(moved), R_base_tool[:, 2], atol=2e-3)


@pytest.mark.parametrize(("frame", "rz"), [("base", math.pi), ("world", 0.0)])
def test_a_link_fixed_to_the_base_outside_the_chain_is_a_frame_too(ros, loop, frame, rz):
    """UR's `base` is base_link turned by π about z (below it, in the URDF); `world` is the root
    above base_link (identity): both are fixed to the base, neither is in the chain."""
    assert frame not in loop.service.chain.link_names
    loop.run(1.0, lambda now: loop.service.on_twist(twist_msg(ros, (0.04, 0, 0), frame=frame), now))
    moved = np.diff(tool_positions(loop.service.chain, loop.positions())[[0, -1]], axis=0)[0]
    expected = np.array([math.cos(rz), math.sin(rz), 0.0])
    assert np.allclose(moved / np.linalg.norm(moved), expected, atol=2e-3)


def test_a_pose_target_is_reached(ros, loop):
    chain = loop.service.chain
    T0 = chain.fk(Q_UR5)
    goal = T0[:3, 3] + np.array([0.05, 0.03, -0.04])
    c, s = math.cos(0.3), math.sin(0.3)
    R_goal = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) @ T0[:3, :3]  # turned 0.3 rad about z
    target = pose_msg(ros, goal, quaternion_from_rows(R_goal.ravel().tolist()))
    loop.run(4.0, lambda now: loop.service.on_pose(target, now))
    T = chain.fk(loop.positions()[-1])
    assert np.linalg.norm(T[:3, 3] - goal) < 1e-4
    angle = np.arccos(np.clip((np.trace(R_goal.T @ T[:3, :3]) - 1) / 2, -1, 1))
    assert angle < 1e-3
    status = loop.statuses()[-1]
    assert values(status)["target_reached"] == "true", status.message


@pytest.mark.parametrize("kind", ["JointState", "JointJog"])
def test_a_jog_moves_only_the_named_joint(ros, loop, kind):
    if kind == "JointState":
        jog = joint_state(ros, ["elbow_joint"], [], [0.3])
        loop.run(1.0, lambda now: loop.service.on_joint_state_jog(jog, now))
    else:
        jog = joint_jog(ros, ["elbow_joint"], [0.3])
        loop.run(1.0, lambda now: loop.service.on_joint_jog(jog, now))
    moved = loop.positions()[-1] - Q_UR5
    assert moved[2] > 0.1
    assert np.abs(np.delete(moved, 2)).max() < 1e-9


# ---------------------------------------------------------------------------- refusals
@pytest.mark.parametrize(
    ("make", "words"),
    [
        (lambda ros: twist_msg(ros, linear=(math.nan, 0, 0)), ["linear", "finite"]),
        (lambda ros: twist_msg(ros, angular=(0, math.inf, 0)), ["angular", "finite"]),
        (lambda ros: twist_msg(ros, linear=(50.0, 0, 0)), ["unit error"]),  # 50 m/s: mm/s?
        (lambda ros: twist_msg(ros, (0.1, 0, 0), frame="camera"), ["'camera'", "'tool0'"]),
    ],
    ids=["nan", "inf", "huge", "unknown-frame"],
)
def test_a_bad_twist_is_refused_with_a_status_and_the_arm_stops(ros, loop, make, words):
    service = loop.service
    loop.run(0.5, lambda now: service.on_twist(twist_msg(ros, linear=(0.05, 0, 0)), now))
    assert np.abs(service.servo.velocities).max() > 0.01  # moving
    answer = service.on_twist(make(ros), loop.now)
    assert answer is not None and answer.level == 1
    assert values(answer)["code_name"] in ("COMMAND_REFUSED", "COMMAND_STALE")
    for word in words:
        assert word in answer.message, answer.message
    loop.run(1.0)  # no more commands: it stops smoothly, and says why on the way
    assert not service.servo.velocities.any()
    assert all_finite(loop.commands())
    assert any(word in s.message for s in loop.statuses() for word in words[:1])


def test_a_stale_twist_is_refused_and_leaves_the_active_one_to_its_timeout(ros, loop):
    service = loop.service
    loop.run(0.5, lambda now: service.on_twist(twist_msg(ros, linear=(0.05, 0, 0), t=now), now))
    seen = len(loop.statuses())
    answer = service.on_twist(twist_msg(ros, linear=(0.1, 0, 0), t=50.0), loop.now)
    assert answer is not None and answer.level == 1
    assert values(answer)["code_name"] == "COMMAND_STALE" and "older than" in answer.message
    loop.run(1.0)  # no more commands: the good twist times out, and the arm stops smoothly
    codes = [values(s)["code_name"] for s in loop.statuses()[seen:]]
    assert codes[0] == "OK" and "TIMEOUT_STOP" in codes and "COMMAND_STALE" not in codes
    assert not service.servo.velocities.any() and all_finite(loop.commands())


def test_twists_queued_while_the_node_was_held_up_keep_the_arm_moving(ros, ur5_text):
    """The node held up for 0.25 s (2.5 timeouts) while the twists kept coming: its late
    callback makes up the periods (MAX_CATCH_UP of them), then takes the queued twists (the
    oldest stale). No timeout stops it: the tool goes on at the commanded speed."""
    held = make_service(ros, ur5_text, **UR5, halt_messages=0)
    held.on_joint_state(joint_state(ros, held.chain.joint_names, Q_UR5))
    period = held.period_s
    answers, codes, commands = [], [], []
    for k in range(100):
        tick = 100.0 + k * period
        if 50 < k < 75:
            continue  # held up: the timer's ticks are skipped, the twists queue up
        if k == 75:  # the late callback, then what was queued
            cycle = held.step(tick, tick)
            codes.append(cycle.status)
            for j in range(51, 76):
                t = 100.0 + j * period
                answers.append(held.on_twist(twist_msg(ros, linear=(0.05, 0.0, 0.0), t=t), tick))
            continue
        held.on_twist(twist_msg(ros, linear=(0.05, 0.0, 0.0), t=tick), tick)
        cycle = held.step(tick, tick)
        codes.append(cycle.status)
        commands.append(cycle.command.data)
    codes = [values(c)["code_name"] for c in codes if c is not None]
    assert codes and set(codes) == {"OK"}  # never a timeout
    stale = [a for a in answers if a is not None and values(a)["code_name"] == "COMMAND_STALE"]
    assert stale  # the oldest queued twists were refused as stale, and changed nothing
    tool = tool_positions(held.chain, np.array(commands[-2:]))
    assert np.linalg.norm(tool[1] - tool[0]) / period == pytest.approx(0.05, rel=1e-3)
    assert values(held.status_message(0, "", None))["late_cycles"] == "1"


def test_wrong_joint_names_are_refused_naming_the_joint(ros, loop):
    answer = loop.service.on_joint_state_jog(joint_state(ros, ["elbow"], [], [0.2]), loop.now)
    assert "'elbow'" in answer.message and "'elbow_joint'" in answer.message
    answer = loop.service.on_joint_state_jog(
        joint_state(ros, ["elbow_joint", "wrist_1_joint"], [], [0.2]), loop.now
    )
    assert "velocities must be 2 finite numbers" in answer.message


@pytest.mark.parametrize(
    ("quaternion", "position"),
    [
        ((0, 0, 0, 0), (0.3, 0.1, 0.4)),
        ((0, 0, 0, 1), (math.nan, 0.1, 0.4)),
        ((0, 0, 0, 1), (3, 0, 0)),
    ],
    ids=["zero-quaternion", "nan-position", "out-of-reach"],
)
def test_a_bad_pose_target_is_refused(ros, loop, quaternion, position):
    answer = loop.service.on_pose(pose_msg(ros, position, quaternion), loop.now)
    assert answer is not None and values(answer)["code_name"] == "COMMAND_REFUSED"
    assert "PoseCommand refused" in answer.message
    loop.run(0.2)
    assert all_finite(loop.commands())


def test_while_paused_commands_are_refused_and_resume_accepts_them(ros, loop):
    service = loop.service
    loop.run(0.5, lambda now: service.on_twist(twist_msg(ros, linear=(0.05, 0, 0)), now))
    assert "paused" in service.set_paused(True)
    answers = loop.run(1.0, lambda now: service.on_twist(twist_msg(ros, linear=(0.05, 0, 0)), now))
    assert answers and all("paused" in a.message for a in answers)
    assert not service.servo.velocities.any()  # stopped
    assert any(values(s)["code_name"] == "PAUSED" for s in loop.statuses())
    assert service.set_paused(False).startswith("resumed")
    q_paused = loop.positions()[-1]
    loop.run(0.5, lambda now: service.on_twist(twist_msg(ros, linear=(0.05, 0, 0)), now))
    assert np.abs(loop.positions()[-1] - q_paused).max() > 1e-3
    assert service.set_paused(False) == "was not paused; nothing to resume"


# ---------------------------------------------------------------------------- stopping and output
def test_after_the_timeout_the_arm_stops_smoothly_and_then_stays_quiet(ros, ur5_text):
    service = make_service(ros, ur5_text, **UR5, period_s=0.002, halt_messages=3)
    loop = Loop(ros, service)
    loop.run(0.6, lambda now: service.on_twist(twist_msg(ros, linear=(0.05, 0, 0)), now))
    last = loop.now
    speeds = []
    for _ in range(400):  # 0.8 s without commands
        loop.run(service.period_s)
        speeds.append(np.abs(service.servo.velocities).max())
    timeout = service.config.command_timeout_s
    k = round(timeout / service.period_s)  # the first period past the timeout
    assert speeds[k + 1] < speeds[k - 2]  # the stop has begun within one period after it
    assert speeds[-1] == 0.0
    stops = [values(s)["code_name"] for s in loop.statuses() if s.message]
    assert "TIMEOUT_STOP" in stops
    # at rest: the hold command is sent halt_messages times, then nothing
    tail = loop.cycles[-100:]
    assert all(c.command is None for c in tail)
    first_idle = next(i for i, c in enumerate(loop.cycles) if c.command is None)
    assert first_idle > round((last - 100.0) / service.period_s)
    held = loop.cycles[first_idle - 3 : first_idle]
    assert all(np.array_equal(c.command.data, held[0].command.data) for c in held)


def test_halt_messages_zero_publishes_every_period(ros, ur5_text):
    service = make_service(ros, ur5_text, **UR5, halt_messages=0)
    loop = Loop(ros, service)
    loop.run(0.5)
    assert all(c.command is not None for c in loop.cycles)


def test_velocity_output_is_the_servos_joint_velocities(ros, ur5_text):
    service = make_service(ros, ur5_text, **UR5, command_out_type="velocity")
    loop = Loop(ros, service)
    assert service.command_out_topic == "/forward_velocity_controller/commands"
    loop.run(0.5, lambda now: service.on_twist(twist_msg(ros, linear=(0.05, 0, 0)), now))
    assert np.allclose(loop.commands()[-1].data, service.servo.velocities)


def test_trajectory_output_is_one_point_one_period_ahead(ros, ur5_text):
    service = make_service(ros, ur5_text, **UR5, command_out_type="trajectory", period_s=0.004)
    loop = Loop(ros, service)
    assert service.command_out_topic == "/joint_trajectory_controller/joint_trajectory"
    loop.run(0.3, lambda now: service.on_twist(twist_msg(ros, linear=(0.05, 0, 0)), now))
    msg = loop.commands()[-1]
    assert list(msg.joint_names) == list(service.chain.joint_names)
    (point,) = msg.points
    assert (point.time_from_start.sec, point.time_from_start.nanosec) == (0, 4_000_000)
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (0, 0)  # start at once
    assert np.allclose(point.positions, service.servo.positions)
    assert np.allclose(point.velocities, service.servo.velocities)
    assert np.allclose(point.accelerations, service.servo.accelerations)
    assert all_finite(loop.commands())


def test_the_status_is_published_on_change_and_every_status_period(ros, ur5_text):
    service = make_service(ros, ur5_text, **UR5, status_period=0.25)
    loop = Loop(ros, service)
    loop.run(1.0)  # idle: the heartbeat only
    idle = [i for i, c in enumerate(loop.cycles) if c.status is not None]
    assert len(idle) == 4 and all(b - a == 25 for a, b in zip(idle[:-1], idle[1:], strict=True))
    assert values(loop.cycles[idle[0]].status)["code_name"] == "IDLE"
    loop.run(0.1, lambda now: service.on_twist(twist_msg(ros, linear=(0.05, 0, 0)), now))
    assert loop.cycles[100].status is not None  # the change, at once
    assert values(loop.cycles[100].status)["code_name"] == "OK"
    assert loop.cycles[100].status.level == 0


def test_status_levels_and_names_cover_every_code():
    for code in (*StatusCode, NOT_READY):
        assert code_name(code)  # no KeyError
    assert code_name(NOT_READY) == "NOT_READY"


# ---------------------------------------------------------------------------- parameters
def test_settings_change_only_at_rest(ros, ur5_text):
    service = make_service(ros, ur5_text, **UR5)
    loop = Loop(ros, service)
    loop.run(0.3, lambda now: service.on_twist(twist_msg(ros, linear=(0.05, 0, 0)), now))
    with pytest.raises(InvalidInputError, match="moving.*pause_servo"):
        service.configure({"max_linear_speed_m_s": 0.2})
    assert service.config.max_linear_speed_m_s == 0.5  # nothing changed
    service.set_paused(True)
    loop.run(0.5)
    service.configure({"max_linear_speed_m_s": 0.02, "period_s": 0.005})
    assert service.config.max_linear_speed_m_s == 0.02 and service.period_s == 0.005
    assert service.servo.config.period_s == 0.005 and service.servo.paused
    service.set_paused(False)
    loop.run(1.0, lambda now: service.on_twist(twist_msg(ros, linear=(0.05, 0, 0)), now))
    p = tool_positions(service.chain, loop.positions()[-21:])
    speed = np.linalg.norm(p[-1] - p[0]) / (20 * 0.005)
    assert speed == pytest.approx(0.02, rel=0.05)  # scaled down to the new maximum


@pytest.mark.parametrize(
    ("changes", "words"),
    [
        ({"command_out_type": "velocity"}, ["read at start-up"]),
        ({"period_s": 0.0}, ["'period_s'", "0.0005"]),
        ({"period_s": 1}, ["'period_s'"]),  # an int for a float: accepted, then out of range
        ({"velocity_limits": "elbow_joint:=-1"}, ["'velocity_limits'", "elbow_joint:=-1"]),
        ({"velocity_limits": "elbow:=1.0"}, ["'elbow'"]),  # not a joint of the chain
        ({"task_axes": "wz vq"}, ["'task_axes'"]),
        ({"task_axes_frame": "world"}, ["'task_axes_frame'", "base", "tip"]),
        ({"status_period": -1.0}, ["'status_period'"]),
        ({"no_such": 1}, ["unknown parameter 'no_such'"]),
    ],
)
def test_bad_parameter_values_are_refused_saying_why(ros, service, changes, words):
    service.on_joint_state(joint_state(ros, service.chain.joint_names, Q_UR5))
    before = service.params
    with pytest.raises(KinematicsError) as info:
        service.configure(changes)
    for word in words:
        assert word in str(info.value), str(info.value)
    assert service.params == before


def test_an_invalid_start_up_parameter_raises(ros, ur5_text):
    with pytest.raises(InvalidInputError, match="command_out_type"):
        make_service(ros, ur5_text, command_out_type="effort")


def test_a_new_tip_rebuilds_the_servo_from_the_next_joint_states(ros, service):
    service.on_joint_state(joint_state(ros, service.chain.joint_names, Q_UR5))
    assert service.servo is not None
    service.configure({"tip_link": "wrist_3_link"})
    assert service.chain.tip_link == "wrist_3_link" and service.servo is None
    service.on_joint_state(joint_state(ros, service.chain.joint_names, Q_UR5))
    assert service.servo is not None and service.servo.chain.tip_link == "wrist_3_link"
    with pytest.raises(KinematicsError, match="'nowhere'"):
        service.configure({"tip_link": "nowhere"})


def test_a_late_cycle_makes_up_the_periods_missed(ros, ur5_text):
    """Stepped every third period (the node's timer skipped two ticks each time), the servo
    ends where a punctual one does: the arm keeps to the commanded speed in real time."""
    twist = twist_msg(ros, linear=(0.05, 0.0, 0.0))
    punctual = make_service(ros, ur5_text, **UR5, halt_messages=0)
    late = make_service(ros, ur5_text, **UR5, halt_messages=0)
    for service in (punctual, late):
        service.on_joint_state(joint_state(ros, service.chain.joint_names, Q_UR5))
    period = punctual.period_s
    for k in range(61):  # both end at k = 60
        now = 100.0 + k * period
        punctual.on_twist(twist, now)
        punctual.step(now)
        if k % 3 == 0:
            late.on_twist(twist, now)
            late.step(now)
    assert np.abs(punctual.servo.velocities).max() > 0.01  # moving
    assert np.allclose(late.servo.positions, punctual.servo.positions, atol=1e-12)
    # a longer stall is made up for MAX_CATCH_UP periods only, and counted
    before = late.servo.positions.copy()
    cycle = late.step(100.0 + 70 * period)
    v = values(late.status_message(0, "", None))
    assert v["late_cycles"] == "21" and v["lost_periods"] == str(10 - 1 - MAX_CATCH_UP)
    assert cycle.command is not None
    assert np.abs(late.servo.positions - before).max() > 0


def _punctual_and(ros, ur5_text, **params):
    """Two services at rest at Q_UR5 under the same twist: a reference stepped on every tick of
    the grid 100 + k·period, and one to step otherwise."""
    services = [make_service(ros, ur5_text, **UR5, halt_messages=0, **params) for _ in range(2)]
    for service in services:
        service.on_joint_state(joint_state(ros, service.chain.joint_names, Q_UR5))
    return services


@pytest.mark.parametrize("told", [True, False], ids=["the node gives its tick", "estimated"])
def test_a_callback_late_within_its_period_makes_up_nothing(ros, ur5_text, told):
    """Catch-up follows the timer's grid, not the callback's start: a callback 0.6 or 0.9 period
    after its tick (the timer skipped nothing) serves its own period, so the servo stays where
    the punctual one is; counting from the previous callback's start would make up a period
    (1.6 periods apart) that was never skipped and run ahead of the punctual servo."""
    twist = twist_msg(ros, linear=(0.05, 0.0, 0.0))
    punctual, jittery = _punctual_and(ros, ur5_text)
    period = punctual.period_s
    delays = [0.0, 0.6, 0.0, 0.9, 0.1, 0.0]  # [periods] after the tick, in turns
    for k in range(120):
        tick = 100.0 + k * period
        now = tick + delays[k % len(delays)] * period
        for service, t in ((punctual, tick), (jittery, now)):
            service.on_twist(twist, t)
        punctual.step(tick)
        jittery.step(now, tick if told else None)
    assert np.abs(punctual.servo.velocities).max() > 0.01  # moving
    assert np.allclose(jittery.servo.positions, punctual.servo.positions, atol=1e-12)
    v = values(jittery.status_message(0, "", None))
    assert v["late_cycles"] == "0" and v["lost_periods"] == "0"


def test_a_callback_a_period_late_makes_up_the_skipped_periods_at_once(ros, ur5_text):
    """A callback that begins 2.3 periods after its tick (the timer then skips the next two)
    serves the period it runs in: it makes up the two skipped, and the next tick is ordinary.
    One command goes out, the last step's: it equals the punctual servo's of that period."""
    twist = twist_msg(ros, linear=(0.05, 0.0, 0.0))
    punctual, late = _punctual_and(ros, ur5_text)
    period = punctual.period_s
    commands = {}
    for k in range(80):
        tick = 100.0 + k * period
        punctual.on_twist(twist, tick)
        commands[k] = punctual.step(tick).command
    for k in range(80):
        tick = 100.0 + k * period
        if k in (51, 52):
            continue  # skipped by the timer: the callback of tick 50 ran 2.3 periods late
        now = tick + 2.3 * period if k == 50 else tick
        late.on_twist(twist, now)
        cycle = late.step(now, tick)
        if k == 50:
            # it serves tick 52's period: one command, the punctual servo's of that period
            assert not np.allclose(commands[50].data, commands[52].data, atol=1e-9)
            assert np.allclose(cycle.command.data, commands[52].data, atol=1e-12)
    assert np.allclose(late.servo.positions, punctual.servo.positions, atol=1e-12)
    v = values(late.status_message(0, "", None))
    assert v["late_cycles"] == "1" and v["lost_periods"] == "0"


def test_a_command_that_finds_the_servo_idle_may_be_stepped_at_once(ros, ur5_text):
    """take_start_now: true once for a command accepted while the servo was idle; false while
    the arm moves, and for a refused command. Stepped at once (the grid restarted there), the
    next tick one period later makes up nothing."""
    service = make_service(ros, ur5_text, **UR5)
    loop = Loop(ros, service)
    loop.run(0.05)  # idle
    assert service.take_start_now() is False
    assert service.on_twist(twist_msg(ros, linear=(float("nan"), 0, 0), t=loop.now), loop.now)
    assert service.take_start_now() is False  # refused
    loop.run(0.01)
    now = loop.now + 0.3 * service.period_s  # between two ticks
    assert service.on_twist(twist_msg(ros, linear=(0.05, 0, 0), t=now), now) is None
    assert service.take_start_now() is True
    assert service.take_start_now() is False  # once
    before = service.servo.positions.copy()
    cycle = service.step(now, now)
    assert cycle.command is not None and not np.array_equal(cycle.command.data, before)
    for k in range(1, 50):  # the restarted grid
        t = now + k * service.period_s
        assert service.on_twist(twist_msg(ros, linear=(0.05, 0, 0), t=t), t) is None
        assert service.take_start_now() is False  # moving: the command waits for the tick
        service.step(t, now + k * service.period_s)
    assert values(service.status_message(0, "", None))["late_cycles"] == "0"


def test_a_new_description_while_moving_stops_the_arm_on_the_old_chain_first(ros, ur5_text):
    """The robot_description topic brings another robot (its last joint renamed) while the arm
    moves: the old chain's servo decelerates it within its acceleration and jerk limits, every
    period published with the old joint names, ending at zero velocity; commands are refused
    meanwhile; then the new chain's servo starts where the arm came to rest."""
    service = make_service(ros, "", **UR5, command_out_type="trajectory", halt_messages=0)
    service.on_description_message(ur5_text)
    old_names = list(service.chain.joint_names)
    new_text = ur5_text.replace('"wrist_3_joint"', '"wrist_3_joint_b"')
    assert new_text != ur5_text
    q = Q_UR5.copy()
    period = service.period_s
    now = 100.0

    def feed(positions):
        names = [*old_names, "wrist_3_joint_b"]
        service.on_joint_state(joint_state(ros, names, [*positions, positions[-1]]))

    def cycle(command=None):
        nonlocal now, q
        answer = command(now) if command is not None else None
        c = service.step(now)
        if c.command is not None:
            (point,) = c.command.points
            q = np.array(point.positions)
            feed(q)
        now += period
        return c, answer

    feed(q)
    limits = service.servo.limits
    for _ in range(300):
        cycle(lambda t: service.on_twist(twist_msg(ros, linear=(0.05, 0, 0.05), t=t), t))
    v_before = service.servo.velocities.copy()
    assert np.abs(v_before).max() > 0.01
    service.on_description_message(new_text)
    assert service.servo is None
    stopping, answers = [], []
    for _ in range(2000):
        c, answer = cycle(lambda t: service.on_twist(twist_msg(ros, linear=(0.05, 0, 0), t=t), t))
        answers.append(answer)
        stopping.append(c)
        if service.servo is not None:  # built from the joint_states after the last stop command
            break
    assert service.servo is not None, "the new chain's servo was never built"
    assert len(stopping) > 10  # a deceleration, not a jump to rest
    msgs = [c.command for c in stopping]
    assert all(m is not None and list(m.joint_names) == old_names for m in msgs)
    assert all_finite(msgs)
    v = np.array([m.points[0].velocities for m in msgs])
    a = np.array([m.points[0].accelerations for m in msgs])
    assert np.all(np.abs(v[-1]) == 0.0)  # ends at zero velocity
    assert np.all(np.abs(v[0] - v_before) <= limits.acceleration * period * (1 + 1e-9))
    assert np.all(np.abs(a) <= limits.acceleration * (1 + 1e-6))
    jerk = np.abs(np.diff(a, axis=0)) / period
    assert np.all(jerk <= limits.jerk * (1 + 1e-6))
    speeds = np.abs(v).max(axis=1)
    assert speeds[-1] == 0.0 and speeds[0] > 0.5 * np.abs(v_before).max()
    refusals = [a for a in answers[:-1] if a is not None]
    assert refusals and all(values(r)["code"] == str(NOT_READY) for r in refusals)
    assert "new robot description" in refusals[0].message
    # the new chain's servo, at rest where the arm stopped
    assert list(service.servo.chain.joint_names)[-1] == "wrist_3_joint_b"
    assert np.allclose(service.servo.positions, q)
    assert not service.servo.velocities.any()


def test_a_new_description_at_rest_switches_at_once(ros, ur5_text):
    service = make_service(ros, "", **UR5)
    service.on_description_message(ur5_text)
    loop = Loop(ros, service)
    loop.run(0.05)
    service.on_description_message(ur5_text.replace('"wrist_3_joint"', '"wrist_3_joint_b"'))
    assert service.servo is None and service.chain.joint_names[-1] == "wrist_3_joint_b"
    assert service.step(loop.now).command is None  # nothing of the old chain is published
