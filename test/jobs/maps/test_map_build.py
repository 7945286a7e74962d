"""`build_map` on a coarse UR5e map: the HDF5 file read back with h5py against Reuleaux's layout
(map_creator's hdf5_dataset.cpp: names, types, shapes, the Resolution attribute, and the exact
pairing of pose rows with spheres that its reader relies on), the quaternions against SciPy, the
chunked job against one `reach_voxels` call over the whole grid, `.npz` = `.h5`, and resume
after an interruption giving the same file."""

from __future__ import annotations

import numpy as np
import pytest
from maps_testing import SMALL, assert_same_file, ur5e

from kinematics_node.core.workspace import VoxelGrid, approach_rotations, reach_voxels
from kinematics_node.jobs.maps.build import MapInterrupted, build_map
from kinematics_node.jobs.maps.storage import MapFileError, read_map
from kinematics_node.jobs.tasks import TaskError

h5py = pytest.importorskip("h5py", reason="pip install 'kinematics_service[maps]'")


@pytest.fixture(scope="module")
def small_map(tmp_path_factory):
    out = tmp_path_factory.mktemp("map") / "ur5e.h5"
    run = build_map(ur5e(), out, processes=2, **SMALL)
    return out, run


def test_the_file_has_reuleaux_layout(small_map):
    out, run = small_map
    m = run.reach_map
    M, K = m.reached.shape
    with h5py.File(out, "r") as f:
        spheres_ds, poses_ds = f["/Spheres/sphere_dataset"], f["/Poses/poses_dataset"]
        # hdf5_dataset.cpp: H5T_NATIVE_DOUBLE (S, 4); H5T_NATIVE_FLOAT (P, 10), chunked,
        # extendible; the attribute Resolution H5T_NATIVE_FLOAT of dataspace (1,)
        assert spheres_ds.dtype == np.float64 and spheres_ds.shape[1] == 4
        assert poses_ds.dtype == np.float32 and poses_ds.shape[1] == 10
        assert poses_ds.chunks is not None and poses_ds.maxshape == (None, 10)
        resolution = spheres_ds.attrs["Resolution"]
        assert resolution.dtype == np.float32 and resolution.shape == (1,)
        assert resolution[0] == np.float32(SMALL["resolution"])
        spheres, poses = spheres_ds[...], poses_ds[...]
    D = 100.0 * m.reached.sum(axis=1) / K
    some = D > 0
    assert 0 < some.sum() < M  # a real map: some voxels reached, some not
    # only the voxels with D > 0 (create_reachability_map.cpp keeps only those), in voxel order
    assert len(spheres) == some.sum()
    assert np.array_equal(spheres[:, 3], D[some])
    assert np.array_equal(spheres[:, :3], m.centres[some].astype(np.float32).astype(np.float64))
    # one pose row per reached orientation
    assert len(poses) == m.reached.sum()
    # Reuleaux's reader pairs each pose row (read as double) with its sphere by exact equality
    keys = {tuple(row) for row in spheres[:, :3]}
    rows = [tuple(r) for r in poses[:, :3].astype(np.float64)]
    assert set(rows) <= keys
    counts: dict[tuple, int] = {}
    for r in rows:
        counts[r] = counts.get(r, 0) + 1
    for x, y, z, d in spheres:
        assert counts[(x, y, z)] == round(d * K / 100)
    # the tool pose: at the voxel centre, in the orientation solved
    assert np.array_equal(poses[:, 3:6], poses[:, 0:3])
    q = poses[:, 6:10].astype(np.float64)
    assert np.allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-6)
    from scipy.spatial.transform import Rotation

    _, k = np.nonzero(m.reached)
    assert np.allclose(Rotation.from_quat(q).as_matrix(), m.rotations[k], atol=1e-6)


def test_our_arrays_are_in_a_group_of_their_own(small_map):
    out, run = small_map
    with h5py.File(out, "r") as f:
        ours = f["KinematicsService"]
        assert ours.attrs["robot"] == "ur5e" and ours.attrs["tip_link"] == "tool0"
        assert ours.attrs["method"] == "closed_form"
        assert ours["chunk_done"][...].all() and ours["chunk_done"].shape == (26,)
        assert np.array_equal(ours["centres"][...], ours["indices"][...] * SMALL["resolution"])
        from scipy.spatial.transform import Rotation

        assert np.allclose(
            Rotation.from_quat(ours["quaternions"][...]).as_matrix(), ours["rotations"][...]
        )


def test_the_chunked_job_is_one_reach_voxels_call_over_the_grid(small_map):
    _, run = small_map
    chain = ur5e().chain()
    grid = VoxelGrid.around(chain, SMALL["resolution"])
    whole = reach_voxels(chain, grid.centres, approach_rotations(SMALL["directions"]))
    m = run.reach_map
    assert np.array_equal(m.centres, grid.centres)
    assert np.array_equal(m.reached, whole.reached)
    assert np.array_equal(m.solutions, whole.solutions)
    assert np.array_equal(m.manipulability, whole.manipulability)


