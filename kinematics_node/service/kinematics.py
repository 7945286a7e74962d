"""Message-level service logic of the kinematics node, with no rclpy import.

`KinematicsService` takes and returns ROS message objects (rclpy's or rosbags'; the classes it
builds come from a `MessageTypes`), so everything the node does except the rclpy wiring is tested on
machines without ROS. Conventions at this boundary: twists as geometry_msgs/Twist (linear, angular),
Jacobian rows (linear x, y, z, angular x, y, z), quaternions (x, y, z, w), [m], [rad], [s].

Threading: not thread-safe. The node calls every method from its one executor thread; IK runs in
worker processes (`kinematics_node.service.ik_pool`) between `prepare_ik` and `finish_ik`, which are cheap.
`compute_ik` does both and the solve in between, in the caller's thread (tests, tools).

The pose path (`on_joint_state`) computes per message only what is published: one FK + world
Jacobian pass, the twist, and the two messages (and, with publish_tf, the /tf of the joints the
message names). Conditioning (SVDs) is computed for diagnostics and the manipulability markers
(`markers`), at their rates, from the last state.

Service callbacks follow rclpy's `(request, response) -> response` and never raise: any failure
gives `success = False` and a `message` naming the problem.
"""

from __future__ import annotations

import hashlib
import logging
import math
import re
import time
from collections import deque
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from enum import IntEnum
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from msg_adapters import (
    MessageTypes,
    fill_jacobian_fields,
    header,
    joint_state_from_q,
    joint_states_from_qs,
    matrix_from_pose,
    pose_stamped_from_matrix,
    q_from_joint_state,
    sample_from_joint_state,
    time_from_seconds,
    twist_stamped_from_core,
)
from msg_adapters.markers import MarkerTypes, manipulability_markers
from msg_adapters.transforms import TFTypes, tf_message

from ..core import IKOptions, SerialChain, se3
from ..core._checks import check_transform
from ..core.analysis import conditioning, translational_ellipsoid
from ..core.exceptions import InvalidInputError, KinematicsError, RobotDescriptionError
from ..core.ik.solver import beyond_reach, duration_text
from ..core.joint_transforms import JointTransforms
from ..core.model import Frame
from .description_file import read_description_file
from .ee_state import (
    FROM_ARRIVAL_UNSTAMPED,
    JUMP_BACK,
    EndEffectorState,
    JointStateTracker,
    compute_ee_state,
)
from .ik_pool import MIN_SOLVE_TIME, IKJob, IKOutcome, chain_blob, solve_job
from .parameters import defaults, validate_parameters
from .robot_model import HeldDescription, RobotModel

FloatArray = NDArray[np.float64]

#: (target_frame, source_frame) -> T_target_source (4×4), the pose of source in target (latest
#: available). Raises any exception when the transform is unavailable (its text is reported).
LookupTransform = Callable[[str, str], ArrayLike]

JACOBIAN_FRAMES: tuple[Frame, ...] = ("world", "body", "space")
JACOBIAN_FRAMES_BY_NAME: dict[str, Frame] = {f: f for f in JACOBIAN_FRAMES}
NO_DESCRIPTION = (
    "no robot description loaded yet: set the robot_description parameter (URDF text) or "
    "robot_description_file (a URDF or xacro path), or publish it on the robot_description "
    "topic (std_msgs/String, transient local)"
)
#: The parameters that give the robot description, in order of precedence (then the topic).
DESCRIPTION_PARAMETERS = ("robot_description", "robot_description_file", "xacro_args")

_log = logging.getLogger(__name__)


def diagnostics_name(node_name: str) -> str:
    """The name of the node's status on /diagnostics: "<node's full name>: end effector"
    (``/arm1/kinematics_node: end effector``), as diagnostic_updater prefixes the node's name,
    so that nodes in different namespaces publish distinct statuses. Filter on it with this
    function, or on the suffix ": end effector"."""
    return f"{node_name}: end effector"


class Severity(IntEnum):
    """How a joint_states problem is reported (the values are DiagnosticStatus levels).

    NOTE: not logged, not in diagnostics (the velocity is not known yet); WARN: logged
    (throttled) and a diagnostics WARN; ERROR: logged and a diagnostics ERROR.
    """

    NOTE = 0
    WARN = 1
    ERROR = 2


@dataclass(frozen=True)
class EEMessages:
    """What to publish after a joint state: any of them may be None.

    `problem` explains why nothing (or only the pose) is published, for logs and diagnostics, and
    `severity` says how loudly.
    """

    pose: Any | None = None
    twist: Any | None = None
    problem: str | None = None
    severity: Severity = Severity.NOTE
    tf: Any | None = None


@dataclass(frozen=True)
class DescriptionStatus:
    """The state of the node's robot model, for logs, /diagnostics and service answers.

    `state` is "none" (no description received yet), "waiting" (a description is held, but its
    chain is not chosen yet: `message` says why and how to choose, `candidates` are the tips
    below the base), "loaded" (a model serves), or "refused" (the last description could not be
    used, and none is held). `source` says where the description came from (a parameter, the
    file, the topic), `robot_name` its <robot name>.
    """

    state: str
    message: str
    source: str = ""
    robot_name: str = ""
    candidates: tuple[str, ...] = ()


class _Rates:
    """joint_states arrival rate [Hz], from their receive times, and latency (receive time −
    stamp) [s] of the stamped ones, over recent samples. An unstamped sample (stamp exactly 0,
    `msg_adapters.sample_from_joint_state`) has no latency: NaN in the window, not now − 0."""

    def __init__(self, window: int = 50) -> None:
        self._arrivals: deque[float] = deque(maxlen=window)
        self._latencies: deque[float] = deque(maxlen=window)

    def record(self, received: float, stamp: float) -> None:
        self._arrivals.append(received)
        self._latencies.append(received - stamp if stamp != 0.0 else math.nan)

    @property
    def last_arrival(self) -> float | None:
        return self._arrivals[-1] if self._arrivals else None

    def rate(self) -> float:
        if len(self._arrivals) < 2:
            return 0.0
        span = self._arrivals[-1] - self._arrivals[0]
        return (len(self._arrivals) - 1) / span if span > 0 else 0.0

    def latency(self) -> float | None:
        """Mean latency of the window's stamped samples [s]; None when the last sample was
        unstamped, or none was received."""
        if not self._latencies or math.isnan(self._latencies[-1]):
            return None
        stamped = [x for x in self._latencies if not math.isnan(x)]
        return sum(stamped) / len(stamped)


@dataclass
class IKAnswerCounts:
    """compute_ik solves answered so far, and how their answers stood against their deadlines
    (the client's send + timeout, `prepare_ik`) when the node sent them. The client sees them
    later by the transport's delay; an answer after its deadline here is the node's own
    lateness."""

    answered: int = 0
    after_deadline: int = 0
    worst_after_deadline: float = 0.0  # [s]; 0 while none was late

    def record(self, after_deadline: float) -> None:
        self.answered += 1
        if after_deadline > 0.0:
            self.after_deadline += 1
            self.worst_after_deadline = max(self.worst_after_deadline, after_deadline)

    def values(self) -> list[tuple[str, str]]:
        return [
            ("ik_answered", str(self.answered)),
            ("ik_after_deadline", str(self.after_deadline)),
            ("ik_worst_after_deadline_s", f"{self.worst_after_deadline:.6f}"),
        ]


@dataclass(frozen=True)
class PendingIK:
    """An IK request between `prepare_ik` and `finish_ik`: the job for a worker, and what the
    answer needs."""

    job: IKJob
    chain: SerialChain  # the model's chain the job was made from (for `ik_pool.solve_at_once`)
    joint_names: tuple[str, ...]
    stamp: Any
    options: IKOptions
    note: str = ""  # why the target cannot be reached, when that is known beforehand
    seed_note: str = ""  # the joints of the seed taken from joint_states, and their age


