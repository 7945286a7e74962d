"""The pictures of a map and of base placements (`jobs.maps.picture`): the slices hold the map's
D voxel for voxel, the files are written, and without matplotlib the refusal names the extra."""

from __future__ import annotations

import sys

import numpy as np
import pytest
from map_testing import small_map

from kinematics_node.jobs.maps.picture import densest_layer, draw_map, draw_placement, slice_grid
from kinematics_node.jobs.maps.placement import floor_pose, place_base


def test_slices_hold_the_maps_index() -> None:
    m = small_map()
    D = np.asarray(m.index)
    c = np.asarray(m.centres)
    z = densest_layer(m)
    layer = np.isclose(c[:, 2], z)
    assert D[layer].sum() == max(
        D[np.isclose(c[:, 2], zz)].sum() for zz in np.unique(np.round(c[:, 2], 9))
    )
    grid, (left, right, bottom, top) = slice_grid(m, 2, z)
    for (x, y, _), d in zip(c[layer], D[layer], strict=True):
        col = int(round((x - left) / m.resolution - 0.5))
        row = int(round((y - bottom) / m.resolution - 0.5))
        assert (np.isnan(grid[row, col]) and d == 0) or grid[row, col] == d
    assert np.count_nonzero(~np.isnan(grid)) == np.count_nonzero(D[layer] > 0)
    assert right - left == pytest.approx(grid.shape[1] * m.resolution)
    assert top - bottom == pytest.approx(grid.shape[0] * m.resolution)


def test_pictures_are_written(tmp_path) -> None:
    pytest.importorskip("matplotlib", reason="pip install 'kinematics_service[demo]'")
    m = small_map()
    draw_map(m, tmp_path / "map.png")
    tasks = np.stack([floor_pose(0.5, 0.1 * k, 0.0) for k in range(3)])
    tasks[:, 2, 3] = 0.3
    result = place_base(m, tasks, top=3)
    draw_placement(m, result, tasks, tmp_path / "place.png")
    for name in ("map.png", "place.png"):
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_without_matplotlib_the_refusal_names_the_extra(tmp_path, monkeypatch) -> None:
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    with pytest.raises(ImportError, match=r"kinematics_service\[demo\]"):
        draw_map(small_map(), tmp_path / "map.png")
