"""Helpers of the ROS-layer tests: real ROS 2 message classes and CDR from rosbags, and our own srv
types parsed from srv/*.srv (fixture `ros` in conftest.py). No rclpy needed."""

from __future__ import annotations

import array
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]

_FLOATS = ("float32", "float64")
_INTS = (
    "int8",
    "int16",
    "int32",
    "int64",
    "uint8",
    "uint16",
    "uint32",
    "uint64",
    "byte",
    "char",
    "octet",
)
_NP_DTYPE = {
    "float32": np.float32,
    "float64": np.float64,
    "int8": np.int8,
    "int16": np.int16,
    "int32": np.int32,
    "int64": np.int64,
    "uint8": np.uint8,
    "uint16": np.uint16,
    "uint32": np.uint32,
    "uint64": np.uint64,
    "byte": np.uint8,
    "char": np.uint8,
    "octet": np.uint8,
    "bool": np.bool_,
}

_TYPECODE = {
    "float32": "f",
    "float64": "d",
    "int8": "b",
    "uint8": "B",
    "int16": "h",
    "uint16": "H",
    "int32": "i",
    "uint32": "I",
    "int64": "q",
    "uint64": "Q",
}


class RosTypes:
    """A rosbags typestore (ROS 2 Humble definitions) with our srv request/response types."""

    def __init__(self) -> None:
        rosbags_typesys = pytest.importorskip("rosbags.typesys", reason="rosbags not installed")
        self.store = rosbags_typesys.get_typestore(rosbags_typesys.Stores.ROS2_HUMBLE)
        self.srv_names: list[str] = []
        for path in sorted((ROOT / "srv").glob("*.srv")):
            request, response = path.read_text(encoding="utf-8").split("\n---\n")
            for suffix, text in (("Request", request), ("Response", response)):
                name = f"kinematics_service/srv/{path.stem}_{suffix}"
                parsed = rosbags_typesys.get_types_from_msg(text, name)
                self.store.register({name: next(iter(parsed.values()))})
                self.srv_names.append(name)
        from msg_adapters import MessageTypes

        self.types = MessageTypes.from_typestore(self.store)

    def cls(self, msgtype: str) -> Any:
        return self.store.types[msgtype]

    # ----------------------------------------------------------------- construction
    def new(self, msgtype: str, **fields: Any) -> Any:
        """A message with every field at its ROS default, overridden by `fields`."""
        _, fielddefs = self.store.fielddefs[msgtype]
        values = {name: self._default(desc) for name, desc in fielddefs}
        values.update(fields)
        return self.cls(msgtype)(**values)

    def _default(self, desc: Any) -> Any:
        kind, detail = desc
        kind = int(kind)
        if kind == 1:  # BASE
            t = detail[0]
            return (
                ""
                if t in ("string", "wstring")
                else False
                if t == "bool"
                else (0.0 if t in _FLOATS else 0)
            )
        if kind == 2:  # NAME
            return self.new(detail)
        sub, length = detail
        if int(sub[0]) == 1 and sub[1][0] not in ("string", "wstring"):
            if kind == 4 and sub[1][0] in _TYPECODE:  # rclpy's default for sequences
                return array.array(_TYPECODE[sub[1][0]])
            return np.zeros(length if kind == 3 else 0, dtype=_NP_DTYPE[sub[1][0]])
        if kind == 3:
            return [self._default(sub) for _ in range(length)]
        return []

    def request(self, srv: str, **fields: Any) -> Any:
        return self.new(f"kinematics_service/srv/{srv}_Request", **fields)

    def response(self, srv: str) -> Any:
        return self.new(f"kinematics_service/srv/{srv}_Response")

    # ----------------------------------------------------------------- checks
    def roundtrip(self, msg: Any) -> Any:
        """CDR-serialise and deserialise `msg` (rosbags wants numpy arrays for numeric sequences:
        lists and array('d') that rclpy wants are converted on a copy first)."""
        msgtype = msg.__msgtype__
        rosbags_msg = self._to_rosbags(msg, msgtype)
        return self.store.deserialize_cdr(self.store.serialize_cdr(rosbags_msg, msgtype), msgtype)

    def _to_rosbags(self, msg: Any, msgtype: str) -> Any:
        _, fielddefs = self.store.fielddefs[msgtype]
        values = {}
        for name, (kind, detail) in fielddefs:
            v = getattr(msg, name)
            kind = int(kind)
            if kind == 2:
                v = self._to_rosbags(v, detail)
            elif kind in (3, 4):
                sub = detail[0]
                if int(sub[0]) == 1 and sub[1][0] not in ("string", "wstring"):
                    v = np.asarray(v, dtype=_NP_DTYPE[sub[1][0]])
                elif int(sub[0]) == 2:
                    v = [self._to_rosbags(x, sub[1]) for x in v]
            values[name] = v
        return self.cls(msgtype)(**values)

    def _fields(self, msg: Any, path: str) -> Iterator[tuple[str, int, Any, Any]]:
        """(path, kind, detail, value) of each field of `msg` (kind: 1 base type, 2 message, 3
        array, 4 sequence, as rosbags numbers them)."""
        _, fielddefs = self.store.fielddefs[msg.__msgtype__]
        for name, (kind, detail) in fielddefs:
            yield f"{path}{name}", int(kind), detail, getattr(msg, name)

    def flatten(self, msg: Any, path: str = "") -> dict[str, Any]:
        """Every leaf value of `msg` by its path ("pose.position.x", "position[2]"), as plain
        Python values (numpy scalars and arrays, array('d') turned into floats and lists)."""
        out: dict[str, Any] = {}
        for where, kind, detail, v in self._fields(msg, path):
            if kind == 1:
                out[where] = v.item() if isinstance(v, np.generic) else v
            elif kind == 2:
                out.update(self.flatten(v, where + "."))
            else:
                for i, x in enumerate(v):
                    if int(detail[0][0]) == 2:
                        out.update(self.flatten(x, f"{where}[{i}]."))
                    else:
                        out[f"{where}[{i}]"] = x.item() if isinstance(x, np.generic) else x
        return out

    def rclpy_type_problems(self, msg: Any, path: str = "") -> list[str]:
        """Fields whose Python types rclpy's generated setters would reject: float fields must be
        `float` (not int, not numpy scalars), integer fields `int` (not bool), float64[] lists or
        array('d') of Python floats (never numpy arrays), strings `str`."""
        problems: list[str] = []
        for where, kind, detail, v in self._fields(msg, path):
            if kind == 1:
                problems += _base_problem(detail[0], v, where)
            elif kind == 2:
                problems += self.rclpy_type_problems(v, where + ".")
            else:
                sub = detail[0]
                if kind == 3 and isinstance(v, np.ndarray):
                    continue  # rclpy stores fixed-size arrays as numpy arrays
                if int(sub[0]) == 1 and sub[1][0] in _FLOATS:
                    ok = isinstance(v, list) or (
                        isinstance(v, array.array) and v.typecode == _TYPECODE[sub[1][0]]
                    )
                    if not ok:
                        problems.append(f"{where}: {type(v).__name__}, want list or array('d')")
                        continue
                if not isinstance(v, (list, array.array)):
                    problems.append(f"{where}: {type(v).__name__}, want list")
                    continue
                for i, x in enumerate(v):
                    if int(sub[0]) == 1:
                        problems += _base_problem(sub[1][0], x, f"{where}[{i}]")
                    elif int(sub[0]) == 2:
                        problems += self.rclpy_type_problems(x, f"{where}[{i}].")
        return problems


def _base_problem(t: str, v: Any, where: str) -> list[str]:
    if t in _FLOATS:
        ok = type(v) is float
    elif t == "bool":
        ok = type(v) is bool
    elif t in ("string", "wstring"):
        ok = type(v) is str
    else:
        ok = type(v) is int
    return [] if ok else [f"{where}: {type(v).__name__} {v!r} for a {t} field"]