class KinematicsService:
    """The kinematics node's behaviour on messages.

    Args:
        types: message classes to build outputs with.
        params: parameter values by name (see `kinematics_node.service.parameters`); missing = defaults.
            A description given by `robot_description` or `robot_description_file` is loaded at
            once; when it cannot be used, the service starts without a model and says why
            (`status`, `take_log`, diagnostics, service answers) rather than raising.
        lookup_transform: TF lookup for IK target frames that are not robot links (None = no TF:
            such targets are refused, saying that TF frames need tf2_ros).
        clock: current time [s] in the time base of the joint_states stamps (the node passes its
            ROS clock, so simulated time works); used for diagnostics only.
        node_name: the node's full name, for the commands that messages suggest
            (``ros2 param set <node_name> tip_link <link>``) and the name of its /diagnostics
            status (`diagnostics_name`).

    Raises:
        InvalidInputError: a parameter value is invalid (wrong type, out of range).
    """

    def __init__(
        self,
        types: MessageTypes,
        params: Mapping[str, Any] | None = None,
        lookup_transform: LookupTransform | None = None,
        clock: Callable[[], float] = time.time,
        node_name: str = "/kinematics_node",
        tf_types: TFTypes | None = None,
    ) -> None:
        """`tf_types`: the classes of /tf's messages; None: no /tf (publish_tf is then refused
        by the node, which says why)."""
        self._types = types
        self._tf_types = tf_types
        self._tree_tf: JointTransforms | None = None
        self._tf_inputs: list[int] = []  # tracker index of each input of _tree_tf
        self._tf_rows: dict[
            tuple[str, ...], tuple[list[int], tuple[str, ...], tuple[str, ...]]
        ] = {}
        self._last_stamp: Any = None  # the Time of the last posed joint_states
        # /tf at most at tf_rate: each joint_states name's time [ns] of its last /tf (`_tf_due`)
        self._tf_published: dict[str, int] = {}
        self.markers_published = 0
        self._lookup = lookup_transform
        self._clock = clock
        self._node_name = node_name
        self._params: dict[str, Any] = defaults()
        self._model: RobotModel | None = None
        self._tracker: JointStateTracker | None = None
        self._chain_index: list[int] = []
        self._chain_blobs: dict[tuple[str, str], tuple[bytes, bytes]] = {}  # pickled chains
        self._rates = _Rates()
        self._last_state: EndEffectorState | None = None
        self._last_problem: tuple[str, Severity] | None = None
        self._ik = IKAnswerCounts()
        self._held: HeldDescription | None = None  # the description in use, or waiting for a tip
        self._status = DescriptionStatus("none", NO_DESCRIPTION)
        self._no_model = NO_DESCRIPTION  # what joint_states and requests get without a model
        self._refusal: tuple[str, str] | None = None  # (source, why) of the last refused one
        self._topic_text: str | None = None  # the topic's last description (used when allowed)
        self._log_lines: list[tuple[str, str]] = []
        given = dict(params or {})
        problem = validate_parameters(given)
        if problem is not None:
            raise InvalidInputError(problem)
        self._params.update(given)
        if self._params["robot_description"] and self._params["robot_description_file"]:
            self._say(
                "warn",
                f"robot_description_file {self._params['robot_description_file']!r} is not used: "
                "the robot_description parameter is set, and takes precedence",
            )
        source = self._parameter_source(self._params)
        if source:
            try:
                held = self._read_parameters(self._params)
            except KinematicsError as exc:
                self._refuse(source, exc)
            else:
                if held is not None:
                    self._adopt(held, self._params)

    # ------------------------------------------------------------------ configuration
    @property
    def params(self) -> dict[str, Any]:
        return dict(self._params)

    @property
    def model(self) -> RobotModel | None:
        return self._model

    @property
    def status(self) -> DescriptionStatus:
        """The state of the robot model: none, waiting (for a tip), loaded, or refused."""
        return self._status

    @property
    def takes_topic(self) -> bool:
        """True while the robot_description topic is the description's source (both
        robot_description and robot_description_file are empty)."""
        return not (self._params["robot_description"] or self._params["robot_description_file"])

    def take_log(self) -> list[tuple[str, str]]:
        """What happened to the robot description since the last call, for the node's log:
        (level, text) with level "info", "warn" or "error"; then forgotten."""
        lines, self._log_lines = self._log_lines, []
        return lines

    def configure(self, changes: Mapping[str, Any]) -> None:
        """Validate and apply parameter changes. On any error nothing changes.

        * `robot_description`, `robot_description_file`, `xacro_args`: the description they give
          (in that order of precedence; when both are empty, the topic's last one, else the one
          held) replaces the one held, checked with base_link and tip_link: when those do not
          give a chain of the new robot, it is held, waiting for them (`status`). Naming
          `robot_description_file` or `xacro_args` reads the file again.
        * `base_link`, `tip_link`: checked against the description held (the newest one): a
          link it does not have, or a chain that cannot be built, is refused. A link that is
          stale (of an earlier robot) while the other is set keeps the description waiting.
          Without a description, they are kept for the one to come.

        Raises:
            InvalidInputError: a value is invalid (message names the parameter), or
                robot_description_file is set while robot_description takes precedence.
            RobotDescriptionError, UnknownNameError: the new description or chain cannot be used.
        """
        problem = validate_parameters(changes)
        if problem is not None:
            raise InvalidInputError(problem)
        merged = {**self._params, **changes}
        changed = {k for k in changes if merged[k] != self._params[k]}
        reread = {"robot_description_file", "xacro_args"} & set(changes)
        if merged["robot_description_file"] and not merged["robot_description"]:
            changed |= reread  # naming the file (or its arguments) again reads it again
        if (
            "robot_description_file" in changed
            and merged["robot_description_file"]
            and merged["robot_description"]
        ):
            raise InvalidInputError(
                "robot_description_file is not used while the robot_description parameter is "
                "set (it takes precedence); clear it first: ros2 param set "
                f"{self._node_name} robot_description ''"
            )
        links = changed & {"base_link", "tip_link"}
        held = self._held
        if changed & set(DESCRIPTION_PARAMETERS):
            source = self._parameter_source(merged)
            try:
                held = self._read_parameters(merged)
            except KinematicsError as exc:
                self._refuse(source, exc)
                raise
            if held is None:  # both parameters cleared: the topic's description, else the held
                held = self._topic_description() or self._held
        if held is None or (held is self._held and not links):
            self._params = merged  # nothing to build now: base/tip wait for a description
            return
        if held is self._held:
            model = self._chain_for(held, merged, links)  # a refusal raises: nothing changes
            self._params = merged
            self._apply(held, model)
        else:
            self._params = merged
            self._adopt(held, merged, links)

    def load_description(
        self, description: str, source: str = "the robot_description topic"
    ) -> DescriptionStatus:
        """Use a robot description (URDF or xacro XML text, e.g. from the robot_description
        topic), replacing the one held, with the base_link and tip_link parameters checked
        against it: when they give no chain of it (a tip to choose among several leaves, links
        of another robot), it is held, waiting (`status`). On error the previous model and
        description stay in use.

        Raises:
            RobotDescriptionError: the description is malformed (naming the culprit).
        """
        try:
            held = HeldDescription.parse(description, source)
        except KinematicsError as exc:
            self._refuse(source, exc)
            raise
        self._adopt(held, self._params)
        return self._status

    def on_description_message(self, text: str) -> bool:
        """A message of the robot_description topic: used at once while the topic is the
        source (`takes_topic`), else kept for when both description parameters are cleared.
        Never raises: a refusal is reported (`status`, `take_log`). Returns whether it was used."""
        self._topic_text = text
        if not self.takes_topic:
            self._say(
                "info",
                "a robot description arrived on the robot_description topic; not used while the "
                f"{'robot_description' if self._params['robot_description'] else 'robot_description_file'}"
                " parameter is set",
            )
            return False
        try:
            self.load_description(text)
        except KinematicsError:
            return False
        return True

    # ------------------------------------------------------------------ description state
    def _parameter_source(self, params: Mapping[str, Any]) -> str:
        if params["robot_description"]:
            return "the robot_description parameter"
        if params["robot_description_file"]:
            path = params["robot_description_file"]
            args = params["xacro_args"]
            return f"the robot_description_file parameter ({path!r}" + (
                f", xacro_args {args!r})" if args else ")"
            )
        return ""

    def _read_parameters(self, params: Mapping[str, Any]) -> HeldDescription | None:
        """The description the parameters give (None when both are empty), parsed.

        Raises:
            RobotDescriptionError: unreadable, malformed, bad xacro arguments.
        """
        source = self._parameter_source(params)
        if params["robot_description"]:
            return HeldDescription.parse(params["robot_description"], source)
        if params["robot_description_file"]:
            description = read_description_file(
                params["robot_description_file"], params["xacro_args"]
            )
            return HeldDescription.of(description, source)
        return None

    def _topic_description(self) -> HeldDescription | None:
        """The topic's last description, parsed (None if none or refused, saying why)."""
        if self._topic_text is None:
            return None
        source = "the robot_description topic"
        try:
            return HeldDescription.parse(self._topic_text, source)
        except KinematicsError as exc:
            self._refuse(source, exc)
            return None

    def _chain_for(
        self, held: HeldDescription, params: Mapping[str, Any], changed: set[str]
    ) -> RobotModel | str:
        """The model of `held` with the params' base_link and tip_link, or, when they give no
        chain, why not (a sentence). A link in `changed` that `held` does not have, or a chain
        that fails on a description unchanged (`held` is the one held), raises instead.

        Raises:
            UnknownNameError, RobotDescriptionError: as said above.
        """
        tree, robot = held.tree, held.tree.robot_name
        base, tip = params["base_link"], params["tip_link"]
        for key, link in (("base_link", base), ("tip_link", tip)):
            if link and link not in held.description.link_names and key in changed:
                raise InvalidInputError(
                    f"{key} {link!r} is not a link of {robot!r} (from {held.source}); its links "
                    f"are: {_names(tree.links)}"
                )
        for key, link in (("base_link", base), ("tip_link", tip)):
            if link and link not in held.description.link_names:
                return f"{key} {link!r} is not a link of {robot!r}"
        strict = bool(changed) and held is self._held  # a link changed on the held description
        if not tip and len(tree.leaves_below(base)) > 1:
            if strict and self._model is not None:  # would drop a working model: refused
                raise RobotDescriptionError(
                    f"several leaf links below {base or tree.root_link!r}; choose one with "
                    f"tip_link: {', '.join(tree.tips_below(base))}"
                )
            return f"several leaf links below {base or tree.root_link!r} and tip_link is not set"
        try:
            return RobotModel(held.description, base, tip, tree)
        except KinematicsError as exc:
            if strict:
                raise
            return str(exc)

    def _adopt(
        self, held: HeldDescription, params: Mapping[str, Any], changed: set[str] | None = None
    ) -> None:
        """Replace the held description with `held` (a new robot), built with the params' links:
        loaded, or held waiting. Raises only for a link in `changed` that `held` lacks."""
        if not changed and self._model is not None and self._model.xml == held.description.xml:
            # the same robot again (robot_state_publisher restarted): keep the model and state
            self._held = HeldDescription(self._model.description, self._model.tree, held.source)
            self._refusal = None
            self._set_status(self._loaded_status(self._model))
            return
        self._apply(held, self._chain_for(held, params, changed or set()))

    def _apply(self, held: HeldDescription, model: RobotModel | str) -> None:
        self._held = held
        self._refusal = None
        if isinstance(model, RobotModel):
            self._install(model)
            chain = model.chain
            self._say(
                "info",
                f"loaded {model.robot_name!r} from {held.source}: {chain.base_link} -> "
                f"{chain.tip_link}, joints {list(chain.joint_names)}",
            )
            self._set_status(self._loaded_status(model))
            for note in held.description.notes:
                self._say("info", f"{model.robot_name!r}: {note}")
            return
        self._install(None)
        status = self._waiting_status(held, model)
        self._set_status(status)
        self._say("warn", status.message)

    def _loaded_status(self, model: RobotModel) -> DescriptionStatus:
        chain = model.chain
        held = self._held
        return DescriptionStatus(
            "loaded",
            f"loaded {model.robot_name!r}: {chain.base_link} -> {chain.tip_link}, {chain.dof} "
            "joints",
            held.source if held is not None else "",
            model.robot_name,
        )

    def _waiting_status(self, held: HeldDescription, reason: str) -> DescriptionStatus:
        """Status of a description held without a chain: why, the tips to choose from, and how."""
        tree, robot, node = held.tree, held.tree.robot_name, self._node_name
        base = self._params["base_link"]
        if base and base not in held.description.link_names:
            candidates = tree.tips_below("")
            what = "a base_link"
            how = (
                f"ros2 param set {node} base_link <link> ('' = its root link "
                f"{tree.root_link!r}), then tip_link (without ros2cli: kinematics ros param set "
                f"{node} base_link <link>, or start the node with "
                "--ros-args -p base_link:=<link> -p tip_link:=<link>)"
            )
        else:
            candidates = tree.tips_below(base)
            what = "a tip"
            how = (
                f"ros2 param set {node} tip_link <link> (without ros2cli: kinematics ros param "
                f"set {node} tip_link <link>, or start the node with --ros-args -p "
                "tip_link:=<link>)"
            )
        tips = ", ".join(candidates) if candidates else "none (no leaf below it moves)"
        message = (
            f"robot {robot!r} from {held.source} is waiting for {what}: {reason}. Candidate tips "
            f"below {(base if what == 'a tip' and base else tree.root_link)!r}: {tips}. Choose "
            f"one: {how}"
        )
        return DescriptionStatus("waiting", message, held.source, robot, candidates)

    def _refuse(self, source: str, exc: BaseException) -> None:
        """Record (diagnostics, log) that the description from `source` was refused; the model
        and description held before stay."""
        reason = str(exc)
        self._refusal = (source, reason)
        kept = (
            f"keeping the model of {self._model.robot_name!r}"
            if self._model is not None
            else (
                f"still waiting with {self._held.tree.robot_name!r}"
                if self._held is not None
                else "still no model"
            )
        )
        self._say("error", f"cannot use the robot description from {source}: {reason}; {kept}")
        if self._held is None:
            self._set_status(
                DescriptionStatus(
                    "refused",
                    f"no robot description loaded: the one from {source} was refused: {reason}",
                    source,
                )
            )

    def _set_status(self, status: DescriptionStatus) -> None:
        self._status = status
        self._no_model = status.message if self._model is None else NO_DESCRIPTION

    def _say(self, level: str, text: str) -> None:
        self._log_lines.append((level, text))
        if len(self._log_lines) > 100:  # nobody takes them (tests, tools): keep the newest
            del self._log_lines[:50]

    def _install(self, model: RobotModel | None) -> None:
        """Swap in `model` (all at once: every later message and request sees only the new one)."""
        self._model = model
        self._chain_blobs.clear()
        self._last_state = None
        self._last_stamp = None
        self._last_problem = None
        self._tree_tf = None
        self._tf_rows = {}
        self._tf_published = {}
        if model is None:
            self._tracker = None
            self._chain_index = []
            return
        chain = model.chain
        self._blob(chain)  # the default chain's IK blob now, with the model load, not at a request
        # One tracker for every moving joint of the robot: the chain's joints are required (a bad
        # value rejects the sample); the others only serve requests that name some joints.
        names = list(chain.joint_names) + [
            j for j in model.moving_joint_names if j not in chain.joint_names
        ]
        continuous = list(chain.continuous) + [False] * (len(names) - chain.dof)
        self._tracker = JointStateTracker(names, continuous, required=chain.joint_names)
        self._chain_index = list(range(chain.dof))
        try:  # every joint of the tree, for /tf and /tf_static
            self._tree_tf = JointTransforms(model.description)
            self._tf_inputs = [names.index(n) for n in self._tree_tf.inputs]
        except (KinematicsError, ValueError) as exc:
            self._tree_tf = None
            self._say("warn", f"/tf cannot be given for this description: {_short(exc)}")

    # ------------------------------------------------------------------ joint states
    def on_joint_state(self, msg: Any, received: float | None = None) -> EEMessages:
        """Merge a sensor_msgs/JointState; return the ee_pose / ee_twist messages to publish.

        Args:
            msg: the JointState.
            received: its arrival time [s], on one clock for every call (the node passes when
                its publisher sent it: the DDS source timestamp); the time base of velocity
                estimates where the stamps cannot be one. Default: `time.monotonic()` now.

        Both are stamped with this message's stamp as given (zero included, as
        robot_state_publisher stamps /tf) and expressed in base_link (the twist in tip_link
        axes when twist_frame is "body"); the twist's reference point is the tip origin. Nothing is
        returned until every chain joint has been received, for stale samples (stamped before the
        last, by up to `ee_state.JUMP_BACK`; older ones start a new timeline, with a WARN), for
        invalid samples (NaN position, length mismatch, a joint named twice), or if a result is not
        finite. The twist is None until velocities are known: from the message, or estimated from
        successive positions over the stamps where they advance, else over the arrival times
        (unstamped joint_states, or stamps that repeat while positions change: a WARN in
        diagnostics, and in the logs when it begins; `ee_state.JointStateTracker`). Values of mimic
        followers are not used: the chain takes them from their leaders, as the URDF says.
        """
        model, tracker = self._model, self._tracker
        if model is None or tracker is None:
            return self._problem(self._no_model, Severity.WARN)
        try:
            names, positions, velocities, stamp = sample_from_joint_state(msg)
            stale_before, jumps_before = tracker.stale_samples, tracker.jumps_back
            episodes_before = tracker.arrival_episodes
            now = self._clock()  # when the joints' values were received (their ages' origin)
            arrival = time.monotonic() if received is None else received
            changed = tracker.update(names, positions, velocities, stamp, arrival, now)
        except (KinematicsError, TypeError, ValueError, AttributeError, OverflowError) as exc:
            return self._problem(f"joint_states sample rejected: {_short(exc)}", Severity.ERROR)
        if not changed:
            if tracker.stale_samples > stale_before:
                return self._problem(
                    "stale joint_states sample (older stamp) ignored", Severity.WARN
                )
            return EEMessages(problem=None)
        self._rates.record(now, stamp)
        jumped = tracker.jumps_back > jumps_before
        index = self._chain_index
        q = tracker.positions(index)
        chain = model.chain
        if not all(math.isfinite(v) for v in q):
            missing = [chain.joint_names[k] for k, v in enumerate(q) if not math.isfinite(v)]
            return EEMessages(
                problem=f"waiting for joint_states of {missing}", severity=Severity.WARN
            )
        qdot = tracker.velocities(index)
        twist_frame = self._params["twist_frame"]
        state = compute_ee_state(
            chain,
            np.array(q),
            None if qdot is None else np.array(qdot),
            stamp,
            twist_frame,
        )
        if not np.isfinite(state.T_base_tip).all():
            return self._problem(
                "end-effector pose is not finite; nothing published", Severity.WARN
            )
        V = state.twist
        twist_ok = V is not None and bool(np.isfinite(V).all())
        self._last_state = state
        self._last_stamp = msg.header.stamp
        self._last_problem = None
        problem, severity = None, Severity.NOTE
        if jumped:  # in diagnostics until the next problem or a good sample clears it
            problem = (
                f"joint_states stamps jumped back by more than {JUMP_BACK:g} s: a new timeline"
            )
            severity = Severity.WARN
            self._last_problem = (problem, severity)
        if tracker.from_arrival_times:  # a WARN in diagnostics; logged when it begins
            if tracker.velocity_source == FROM_ARRIVAL_UNSTAMPED:
                why = "which are unstamped (stamp 0)"
                how = " (ros2 topic pub: header: auto)"
            else:
                why, how = "whose stamps do not advance while positions change", ""
            note = (
                f"ee_twist estimated from the arrival times of joint_states, {why}; stamp each "
                f"with the time of its sample{how}"
            )
            problem = note if problem is None else f"{problem}; {note}"
            if tracker.arrival_episodes > episodes_before:
                severity = Severity.WARN
            self._last_problem = (problem, Severity.WARN)
        types = self._types
        pose = pose_stamped_from_matrix(types, state.T_base_tip, chain.base_link, msg.header.stamp)
        twist = None
        if V is not None and twist_ok:
            frame = chain.tip_link if twist_frame == "body" else chain.base_link
            twist = twist_stamped_from_core(types, V, frame, msg.header.stamp)
        if not twist_ok:
            problem = "velocity unknown" if problem is None else f"{problem}; velocity unknown"
        tf = None
        if self._params["publish_tf"]:
            if jumped:  # a new timeline: every joint's /tf is due again
                self._tf_published.clear()
            if self._tf_due(names, msg.header.stamp, arrival):
                tf = self.tf(names, msg.header.stamp)
        return EEMessages(pose=pose, twist=twist, problem=problem, severity=severity, tf=tf)

    # ------------------------------------------------------------------ /tf, markers
    def _tf_due(self, names: Sequence[str], stamp: Any, arrival: float) -> bool:
        """Whether a joint_states naming `names` gets its /tf, at most tf_rate, by
        robot_state_publisher's rule (its publish_frequency): when the least recently published
        of the joints it names was published at least 1/tf_rate before this message, by the
        messages' stamps (their arrival times where unstamped, as the velocity estimate falls
        back to them); then all of them count as published now. tf_rate 0: every message."""
        rate = float(self._params["tf_rate"])
        if rate <= 0:
            return True
        t = int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)
        if t == 0:
            t = int(arrival * 1e9)
        published = self._tf_published
        least = min((published.get(name, -(2**63)) for name in names), default=-(2**63))
        if t - least < round(1e9 / rate):
            return False
        for name in names:
            published[name] = t
        return True

    def tf(self, names: Sequence[str], stamp: Any) -> Any | None:
        """/tf as robot_state_publisher gives it for a joint_states naming `names`: each moving
        joint of the description driven by one of them (mimic joints by their leader), child
        link in parent link, from the latest positions, stamped `stamp`; None without TF types,
        a description, or such a joint."""
        types, tree, tracker = self._tf_types, self._tree_tf, self._tracker
        if types is None or tree is None or tracker is None:
            return None
        key = tuple(names)
        rows = self._tf_rows.get(key)
        if rows is None:
            named = set(key)
            inputs = tree.inputs
            moving = np.flatnonzero(tree.moving)
            column = tree.input_columns
            chosen = [int(i) for i, c in zip(moving, column, strict=True) if inputs[c] in named]
            rows = (
                chosen,
                tuple(tree.parents[i] for i in chosen),
                tuple(tree.children[i] for i in chosen),
            )
            self._tf_rows[key] = rows
        chosen, parents, children = rows
        if not chosen:
            return None
        values = np.array([tracker.positions(self._tf_inputs)])
        t, quat = tree.transforms(values)
        t, quat = t[0, chosen], quat[0, chosen]
        finite = np.isfinite(t).all(axis=1) & np.isfinite(quat).all(axis=1)
        if not finite.all():  # a joint of another chain not received yet
            keep = np.flatnonzero(finite).tolist()
            parents = tuple(parents[i] for i in keep)
            children = tuple(children[i] for i in keep)
            t, quat = t[finite], quat[finite]
        return tf_message(types, stamp, parents, children, t, quat)

    def static_tf(self, stamp: Any) -> Any | None:
        """/tf_static: every fixed joint of the description, stamped `stamp`; None without TF
        types, a description, or a fixed joint."""
        types, tree = self._tf_types, self._tree_tf
        if types is None or tree is None or tree.moving.all():
            return None
        t, quat = tree.transforms(np.zeros((1, len(tree.inputs))))
        fixed = ~tree.moving
        return tf_message(
            types,
            stamp,
            tuple(np.array(tree.parents)[fixed].tolist()),
            tuple(np.array(tree.children)[fixed].tolist()),
            t[0, fixed],
            quat[0, fixed],
        )

    def markers(self, types: MarkerTypes) -> Any | None:
        """~/markers (`msg_adapters.markers`) of the last posed joint_states: the translational
        manipulability ellipsoid at the tool and its most singular direction, in the base link,
        stamped like those joint_states; None before one (counted in `markers_published`)."""
        model, state, stamp = self._model, self._last_state, self._last_stamp
        if model is None or state is None or stamp is None:
            return None
        J = model.chain.jacobian(state.q, "world")
        try:
            ellipsoid = translational_ellipsoid(J, state.T_base_tip[:3, 3])
        except ValueError:  # not finite: nothing drawn
            return None
        self.markers_published += 1
        return manipulability_markers(
            types, ellipsoid, model.chain.base_link, int(stamp.sec), int(stamp.nanosec)
        )

    def _problem(self, text: str, severity: Severity) -> EEMessages:
        self._last_problem = (text, severity)
        return EEMessages(problem=text, severity=severity)

    # ------------------------------------------------------------------ services
    def compute_fk(self, request: Any, response: Any) -> Any:
        """ComputeFK: pose of request.tip_link (default: tip_link) in base_link, see the srv."""
        return self._answer("compute_fk", self._fk, request, response)

    def compute_jacobian(self, request: Any, response: Any) -> Any:
        """ComputeJacobian: the 6×n Jacobian in ROS row order (linear, angular), see the srv."""
        return self._answer("compute_jacobian", self._jacobian, request, response)

    def compute_ik(self, request: Any, response: Any) -> Any:
        """ComputeIK: joint positions placing tip_link at request.target, see the srv.

        Solves in the calling thread; the node instead runs `prepare_ik`, the solve in a worker
        process (`ik_pool.solve_job`), then `finish_ik`: the same answer without blocking its thread.
        """
        pending = self.prepare_ik(request, response)
        if pending is None:
            return response
        try:
            outcome = solve_job(pending.job)
        except Exception as exc:  # noqa: BLE001 - as a worker does: every request is answered
            outcome = IKOutcome.failed(f"the IK solver failed: {exc}")
        return self.finish_ik(pending, outcome, response)

    def prepare_ik(
        self, request: Any, response: Any, now: float | None = None, waited: float = 0.0
    ) -> PendingIK | None:
        """Check an IK request and turn it into a job for a worker. Returns None when the request
        is refused; `response` then holds `success = False` and the reason.

        `now` is the request's arrival on `time.monotonic()` [s] (default: now), and `waited`
        how long it had waited before then [s] (since the client sent it: in the middleware's
        queues, behind other callbacks). The job's deadline is now − waited + timeout, so time
        spent waiting anywhere counts against the timeout. A `waited` of the timeout or more is
        ignored (0): a client's clock behind this machine's by that much, more likely than a
        request that waited its whole timeout.
        """
        arrival = time.monotonic() if now is None else now
        box: list[PendingIK] = []

        def prepare(request: Any, response: Any) -> None:
            box.append(self._prepare_ik(request, arrival, waited))

        self._answer("compute_ik", prepare, request, response)
        return box[0] if box and response.success else None

    def finish_ik(
        self, pending: PendingIK, outcome: IKOutcome, response: Any, now: float | None = None
    ) -> Any:
        """Fill `response` from a worker's `outcome` of `pending` (success, solution, errors and a
        message that says why when it failed, with the request's timeout and the time the answer
        took since the request was sent). `now` (`time.monotonic()` [s], default: now) is
        compared with the job's deadline for the counts in `diagnostics`."""
        now = time.monotonic() if now is None else now
        self._ik.record(now - pending.job.deadline)
        sent = pending.job.deadline - pending.options.timeout  # `_prepare_ik`'s arrival − waited

        def finish(request: Any, response: Any) -> str | None:
            return self._finish_ik(pending, outcome, response, max(now - sent, 0.0))

        return self._answer("compute_ik", finish, None, response)

    def _answer(
        self, service: str, fn: Callable[[Any, Any], str | None], request: Any, response: Any
    ) -> Any:
        """Run `fn(request, response)`, which fills the response and returns None (success:
        "ok"), a `_Note` (success: "ok; <note>") or why it failed; a `KinematicsError` it raises
        is a refusal with its text."""
        try:
            failure = fn(request, response)
            response.success = failure is None or isinstance(failure, _Note)
            if failure is None:
                response.message = "ok"
            else:
                response.message = f"ok; {failure}" if isinstance(failure, _Note) else failure
            return response
        except KinematicsError as exc:
            response.message = str(exc)
        except Exception as exc:  # a request must never take the node down
            _log.exception("%s: unexpected error", service)
            response.message = f"internal error ({type(exc).__name__}): {exc}"
        response.success = False
        if hasattr(response, "position_error"):  # ComputeIK refused: no solve ran (see the srv)
            response.position_error = response.orientation_error = -1.0
        return response

    def _snapshot(self) -> tuple[RobotModel, _Current, dict[str, Any]]:
        """(model, the current positions of the joints received so far, params)."""
        model, tracker = self._model, self._tracker
        if model is None or tracker is None:
            raise RobotDescriptionError(self._no_model)
        current = _Current(
            {
                n: v
                for n, v in zip(tracker.joint_names, tracker.q.tolist(), strict=True)
                if math.isfinite(v)
            },
            tracker.taken_at(),
        )
        return model, current, self._params

    def _q(
        self, model: RobotModel, chain: SerialChain, js: Any, current: _Current, name: str
    ) -> FloatArray:
        """The chain's joint vector from the request's JointState `js`, the joints it leaves out
        from joint_states (noted in `current.used`)."""
        q_default = [current.get(j, math.nan) for j in chain.joint_names]
        q = q_from_joint_state(
            js, chain.joint_names, q_default=q_default, known_names=model.joint_names, name=name
        )
        given = {str(n) for n in js.name}
        current.use(j for j in chain.joint_names if j not in given)
        return q

    def _from_joint_states(self, current: _Current, refuse: str | None) -> str:
        """What a request took from joint_states (`current.used`, then forgotten): "" when
        nothing, else "<joints> (received <age> s ago); ...". With `refuse` (what left them out,
        e.g. "joint_state"), a joint older than joint_states_max_age (unless 0) is refused.

        Raises:
            InvalidInputError: `refuse` is given and a value is too old, naming the joints.
        """
        used = current.take_used()
        if not used:
            return ""
        now = self._clock()
        text = _ages_text(used, now)
        limit = float(self._params["joint_states_max_age"])
        if refuse is not None and limit > 0:
            old = [j for j, t in used.items() if now - t > limit]
            if old:
                raise InvalidInputError(
                    f"{refuse} leaves out {old}, and their values from joint_states are older "
                    f"than joint_states_max_age ({limit:g} s): {text}. Give them in {refuse}, "
                    "or check that joint_states still arrive (joint_states_max_age 0: no limit)"
                )
        return text

    def _fk(self, request: Any, response: Any) -> _Note | None:
        model, current, _ = self._snapshot()
        js, stamp = request.joint_state, request.joint_state.header.stamp
        chain = _chain_to(model, str(request.tip_link))
        q = self._q(model, chain, js, current, "joint_state")
        T = chain.fk(q)
        _require_finite(T, "pose")
        poses = []
        default_poses: FloatArray | None = None  # every link of the default chain, when asked
        for k, name in enumerate(request.link_names):
            link = str(name)
            try:
                source = model.link_pose_source(link)
            except KinematicsError as exc:
                raise InvalidInputError(f"link_names[{k}]: {exc}") from None
            if source is model.chain:
                if default_poses is None:
                    q_chain = (
                        q
                        if chain is model.chain
                        else self._q(model, model.chain, js, current, "joint_state")
                    )
                    default_poses = model.chain.link_poses(q_chain)
                T_link = default_poses[model.chain.link_names.index(link)]
            elif isinstance(source, SerialChain):
                T_link = source.fk(self._q(model, source, js, current, "joint_state"))
            else:  # no moving joint between the base and the link
                T_link = source
            _require_finite(T_link, f"pose of link_names[{k}] {link!r}")
            poses.append(pose_stamped_from_matrix(self._types, T_link, model.base_link, stamp))
        states = self._from_joint_states(current, "joint_state")
        response.pose = pose_stamped_from_matrix(self._types, T, chain.base_link, stamp)
        response.poses = poses
        return _Note(f"from joint_states: {states}") if states else None

    def _jacobian(self, request: Any, response: Any) -> _Note | None:
        model, current, _ = self._snapshot()
        frame = JACOBIAN_FRAMES_BY_NAME.get(str(request.frame) or "world")
        if frame is None:
            raise InvalidInputError(
                f"frame must be one of {list(JACOBIAN_FRAMES)} (or empty), got "
                f"{str(request.frame)!r}"
            )
        chain = _chain_to(model, str(request.tip_link))
        q = self._q(model, chain, request.joint_state, current, "joint_state")
        states = self._from_joint_states(current, "joint_state")
        _, J_world = chain.fk_jacobian(q, "world")
        J = J_world if frame == "world" else chain.jacobian(q, frame)
        _require_finite(J, "Jacobian")
        fill_jacobian_fields(response, J, chain.joint_names)
        response.frame = frame
        response.reference_frame = chain.tip_link if frame == "body" else chain.base_link
        response.reference_point_frame = chain.base_link if frame == "space" else chain.tip_link
        response.base_link = chain.base_link
        response.tip_link = chain.tip_link
        with np.errstate(over="ignore", invalid="ignore"):  # an overflow is refused just below
            c = conditioning(J_world)
        _require_finite([c.manipulability, c.min_singular_value], "manipulability")
        response.manipulability = c.manipulability
        response.min_singular_value = c.min_singular_value
        # the srv's documented -1.0 for an infinite condition number (exact singularity)
        response.condition_number = _finite_or(c.condition_number, -1.0)
        return _Note(f"from joint_states: {states}") if states else None

    def _prepare_ik(self, request: Any, arrival: float, waited: float) -> PendingIK:
        model, current, params = self._snapshot()
        chain = _chain_to(model, str(request.tip_link))
        T_frame_target = matrix_from_pose(request.target.pose, "target.pose")
        frame = str(request.target.header.frame_id)
        T_base_frame = self._frame_pose(model, frame, current)
        # a target in a moving link's frame is placed by joint_states: refused when too old
        self._from_joint_states(current, f"target frame {frame!r} (a robot link)")
        with np.errstate(over="ignore", invalid="ignore"):  # checked below
            T_base_target = T_base_frame @ T_frame_target
        if not np.all(np.isfinite(T_base_target)):  # finite values whose product overflows
            raise InvalidInputError(
                f"target.pose in frame {frame or chain.base_link!r} is too large to express in "
                f"{chain.base_link} (its values overflow)"
            )
        options = _ik_options(request, params)
        note = beyond_reach(chain, T_base_target, options)
        seed = request.seed
        q_seed = None
        if len(seed.name) > 0 or all(
            math.isfinite(current.get(j, math.nan)) for j in chain.joint_names
        ):
            q_seed = self._q(model, chain, seed, current, "seed")
        # a seed is only where the search starts: its age is said, never refused
        from_states = self._from_joint_states(current, None)
        seed_note = f"seed from joint_states: {from_states}" if from_states else ""
        key, blob = self._blob(chain)
        if not 0.0 <= waited < options.timeout:
            waited = 0.0
        job = IKJob(key, blob, T_base_target, q_seed, options, arrival - waited + options.timeout)
        return PendingIK(
            job, chain, chain.joint_names, request.target.header.stamp, options, note, seed_note
        )

    def _blob(self, chain: SerialChain) -> tuple[bytes, bytes]:
        """(key, blob) of `chain` for IK jobs, made once per chain of the model. The blob carries
        the closed-form family (`ik_pool.chain_blob`), detected here once (20–100 ms) rather than
        in every worker inside a job's time; the key is a digest of the content."""
        cached = self._chain_blobs.get((chain.base_link, chain.tip_link))
        if cached is None:
            blob = chain_blob(chain)
            cached = (hashlib.blake2b(blob, digest_size=16).digest(), blob)
            self._chain_blobs[(chain.base_link, chain.tip_link)] = cached
        return cached

    def _finish_ik(
        self, pending: PendingIK, outcome: IKOutcome, response: Any, elapsed: float
    ) -> str | None:
        """Fill the response; None or a `_Note` (the seed's age) on success, else why not (with
        the seed's age)."""
        failure = self._fill_ik(pending, outcome, response, elapsed)
        if not pending.seed_note:
            return failure
        return _Note(pending.seed_note) if failure is None else f"{failure}; {pending.seed_note}"

    def _fill_ik(
        self, pending: PendingIK, outcome: IKOutcome, response: Any, elapsed: float
    ) -> str | None:
        options = pending.options
        q = outcome.q
        if q is None:  # no solve ran: answer with the seed (or nothing) and say why
            q = pending.job.q_seed
        response.solution = joint_state_from_q(
            self._types,
            pending.joint_names if q is not None else (),
            np.zeros(0) if q is None else q,
            header(self._types, pending.stamp, ""),
        )
        if q is not None:
            _require_finite(q, "IK solution")
        response.position_error = _finite_or(outcome.position_error, -1.0)
        response.orientation_error = _finite_or(outcome.orientation_error, -1.0)
        response.iterations = int(min(max(outcome.iterations, 0), 2**32 - 1))
        response.solutions = []
        response.complete = False
        if outcome.success and outcome.q is not None:  # (a success always carries its q)
            # `solution` first, then the others the worker found (at most num_solutions in all)
            rest = [s for s in outcome.solutions if not np.array_equal(s, outcome.q)]
            solutions = np.array([outcome.q, *rest][: options.num_solutions], dtype=np.float64)
            _require_finite(solutions, "IK solution")
            response.solutions = joint_states_from_qs(
                self._types, pending.joint_names, solutions, pending.stamp
            )
            response.complete = bool(outcome.complete) and len(rest) + 1 <= options.num_solutions
            return None
        return _ik_failure(pending, outcome, response, elapsed)

    def _frame_pose(self, model: RobotModel, frame: str, current: _Current) -> FloatArray:
        """T_base_frame for an IK target frame: the base, a robot link (FK of the current state),
        or a TF frame.

        Raises:
            KinematicsError: the frame cannot be resolved, saying why.
        """
        base = model.base_link
        name = frame[1:] if frame.startswith("/") else frame
        if name in ("", base):
            return np.eye(4)
        reasons = []
        if name in model.link_names:
            for a, b, invert in ((base, name, False), (name, base, True)):
                try:
                    chain = model.chain_between(a, b)
                except KinematicsError as exc:
                    reasons.append(str(exc))
                    continue
                missing = [j for j in chain.joint_names if j not in current]
                if missing:
                    raise InvalidInputError(
                        f"target frame {name!r} is a robot link, but its pose needs joint_states "
                        "of "
                        f"{missing}, which have not been received"
                    )
                current.use(chain.joint_names)
                T = chain.fk([current[j] for j in chain.joint_names])
                return se3.inverse(T) if invert else T
        if self._lookup is None:
            raise InvalidInputError(
                f"unknown target frame {name!r}: not a link of the robot, and frames from TF "
                "need tf2_ros, which this node runs without"
                + (f" ({'; '.join(reasons)})" if reasons else "")
            )
        try:
            T_base_frame = check_transform(self._lookup(base, name), "TF transform")
        except Exception as exc:
            raise InvalidInputError(
                f"unknown target frame {name!r}: not a link of the robot with moving joints to "
                f"{base!r}, and the TF lookup {base!r} <- {name!r} failed: {exc}"
            ) from None
        return np.array(T_base_frame, dtype=np.float64)

    # ------------------------------------------------------------------ diagnostics
    def _description_values(self) -> list[tuple[str, str]]:
        """Diagnostics values of the robot model's state (`DescriptionStatus`): description =
        none | waiting | loaded | refused, its source, the robot's name, the candidate tips while
        waiting, the description's notes, and the last refusal (source: why)."""
        status, held = self._status, self._held
        values = [("description", status.state)]
        if status.source:
            values.append(("description_source", status.source))
        if status.robot_name:
            values.append(("robot_name", status.robot_name))
        if status.state == "waiting":
            values.append(("candidate_tips", ", ".join(status.candidates)))
        if held is not None and held.description.notes:
            values.append(("description_notes", "; ".join(held.description.notes)))
        if self._refusal is not None:
            values.append(("last_refusal", "{}: {}".format(*self._refusal)))
        return values

    def diagnostics(self, pool: Mapping[str, int] | None = None) -> Any:
        """diagnostic_msgs/DiagnosticArray: one status with manipulability, condition number,
        near-singularity (WARN), joint_states rate [Hz] and latency [s] ("unknown (...)" while
        the last sample is unstamped or none came; stale → WARN), the last
        problem (rejected samples → ERROR), the robot model's state (`_description_values`; no
        description or a refused one → ERROR, waiting for a tip → WARN, a refused one while
        another is held → WARN), and the IK answers so far (`IKAnswerCounts`) with the worker
        pool's counts `pool` (keys prefixed "ik_pool_")."""
        types = self._types
        S = types.DiagnosticStatus
        now = self._clock()
        model, state, problem = self._model, self._last_state, self._last_problem
        params = self._params
        last = self._rates.last_arrival
        rate, latency = self._rates.rate(), self._rates.latency()
        severity, notes = 0, []
        values: list[tuple[str, str]] = self._description_values()
        if model is None:
            severity = 1 if self._status.state == "waiting" else 2
            notes = [self._status.message]
        else:
            values += [
                ("base_link", model.base_link),
                ("tip_link", model.chain.tip_link),
                ("dof", str(model.chain.dof)),
            ]
            if last is None or now - last > params["joint_states_timeout"]:
                severity = max(severity, 1)
                notes.append("no recent joint_states naming the chain's joints")
            if latency is not None:
                latency_text = f"{latency:.6f}"
            elif last is None:
                latency_text = "unknown (no joint_states received)"
            else:  # now − 0 would be the time since 1970
                latency_text = "unknown (unstamped joint_states)"
            values += [
                ("joint_states_rate_hz", f"{rate:.3f}"),
                ("joint_states_latency_s", latency_text),
            ]
            if self._tracker is not None:  # where ee_twist's joint velocities come from
                values.append(("velocity_source", self._tracker.velocity_source))
            if state is not None:
                J = model.chain.jacobian(state.q, "world")
                c = conditioning(J, params["singular_threshold"])
                cond = c.condition_number
                values += [
                    ("manipulability", f"{c.manipulability:.6g}"),
                    ("condition_number", f"{cond:.6g}" if math.isfinite(cond) else "inf"),
                    ("near_singular", str(c.near_singular).lower()),
                ]
                if c.near_singular:
                    severity = max(severity, 1)
                    notes.append("near a singularity")
            if problem is not None:
                text, level = problem
                severity = max(severity, int(level))
                notes.append(text)
        if self._refusal is not None and self._held is not None:  # refused, but one is held
            source, why = self._refusal
            severity = max(severity, 1)
            notes.append(
                f"the robot description from {source} was refused ({why}); still using "
                f"{self._held.tree.robot_name!r} from {self._held.source}"
            )
        values.append(("markers_published", str(self.markers_published)))
        values += self._ik.values()
        values += [(f"ik_pool_{k}", str(v)) for k, v in (pool or {}).items()]
        status = S(
            level=(S.OK, S.WARN, S.ERROR)[severity],
            name=diagnostics_name(self._node_name),
            message="; ".join(notes) if notes else "ok",
            hardware_id=self._status.robot_name,
            values=[types.KeyValue(key=k, value=v) for k, v in values],
        )
        return types.DiagnosticArray(
            header=types.Header(stamp=time_from_seconds(types, now), frame_id=""), status=[status]
        )


