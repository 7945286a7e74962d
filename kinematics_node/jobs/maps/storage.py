"""A reachability map's files: HDF5 in Reuleaux's layout (written chunk by chunk, resumable) and
`.npz`; `read_map` reads either back as a `ReachMap`.

HDF5 layout. Reuleaux's own (map_creator's `hdf5_dataset.cpp`, read by its RViz and base
placement plugins through the same class), matched type for type:

* ``/Spheres/sphere_dataset``: float64 (S, 4), one row per voxel with D > 0, in voxel order:
  x, y, z [m] and D = 100 · reached / K. Its attribute ``Resolution`` is float32, shape (1,).
  x, y, z are the float32 values of the centres, widened: Reuleaux's reader pairs each pose row
  (float32) with its sphere by exact equality of the coordinates.
* ``/Poses/poses_dataset``: float32 (P, 10), chunked, extendible: one row per reachable
  orientation, voxel-major: the voxel centre x, y, z, then the tool pose x, y, z, qx, qy, qz, qw
  (the pose that was solved: the tool at the centre, z axis along the approach direction).

Ours, in ``/KinematicsService`` (attributes: format, robot, base_link, tip_link, urdf_sha256,
resolution, directions, rolls, requested_method, tolerance, chunk_voxels, and method once a
chunk is in): ``centres`` (M, 3) float64, ``indices`` (M, 3) int64 (centre = index ·
resolution), ``rotations`` (K, 3, 3) and ``quaternions`` (K, 4; x, y, z, w with w ≥ 0) float64,
``reached`` (M, K) bool, ``solutions`` (M, K) int32, ``manipulability`` (M, K) float64, and
``chunk_done`` (C,) uint8: chunk c (voxels c · chunk_voxels onwards) is in. Its datasets are
allocated whole when the file is made, so writing a chunk only fills bytes in place; a chunk is
marked done after its data is written and flushed, so a file cut off at any point holds only
whole chunks marked done.

The `.npz` holds the same arrays under the same names (``spheres``, ``poses`` for Reuleaux's,
``header`` as JSON text).
"""

from __future__ import annotations

import contextlib
import json
import os
from collections.abc import Iterator
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...core import KinematicsError
from ...core.so3 import quaternion_from_matrix
from .reach_map import ReachMap

INSTALL = "pip install 'kinematics_service[maps]'"
FORMAT = "kinematics_service reach map 1"
GROUP = "KinematicsService"
#: Voxels read back per step when assembling Reuleaux's datasets (bounded memory).
ASSEMBLY_VOXELS = 8192

FloatArray = NDArray[np.float64]


class MapFileError(KinematicsError):
    """A map file that cannot be made, resumed or read, said in one line."""


def h5py_module() -> ModuleType:
    """h5py, or a `MapFileError` naming the extra that installs it."""
    try:
        import h5py
    except ImportError:
        raise MapFileError(f"HDF5 maps (.h5) need h5py: {INSTALL} (or write .npz)") from None
    return h5py


@dataclass(frozen=True)
class MapHeader:
    """What a map was made of and with; two runs whose headers are equal make the same map."""

    robot: str
    base_link: str
    tip_link: str
    urdf_sha256: str
    resolution: float
    directions: int
    rolls: int
    requested_method: str
    tolerance: float
    chunk_voxels: int

    def differences(self, other: MapHeader) -> list[str]:
        """'name: ours (there: theirs)' for each field that differs."""
        return [
            f"{f.name} {getattr(self, f.name)!r} (the file has {getattr(other, f.name)!r})"
            for f in fields(self)
            if getattr(self, f.name) != getattr(other, f.name)
        ]

    @classmethod
    def from_attrs(cls, attrs: Any) -> MapHeader:
        kinds = {f.name: f.type for f in fields(cls)}
        values = {}
        for name, kind in kinds.items():
            value = attrs[name]
            value = value.item() if hasattr(value, "item") else value
            values[name] = {"float": float, "int": int}.get(str(kind), str)(value)
        return cls(**values)


def chunk_ranges(voxels: int, chunk_voxels: int) -> list[tuple[int, int]]:
    """[start, stop) of each chunk: voxels in order, `chunk_voxels` each (the last fewer)."""
    return [(a, min(a + chunk_voxels, voxels)) for a in range(0, voxels, chunk_voxels)]


def quaternions(rotations: FloatArray) -> FloatArray:
    """(K, 4) x, y, z, w (w ≥ 0) of (K, 3, 3) rotations."""
    return np.asarray(quaternion_from_matrix(rotations), dtype=np.float64)


