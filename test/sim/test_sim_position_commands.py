"""The simulator's position mode (what ros2_control's forward position controller does with the
servo's commands) and its Float64MultiArray adapter."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics_node.core import InvalidInputError
from kinematics_node.core.model import middle_of_limits
from kinematics_node.sim import robots
from kinematics_node.sim.arm import MODES, ArmSimulator
from msg_adapters.joint_commands import apply_position_msg


@pytest.fixture
def sim() -> ArmSimulator:
    chain = robots.load_robot("ur5e")
    return ArmSimulator.from_chain(chain, 0.01, q0=np.zeros(6), demo=False)


def test_a_feasible_position_is_reached_in_one_step_and_held(sim):
    target = sim.velocity_limit * sim.dt * np.linspace(-0.9, 0.9, 6)
    sim.command_position(target)
    assert sim.mode == "position" and "position" in MODES
    assert np.allclose(sim.step().q, target)
    assert np.allclose(sim.qdot, target / sim.dt)
    for _ in range(200):  # 2 s: no timeout, unlike a velocity command
        sim.step()
    assert np.allclose(sim.q, target) and not sim.qdot.any() and sim.mode == "position"


def test_a_far_position_is_approached_along_a_line_the_slowest_joint_at_its_limit():
    """A position out of one step's reach: every joint moves toward it in proportion (a straight
    line in joint space, so a streamed path that arrives late is caught up along it, not joint by
    joint), the joint that needs longest at its velocity limit, none over its own."""
    chain = robots.load_robot("panda")  # velocity limits 2.175 and 2.61 rad/s
    sim = ArmSimulator.from_chain(
        chain, 0.002, q0=middle_of_limits(chain.lower, chain.upper), demo=False
    )
    start = sim.q.copy()
    target = start + np.array([0.3, -0.1, 0.05, 0.2, 0.3, -0.3, 0.01])
    sim.command_position(target)
    q1 = sim.step().q
    step = q1 - start
    np.testing.assert_allclose(
        step / np.linalg.norm(step), (target - start) / np.linalg.norm(target - start), atol=1e-12
    )
    used = np.abs(step) / (sim.velocity_limit * sim.dt)
    assert used.max() == pytest.approx(1.0) and used.min() < 0.1
    for _ in range(300):
        sim.step()
    np.testing.assert_allclose(sim.q, target)


def test_a_position_outside_the_limits_is_clamped():
    chain = robots.load_robot("panda")
    sim = ArmSimulator.from_chain(chain, 0.01, demo=False)
    target = chain.upper + 1.0
    sim.command_position(target)
    for _ in range(2000):
        sim.step()
    assert np.allclose(sim.q, chain.upper)


@pytest.mark.parametrize("bad", [np.zeros(5), np.array([0, 0, 0, np.nan, 0, 0])])
def test_a_bad_position_command_is_refused_and_changes_nothing(sim, bad):
    with pytest.raises(InvalidInputError, match="position command"):
        sim.command_position(bad)
    assert sim.mode == "hold"


def test_a_float64_multi_array_commands_positions_naming_the_topic_on_error(ros, sim):
    F64 = ros.cls("std_msgs/msg/Float64MultiArray")
    layout = ros.new("std_msgs/msg/MultiArrayLayout")
    msg = F64(layout=layout, data=np.array([0.01, 0, 0, 0, 0, -0.01]))
    q = apply_position_msg(sim, ros.roundtrip(msg), "/forward_position_controller/commands")
    assert np.allclose(q, [0.01, 0, 0, 0, 0, -0.01]) and sim.mode == "position"
    short = F64(layout=layout, data=np.array([0.0, 0.0]))
    with pytest.raises(InvalidInputError, match="/forward_position_controller/commands"):
        apply_position_msg(sim, short, "/forward_position_controller/commands")