class _Note(str):
    """A successful answer's words after "ok" (`KinematicsService._answer`)."""


class _Current(dict[str, float]):
    """{joint: position} of the joints received on joint_states so far, with when the node
    received each (`taken`: its clock [s]) and the joints a request took from them (`used`)."""

    def __init__(self, positions: Mapping[str, float], taken: Mapping[str, float]) -> None:
        super().__init__(positions)
        self.taken = dict(taken)
        self.used: dict[str, float] = {}

    def use(self, joints: Iterable[str]) -> None:
        """Note that the request took `joints`' values from here."""
        for j in joints:
            self.used[j] = self.taken.get(j, -math.inf)

    def take_used(self) -> dict[str, float]:
        """The joints used so far ({joint: when received}); then forgotten."""
        used, self.used = self.used, {}
        return used


def _ages_text(used: Mapping[str, float], now: float) -> str:
    """'a, b (received 0.0121 s ago); c (received 65.2 s ago)': the joints grouped by the
    joint_states message that gave them, the oldest first (a clock that went back, as simulated
    time restarting: 0 s)."""
    groups: dict[float, list[str]] = {}
    for joint, t in used.items():
        groups.setdefault(t, []).append(joint)
    return "; ".join(
        f"{', '.join(joints)} (received {max(now - t, 0.0):.3g} s ago)"
        for t, joints in sorted(groups.items())
    )