def reuleaux_rows(
    centres: FloatArray, quats: FloatArray, reached: NDArray[np.bool_]
) -> tuple[FloatArray, NDArray[np.float32]]:
    """Reuleaux's rows of some voxels: spheres (S, 4) float64 of the voxels with D > 0 and
    poses (P, 10) float32 of every reached orientation, voxel-major (module docstring)."""
    K = reached.shape[1]
    count = reached.sum(axis=1)
    some = count > 0
    xyz = centres.astype(np.float32).astype(np.float64)
    spheres = np.column_stack([xyz[some], 100.0 * count[some] / K])
    m, k = np.nonzero(reached)
    poses = np.empty((m.size, 10), dtype=np.float32)
    poses[:, 0:3] = centres[m]
    poses[:, 3:6] = centres[m]
    poses[:, 6:10] = quats[k]
    return spheres, poses


class MapWriter:
    """An HDF5 map being built: made new, or opened to resume (`open`); chunks written as they
    come (`write_chunk`), then Reuleaux's datasets (`finish`)."""

    def __init__(self, file: Any, path: Path, header: MapHeader, chunks: list[tuple[int, int]]):
        self._file = file
        self.path = path
        self.header = header
        self.chunks = chunks
        self._ours = file[GROUP]
        self.done = np.asarray(self._ours["chunk_done"][...], dtype=bool)

    @classmethod
    def open(
        cls,
        path: Path,
        header: MapHeader,
        indices: NDArray[np.int64],
        rotations: FloatArray,
        force: bool = False,
    ) -> MapWriter:
        """The file at `path`: resumed if it holds a map with this header (its done chunks
        kept), made new if absent (or with `force`).

        Raises:
            MapFileError: h5py missing; the file holds something else or a map made otherwise
                (without `force`); it cannot be read or written.
        """
        h5py = h5py_module()
        chunks = chunk_ranges(len(indices), header.chunk_voxels)
        if path.exists() and not force:
            try:
                file = h5py.File(path, "r+")
            except OSError as exc:
                raise MapFileError(f"{path}: cannot open it to resume: {_why(exc)}") from None
            try:
                cls._check_resumable(file, path, header, indices, rotations)
            except BaseException:
                file.close()
                raise
            return cls(file, path, header, chunks)
        try:
            file = h5py.File(path, "w")
        except OSError as exc:
            raise MapFileError(f"{path}: cannot write it: {_why(exc)}") from None
        try:
            cls._create(file, header, indices, rotations, len(chunks))
        except BaseException:
            file.close()
            path.unlink(missing_ok=True)
            raise
        return cls(file, path, header, chunks)

    @staticmethod
    def _check_resumable(
        file: Any, path: Path, header: MapHeader, indices: Any, rotations: FloatArray
    ) -> None:
        if GROUP not in file or file[GROUP].attrs.get("format") != FORMAT:
            raise MapFileError(
                f"{path} exists and is not a map of kinematics reach: give --force to replace it, "
                "or another --out"
            )
        there = MapHeader.from_attrs(file[GROUP].attrs)
        diff = header.differences(there)
        if diff:
            raise MapFileError(
                f"{path} was made with other settings: {'; '.join(diff)}. Give --force to start "
                "again, or another --out"
            )
        ours = file[GROUP]
        if (
            ours["indices"].shape != indices.shape
            or not np.array_equal(ours["indices"][...], indices)
            or not np.array_equal(ours["rotations"][...], rotations)
        ):
            raise MapFileError(
                f"{path} holds another grid or other orientations for the same settings (made "
                "by another version?): give --force to start again"
            )

    @staticmethod
    def _create(
        file: Any, header: MapHeader, indices: NDArray[np.int64], rotations: FloatArray, n: int
    ) -> None:
        h5py = h5py_module()
        M, K = len(indices), len(rotations)
        ours = file.create_group(GROUP)
        ours.attrs["format"] = FORMAT
        for key, value in asdict(header).items():
            ours.attrs[key] = value

        def early(name: str, shape: tuple[int, ...], dtype: Any) -> None:
            # every byte allocated now: a chunk's write later fills bytes and changes no metadata
            dcpl = h5py.h5p.create(h5py.h5p.DATASET_CREATE)
            dcpl.set_alloc_time(h5py.h5d.ALLOC_TIME_EARLY)
            ours.create_dataset(name, shape=shape, dtype=dtype, dcpl=dcpl)

        ours.create_dataset("centres", data=indices * header.resolution)
        ours.create_dataset("indices", data=indices)
        ours.create_dataset("rotations", data=rotations)
        ours.create_dataset("quaternions", data=quaternions(rotations))
        early("reached", (M, K), np.bool_)
        early("solutions", (M, K), np.int32)
        early("manipulability", (M, K), np.float64)
        early("chunk_done", (n,), np.uint8)
        file.flush()

    def write_chunk(
        self,
        chunk: int,
        reached: NDArray[np.bool_],
        solutions: NDArray[np.integer],
        manipulability: FloatArray,
        method: str,
    ) -> None:
        """Chunk `chunk`'s data, flushed, then its done mark, flushed."""
        start, stop = self.chunks[chunk]
        if reached.shape != (stop - start, self._ours["reached"].shape[1]):
            raise MapFileError(f"chunk {chunk}: shape {reached.shape} does not fit the map")
        known = self._ours.attrs.get("method")
        if known is not None and known != method:
            raise MapFileError(f"chunk {chunk} was solved by {method}, the others by {known}")
        ours = self._ours
        ours["reached"][start:stop] = reached
        ours["solutions"][start:stop] = solutions.astype(np.int32)
        ours["manipulability"][start:stop] = manipulability
        if known is None:
            ours.attrs["method"] = method
        self._file.flush()
        ours["chunk_done"][chunk] = 1
        self._file.flush()
        self.done[chunk] = True

    def finish(self) -> None:
        """Reuleaux's /Spheres and /Poses from the chunks (all must be done), in voxel blocks."""
        if not self.done.all():
            raise MapFileError(f"{self.path}: {int((~self.done).sum())} chunks are missing")
        ours = self._ours
        reached_ds, centres_ds = ours["reached"], ours["centres"]
        quats = ours["quaternions"][...]
        M = reached_ds.shape[0]
        total = 0
        for a in range(0, M, ASSEMBLY_VOXELS):
            total += int(np.count_nonzero(reached_ds[a : a + ASSEMBLY_VOXELS]))
        for name in ("Spheres", "Poses"):
            if name in self._file:
                del self._file[name]
        spheres_parts = []
        poses = self._file.create_group("Poses").create_dataset(
            "poses_dataset",
            shape=(total, 10),
            maxshape=(None, 10),
            chunks=(max(1, min(total, 65536)), 10),
            dtype=np.float32,
        )
        row = 0
        for a in range(0, M, ASSEMBLY_VOXELS):
            block = slice(a, min(a + ASSEMBLY_VOXELS, M))
            s, p = reuleaux_rows(centres_ds[block], quats, reached_ds[block])
            spheres_parts.append(s)
            poses[row : row + len(p)] = p
            row += len(p)
        spheres = np.concatenate(spheres_parts) if spheres_parts else np.zeros((0, 4))
        sphere_ds = self._file.create_group("Spheres").create_dataset(
            "sphere_dataset", data=spheres.astype(np.float64)
        )
        sphere_ds.attrs.create("Resolution", np.array([self.header.resolution], dtype=np.float32))
        self._file.flush()

    def read(self) -> ReachMap:
        """The map in this file (every chunk done)."""
        return _from_h5(self._file, self.path)

    def close(self) -> None:
        self._file.close()

    def __enter__(self) -> MapWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def stored_chunk_voxels(path: Path) -> int | None:
    """The chunk size an existing MAP.h5 was made with; None where there is no such map to read
    (no h5py, not HDF5, not ours)."""
    try:
        import h5py

        with h5py.File(path, "r") as file:
            return int(file[GROUP].attrs["chunk_voxels"])
    except (ImportError, OSError, KeyError, ValueError, TypeError):
        return None


