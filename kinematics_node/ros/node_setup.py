"""How our rclpy nodes (the kinematics node, the servo, the simulated arm) set up around their
service logic: declare their table of parameters (`service.parameters.ParameterSpec`) with
descriptors that say what each takes, answer a parameter change by what the service's
`configure` says of it (`answer_parameter_change`), say which given parameters they do not know
(`check_parameter_names`), and freeze the heap once they are built.

Descriptors: the description, the choices where there are some, and the range of a number that
has both bounds (what `ros2 param describe` shows and where rclpy refuses a value itself; the
node's own validation, `service.parameters.validate`, checks the rest: open bounds, strict
positivity, choices). ROS descriptors cannot say "> 0", so a `positive` spec's range is its
inclusive one.
"""

from __future__ import annotations

import gc
from collections.abc import Callable, Iterable
from typing import Any

from rcl_interfaces.msg import (
    FloatingPointRange,
    IntegerRange,
    ParameterDescriptor,
    SetParametersResult,
)
from rcl_interfaces.srv import ListParameters
from rclpy.exceptions import ParameterNotDeclaredException
from rclpy.node import Node
from rclpy.parameter import Parameter

from ..core.exceptions import KinematicsError
from ..service.parameter_names import override_warnings, refusal_text
from ..service.parameters import ParameterSpec


def descriptor(spec: ParameterSpec) -> ParameterDescriptor:
    """The `ParameterDescriptor` of `spec`: its description (with its choices), and the range of
    a number bounded on both sides."""
    text = spec.description
    if spec.choices:
        text += f" One of: {', '.join(spec.choices)}."
    d = ParameterDescriptor(description=text)
    if isinstance(spec.default, bool) or spec.minimum is None or spec.maximum is None:
        return d
    if isinstance(spec.default, float):
        d.floating_point_range = [
            FloatingPointRange(
                from_value=float(spec.minimum), to_value=float(spec.maximum), step=0.0
            )
        ]
    elif isinstance(spec.default, int):
        d.integer_range = [
            IntegerRange(from_value=int(spec.minimum), to_value=int(spec.maximum), step=1)
        ]
    return d


def declare_parameters(node: Node, specs: Iterable[ParameterSpec]) -> dict[str, Any]:
    """Declare every parameter of `specs` on `node` (default and descriptor from its spec);
    returns {name: value} as the node got them (its defaults, overridden by the command line,
    parameter files or launch)."""
    specs = tuple(specs)
    for spec in specs:
        node.declare_parameter(spec.name, spec.default, descriptor(spec))
    return {spec.name: node.get_parameter(spec.name).value for spec in specs}


class UnknownParameterError(ParameterNotDeclaredException):
    """A run-time set of parameters the node does not declare, naming each and the closest
    declared name. It is rclpy's own exception type, so rclpy's parameter service answers it as
    it answers its own (`SetParametersResult.reason` = this text), where rclpy's own text lists
    no name at all ("Invalid access to undeclared parameter(s): []": rclpy 7's
    `_check_undeclared_parameters` consumes its generator of names in `any()` before listing
    it)."""

    def __init__(self, text: str) -> None:
        Exception.__init__(self, text)


def declared_names(node: Node) -> list[str]:
    """Every parameter `node` has declared (ours and ROS's own, such as use_sim_time)."""
    return list(node.list_parameters([], ListParameters.Request.DEPTH_RECURSIVE).names)


def check_parameter_names(node: Node) -> None:
    """Call once a node has declared its parameters: warn about each parameter the command line
    (``-p``) or a parameter file (the node's own section, or ``/**``) gave it that it does not
    know, naming the closest known name (``unknown parameter 'tip_lnk' (did you mean
    'tip_link'?): ignored``); and from then on refuse a run-time set of an undeclared name
    saying the same (`UnknownParameterError`). Parameters ROS declares or reads itself
    (use_sim_time, qos_overrides.*) are not reported (`service.parameter_names`).

    The overrides are rclpy's `Node._parameter_overrides` (what rcl parsed for this node's name
    and namespace), which rclpy offers no public accessor for. The refusal is a pre-set-parameters
    callback (rclpy of Iron and later); on Humble's rclpy its own refusal stays."""
    declared = declared_names(node)
    overrides = getattr(node, "_parameter_overrides", None) or {}
    for line in override_warnings(overrides, declared):
        node.get_logger().warning(line)
    add_pre_set = getattr(node, "add_pre_set_parameters_callback", None)
    if add_pre_set is None:  # pragma: no cover - Humble
        return

    def refuse_unknown(params: list[Parameter]) -> list[Parameter]:
        unknown = [p.name for p in params if not node.has_parameter(p.name)]
        if unknown:
            raise UnknownParameterError(refusal_text(unknown, declared_names(node)))
        return params

    add_pre_set(refuse_unknown)


def answer_parameter_change(
    configure: Callable[[], object], log: Callable[[], None]
) -> SetParametersResult:
    """A set-parameters callback's answer: `configure()` (the service taking the new values)
    succeeds, or the change is refused with its reason (a `KinematicsError`'s message, or an
    internal error: never raised into rclpy); `log()` (the service's log lines) runs either
    way."""
    try:
        configure()
    except KinematicsError as exc:
        return SetParametersResult(successful=False, reason=str(exc))
    except Exception as exc:  # noqa: BLE001 - refused, never raised into rclpy
        return SetParametersResult(successful=False, reason=f"internal error: {exc!r}")
    finally:
        log()
    return SetParametersResult(successful=True)


def freeze_heap() -> None:
    """Exempt everything allocated so far (numpy, scipy, yourdfpy, rclpy, the model: ~100k
    objects) from the cyclic garbage collector. A full collection walks every tracked object:
    60 ms on a quiet machine, 250 ms on a busy one, during which no joint_states are served and
    a 1 kHz servo misses its ticks. What a node allocates per message is freed by reference
    counting anyway. Call it when a node is built, and again when it has built a new model."""
    gc.collect()
    gc.freeze()