def _chain_to(model: RobotModel, tip_link: str) -> SerialChain:
    """The chain of a request's `tip_link` (empty: the node's); a refusal names the field."""
    try:
        return model.chain_to(tip_link)
    except KinematicsError as exc:
        raise InvalidInputError(f"tip_link: {exc}") from None


def _names(names: Sequence[str], limit: int = 40) -> str:
    """'a', 'b', ... for a message: at most `limit` names, then how many more."""
    shown = ", ".join(repr(n) for n in names[:limit])
    return shown + (f" (+{len(names) - limit} more)" if len(names) > limit else "")


def _short(exc: BaseException, limit: int = 200) -> str:
    """The exception's text, cut to `limit` characters (a sample with 10,000 names must not make
    a 10,000-name log line)."""
    text = str(exc)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _require_finite(a: ArrayLike, what: str) -> None:
    if not np.all(np.isfinite(np.asarray(a, dtype=np.float64))):
        raise KinematicsError(f"{what} is not finite; refusing to return it")


def _finite_or(value: Any, fallback: float) -> float:
    v = float(value)
    return v if math.isfinite(v) else fallback


def _request_value(request: Any, field: str, params: Mapping[str, Any], unit: str) -> float:
    """ComputeIK.`field`, or for 0 the node's parameter ik.`field`."""
    value = float(getattr(request, field))
    if not math.isfinite(value) or value < 0:
        raise InvalidInputError(
            f"{field} must be >= 0 {unit} (0 = the node's parameter ik.{field}), got {value}"
        )
    return value if value > 0 else float(params[f"ik.{field}"])


