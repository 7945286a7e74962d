"""The node's parameters: one table used for declaration (descriptors, ranges) and validation.

No rclpy here: `ros/kinematics.py` turns each `ParameterSpec` into a `ParameterDescriptor`, and its
set-parameters callback calls `validate_parameters` so that a bad `ros2 param set` is refused with
the same message a test sees. `validate` checks values against any node's table of specs: the
servo node's (`servo_parameters`) is checked by the same rules, with the same sentences.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from ..core.ik.options import IKOptions


@dataclass(frozen=True)
class ParameterSpec:
    """One parameter: name, default (its type is the parameter type), description, and limits.

    `minimum`/`maximum` are inclusive range bounds for the descriptor; `positive` additionally
    refuses 0 (ranges in ROS descriptors are inclusive, so "> 0" cannot be expressed there).
    """

    name: str
    default: Any
    description: str
    minimum: float | None = None
    maximum: float | None = None
    positive: bool = False
    choices: tuple[str, ...] = ()


#: The IK defaults are the library's (one source): a node and `chain.ik` agree unless configured.
_IK = IKOptions()

PARAMETERS: tuple[ParameterSpec, ...] = (
    ParameterSpec(
        "robot_description",
        "",
        "URDF or xacro XML text of the robot (for a file, use robot_description_file). The robot "
        "description comes from the first of: this parameter, robot_description_file, the "
        "robot_description topic (std_msgs/String, transient local, as robot_state_publisher "
        "publishes it), which is used while both parameters are empty.",
    ),
    ParameterSpec(
        "robot_description_file",
        "",
        "Path of a URDF or xacro file of the robot, used when robot_description is empty (it "
        "takes precedence over the robot_description topic). A .xacro file, or any file when "
        "xacro_args is set, is expanded with xacro.",
    ),
    ParameterSpec(
        "xacro_args",
        "",
        "Arguments for xacro when it expands robot_description_file, as on xacro's command "
        "line: 'name:=value other:=value' (quote a value with spaces: name:='a b'). An argument "
        "the file neither declares nor uses is refused.",
    ),
    ParameterSpec(
        "base_link",
        "",
        "Root link of the kinematic chain; empty = the URDF root link. Set at run time, it must "
        "be a link of the description the node holds.",
    ),
    ParameterSpec(
        "tip_link",
        "",
        "End-effector link; empty = the single leaf link below base_link. When there are several "
        "(a gripper's fingers, cameras, other arms), the node holds the description and waits "
        "for one, listing the candidates (logs, /diagnostics, service answers). Set at run time, "
        "it must be a link of the description the node holds.",
    ),
    ParameterSpec(
        "twist_frame",
        "world",
        "Axes of the published ee_twist: 'world' = base_link axes (frame_id base_link), "
        "'body' = tip_link axes (frame_id tip_link). Reference point: the tip_link origin.",
        choices=("world", "body"),
    ),
    ParameterSpec(
        "ik.position_tolerance",
        _IK.position_tolerance,
        "Default IK position tolerance [m] (requests may override).",
        minimum=1e-12,
        maximum=1.0,
        positive=True,
    ),
    ParameterSpec(
        "ik.orientation_tolerance",
        _IK.orientation_tolerance,
        "Default IK orientation tolerance [rad] (requests may override).",
        minimum=1e-12,
        maximum=math.pi,
        positive=True,
    ),
    ParameterSpec(
        "ik.timeout",
        _IK.timeout,
        "Default IK wall-clock budget [s] (requests may override; honoured to the ms).",
        minimum=1e-4,
        maximum=60.0,
        positive=True,
    ),
    ParameterSpec(
        "ik.max_restarts",
        _IK.max_restarts,
        "Maximum random restarts of the IK solver within its timeout. The default leaves the "
        "timeout to decide (one restart takes ~0.5 ms); lower it to give up on unreachable "
        "targets before their timeout.",
        minimum=0,
        maximum=10**9,
    ),
    ParameterSpec(
        "ik.workers",
        0,
        "Worker processes that solve IK requests in parallel (read at start-up); 0 = one per "
        "core, between 4 and 8. Workers run at a lower CPU priority than the pose path.",
        minimum=0,
        maximum=64,
    ),
    ParameterSpec(
        "singular_threshold",
        1e-3,
        "Smallest singular value of the 6 x n world Jacobian below which the arm is reported "
        "as near-singular (diagnostics WARN).",
        minimum=0.0,
        maximum=1e3,
    ),
    ParameterSpec(
        "markers_rate",
        10.0,
        "Rate [Hz] of the manipulability markers on ~/markers (visualization_msgs/MarkerArray: "
        "the translational manipulability ellipsoid at the tool, green to red by condition "
        "number, and its most singular direction), published only while someone subscribes; "
        "0 = never (read at start-up).",
        minimum=0.0,
        maximum=100.0,
    ),
    ParameterSpec(
        "publish_tf",
        False,
        "Publish every link of the robot description on /tf (each moving joint named by a "
        "joint_states message, child link in parent link, stamped like it; mimic joints with "
        "their leader) and its fixed joints on /tf_static (transient local), as "
        "robot_state_publisher does: run one or the other (read at start-up).",
    ),
    ParameterSpec(
        "tf_rate",
        20.0,
        "With publish_tf: the most /tf messages a second [Hz], by robot_state_publisher's rule "
        "(its publish_frequency, also 20 Hz by default): a joint_states message gets its /tf "
        "when the least recently published joint it names was published at least 1/tf_rate "
        "earlier, by the messages' stamps. 0 = every joint_states message (at 1 kHz that costs "
        "the node about 0.2 ms a message, four times its pose).",
        minimum=0.0,
        maximum=10000.0,
    ),
    ParameterSpec(
        "publish_diagnostics", True, "Publish diagnostic_msgs/DiagnosticArray on /diagnostics."
    ),
    ParameterSpec(
        "diagnostics_period",
        1.0,
        "Period of the diagnostics publication [s].",
        minimum=0.01,
        maximum=3600.0,
        positive=True,
    ),
    ParameterSpec(
        "executor",
        "lean",
        "Executor of the node's one thread: 'lean' = this package's LeanExecutor (one wait per "
        "callback, a wait set built once; about half the CPU per joint_states message of "
        "rclpy's), 'rclpy' = rclpy's SingleThreadedExecutor. Where this rclpy lacks what the "
        "lean one uses, the node says so and uses rclpy's.",
        choices=("lean", "rclpy"),
    ),
    ParameterSpec(
        "joint_states_timeout",
        1.0,
        "Diagnostics report joint_states as stale after this long without a sample [s].",
        minimum=1e-3,
        maximum=3600.0,
        positive=True,
    ),
    ParameterSpec(
        "joint_states_max_age",
        1.0,
        "compute_fk and compute_jacobian refuse a request that leaves out a joint whose value "
        "from joint_states is older than this [s], or that no joint_states have named (the "
        "answer names them); 0 = no limit. Age = now on the node's clock minus when the node "
        "received the joint_states that last gave the joint (not their stamp). Every answer "
        "says which joints came from joint_states and how old they were; an IK seed taken from "
        "them is only reported.",
        minimum=0.0,
        maximum=3600.0,
    ),
)

SPECS: dict[str, ParameterSpec] = {spec.name: spec for spec in PARAMETERS}

#: Parameters the node reads once at start-up; changing them at run time is refused.
STARTUP_ONLY = frozenset(
    {"diagnostics_period", "ik.workers", "executor", "markers_rate", "publish_tf"}
)


def defaults() -> dict[str, Any]:
    """{name: default} of every parameter."""
    return {spec.name: spec.default for spec in PARAMETERS}


def validate_parameters(values: Mapping[str, Any]) -> str | None:
    """None if every value in `values` is an acceptable kinematics node parameter, else a message
    naming the first bad one (`validate` against `SPECS`)."""
    return validate(values, SPECS)


def validate(values: Mapping[str, Any], specs: Mapping[str, ParameterSpec]) -> str | None:
    """None if every value in `values` is acceptable by its spec in `specs` (a node's table, by
    name), else a message naming the first bad one.

    Checks types (bool is not accepted as a number; an int is accepted for a float parameter),
    finiteness, ranges, strict positivity and choices. Unknown names are refused. (The servo
    node's table, `servo_parameters.SERVO_SPECS`, goes through here too.)
    """
    for name, value in values.items():
        spec = specs.get(name)
        if spec is None:
            return f"unknown parameter {name!r}; known: {sorted(specs)}"
        problem = check_value(spec, value)
        if problem is not None:
            return problem
    return None


def check_value(spec: ParameterSpec, value: Any) -> str | None:
    """None if `value` is acceptable for `spec`, else a sentence naming the parameter, what it
    takes and what it got."""
    name, want = spec.name, type(spec.default)
    if want is bool:
        ok = isinstance(value, bool)
    elif want is float:
        ok = isinstance(value, (int, float)) and not isinstance(value, bool)
    elif want is int:
        ok = isinstance(value, int) and not isinstance(value, bool)
    else:
        ok = isinstance(value, want)
    if not ok:
        return f"parameter {name!r} must be of type {want.__name__}, got {value!r}"
    if want in (int, float):
        v = float(value)
        if not math.isfinite(v):
            return f"parameter {name!r} must be finite, got {value!r}"
        if spec.positive and v <= 0:
            return f"parameter {name!r} must be > 0, got {value!r}"
        if spec.minimum is not None and v < spec.minimum:
            return f"parameter {name!r} must be >= {spec.minimum:g}, got {value!r}"
        if spec.maximum is not None and v > spec.maximum:
            return f"parameter {name!r} must be <= {spec.maximum:g}, got {value!r}"
    if spec.choices and value not in spec.choices:
        return f"parameter {name!r} must be one of {list(spec.choices)}, got {value!r}"
    return None
