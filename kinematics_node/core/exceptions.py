"""Exception tree of the kinematics core: everything raised on purpose derives from `KinematicsError`.

Each class also derives from the built-in exception a caller would naturally catch (`ValueError`,
`LookupError`), so ``except ValueError`` keeps working for code that does not know this package.
"""

from __future__ import annotations

from collections.abc import Iterable


class KinematicsError(Exception):
    """Base class of every error this package raises deliberately."""


class InvalidInputError(KinematicsError, ValueError):
    """A numeric input has the wrong shape, is not finite, or is otherwise unusable."""


class RobotDescriptionError(KinematicsError, ValueError):
    """A robot description (URDF, xacro or DH table) is malformed or uses something unsupported.

    The message names the offending joint or link.
    """


class UnknownNameError(KinematicsError, LookupError):
    """A joint, link or frame name is not part of the model; the message lists the valid names."""

    def __init__(self, kind: str, name: str, valid: Iterable[str]) -> None:
        self.kind = kind
        self.name = name
        self.valid = tuple(valid)
        shown = ", ".join(repr(v) for v in self.valid[:40])
        more = f" (+{len(self.valid) - 40} more)" if len(self.valid) > 40 else ""
        super().__init__(f"unknown {kind} {name!r}; valid {kind}s are: {shown}{more}")

    def __str__(self) -> str:  # LookupError would otherwise print the repr of the args
        return str(self.args[0])


class NoClosedFormError(KinematicsError):
    """The chain's geometry admits no closed-form IK here (`SerialChain.ik_all`); the message says
    what was looked for and missed. The numeric `SerialChain.ik` still applies."""