#: Largest ComputeIK.max_solutions accepted: more than any closed form gives (a UR with ±2π
#: limits has up to 512), and a bound on the size of the answer.
MAX_SOLUTIONS = 10_000


def _max_solutions(request: Any) -> int:
    """ComputeIK.max_solutions as a count ≥ 1 (0 and 1 both mean one solution)."""
    value = request.max_solutions
    try:
        count = None if isinstance(value, bool) or int(value) != value else int(value)
    except (TypeError, ValueError, OverflowError):
        count = None
    if count is None or not 0 <= count <= MAX_SOLUTIONS:
        raise InvalidInputError(
            f"max_solutions must be an integer from 0 to {MAX_SOLUTIONS} (0 or 1: one solution), "
            f"got {value}"
        )
    return max(count, 1)


def _axis_tolerances(request: Any) -> tuple[float, ...] | None:
    """ComputeIK.axis_tolerances (None when empty), checked as the srv says, in its words."""
    bounds = [float(x) for x in request.axis_tolerances]
    if not bounds:
        return None
    if len(bounds) != 6:
        raise InvalidInputError(
            "axis_tolerances must be empty or 6 values (wx, wy, wz, x, y, z) [rad, m], got "
            f"{len(bounds)} values"
        )
    if any(math.isnan(b) or b <= 0 for b in bounds):
        raise InvalidInputError(f"axis_tolerances must be > 0 (inf frees an axis), got {bounds}")
    if all(math.isinf(b) for b in bounds):
        raise InvalidInputError("axis_tolerances must bound at least one axis (all 6 are inf)")
    if request.position_only:
        raise InvalidInputError(
            "axis_tolerances and position_only cannot be combined: give inf for the three "
            "rotation bounds (wx, wy, wz) instead"
        )
    return tuple(bounds)