def read_map(path: str | os.PathLike[str]) -> ReachMap:
    """The map of a `.h5` (made by `kinematics reach`) or `.npz` file.

    Raises:
        MapFileError: unreadable, not a map of ours, or unfinished (chunks missing).
    """
    p = Path(path)
    if p.suffix.lower() == ".npz":
        try:
            with np.load(p, allow_pickle=False) as data:
                return _from_arrays({k: data[k] for k in data.files}, p)
        except (OSError, ValueError, KeyError) as exc:
            raise MapFileError(f"{p}: not a readable map: {_why(exc)}") from None
    h5py = h5py_module()
    try:
        with h5py.File(p, "r") as file:
            return _from_h5(file, p)
    except OSError as exc:
        raise MapFileError(f"{p}: cannot read it: {_why(exc)}") from None


def _from_h5(file: Any, path: Path) -> ReachMap:
    if GROUP not in file or file[GROUP].attrs.get("format") != FORMAT:
        raise MapFileError(f"{path} is not a map of kinematics reach (no /{GROUP})")
    ours = file[GROUP]
    done = ours["chunk_done"][...]
    if not done.all():
        raise MapFileError(
            f"{path} is unfinished: {int(done.sum())} of {done.size} chunks; run the same "
            "kinematics reach command again to finish it"
        )
    arrays = {name: ours[name][...] for name in _ARRAYS}
    arrays["header"] = np.array(json.dumps(_attrs(ours.attrs)))
    return _from_arrays(arrays, path)


