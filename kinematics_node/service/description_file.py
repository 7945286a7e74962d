"""A robot description read from a file, as the node's `robot_description_file` parameter names
it: a URDF, or a xacro file expanded with the arguments of the `xacro_args` parameter, as
``xacro <file> name:=value ...`` (and a launch file's ``Command(["xacro ", file, " name:=value"])``)
would expand it.

Every error names the parameter and what was wrong in it: the file, or the argument.
"""

from __future__ import annotations

import contextlib
import io
import os
import shlex
from typing import Any

from ..core.exceptions import RobotDescriptionError
from ..core.urdf import RobotDescription, shorten

#: xacro's separator of an argument's name and value, as on its command line.
XACRO_ARG_SEPARATOR = ":="


def parse_xacro_args(text: str) -> dict[str, str]:
    """{name: value} of ``"name:=value other:='a value with spaces'"`` (split as a shell splits
    words, so values may be quoted).

    Raises:
        RobotDescriptionError: an item that is not name:=value, or a name given twice, naming it.
    """
    try:
        words = shlex.split(text)
    except ValueError as exc:  # an unclosed quote
        raise RobotDescriptionError(f"xacro_args {shorten(text)!r}: {exc}") from None
    args: dict[str, str] = {}
    for word in words:
        name, separator, value = word.partition(XACRO_ARG_SEPARATOR)
        name = name.strip()
        if not separator or not name:
            raise RobotDescriptionError(
                f"xacro_args: {shorten(word)!r} is not name:=value (expected e.g. "
                "'name:=ur5e prefix:=left_')"
            )
        if name in args:
            raise RobotDescriptionError(f"xacro_args: {name!r} is given twice")
        args[name] = value
    return args


class _RecordedArgs(dict[str, str]):
    """xacro's argument table, recording every name xacro declares (<xacro:arg>) or reads
    ($(arg name)), so that arguments nobody reads can be reported."""

    def __init__(self, given: dict[str, str]) -> None:
        super().__init__(given)
        self.seen: list[str] = []

    def _see(self, name: object) -> None:
        if isinstance(name, str) and name not in self.seen:
            self.seen.append(name)

    def __contains__(self, name: object) -> bool:
        self._see(name)
        return super().__contains__(name)

    def __getitem__(self, name: str) -> str:
        self._see(name)
        return super().__getitem__(name)

    def get(self, name: str, default: Any = None) -> Any:  # type: ignore[override]
        self._see(name)
        return super().get(name, default)


def read_description_file(path: str, xacro_args: str = "") -> RobotDescription:
    """The description in the file `path` (``~`` expanded), run through xacro with `xacro_args`
    (see `parse_xacro_args`) when it is a .xacro file or arguments are given. A URDF that uses
    xacro without arguments is expanded as `RobotDescription` does.

    Raises:
        RobotDescriptionError: no such file, not readable, malformed, xacro missing or failing
            (e.g. an argument the file needs and nobody gave), or an argument the file neither
            declares nor reads; each message names the file or the argument.
    """
    shown = shorten(path, 200)
    filename = os.path.expanduser(path.strip())
    if not filename:
        raise RobotDescriptionError("robot_description_file is empty")
    if not os.path.exists(filename):
        raise RobotDescriptionError(f"robot_description_file {shown!r}: no such file")
    if os.path.isdir(filename):
        raise RobotDescriptionError(
            f"robot_description_file {shown!r} is a directory; expected a URDF or xacro file"
        )
    args = parse_xacro_args(xacro_args)
    try:
        if args or filename.endswith(".xacro"):
            return RobotDescription(_expand_xacro(filename, args, shown))
        return RobotDescription(filename)
    except RobotDescriptionError as exc:
        text = str(exc)
        if shorten(filename) in text or shown in text:
            raise
        raise RobotDescriptionError(f"robot_description_file {shown!r}: {text}") from None


def _expand_xacro(filename: str, args: dict[str, str], shown: str) -> str:
    """The URDF text of the xacro file `filename` with the arguments `args`."""
    try:
        import xacro
    except ImportError:
        raise RobotDescriptionError(
            f"robot_description_file {shown!r} needs xacro"
            + (" (xacro_args are given)" if args else "")
            + ", but the 'xacro' package is not installed (ROS: ros-<distro>-xacro; pip: "
            "pip install xacro)"
        ) from None
    recorded = _RecordedArgs(args)
    try:
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            doc = xacro.process_file(filename, mappings=recorded)
    except Exception as exc:  # xacro raises XacroException and plain Python errors
        text = " ".join(str(exc).split()) or type(exc).__name__
        if "Undefined substitution argument" in text:
            text += " (give it in xacro_args: 'name:=value')"
        raise RobotDescriptionError(f"xacro failed on {shown!r}: {text}") from None
    unused = [name for name in args if name not in recorded.seen]
    if unused:
        declared = recorded.seen
        raise RobotDescriptionError(
            f"xacro_args: {unused[0]!r} is not an argument of {shown!r} ("
            + (f"it declares {declared}" if declared else "it declares none")
            + ")"
        )
    return str(doc.toxml())
