"""Helpers of the servo node's tests: a `ServoService` on a real UR5 description with real message
classes (rosbags), command messages, and an arm that follows what the service publishes."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from kinematics_node.service.servo import ServoCycle, ServoService
from msg_adapters.servo_messages import ServoMessageTypes

#: control_msgs/msg/JointJog (control_msgs 4.x, as moveit_servo takes it): not in rosbags'
#: stores, nor on PyPI; `joint_jog` registers it from this definition.
JOINT_JOG = """\
std_msgs/Header header
string[] joint_names
float64[] displacements
float64[] velocities
float64 duration
"""

#: A well-conditioned UR5 configuration (σ_min of the world Jacobian ≈ 0.2).
Q_UR5 = np.array([0.0, -1.57, 1.57, -1.57, -1.57, 0.0])


def make_service(ros: Any, description: str, **params: Any) -> ServoService:
    return ServoService(
        ros.types,
        ServoMessageTypes.from_typestore(ros.store),
        {"robot_description": description, **params},
    )


def stamp(ros: Any, t: float) -> Any:
    sec = math.floor(t)
    return ros.new("builtin_interfaces/msg/Time", sec=sec, nanosec=round((t - sec) * 1e9))


def header(ros: Any, t: float = 0.0, frame: str = "") -> Any:
    return ros.new("std_msgs/msg/Header", stamp=stamp(ros, t), frame_id=frame)


def vector3(ros: Any, xyz: Any) -> Any:
    x, y, z = (float(v) for v in xyz)
    return ros.new("geometry_msgs/msg/Vector3", x=x, y=y, z=z)


def twist_msg(ros: Any, linear=(0, 0, 0), angular=(0, 0, 0), frame="", t=0.0) -> Any:
    return ros.new(
        "geometry_msgs/msg/TwistStamped",
        header=header(ros, t, frame),
        twist=ros.new(
            "geometry_msgs/msg/Twist", linear=vector3(ros, linear), angular=vector3(ros, angular)
        ),
    )


def pose_msg(ros: Any, position, quaternion_xyzw, frame="", t=0.0) -> Any:
    x, y, z, w = (float(v) for v in quaternion_xyzw)
    return ros.new(
        "geometry_msgs/msg/PoseStamped",
        header=header(ros, t, frame),
        pose=ros.new(
            "geometry_msgs/msg/Pose",
            position=ros.new(
                "geometry_msgs/msg/Point", **dict(zip("xyz", map(float, position), strict=True))
            ),
            orientation=ros.new("geometry_msgs/msg/Quaternion", x=x, y=y, z=z, w=w),
        ),
    )


def joint_state(ros: Any, names, positions=(), velocities=(), t=0.0) -> Any:
    return ros.new(
        "sensor_msgs/msg/JointState",
        header=header(ros, t),
        name=list(names),
        position=np.asarray(positions, dtype=float),
        velocity=np.asarray(velocities, dtype=float),
    )


def joint_jog(ros: Any, names, velocities, t=0.0) -> Any:
    """A control_msgs/JointJog (its definition registered in `ros`'s store on first use)."""
    name = "control_msgs/msg/JointJog"
    if name not in ros.store.types:
        from rosbags.typesys import get_types_from_msg

        ros.store.register(get_types_from_msg(JOINT_JOG, name))
    return ros.new(
        name,
        header=header(ros, t),
        joint_names=list(names),
        velocities=np.asarray(velocities, dtype=float),
    )


class Loop:
    """Runs a service period by period with an arm that reaches every commanded position (the
    published Float64MultiArray) before the next period, and records what was published."""

    def __init__(self, ros: Any, service: ServoService, q0: Any = Q_UR5, now: float = 100.0):
        self.ros = ros
        self.service = service
        self.now = now
        assert service.chain is not None
        self.names = service.chain.joint_names
        self.q = np.array(q0, dtype=float)
        self.cycles: list[ServoCycle] = []
        self.times: list[float] = []
        self.feed()

    def feed(self) -> None:
        assert self.service.on_joint_state(joint_state(self.ros, self.names, self.q)) is None

    def run(self, seconds: float, command: Callable[[float], Any] | None = None) -> list[Any]:
        """Step for `seconds`; `command(now)` (if given) is called before each step (it may
        submit a command). Returns the statuses that `command` got back (refusals)."""
        answers = []
        period = self.service.period_s
        for _ in range(round(seconds / period)):
            if command is not None:
                answer = command(self.now)
                if answer is not None:
                    answers.append(answer)
            cycle = self.service.step(self.now)
            self.cycles.append(cycle)
            self.times.append(self.now)
            if cycle.command is not None and self.service.command_out_type == "position":
                self.q = np.array(cycle.command.data, dtype=float)
                self.feed()
            self.now += period
        return answers

    def commands(self) -> list[Any]:
        return [c.command for c in self.cycles if c.command is not None]

    def statuses(self) -> list[Any]:
        return [c.status for c in self.cycles if c.status is not None]

    def positions(self) -> np.ndarray:
        """(K, n) the positions published so far (position output)."""
        return np.array([list(m.data) for m in self.commands()])


def values(status: Any) -> dict[str, str]:
    return {kv.key: kv.value for kv in status.values}


def all_finite(messages: list[Any]) -> bool:
    """Every number of every joint command (Float64MultiArray or JointTrajectory) is finite."""
    for m in messages:
        if hasattr(m, "data"):
            numbers = list(m.data)
        else:
            numbers = [x for p in m.points for x in (*p.positions, *p.velocities, *p.accelerations)]
        if not all(math.isfinite(x) for x in numbers):
            return False
    return True


def servo_ready(statuses: list[Any], states: list[Any], twist_publisher: Any) -> bool:
    """The live servo tests' start condition: the servo says IDLE on ~/status, joint_states
    flow, and our twist publisher has matched the servo's subscription."""
    return (
        any(values(s).get("code_name") == "IDLE" for s in statuses)
        and len(states) > 5
        and twist_publisher.get_subscription_count() > 0
    )


def velocity(t: np.ndarray, p: np.ndarray, width: float = 0.15) -> np.ndarray:
    """The tool's velocity [m/s]: the median of straight-line fits over windows of `width` [s].
    A process held up on a loaded machine stops the arm for as long (the servo makes up at most
    MAX_CATCH_UP periods, so as not to throw the arm forward): that costs one or two windows,
    not the whole judgement."""
    fits = []
    for a in np.arange(t[0], t[-1] - 0.5 * width, width):
        inside = (t >= a) & (t < a + width)
        if inside.sum() >= 3:
            fits.append(np.polyfit(t[inside] - a, p[inside], 1)[0])
    assert len(fits) >= 3, f"{len(t)} positions over {t[-1] - t[0]:.3f} s"
    return np.median(fits, axis=0)


def servo_held_up(
    arrivals: list[float], statuses: list[Any], start: float, end: float, period_s: float
) -> str | None:
    """Why the servo could not serve a stream of commands sent from `start` to `end` [s, the
    arrival times' clock], by its own ~/status: commands that reached it stale or not at all
    while they were sent (TIMEOUT_STOP, COMMAND_STALE: it stops the arm, then ramps up again),
    or more than a tenth of the stream's periods that its late cycles could not make up
    (`lost_periods`: at most MAX_CATCH_UP a cycle, so that the arm is never thrown forward; it
    falls behind). None when it served them: then its speed can be judged."""
    pairs = list(zip(arrivals, statuses, strict=False))

    def lost_before(when: float) -> int:
        last = [s for t, s in pairs if t < when]
        return int(values(last[-1]).get("lost_periods", 0)) if last else 0

    said = [values(s).get("code_name") for t, s in pairs if start <= t < end]
    # (from its first following code on: until then it may still report an earlier stop)
    following = [i for i, c in enumerate(said) if c in ("OK", "NEAR_SINGULARITY", "AT_JOINT_LIMIT")]
    said = said[following[0] :] if following else said
    stopped = sorted({c for c in said if c in ("TIMEOUT_STOP", "COMMAND_STALE")})
    lost = lost_before(end + 0.05) - lost_before(start)
    periods = (end - start) / period_s
    if stopped or lost > 0.1 * periods:
        return (
            f"by its ~/status: {stopped or 'no stop'} after it began to follow, {lost} of "
            f"{periods:.0f} periods lost"
        )
    return None
