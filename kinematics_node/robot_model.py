"""`RobotModel`: one robot description, its default chain, and lazily built chains to other links.

Immutable after construction except for the chain cache, which is guarded by a lock so that
service threads can share one model.
"""

from __future__ import annotations

import threading

from .core import SerialChain
from .core.exceptions import KinematicsError, RobotDescriptionError, UnknownNameError
from .core.urdf import RobotDescription


class RobotModel:
    """A parsed robot description with the default chain `base_link` → `tip_link`.

    Attributes:
        description: the parsed description (`core.urdf.RobotDescription`), parsed once.
        xml: the URDF text (xacro already expanded).
        robot_name: the `<robot name>` attribute.
        joint_names: every joint of the robot (any type): names a request may mention.
        moving_joint_names: revolute, continuous and prismatic joints (mimic followers included).
        link_names: every link of the robot.
        chain: the default chain.
    """

    def __init__(self, description: str, base_link: str = "", tip_link: str = "") -> None:
        """Parse `description` (URDF or xacro XML text, or a file path) and build the default chain.

        Raises:
            RobotDescriptionError: malformed or unsupported description, naming the culprit.
            UnknownNameError: base_link or tip_link is not a link of the robot.
        """
        if not str(description).strip():
            raise RobotDescriptionError("robot description is empty")
        self.description = RobotDescription(description)  # the one parse of the description
        self.xml = self.description.xml
        self.robot_name = self.description.robot_name
        self.joint_names = self.description.joint_names
        self.moving_joint_names = self.description.moving_joint_names
        self.link_names = self.description.link_names
        self.chain = SerialChain.from_spec(
            self.description.chain_spec(base_link or None, tip_link or None)
        )
        self._lock = threading.Lock()
        self._chains: dict[tuple[str, str], SerialChain | KinematicsError] = {
            (self.chain.base_link, self.chain.tip_link): self.chain
        }

    @property
    def base_link(self) -> str:
        return self.chain.base_link

    def chain_between(self, base_link: str, tip_link: str) -> SerialChain:
        """The chain `base_link` → `tip_link` (built on first use, then cached; thread-safe).

        Raises:
            UnknownNameError: a link that is not in the robot (the message lists the links).
            RobotDescriptionError: no moving joint between them, or tip not below base.
        """
        for link in (base_link, tip_link):
            if link not in self.link_names:
                raise UnknownNameError("link", link, sorted(self.link_names))
        key = (base_link, tip_link)
        with self._lock:
            cached = self._chains.get(key)
        if cached is None:
            try:
                cached = SerialChain.from_spec(self.description.chain_spec(base_link, tip_link))
            except KinematicsError as exc:  # remember failures too: rebuilding them is as slow
                cached = exc
            with self._lock:
                cached = self._chains.setdefault(key, cached)
        if isinstance(cached, KinematicsError):
            raise cached
        return cached

    def chain_to(self, tip_link: str) -> SerialChain:
        """The chain from the default base to `tip_link`; empty = the default chain."""
        if not tip_link or tip_link == self.chain.tip_link:
            return self.chain
        return self.chain_between(self.chain.base_link, tip_link)
