"""A cache of parsed robot descriptions for the command line, so that start-up needs neither
yourdfpy (and trimesh, networkx, scipy.spatial below it) nor xacro once a file has been seen.

Entries are keyed by the SHA-256 of the file's bytes, the requested base and tip links and the
cache format, so an edited file is simply a new entry (never a stale one). They hold the parsed
`ChainSpec` as JSON (no pickle: nothing in the cache is executed). Descriptions that need xacro
are not cached, because their result also depends on the files they include.

An entry also keeps the chain's closed-form family once `ik` has detected it (`detect_family`;
detection solves sample targets: ~0.1 s for a general 6R arm, ~0.3 s for Baxter), tagged with a
fingerprint of the detection's source (`_detector_fingerprint`), so that code which detects
differently never takes an old answer.

Location: ``$KINEMATICS_CACHE_DIR``, else ``$XDG_CACHE_HOME/kinematics_service``, else
``~/.cache/kinematics_service``. ``KINEMATICS_CACHE_DIR=off`` (or empty) disables the cache.
A cache that cannot be read or written is ignored.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import tempfile
import weakref
from pathlib import Path
from typing import Any

import numpy as np

from ..core import SerialChain
from ..core.exceptions import InvalidInputError
from ..core.model import ChainSpec, JointModel

FORMAT = "kinematics-chain-cache-3"


def cache_directory() -> Path | None:
    """Where entries live, or None when the cache is disabled."""
    configured = os.environ.get("KINEMATICS_CACHE_DIR")
    if configured is not None:
        if configured.strip().lower() in ("", "0", "off", "no", "false"):
            return None
        return Path(configured)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "kinematics_service"


def chain_from_urdf_file(
    path: str | os.PathLike[str], base: str | None, tip: str | None
) -> SerialChain:
    """`SerialChain.from_urdf(path, base, tip)`, answered from the cache when the same bytes were
    parsed before with the same links. Raises what `from_urdf` raises."""
    directory = cache_directory()
    try:
        data = Path(path).read_bytes()
    except (OSError, ValueError):
        directory = None  # let from_urdf report the unreadable file in its words
        data = b""
    if directory is None or str(path).endswith(".xacro"):
        return SerialChain.from_urdf(path, base, tip)
    key = hashlib.sha256(json.dumps([FORMAT, base, tip]).encode() + b"\0" + data).hexdigest()
    entry = directory / f"{key}.json"
    try:
        payload = json.loads(entry.read_text("utf-8"))
        chain = SerialChain.from_spec(_spec_from_json(payload))
    except (OSError, ValueError, KeyError, TypeError, IndexError):
        pass  # no entry yet, or an unreadable one: parse and (re)write it
    else:
        _ENTRIES[chain] = (directory, entry, payload.get("family"))
        return chain
    from ..core.urdf import RobotDescription, decode_xml

    description = RobotDescription(path)  # errors name the file
    spec = description.chain_spec(base, tip)
    chain = SerialChain.from_spec(spec)
    if description.xml == decode_xml(data):  # no xacro expansion took place
        _write(directory, entry, _spec_to_json(spec))
        _ENTRIES[chain] = (directory, entry, None)
    return chain


#: The cache entry each chain came from (or was written to), and the family kept in it.
_ENTRIES: weakref.WeakKeyDictionary[SerialChain, tuple[Path, Path, Any]] = (
    weakref.WeakKeyDictionary()
)


def detect_family(chain: SerialChain) -> None:
    """Settle `chain`'s closed-form family before `ik` needs it: the one an earlier run of this
    code kept in the chain's cache entry, else detected now and kept there (a chain not from the
    cache: detected). Only `ik` calls this: the closed form imports SciPy, which `fk` need not."""
    from ..core.ik.closed_form import export_family, import_family

    place = _ENTRIES.get(chain)
    if place is None:
        export_family(chain)  # (detects it)
        return
    directory, entry, kept = place
    fingerprint = _detector_fingerprint()
    if isinstance(kept, dict) and kept.get("detector") == fingerprint:
        value = kept.get("value")
        try:
            import_family(chain, None if value is None else tuple(value))
            return
        except (InvalidInputError, TypeError):
            pass  # not a family of this chain: detect it
    value = export_family(chain)
    family = {"detector": fingerprint, "value": None if value is None else list(value)}
    try:
        payload = json.loads(entry.read_text("utf-8"))
    except (OSError, ValueError):
        return
    payload["family"] = family
    _write(directory, entry, payload)
    _ENTRIES[chain] = (directory, entry, family)


@functools.lru_cache(maxsize=1)
def _detector_fingerprint() -> str:
    """A hash of the closed-form package's source (detection and the solvers it confirms)."""
    root = Path(__file__).resolve().parents[1] / "core" / "closed_form"
    digest = hashlib.sha256()
    for source in sorted(root.glob("*.py")):
        digest.update(source.name.encode() + b"\0" + source.read_bytes())
    return digest.hexdigest()


def _write(directory: Path, entry: Path, payload: dict[str, Any]) -> None:
    try:
        directory.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=directory, suffix=".tmp")
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            json.dump(payload, fh)
        os.replace(tmp, entry)  # atomic: concurrent runs never see half an entry
    except OSError:
        pass


def _spec_to_json(spec: ChainSpec) -> dict[str, Any]:
    return {
        "format": FORMAT,
        "base_link": spec.base_link,
        "tip_link": spec.tip_link,
        "joints": [[j.name, j.prismatic, j.H.tolist(), j.lower, j.upper] for j in spec.joints],
        "M": spec.M.tolist(),
        "actuated_names": list(spec.actuated_names),
        "joint_types": list(spec.joint_types),
        "lower": spec.lower.tolist(),
        "upper": spec.upper.tolist(),
        "velocity_limit": spec.velocity_limit.tolist(),
        "G": spec.G.tolist(),
        "offset": spec.offset.tolist(),
        "links": [[name, T.tolist(), k] for name, T, k in spec.links],
        "leader_index": None if spec.leader_index is None else list(spec.leader_index),
        "notes": list(spec.notes),
    }


def _spec_from_json(d: dict[str, Any]) -> ChainSpec:
    if d["format"] != FORMAT:
        raise ValueError("other cache format")
    return ChainSpec(
        base_link=str(d["base_link"]),
        tip_link=str(d["tip_link"]),
        joints=[
            JointModel(str(n), bool(p), np.array(H, dtype=float), float(lo), float(up))
            for n, p, H, lo, up in d["joints"]
        ],
        M=np.array(d["M"], dtype=float),
        actuated_names=[str(n) for n in d["actuated_names"]],
        joint_types=[str(t) for t in d["joint_types"]],
        lower=np.array(d["lower"], dtype=float),
        upper=np.array(d["upper"], dtype=float),
        velocity_limit=np.array(d["velocity_limit"], dtype=float),
        G=np.array(d["G"], dtype=float),
        offset=np.array(d["offset"], dtype=float),
        links=[(str(n), np.array(T, dtype=float), int(k)) for n, T, k in d["links"]],
        leader_index=None
        if d["leader_index"] is None
        else tuple(int(i) for i in d["leader_index"]),
        notes=tuple(str(note) for note in d["notes"]),
    )
