"""The robot descriptions bundled with the package (`config/robots/*.urdf`) and where to find them.

The files are found in each of the three ways the package is installed:

1. source tree or editable ``pip install -e .``: ``<repo>/config/robots`` next to the package
   ``kinematics_node`` (this module is ``kinematics_node/sim/robots.py``);
2. ``pip install .`` (setup.py ``data_files``):
   ``<sys.prefix>/share/kinematics_service/config/robots``
   (also the user base for ``pip install --user``);
3. a colcon/ament install: ``<prefix>/share/kinematics_service/config/robots`` for every prefix in
   ``AMENT_PREFIX_PATH``, and for every directory above this file (the install prefix of the
   package itself), so it works without ``ament_index_python``.

The first directory that exists and holds at least one ``*.urdf`` wins.

Default chains (base link → tip link) per bundled robot, as used by `load_robot` and the launch
files:

========  =============  ================  ==========================================
robot     base           tip               note
========  =============  ================  ==========================================
ur5e      base_link      tool0             DH frame 0 → flange (DH frame 6)
panda     panda_link0    panda_hand_tcp    fingers are branches; flange = panda_link8
iiwa14    iiwa_link_0    iiwa_link_ee      flange (DH frame 7)
scara     base_link      tool0             De Luca's SCARA, frame 4
planar3r  base_link      tool0             planar 3R, frame 3
========  =============  ================  ==========================================
"""

from __future__ import annotations

import os
import site
import sys
from collections.abc import Iterator, Mapping
from pathlib import Path

from ..core import SerialChain
from ..core.exceptions import RobotDescriptionError, UnknownNameError

PACKAGE_NAME = "kinematics_service"
"""The ROS / distribution name under which the data files are installed (``share/<this>``)."""

_RELATIVE_DIR = Path("config") / "robots"
_SHARE_RELATIVE_DIR = Path("share") / PACKAGE_NAME / _RELATIVE_DIR

_DEFAULT_CHAINS: dict[str, tuple[str, str]] = {
    "ur5e": ("base_link", "tool0"),
    "panda": ("panda_link0", "panda_hand_tcp"),
    "iiwa14": ("iiwa_link_0", "iiwa_link_ee"),
    "scara": ("base_link", "tool0"),
    "planar3r": ("base_link", "tool0"),
}


def candidate_directories(
    package_file: str | os.PathLike[str] | None = None,
    prefix: str | None = None,
    environ: Mapping[str, str] | None = None,
) -> list[Path]:
    """Directories searched for the bundled robots, in order (see the module docstring).

    Args:
        package_file: path of this module (default: ``__file__``); parameterised for tests.
        prefix: the Python installation prefix (default: ``sys.prefix``).
        environ: environment (default: ``os.environ``), read for ``AMENT_PREFIX_PATH``.
    """
    here = Path(package_file if package_file is not None else __file__).resolve().parent
    package = here.parent  # kinematics_node/ (this module is kinematics_node/sim/robots.py)
    env = os.environ if environ is None else environ
    dirs: list[Path] = [package.parent / _RELATIVE_DIR]  # 1. source tree / editable install
    prefixes = [Path(prefix if prefix is not None else sys.prefix)]  # 2. pip data_files
    if prefix is None:
        user_base = getattr(site, "USER_BASE", None)
        if user_base:
            prefixes.append(Path(user_base))
    prefixes += [Path(p) for p in env.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]  # 3.
    prefixes += list(
        package.parents
    )  # 3'. e.g. <prefix>/lib/python3.X/site-packages/kinematics_node
    seen: set[Path] = set(dirs)
    for p in prefixes:
        d = p / _SHARE_RELATIVE_DIR
        if d not in seen:
            seen.add(d)
            dirs.append(d)
    return dirs


def _existing(dirs: list[Path]) -> Iterator[Path]:
    for d in dirs:
        if d.is_dir() and any(d.glob("*.urdf")):
            yield d


def robots_directory(
    package_file: str | os.PathLike[str] | None = None,
    prefix: str | None = None,
    environ: Mapping[str, str] | None = None,
) -> Path:
    """The directory holding the bundled ``*.urdf`` files.

    Raises:
        RobotDescriptionError: none of the candidate directories exists; the message lists them.
    """
    dirs = candidate_directories(package_file, prefix, environ)
    for d in _existing(dirs):
        return d
    searched = "\n  ".join(str(d) for d in dirs)
    raise RobotDescriptionError(
        "the bundled robot descriptions (config/robots/*.urdf) were not found; the package data "
        f"seems not to be installed. Searched:\n  {searched}"
    )


def available_robots() -> tuple[str, ...]:
    """Names of the bundled robots (file stems of ``config/robots/*.urdf``), sorted."""
    return tuple(sorted(p.stem for p in robots_directory().glob("*.urdf")))


def robot_path(name: str) -> Path:
    """Path of the bundled description ``<name>.urdf``.

    Raises:
        UnknownNameError: `name` is not a bundled robot (the message lists those available).
        RobotDescriptionError: the bundled files are not installed at all.
    """
    directory = robots_directory()
    path = directory / f"{name}.urdf"
    try:
        found = isinstance(name, str) and "/" not in name and os.sep not in name and path.is_file()
    except OSError:  # e.g. a name longer than a file name may be
        found = False
    if not found:
        raise UnknownNameError("robot", str(name)[:80], available_robots())
    return path


def default_chain_links(name: str) -> tuple[str, str]:
    """(base link, tip link) of the default chain of a bundled robot (table in the module doc).

    Raises:
        UnknownNameError: `name` is not a bundled robot.
    """
    if name not in _DEFAULT_CHAINS:
        raise UnknownNameError("robot", str(name), sorted(_DEFAULT_CHAINS))
    return _DEFAULT_CHAINS[name]


def load_robot(name: str, base_link: str | None = None, tip_link: str | None = None) -> SerialChain:
    """`SerialChain` of a bundled robot; `base_link`/`tip_link` default to `default_chain_links`."""
    path = robot_path(name)
    default_base, default_tip = default_chain_links(name)
    return SerialChain.from_urdf(
        path,
        base_link=default_base if base_link is None else base_link,
        tip_link=default_tip if tip_link is None else tip_link,
    )
