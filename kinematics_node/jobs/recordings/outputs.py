"""What a batch of joint motion adds to a recording: the end effector's pose and twist, and the
chain's transforms, as serialized messages ready to write (one row of bytes each).

The same quantities the kinematics node publishes for the same joint_states (`ee_pose`,
`ee_twist`; `compute_ee_state`), computed for the whole batch at once: one batched FK/Jacobian
pass, the quaternion by the same Shepperd's method (w ≥ 0), the twist J(q) q̇ in the node's
`twist_frame`. /tf holds, for every joint of the chain that moves, the pose of its child link in
its parent link, as robot_state_publisher gives it; /tf_static the fixed joints' (written once):
both from `core.joint_transforms.JointTransforms`, the code the node's /tf uses. `Markers` gives
the node's manipulability markers (`msg_adapters.markers`) at sampled rows.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from msg_adapters.cdr import pose_stamped_cdr, tf_message_cdr, twist_stamped_cdr
from msg_adapters.markers import MARKER_ARRAY_TYPE, manipulability_markers_cdr

from ...core import SerialChain, so3
from ...core.analysis import RED_CONDITION, singular_values, translational_ellipsoid
from ...core.joint_transforms import JointTransforms
from .joint_motion import Motion

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
Rows = NDArray[np.uint8]

POSE_TYPE = "geometry_msgs/msg/PoseStamped"
TWIST_TYPE = "geometry_msgs/msg/TwistStamped"
TF_TYPE = "tf2_msgs/msg/TFMessage"
MARKERS_TYPE = MARKER_ARRAY_TYPE


@dataclass(frozen=True)
class Written:
    """Messages for one topic: log times (k,) [ns] and their bytes (k, L)."""

    log_time_ns: IntArray
    rows: Rows


@dataclass(frozen=True)
class Conditioning:
    """Per row of a `Motion` (or of a decimated part of it): translational manipulability
    (product of the linear rows' singular values), the full Jacobian's condition number and its
    smallest singular value."""

    log_time_ns: IntArray
    manipulability: FloatArray
    condition_number: FloatArray
    min_singular_value: FloatArray

    def take(self, rows: IntArray) -> Conditioning:
        """The samples at `rows`."""
        return Conditioning(
            self.log_time_ns[rows],
            self.manipulability[rows],
            self.condition_number[rows],
            self.min_singular_value[rows],
        )


@dataclass(frozen=True)
class Computed:
    """What `EndEffector.messages` gives for m rows: the messages, the poses T (m, 4, 4), their
    quaternions (m, 4), the world Jacobians J (m, 6, n), rows (ω, v), and the world twists
    V (m, 6), (ω, v) (NaN rows where q̇ is unknown)."""

    pose: Written
    twist: Written
    tf: Written
    T: FloatArray
    J: FloatArray
    V: FloatArray
    quaternion: FloatArray


class EndEffector:
    """Turns `Motion` into the messages the recording gains.

    Args:
        chain: the chain (base → tip) whose pose the node publishes.
        transforms: the joints /tf and /tf_static hold (`JointTransforms.of_links` of the chain's
            links); their inputs must be joints of the chain.
        twist_frame: "world" (default, as the node's): ω and the tip origin's velocity in base
            axes, frame_id the base link; "body": both in tip axes, frame_id the tip link.
    """

    def __init__(
        self,
        chain: SerialChain,
        transforms: JointTransforms,
        twist_frame: Literal["world", "body"] = "world",
    ):
        self.chain = chain
        self.twist_frame = twist_frame
        self.transforms = transforms
        missing = [n for n in transforms.inputs if n not in chain.joint_names]
        if missing:
            raise ValueError(f"the transforms need joints {missing}, which the chain does not have")
        self._columns = [chain.joint_names.index(n) for n in transforms.inputs]
        moving = transforms.moving
        self._moving = moving
        self.tf_parents = tuple(np.array(transforms.parents)[moving].tolist())
        self.tf_children = tuple(np.array(transforms.children)[moving].tolist())
        self.static_parents = tuple(np.array(transforms.parents)[~moving].tolist())
        self.static_children = tuple(np.array(transforms.children)[~moving].tolist())

    def messages(self, motion: Motion) -> Computed:
        """The messages and quantities of the rows of `motion`; twists only where q̇ is known."""
        chain, stamp, log = self.chain, motion.stamp_ns, motion.log_time_ns
        T, J = chain.fk_jacobian(motion.q, "world")
        quat = so3.quaternion_from_matrix(T[:, :3, :3])
        pose = Written(log, pose_stamped_cdr(stamp, chain.base_link, T[:, :3, 3], quat))
        known = np.isfinite(motion.qdot).all(axis=1)
        V_world = np.full((len(log), 6), np.nan)
        V_world[known] = (J[known] @ motion.qdot[known][:, :, None])[:, :, 0]
        omega, v = V_world[known, :3], V_world[known, 3:]
        frame = chain.base_link
        if self.twist_frame == "body":
            Rt = np.swapaxes(T[known, :3, :3], 1, 2)
            omega, v = (Rt @ omega[:, :, None])[:, :, 0], (Rt @ v[:, :, None])[:, :, 0]
            frame = chain.tip_link
        twist = Written(log[known], twist_stamped_cdr(stamp[known], frame, v, omega))
        return Computed(pose, twist, self._tf(motion), T, J, V_world, quat)

    def _tf(self, motion: Motion) -> Written:
        t, quat = self.transforms.transforms(motion.q[:, self._columns])
        rows = tf_message_cdr(
            motion.stamp_ns,
            self.tf_parents,
            self.tf_children,
            t[:, self._moving],
            quat[:, self._moving],
        )
        return Written(motion.log_time_ns, rows)

    def static_tf(self, log_time_ns: int, stamp_ns: int) -> Written | None:
        """The fixed joints' /tf_static message (None when the chain has none)."""
        if not self.static_children:
            return None
        t, quat = self.transforms.transforms(np.zeros((1, len(self._columns))))
        rows = tf_message_cdr(
            np.array([stamp_ns]),
            self.static_parents,
            self.static_children,
            t[:, ~self._moving],
            quat[:, ~self._moving],
        )
        return Written(np.array([log_time_ns]), rows)


def conditioning(log_time_ns: IntArray, J: FloatArray) -> Conditioning:
    """`Conditioning` of Jacobians (m, 6, n), rows (ω, v), as the node's /diagnostics reports it
    (`core.analysis.conditioning`, batched)."""
    s = singular_values(J, "full")
    linear = singular_values(J, "linear")
    with np.errstate(divide="ignore"):
        cond = np.where(s[:, -1] > 0, s[:, 0] / s[:, -1], np.inf)
    return Conditioning(log_time_ns, np.prod(linear, axis=-1), cond, s[:, -1])


class Markers:
    """The node's manipulability markers (`msg_adapters.markers`) of rows of a batch, serialised
    as visualization_msgs of ROS 2 Jazzy (the output's typestore) in one batch.

    Args:
        chain: the chain; frame_id the base link.
        red_at: condition number drawn red (`core.analysis.condition_colour`).
    """

    def __init__(self, chain: SerialChain, red_at: float = RED_CONDITION):
        self.chain = chain
        self.red_at = red_at

    def messages(self, motion: Motion, computed: Computed, rows: IntArray) -> Written:
        """The markers at `rows` of `motion` (and `computed`, its messages), serialised in one
        batch (`manipulability_markers_cdr`); rows whose pose or Jacobian is not finite are
        skipped."""
        T, J = computed.T[rows], computed.J[rows]
        finite = np.isfinite(T).all(axis=(1, 2)) & np.isfinite(J).all(axis=(1, 2))
        rows = rows[finite]
        ellipsoids = [translational_ellipsoid(computed.J[r], computed.T[r, :3, 3]) for r in rows]
        data = manipulability_markers_cdr(
            ellipsoids, self.chain.base_link, motion.stamp_ns[rows], self.red_at
        )
        return Written(motion.log_time_ns[rows], data)