def _ik_options(request: Any, params: Mapping[str, Any]) -> IKOptions:
    """IKOptions from the request, falling back to the node's parameters for zero fields."""
    wanted: dict[str, Any] = {
        "position_tolerance": _request_value(request, "position_tolerance", params, "[m]"),
        "orientation_tolerance": _request_value(request, "orientation_tolerance", params, "[rad]"),
        "timeout": _request_value(request, "timeout", params, "[s]"),
        "max_restarts": int(params["ik.max_restarts"]),
        "position_only": bool(request.position_only),
        "axis_tolerances": _axis_tolerances(request),
    }
    wanted_solutions = _max_solutions(request)
    if wanted_solutions > 1:  # the solutions nearest the seed that the timeout lets it find
        wanted["mode"] = "distance"
        wanted["num_solutions"] = wanted_solutions
    try:
        return IKOptions(**wanted)
    except InvalidInputError as exc:  # (checked above; should the library find more: its reason)
        raise InvalidInputError(_request_words(str(exc))) from None


def _timeout_text(seconds: float) -> str:
    """A request's timeout as its user would write it: "50 ms", "0.01 ms", "1.5 s"."""
    return f"{seconds * 1e3:.4g} ms" if seconds < 1.0 else f"{seconds:.4g} s"


#: The IK library's words (`core.ik`'s messages, which a worker passes on) → a ComputeIK
#: request's: the reason stays, the library's option names become the request's fields. The
#: times in them are the worker's (its share of the time left); `_ik_failure` puts the request's.
_REQUEST_WORDS: tuple[tuple[re.Pattern[str], str], ...] = (
    (re.compile(r"; numeric search: no solution: "), "; numeric search: "),
    (re.compile(r"^no solution: "), ""),
    (re.compile(r"\(tolerances (\S+) m / (\S+) rad\)"),
     r"(position_tolerance \1 m, orientation_tolerance \2 rad)"),
    (re.compile(r"\(tolerance (\S+) m, orientation free\)"),
     r"(position_tolerance \1 m, position_only)"),
    (re.compile(r"\(per-axis bounds ([^)]*)\)"), r"(axis_tolerances [\1])"),
    (re.compile(r"a freed pose component"), "an axis freed by axis_tolerances (inf)"),
    (re.compile(r"\bIKOptions\."), ""),
    (re.compile(r"\((ωx, ωy, ωz, vx, vy, vz)\)"), "(wx, wy, wz, x, y, z)"),
    (re.compile(r"\bnum_solutions\b"), "max_solutions"),
    (re.compile(r"(?<![\w'\"])q_seed(?![\w'\"])"), "seed"),
    (re.compile(r"(?<![\w'\"])T_target(?![\w'\"])"), "target"),
)  # fmt: skip
_DURATION = r"[\d.e+-]+ m?s"
#: How the library says a search stopped: its timeout (the worker's time left) ran out, after
#: the worker's time; or max_restarts, the node's parameter ik.max_restarts, was used up.
_STOPPED = re.compile(
    rf"the {_DURATION} timeout ran out(?P<after> after {_DURATION})?"
    rf"|max_restarts=(?P<restarts>\d+) reached after {_DURATION}(?:, \d+ restarts?)?"
    rf"|(?P<effort>best effort from the seed) in {_DURATION}"
)