_ARRAYS = ("centres", "indices", "rotations", "reached", "solutions", "manipulability")


def _attrs(attrs: Any) -> dict[str, Any]:
    out = {}
    for key, value in attrs.items():
        out[key] = value.item() if hasattr(value, "item") else value
    return out


def _from_arrays(arrays: dict[str, Any], path: Path) -> ReachMap:
    try:
        header = json.loads(str(arrays["header"]))
        if header.get("format") != FORMAT:
            raise MapFileError(f"{path} is not a map of kinematics reach")
        return ReachMap(
            robot=str(header["robot"]),
            base_link=str(header["base_link"]),
            tip_link=str(header["tip_link"]),
            resolution=float(header["resolution"]),
            directions=int(header["directions"]),
            rolls=int(header["rolls"]),
            centres=np.asarray(arrays["centres"], dtype=np.float64),
            rotations=np.asarray(arrays["rotations"], dtype=np.float64),
            reached=np.asarray(arrays["reached"], dtype=bool),
            solutions=np.asarray(arrays["solutions"], dtype=np.int64),
            manipulability=np.asarray(arrays["manipulability"], dtype=np.float64),
            method=str(header.get("method", header.get("requested_method"))),
        )
    except (KeyError, ValueError, TypeError) as exc:
        raise MapFileError(f"{path} is not a whole map: {_why(exc)}") from None


def write_npz(path: Path, reach_map: ReachMap, header: MapHeader) -> None:
    """The map as `.npz`: our arrays, Reuleaux's rows and the header (JSON), written to a
    temporary file first and renamed, so a file at `path` is always whole."""
    quats = quaternions(reach_map.rotations)
    poses = np.empty((int(np.count_nonzero(reach_map.reached)), 10), dtype=np.float32)
    parts, row = [], 0
    for a in range(0, len(reach_map.centres), ASSEMBLY_VOXELS):  # few temporaries at a time
        block = slice(a, a + ASSEMBLY_VOXELS)
        s, p = reuleaux_rows(reach_map.centres[block], quats, reach_map.reached[block])
        parts.append(s)
        poses[row : row + len(p)] = p
        row += len(p)
    spheres = np.concatenate(parts) if parts else np.zeros((0, 4))
    meta = {"format": FORMAT, **asdict(header), "method": reach_map.method}
    tmp = path.with_name(path.name + ".part.npz")
    try:
        with tmp.open("wb") as fh:
            np.savez(
                fh,
                header=np.array(json.dumps(meta)),
                centres=reach_map.centres,
                indices=np.rint(reach_map.centres / reach_map.resolution).astype(np.int64),
                rotations=reach_map.rotations,
                quaternions=quats,
                reached=reach_map.reached,
                solutions=reach_map.solutions.astype(np.int32),
                manipulability=reach_map.manipulability,
                spheres=spheres,
                poses=poses,
                resolution=np.array([reach_map.resolution], dtype=np.float32),
            )
        os.replace(tmp, path)
    finally:
        with contextlib.suppress(OSError):
            tmp.unlink()


def h5_datasets(path: Path) -> Iterator[tuple[str, Any, dict[str, Any]]]:
    """(name, value, attributes) of every dataset and group of an HDF5 file, in name order (to
    compare two maps in full)."""
    h5py = h5py_module()
    with h5py.File(path, "r") as file:
        names: list[str] = []
        file.visit(names.append)
        yield "/", None, _attrs(file.attrs)
        for name in sorted(names):
            item = file[name]
            value = item[...] if isinstance(item, h5py.Dataset) else None
            yield name, value, _attrs(item.attrs)


def _why(exc: BaseException) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__
