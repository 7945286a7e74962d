"""Pictures of a reachability map (`kinematics reach --plot`) and of base placements (`kinematics
place --plot`). Needs matplotlib (the `demo` extra); the colours of D are the markers' own
(`msg_adapters.reach_markers.index_colours`), so the picture and RViz read alike.

* `draw_map`: a horizontal slice through the map (at `z`, default the layer with the most reach:
  about the shoulder's height), the vertical slice through the base axis (y = 0), and how many
  voxels have each D.
* `draw_placement`: a top view of the task poses (dots, arrows: their approach direction projected
  on the floor) and the best base placements (a square, an arrow along the base's x axis, the rank
  number), over the map's slice at the tasks' median height seen from the best placement.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from msg_adapters.reach_markers import index_colours

from .placement import PlacementResult
from .reach_map import ReachMap

INSTALL = "pip install 'kinematics_service[demo]'"


def _pyplot() -> Any:
    try:
        import matplotlib
    except ImportError:
        raise ImportError(f"the picture needs matplotlib: {INSTALL}") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _colour_map() -> Any:
    from matplotlib.colors import ListedColormap

    rgba = index_colours(np.linspace(0.0, 100.0, 256))
    rgba[:, 3] = 1.0
    return ListedColormap(rgba, name="reachability")


def densest_layer(reach_map: ReachMap) -> float:
    """z [m] of the horizontal voxel layer with the largest summed D."""
    c = np.asarray(reach_map.centres)
    k = np.rint(c[:, 2] / reach_map.resolution).astype(np.int64)
    layers, inverse = np.unique(k, return_inverse=True)
    total = np.bincount(inverse.ravel(), weights=np.asarray(reach_map.index))
    return float(layers[int(np.argmax(total))] * reach_map.resolution)


def slice_grid(
    reach_map: ReachMap, axis: int, value: float
) -> tuple[NDArray[np.float64], tuple[float, float, float, float]]:
    """The map's D [%] on the voxel layer nearest `value` [m] along `axis` (0 x, 1 y, 2 z): a 2-D
    array over the other two axes (rows: the second, columns: the first; NaN where the map has
    no voxel or D = 0) and its extent (left, right, bottom, top) [m] for imshow."""
    res = reach_map.resolution
    k = np.rint(np.asarray(reach_map.centres) / res).astype(np.int64)
    D = np.asarray(reach_map.index, dtype=np.float64)
    layer = k[:, axis] == round(value / res)
    a, b = (i for i in range(3) if i != axis)
    lo, hi = k.min(axis=0), k.max(axis=0)
    grid = np.full((hi[b] - lo[b] + 1, hi[a] - lo[a] + 1), np.nan)
    sel = layer & (D > 0)
    grid[k[sel, b] - lo[b], k[sel, a] - lo[a]] = D[sel]
    extent = (
        (lo[a] - 0.5) * res,
        (hi[a] + 0.5) * res,
        (lo[b] - 0.5) * res,
        (hi[b] + 0.5) * res,
    )
    return grid, extent


def draw_map(reach_map: ReachMap, path: str | Path, z: float | None = None) -> None:
    """Draw the map's slices and its histogram of D into the picture file `path`."""
    plt = _pyplot()
    cmap = _colour_map()
    z_cut = densest_layer(reach_map) if z is None else float(z)
    fig, axes = plt.subplots(1, 3, figsize=(15, 5.2), constrained_layout=True)
    frame = reach_map.base_link
    image = None
    for ax, axis, value, labels, title in (
        (axes[0], 2, z_cut, ("x", "y"), f"horizontal slice z = {z_cut:.2f} m"),
        (axes[1], 1, 0.0, ("x", "z"), "vertical slice through the base axis (y = 0)"),
    ):
        grid, extent = slice_grid(reach_map, axis, value)
        image = ax.imshow(
            grid, origin="lower", extent=extent, cmap=cmap, vmin=0, vmax=100, aspect="equal"
        )
        ax.set_xlabel(f"{labels[0]} [m] ({frame})")
        ax.set_ylabel(f"{labels[1]} [m]")
        ax.set_title(title)
        ax.plot(0, 0, marker="+", color="black", ms=12, mew=2)
        ax.grid(alpha=0.3)
    fig.colorbar(image, ax=axes[:2], shrink=0.85, label="reachability index D [%]")
    D = np.asarray(reach_map.index)
    reached = D[D > 0]
    bins = np.linspace(0, 100, 21)
    counts, edges, patches = axes[2].hist(reached, bins=bins, edgecolor="white")
    for patch, left in zip(patches, edges[:-1], strict=True):
        patch.set_facecolor(cmap((left + 2.5) / 100.0))
    axes[2].set_xlabel("reachability index D [%]")
    axes[2].set_ylabel("voxels")
    axes[2].set_title(
        f"{len(reached)} of {len(D)} voxels with D > 0\n(mean D {reached.mean():.0f} %)"
        if len(reached)
        else "no voxel reached"
    )
    fig.suptitle(
        f"{reach_map.robot or 'robot'} {reach_map.base_link} → {reach_map.tip_link}: "
        f"{reach_map.resolution * 100:g} cm voxels, {reach_map.directions} approach directions"
        f" × {reach_map.rolls} roll{'s' if reach_map.rolls != 1 else ''}"
    )
    fig.savefig(path, dpi=110)
    plt.close(fig)


