"""Parameter names a node does not know: which of a start-up's overrides are typos, and the
closest name each was probably meant to be. No rclpy here: `ros/node_setup.py` feeds it the
overrides rclpy parsed (``-p name:=value``, ``--params-file``) and the names a node declared.

ROS declares some parameters on every node by itself (`ROS_OWN`), and `qos_overrides.*` only for
publishers and subscriptions that opt in; neither is ours to judge, so neither is reported.
"""

from __future__ import annotations

import difflib
from collections.abc import Collection, Iterable

#: Parameters rclpy declares on every node by itself.
ROS_OWN = frozenset({"use_sim_time", "start_type_description_service"})
#: Prefixes of parameters ROS reads where an entity opts in (QoS overrides of a topic).
ROS_OWN_PREFIXES = ("qos_overrides.",)

#: How alike a name must be to a known one to be suggested (difflib's ratio, 0..1; 0.6 is
#: difflib's own default: 'tip_lnk' -> 'tip_link' is 0.93, 'ik.timout' -> 'ik.timeout' 0.95).
SIMILARITY = 0.6


def closest_name(name: str, known: Iterable[str]) -> str | None:
    """The known name most like `name` (case ignored), or None when none is alike enough
    (`SIMILARITY`). A name without its group ('timeout' for 'ik.timeout') is matched too."""
    by_lower: dict[str, str] = {}
    for k in sorted(known):
        by_lower.setdefault(k.lower(), k)
    wanted = name.lower()
    best = difflib.get_close_matches(wanted, by_lower, n=1, cutoff=SIMILARITY)
    if best:
        return by_lower[best[0]]
    # 'timeout' for 'ik.timeout': compare with each name's last part
    leaves: dict[str, str] = {}
    for k_lower, k in by_lower.items():
        leaves.setdefault(k_lower.rpartition(".")[2], k)
    best = difflib.get_close_matches(wanted.rpartition(".")[2], leaves, n=1, cutoff=0.8)
    return leaves[best[0]] if best else None


def unknown_parameter_text(name: str, known: Iterable[str]) -> str:
    """ "unknown parameter 'tip_lnk' (did you mean 'tip_link'?)", or without the question when no
    known name is close."""
    guess = closest_name(name, known)
    return f"unknown parameter {name!r}" + (f" (did you mean {guess!r}?)" if guess else "")


def is_ros_own(name: str) -> bool:
    """True for a parameter ROS itself declares or reads (`ROS_OWN`, `ROS_OWN_PREFIXES`)."""
    return name in ROS_OWN or name.startswith(ROS_OWN_PREFIXES)


def unknown_overrides(overrides: Iterable[str], declared: Collection[str]) -> list[str]:
    """The names of `overrides` (what the command line and parameter files gave the node) that
    it did not declare and ROS does not read, sorted."""
    return sorted({n for n in overrides if n not in declared and not is_ros_own(n)})


def override_warnings(overrides: Iterable[str], declared: Collection[str]) -> list[str]:
    """One warning per unknown override (`unknown_overrides`), naming the closest declared
    name: "unknown parameter 'tip_lnk' (did you mean 'tip_link'?): ignored"."""
    return [
        f"{unknown_parameter_text(name, declared)}: ignored"
        for name in unknown_overrides(overrides, declared)
    ]


def refusal_text(names: Iterable[str], known: Iterable[str]) -> str:
    """Why a run-time set of undeclared parameters is refused, one clause per name:
    "unknown parameter 'ik.timout' (did you mean 'ik.timeout'?): not set"."""
    known = tuple(known)
    return "; ".join(f"{unknown_parameter_text(n, known)}: not set" for n in names)
