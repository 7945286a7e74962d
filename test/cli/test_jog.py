"""`kinematics ros jog`'s keyboard (cli/jog.py): which twist each key sends, for how long, and
what the other keys do. Against the servo node: test/live/test_servo_node.py."""

from __future__ import annotations

import pytest

from kinematics_node.cli.jog import HOLD_S, KEYS, STEP, Jog


@pytest.mark.parametrize("key", sorted(KEYS))
def test_each_key_moves_along_or_about_one_axis_at_its_speed(key):
    jog = Jog(speed=0.05, turn=0.3)
    assert jog.press(key, 10.0) is None
    twist = jog.current(10.0)
    assert twist is not None and sum(1 for v in twist if v) == 1
    (index,) = [i for i, v in enumerate(twist) if v]
    # lower case: linear (v, the last three); upper case: angular (ω, the first three)
    assert (index >= 3) == key.islower()
    assert abs(twist[index]) == (0.05 if key.islower() else 0.3)
    opposite = {"w": "s", "a": "d", "r": "f"}
    pair = {**opposite, **{b: a for a, b in opposite.items()}}[key.lower()]
    jog.press(pair.upper() if key.isupper() else pair, 10.0)
    assert jog.current(10.0)[index] == -twist[index]  # its partner goes the other way


def test_a_twist_is_held_until_hold_after_the_last_press_or_repeat():
    jog = Jog()
    jog.press("w", 0.0)
    assert jog.current(HOLD_S - 1e-3) is not None
    jog.press("w", 0.5)  # the terminal's auto-repeat of a held key
    assert jog.current(0.5 + HOLD_S - 1e-3) is not None
    assert jog.current(0.5 + HOLD_S) is None  # released: nothing more is sent
    assert jog.current(5.0) is None


def test_space_sends_a_zero_twist_and_plus_minus_scale_every_speed():
    jog = Jog(speed=0.04, turn=0.2)
    jog.press("r", 0.0)
    assert "speed 0.05 m/s" in jog.press("+", 0.1)
    assert jog.turn == pytest.approx(0.2 * STEP)
    assert jog.current(0.1)[5] == pytest.approx(0.04 * STEP)  # the held motion too
    jog.press("-", 0.2)
    assert jog.speed == pytest.approx(0.04)
    assert jog.press(" ", 0.3) == "stop"
    assert jog.current(0.3) == (0.0,) * 6


@pytest.mark.parametrize("key", ["q", "\x03", "\x04"])
def test_q_ctrl_c_and_ctrl_d_quit(key):
    jog = Jog()
    jog.press(key, 0.0)
    assert jog.quit


def test_other_keys_say_what_the_keys_are_and_send_nothing():
    jog = Jog()
    assert "w/s a/d r/f" in jog.press("x", 0.0)
    assert jog.press("\n", 0.0) is None and jog.current(0.0) is None and not jog.quit