def draw_placement(
    reach_map: ReachMap,
    result: PlacementResult,
    tasks: ArrayLike,
    path: str | Path,
    top: int = 5,
) -> None:
    """Draw the task poses and the best `top` placements of `result` from above into `path`."""
    plt = _pyplot()
    cmap = _colour_map()
    T = np.asarray(tasks, dtype=np.float64)
    fig, ax = plt.subplots(figsize=(9, 8), constrained_layout=True)
    best = result.placements[:top]
    res = reach_map.resolution
    if best:  # the map's slice at the tasks' height, seen from the best placement
        z = float(np.median(T[:, 2, 3]))
        c = np.asarray(reach_map.centres)
        D = np.asarray(reach_map.index)
        sel = (np.rint(c[:, 2] / res) == round(z / res)) & (D > 0)
        p0 = best[0]
        cs, sn = math.cos(p0.yaw), math.sin(p0.yaw)
        x = p0.x + cs * c[sel, 0] - sn * c[sel, 1]
        y = p0.y + sn * c[sel, 0] + cs * c[sel, 1]
        dots = ax.scatter(
            x, y, c=D[sel], cmap=cmap, vmin=0, vmax=100, marker="s", s=30, alpha=0.35, lw=0
        )
        fig.colorbar(dots, ax=ax, shrink=0.7, label=f"D [%] at z = {z:.2f} m from placement 1")
    span = max(float(np.ptp(T[:, 0, 3])), float(np.ptp(T[:, 1, 3])), 0.5)
    arrow = 0.08 * span
    down = T[:, 2, 2] < -0.7
    up = T[:, 2, 2] > 0.7
    side = ~(down | up)
    for sel, marker, label in (
        (down, "v", "task pose, approach down"),
        (up, "^", "task pose, approach up"),
        (side, "o", "task pose (arrow: approach)"),
    ):
        if sel.any():
            ax.scatter(
                T[sel, 0, 3],
                T[sel, 1, 3],
                color="black",
                marker=marker,
                s=40,
                zorder=5,
                label=label,
            )
    approach = T[:, :2, 2]
    ax.quiver(
        T[:, 0, 3],
        T[:, 1, 3],
        approach[:, 0],
        approach[:, 1],
        color="black",
        angles="xy",
        scale_units="xy",
        scale=1.0 / arrow,
        width=0.004,
        zorder=5,
    )
    lines = []
    for rank, p in enumerate(best, 1):
        colour = "tab:blue" if rank == 1 else "tab:purple"
        ax.scatter(p.x, p.y, marker="s", s=60, color=colour, edgecolor="white", zorder=6)
        ax.annotate(
            "",
            xy=(p.x + 2 * arrow * math.cos(p.yaw), p.y + 2 * arrow * math.sin(p.yaw)),
            xytext=(p.x, p.y),
            arrowprops={"arrowstyle": "->", "color": colour, "lw": 1.5},
            zorder=6,
        )
        ax.annotate(
            str(rank),
            (p.x, p.y),
            xytext=(-4, 5),
            textcoords="offset points",
            ha="right",
            color=colour,
            fontsize=10,
            fontweight="bold",
            zorder=7,
        )
        reached = p.verified if p.verified is not None else p.map_reached
        lines.append(
            f"{rank}: x {p.x:.2f}  y {p.y:.2f}  yaw {math.degrees(p.yaw):.0f}°  "
            f"{reached}/{result.tasks}"
        )
    if lines:
        ax.text(
            0.02,
            0.02,
            "\n".join(lines),
            transform=ax.transAxes,
            fontsize=9,
            family="monospace",
            va="bottom",
            bbox={"facecolor": "white", "alpha": 0.85, "edgecolor": "0.7"},
            zorder=8,
        )
    ax.set_aspect("equal")
    ax.set_xlabel("x [m] (world)")
    ax.set_ylabel("y [m] (world)")
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right")
    verified = any(p.verified is not None for p in best)
    ax.set_title(
        f"best {len(best)} base placements for {result.tasks} task poses "
        f"({'tasks reached, verified by IK' if verified else 'tasks reached, by the map'}; "
        "arrow: the base's x axis)"
    )
    fig.savefig(path, dpi=110)
    plt.close(fig)
