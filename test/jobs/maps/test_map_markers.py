"""The map's markers in an MCAP file (`jobs.maps.markers`), decoded with mcap-ros2-support's own
decoder (not rosbags, which wrote them): one MarkerArray on /reachability_map, offered transient
local, a CUBE_LIST whose cubes and colours are the map's voxels with D > 0."""

from __future__ import annotations

import numpy as np
import pytest
from map_testing import small_map

from kinematics_node.jobs.maps.markers import MarkersError, write_map_markers
from msg_adapters.reach_markers import index_colours

pytest.importorskip(
    "rosbags", reason="the markers need rosbags: pip install 'kinematics_service[bags]'"
)


def _decoded(path):
    reader_mod = pytest.importorskip(
        "mcap.reader", reason="decoding needs mcap-ros2-support (the test extra)"
    )
    decoder_mod = pytest.importorskip("mcap_ros2.decoder", reason="pip install mcap-ros2-support")
    with open(path, "rb") as fh:
        reader = reader_mod.make_reader(fh, decoder_factories=[decoder_mod.DecoderFactory()])
        summary = reader.get_summary()
        channels = list(summary.channels.values())
        messages = [(c, m) for _, c, _, m in reader.iter_decoded_messages()]
    return channels, messages


def test_markers_file_holds_the_map(tmp_path) -> None:
    m = small_map()
    path = tmp_path / "map.mcap"
    cubes = write_map_markers(m, path)
    channels, messages = _decoded(path)
    assert [c.topic for c in channels] == ["/reachability_map"]
    assert "transient_local" in channels[0].metadata["offered_qos_profiles"]
    assert len(messages) == 1
    channel, array = messages[0]
    assert channel.topic == "/reachability_map"
    (marker,) = array.markers
    assert marker.type == 6 and marker.action == 0  # CUBE_LIST, ADD
    assert marker.header.frame_id == m.base_link == "base_link"
    assert (marker.scale.x, marker.scale.y, marker.scale.z) == (m.resolution,) * 3
    D = np.asarray(m.index)
    drawn = D > 0
    assert 0 < drawn.sum() < len(D)  # the coarse grid has voxels out of reach: left out
    assert cubes == len(marker.points) == len(marker.colors) == drawn.sum()
    points = np.array([[p.x, p.y, p.z] for p in marker.points])
    np.testing.assert_array_equal(points, np.asarray(m.centres)[drawn])
    colours = np.array([[c.r, c.g, c.b, c.a] for c in marker.colors])
    np.testing.assert_allclose(colours, index_colours(D[drawn]), rtol=1e-6)  # float32 fields


def test_colours_run_from_red_to_green_and_opaque_with_D() -> None:
    rgba = index_colours([1.0, 50.0, 100.0])
    assert rgba[0, 0] == 1.0 and rgba[0, 1] < 0.05  # red
    assert rgba[1, 0] == 1.0 and rgba[1, 1] > 0.8  # yellow
    assert rgba[2, 0] == 0.0 and rgba[2, 1] > 0.7  # green
    assert rgba[0, 3] < rgba[1, 3] < rgba[2, 3]


def test_an_existing_file_is_not_replaced(tmp_path) -> None:
    path = tmp_path / "map.mcap"
    path.write_bytes(b"keep")
    with pytest.raises(MarkersError, match="exists"):
        write_map_markers(small_map(), path)
    assert path.read_bytes() == b"keep"
    with pytest.raises(MarkersError, match="not a folder"):
        write_map_markers(small_map(), tmp_path / "none" / "map.mcap")