def test_the_npz_beside_it_holds_the_same_map(small_map):
    out, run = small_map
    a, b = read_map(out), read_map(out.with_suffix(".npz"))
    for field in ("centres", "rotations", "reached", "solutions", "manipulability"):
        assert np.array_equal(getattr(a, field), getattr(b, field)), field
        assert np.array_equal(getattr(a, field), getattr(run.reach_map, field)), field
    assert (a.robot, a.resolution, a.directions, a.method) == (
        b.robot,
        b.resolution,
        b.directions,
        b.method,
    )
    with np.load(out.with_suffix(".npz")) as z, h5py.File(out, "r") as f:
        assert np.array_equal(z["spheres"], f["/Spheres/sphere_dataset"][...])
        assert np.array_equal(z["poses"], f["/Poses/poses_dataset"][...])


def test_an_interrupted_map_resumes_to_the_same_file(small_map, tmp_path):
    whole, _ = small_map
    out = tmp_path / "ur5e.h5"

    def interrupt_after_five(done: int, total: int) -> None:
        if done == 5:
            raise KeyboardInterrupt

    with pytest.raises(MapInterrupted, match=r"interrupted: 5 of 26 chunks kept in .*ur5e\.h5"):
        build_map(ur5e(), out, processes=2, progress=interrupt_after_five, **SMALL)
    with h5py.File(out, "r") as f:
        assert f["KinematicsService/chunk_done"][...].sum() == 5
    with pytest.raises(MapFileError, match="unfinished: 5 of 26 chunks"):
        read_map(out)
    seen = []
    run = build_map(ur5e(), out, processes=2, progress=lambda d, t: seen.append(d), **SMALL)
    assert run.kept == 5 and run.problems == (413 - 5 * 16) * 12
    assert seen == list(range(5, 27))  # each of the 21 others once
    assert_same_file(out, whole)


def test_a_file_made_otherwise_is_refused_unless_forced(small_map, tmp_path):
    whole, _ = small_map
    out = tmp_path / "ur5e.h5"
    out.write_bytes(whole.read_bytes())
    other = {**SMALL, "directions": 10}
    with pytest.raises(MapFileError, match=r"other settings: directions 10 \(the file has 12\)"):
        build_map(ur5e(), out, processes=1, **other)
    assert read_map(out).directions == 12  # untouched
    build_map(ur5e(), out, processes=2, force=True, **other)
    assert read_map(out).directions == 10
    (tmp_path / "notes.h5").write_bytes(b"not a map")
    with pytest.raises(MapFileError, match="notes.h5: cannot open it to resume"):
        build_map(ur5e(), tmp_path / "notes.h5", processes=1, **SMALL)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"resolution": 0.0}, "resolution must be a finite length > 0"),
        ({"resolution": float("nan")}, "resolution must be a finite length > 0"),
        ({"directions": 0}, "directions must be a whole number"),
        ({"chunk_voxels": 0}, "chunk_voxels must be a whole number"),
    ],
)
def test_bad_settings_are_one_line_and_leave_no_file(tmp_path, kwargs, message):
    out = tmp_path / "bad.h5"
    with pytest.raises(ValueError if "chunk" not in message else MapFileError, match=message):
        build_map(ur5e(), out, **{**SMALL, **kwargs})
    assert not out.exists()


def test_an_unreachable_scheduler_is_one_line_and_keeps_nothing_half_made(tmp_path):
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    pytest.importorskip("distributed", reason="pip install 'kinematics_service[dask]'")
    out = tmp_path / "m.h5"
    with pytest.raises(
        TaskError, match=f"cannot reach the Dask scheduler at tcp://127.0.0.1:{port}"
    ):
        build_map(ur5e(), out, scheduler=f"tcp://127.0.0.1:{port}", connect_timeout_s=1.0, **SMALL)
    with h5py.File(out, "r") as f:  # made, nothing counted: the same command resumes it
        assert f["KinematicsService/chunk_done"][...].sum() == 0


def test_pose_rows_pair_with_their_spheres_exactly_at_any_resolution():
    """Reuleaux's reader matches a pose row (float32, read as double) to its sphere by exact
    equality: at 5 cm most centres are not float32 numbers, so the spheres' must be widened."""
    from kinematics_node.jobs.maps.storage import quaternions, reuleaux_rows

    rng = np.random.default_rng(7)
    centres = rng.integers(-20, 21, size=(300, 3)) * 0.05
    rotations = np.asarray(approach_rotations(6))
    reached = rng.random((300, 6)) < 0.4
    spheres, poses = reuleaux_rows(centres, quaternions(rotations), reached)
    assert not np.array_equal(centres.astype(np.float32).astype(np.float64), centres)
    keys = {tuple(r) for r in spheres[:, :3]}
    assert {tuple(r) for r in poses[:, :3].astype(np.float64)} <= keys
    assert len(keys) == len(spheres) == reached.any(axis=1).sum()