def _request_words(text: str) -> str:
    """A library message in a ComputeIK request's words (`_REQUEST_WORDS`)."""
    for pattern, words in _REQUEST_WORDS:
        text = pattern.sub(words, text)
    return text


def _ik_failure(pending: PendingIK, outcome: IKOutcome, response: Any, elapsed: float) -> str:
    """Why a ComputeIK request found no solution, once, in the request's words: its reason (out
    of reach: how far and the reach; the closed form's reason; how the search stopped), the
    request's timeout where it ran out, the time the answer took since the request was sent
    (`elapsed` [s]), and the best configuration's errors against the request's tolerances."""
    options, took = pending.options, duration_text(elapsed)
    if pending.note:  # beyond reach, known before the solve
        if response.position_error < 0:  # too far to represent the error
            return f"no solution: unreachable: {pending.note}"
        errors = f"position error {response.position_error:.3g} m" + (
            ""
            if options.position_only
            else f", orientation error {response.orientation_error:.3g} rad"
        )
        return (
            f"no solution: unreachable: {pending.note}; best effort from the seed in {took}: "
            f"{errors}"
        )
    timeout = _timeout_text(options.timeout)
    if outcome.q is None:  # no solve ran
        if outcome.timed_out:
            return f"no solution: the timeout of {timeout} ran out after {took} {outcome.message}"
        if options.timeout < MIN_SOLVE_TIME:
            return f"no solution: {_request_words(outcome.message)}"
        return f"no solution: {_request_words(outcome.message)} (after {took})"

    def stopped(m: re.Match[str]) -> str:
        if m["restarts"] is not None:
            return (
                f"all {m['restarts']} restarts that the node's parameter ik.max_restarts allows "
                f"were made in {took}"
            )
        if m["effort"] is not None:
            return f"{m['effort']} in {took}"
        return f"the timeout of {timeout} ran out" + (f" after {took}" if m["after"] else "")

    text = _STOPPED.sub(stopped, _request_words(outcome.message))
    if not text:
        text = (
            f"best position error {response.position_error:.3g} m, orientation error "
            f"{response.orientation_error:.3g} rad"
        )
    if took not in text:  # a message that does not say how long: the time, once
        text += f" (after {took}; timeout {timeout})"
    return f"no solution: {text}"
