"""Which closed-form structure the relations of six axis lines allow (before confirmation).

Families are read from the screw axes alone (never from names or DH tables), with tolerances
`ANGLE_TOLERANCE` [rad] and `DISTANCE_TOLERANCE` [m] that absorb the rounding of real URDFs. Also
the derived points and directions each family's solver reads (`lane_geometry`) and the public
description of a family (`ClosedFormFamily`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import subproblems as sp
from .geometry import FloatArray, LaneGeometry, meet_point, perpendicular_lanes

#: Axes closer to parallel than this count as parallel [rad].
ANGLE_TOLERANCE = 1e-5


#: Axes that pass closer than this count as meeting [m].
DISTANCE_TOLERANCE = 1e-5


@dataclass(frozen=True)
class ClosedFormFamily:
    """The closed-form structure detected in a chain.

    Attributes:
        name: "three_parallel", "spherical_wrist", "7r_three_parallel" or "7r_spherical_wrist".
        held_joint: for 7R arms the joint whose values are swept; None for 6R.
        reversed: True when the structure is read from the tip (e.g. a spherical shoulder).
        position_case: for spherical wrists, how the first three axes are related
            ("2∥3", "1∩2", "2∩3", "1∥2"); "" otherwise.
        description: one line for people, naming the axes (1-based) and the special points.
    """

    name: str
    held_joint: str | None
    reversed: bool
    position_case: str
    description: str


@dataclass(frozen=True)
class Structure:
    kind: str  # "three_parallel" | "spherical_wrist" | "general_6r"
    case: str  # spherical wrist: "par23" | "int12" | "int23" | "par12"; general_6r: the joint
    # (0-based, "" for 0) its loop is read from; else ""
    reversed: bool


CASE_LABEL = {"par23": "2∥3", "int12": "1∩2", "int23": "2∩3", "par12": "1∥2", "": ""}


def _parallel(w: FloatArray, i: int, j: int) -> bool:
    return bool(sp.norm(sp.cross(w[i], w[j])) <= ANGLE_TOLERANCE)


def _meets(w: FloatArray, r: FloatArray, idx: tuple[int, ...]) -> bool:
    """The lines idx (consecutive joints) pass through one point, and no two neighbours are parallel.

    Only neighbours are compared: their relation is the same in every configuration, while two
    lines further apart may coincide at home (Panda's joints 1 and 3) and not elsewhere.
    """
    for a, b in zip(idx[:-1], idx[1:], strict=True):
        if _parallel(w, a, b):
            return False
    _, miss = meet_point(w[list(idx)], r[list(idx)])
    return bool(miss <= DISTANCE_TOLERANCE)


def collinear_axes(w: FloatArray, r: FloatArray) -> tuple[int, int] | None:
    """The first two neighbouring joints (0-based) whose lines (unit directions w, points r
    (n, 3)) are one line, to `ANGLE_TOLERANCE` and `DISTANCE_TOLERANCE`, or None. With no joint
    between them they stay one line in every configuration and act as one joint: the tip moves
    with the sum of their angles (the difference, where the axes are opposed). Only neighbours,
    as in `_meets`."""
    for i in range(w.shape[0] - 1):
        if _parallel(w, i, i + 1):
            d = r[i + 1] - r[i]
            if float(sp.norm(d - sp.dot(d, w[i]) * w[i])) <= DISTANCE_TOLERANCE:
                return i, i + 1
    return None


#: A named family whose axis relations hold only to more than this (angle [rad], distance / the
#: arm's size) is left to the general 6R solver: its candidates would each need Newton steps.
EXACT_RELATION = 1e-9


def structure_residual(st: Structure, w6: FloatArray, r6: FloatArray, scale: float) -> float:
    """How far the 6R lines (w6, r6) are from the relations of the named structure st: the largest
    sine between axes taken as parallel and miss distance / scale of axes taken as meeting."""
    w, r = (w6[::-1], r6[::-1]) if st.reversed else (w6, r6)

    def par(i: int, j: int) -> float:
        return float(sp.norm(sp.cross(w[i], w[j])))

    def miss(*idx: int) -> float:
        return float(meet_point(w[list(idx)], r[list(idx)])[1]) / scale

    if st.kind == "three_parallel":
        return max(par(1, 2), par(2, 3), miss(4, 5))
    relation = {
        "par23": lambda: par(1, 2), "int12": lambda: miss(0, 1),
        "int23": lambda: miss(1, 2), "par12": lambda: par(0, 1),
    }.get(st.case, lambda: 0.0)  # fmt: skip
    return max(miss(3, 4, 5), relation())


def structure_candidates(w6: FloatArray, r6: FloatArray) -> list[Structure]:
    """Structures whose axis relations hold for the 6R lines (w6, r6); not yet confirmed."""
    out: list[Structure] = []
    for rev in (False, True):
        w, r = (w6[::-1], r6[::-1]) if rev else (w6, r6)
        if (
            _parallel(w, 1, 2)
            and _parallel(w, 2, 3)
            and not _parallel(w, 0, 1)
            and not _parallel(w, 3, 4)
            and _meets(w, r, (4, 5))
        ):
            out.append(Structure("three_parallel", "", rev))
        if _meets(w, r, (3, 4, 5)):
            if _parallel(w, 1, 2) and not _parallel(w, 0, 1):
                out.append(Structure("spherical_wrist", "par23", rev))
            if _meets(w, r, (0, 1)):
                out.append(Structure("spherical_wrist", "int12", rev))
            if _meets(w, r, (1, 2)):
                out.append(Structure("spherical_wrist", "int23", rev))
            if _parallel(w, 0, 1) and not _parallel(w, 1, 2):
                out.append(Structure("spherical_wrist", "par12", rev))
    return out


def lane_geometry(st: Structure, w: FloatArray, r: FloatArray, scale: float) -> LaneGeometry:
    """Derived points and directions for lanes of 6R lines w, r (L, 6, 3), forward order."""
    if st.reversed:
        w, r = w[:, ::-1], r[:, ::-1]
    L = w.shape[0]
    zeros, ones = np.zeros((L, 3)), np.ones((L, 3))
    if st.kind == "general_6r":  # the axes alone (`general_6r`)
        return LaneGeometry(w, r, zeros, zeros, zeros, perpendicular_lanes(w[:, 5]), ones, scale)
    if st.kind == "three_parallel":
        h = w[:, 1]
        c, _ = meet_point(w[:, 4:6], r[:, 4:6])
        return LaneGeometry(
            w, r, c, zeros, h, perpendicular_lanes(h), sp.dot(w[:, 1:4], h[:, None]), scale
        )
    c, _ = meet_point(w[:, 3:6], r[:, 3:6])
    b, h = zeros, zeros
    if st.case == "int12":
        b, _ = meet_point(w[:, 0:2], r[:, 0:2])
    elif st.case == "int23":
        b, _ = meet_point(w[:, 1:3], r[:, 1:3])
    elif st.case == "par23":
        h = w[:, 1]
    else:
        h = w[:, 0]
    return LaneGeometry(w, r, c, b, h, perpendicular_lanes(w[:, 5]), ones, scale)
