"""`kinematics ros jog`'s keyboard: keys in, the twist to send now out (no ROS, no terminal here:
`ros_commands` reads the keys and publishes).

Keys, one per axis and direction, lower case to move along an axis, upper case (Shift) to turn
about it:

    w / s   +x / -x        W / S   about +x / -x
    a / d   +y / -y        A / D   about +y / -y
    r / f   +z / -z        R / F   about +z / -z
    space   stop           + / -   faster / slower (x1.25)        q   quit

Why it holds a twist after each key: a terminal reports key presses, not releases, and a held
key repeats only after ~0.5 s, then ~30 times a second. teleop_twist_keyboard sends one twist per
press, so the servo's 0.1 s command timeout (moveit_servo's too) stops the arm between the first
press and the repeats, and the README had users raise the timeout. Here the last key's twist is
sent at the publishing rate for `HOLD_S` after its last press or repeat: a held key moves the arm
without a pause, a released one stops it within `HOLD_S` plus the servo's timeout and its smooth
stop, and the servo keeps its 0.1 s timeout for every other sender.
"""

from __future__ import annotations

from dataclasses import dataclass

#: Seconds a key's twist is held after its last press or repeat (a terminal's auto-repeat delay
#: is 0.25-0.6 s: xset's and the Linux console's default 0.5 s, macOS's shortest ~0.25 s).
HOLD_S = 0.6
#: Factor of `+` and `-`.
STEP = 1.25

#: key -> (index in the twist (ω, v) = (wx, wy, wz, vx, vy, vz), sign)
KEYS: dict[str, tuple[int, float]] = {
    "w": (3, 1.0),
    "s": (3, -1.0),
    "a": (4, 1.0),
    "d": (4, -1.0),
    "r": (5, 1.0),
    "f": (5, -1.0),
    "W": (0, 1.0),
    "S": (0, -1.0),
    "A": (1, 1.0),
    "D": (1, -1.0),
    "R": (2, 1.0),
    "F": (2, -1.0),
}

HELP = (
    "w/s a/d r/f: move along x/y/z; Shift (W/S A/D R/F): turn about them; "
    "space: stop; +/-: faster/slower; q: quit"
)


@dataclass
class Jog:
    """The keyboard's state: the held twist, its speeds, and when it lapses.

    Attributes:
        speed: linear speed [m/s] of a translation key.
        turn: angular speed [rad/s] of a rotation key.
        twist: the twist (ω, v) being held, or None (nothing to send).
        until: time [s] the held twist lapses.
        quit: `q` was pressed.
    """

    speed: float = 0.05
    turn: float = 0.3
    twist: tuple[float, ...] | None = None
    until: float = 0.0
    quit: bool = False

    def press(self, key: str, now: float) -> str | None:
        """Take one key pressed (or repeated) at `now` [s]; a line to show, if any."""
        if key in KEYS:
            index, sign = KEYS[key]
            twist = [0.0] * 6
            twist[index] = sign * (self.turn if index < 3 else self.speed)
            self.twist, self.until = tuple(twist), now + HOLD_S
            return None
        if key == " ":
            self.twist, self.until = (0.0,) * 6, now + HOLD_S  # a zero twist: the servo stops
            return "stop"
        if key and key in "+-":
            factor = STEP if key == "+" else 1.0 / STEP
            self.speed *= factor
            self.turn *= factor
            if self.twist is not None and any(self.twist):  # the held motion changes speed too
                self.twist = tuple(v * factor for v in self.twist)
            return f"speed {self.speed:.3g} m/s, turn {self.turn:.3g} rad/s"
        if key in ("q", "\x03", "\x04"):  # q, Ctrl-C, Ctrl-D (raw mode delivers them as keys)
            self.quit = True
            return None
        if key.isprintable() and not key.isspace():
            return f"key {key!r} does nothing ({HELP})"
        return None

    def current(self, now: float) -> tuple[float, ...] | None:
        """The twist to send at `now` [s]: the held one until it lapses, then None (the servo's
        timeout then stops the arm smoothly)."""
        if self.twist is not None and now >= self.until:
            self.twist = None
        return self.twist
