"""Fuzz harness over the five input surfaces of issue 11.

Surfaces: URDF text (mutated real URDFs, other encodings), DH tables, CLI argument vectors,
JointState messages, and the three service requests (rosbags message types).

Invariant, for every input: a valid answer (every number in it finite), or a refusal — a
`KinematicsError` from the core, a one-line `kinematics` error from the CLI, `success = false`
with a message from a service (not "internal error") — never another exception, a non-finite
number in a result, or a hang (each input runs under a SIGALRM time bound). A refused URDF is a
`RobotDescriptionError` (or an `UnknownNameError` for the base or tip asked for) whose message is
ours, not a parser's exception passed on (`refusal_problem`: no bare `'name'`).

`element_mutations` makes every single-step mutation of a description (each attribute of each
element dropped or garbled, each element removed or emptied); `test_fuzz.py` checks that each is
loaded, or refused by a message that names the element (`names_element`).

`run(surface, n, seed)` returns the counts; `test_fuzz.py` runs a seeded sample in CI and
`benchmarks/fuzz_long.py` the long run.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
import re
import signal
import sys
import tempfile
import traceback
import xml.etree.ElementTree as ET
from collections import Counter
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from kinematics_node.core import (
    KinematicsError,
    RobotDescriptionError,
    SerialChain,
    UnknownNameError,
)

ROOT = Path(__file__).resolve().parents[2]
ROBOTS = ROOT / "config" / "robots"
TIME_BOUND = 5.0  # [s] per input; generous for a loaded 2-core machine (typical: milliseconds)


class Hang(BaseException):
    """Raised by the alarm: a BaseException, so that `except Exception` in the code under test
    cannot swallow it."""


class Violation(Exception):
    """The invariant does not hold for an input."""


@contextlib.contextmanager
def time_bound(seconds: float) -> Iterator[None]:
    def on_alarm(signum: int, frame: Any) -> None:
        raise Hang(f"no answer within {seconds} s")

    previous = signal.signal(signal.SIGALRM, on_alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


@dataclass
class Report:
    counts: Counter[str] = field(default_factory=Counter)
    violations: list[tuple[str, str]] = field(default_factory=list)  # (input, traceback)


def run(surface: str, n: int, seed: int) -> Report:
    """Draw `n` inputs of `surface` from `default_rng(seed)` and check each."""
    rng = np.random.default_rng(seed)
    gen, check = SURFACES[surface]()
    report = Report()
    for _ in range(n):
        item = gen(rng)
        try:
            with time_bound(TIME_BOUND):
                outcome = check(item)
            report.counts[outcome] += 1
        except (Violation, Hang, Exception) as exc:
            report.counts["violation"] += 1
            tb = "".join(traceback.format_exception(type(exc), exc, exc.__traceback__)[-6:])
            report.violations.append((_describe(item), tb))
    return report


def _describe(item: Any) -> str:
    text = repr(item)
    return text if len(text) < 2000 else text[:2000] + "…"


def _finite(values: Any, what: str) -> None:
    arr = np.asarray(values, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise Violation(f"non-finite number in {what}: {arr.ravel()[:12]}")


# ====================================================================== shared value pools
_BAD_NUMBERS = ["nan", "inf", "-inf", "1e308", "-1e308", "1e20", "-1", "0", "", "x", "1 2", "1e999"]


def _weird_float(rng: np.random.Generator) -> Any:
    pool: list[Any] = [
        math.nan,
        math.inf,
        -math.inf,
        1e308,
        -1e308,
        1e-308,
        0.0,
        -0.0,
        1e9,
        float(rng.normal()),
        float(rng.uniform(-4, 4)),
        "1.5",
        "abc",
        None,
        True,
        [1.0, 2.0],
        {"a": 1},
    ]
    return pool[rng.integers(len(pool))]


def _number_text(rng: np.random.Generator) -> str:
    if rng.random() < 0.5:
        return _BAD_NUMBERS[rng.integers(len(_BAD_NUMBERS))]
    return repr(float(rng.normal(scale=float(rng.choice([0.1, 1.0, 10.0, 1e6])))))


def _check_chain(chain: SerialChain, rng: np.random.Generator) -> None:
    """FK, Jacobians and a short IK of a chain that was accepted: every number finite."""
    _finite(chain.S, "S")
    _finite(chain.B, "B")
    _finite(chain.M, "M")
    lo = np.where(np.isfinite(chain.lower), chain.lower, -np.pi)
    hi = np.where(np.isfinite(chain.upper), chain.upper, np.pi)
    lo, hi = np.maximum(lo, -1e3), np.minimum(hi, 1e3)
    Q = rng.uniform(np.minimum(lo, hi), np.maximum(lo, hi), size=(3, chain.dof))
    for q in Q:
        _finite(chain.fk(q), "fk")
        for frame in ("space", "body", "world"):
            _finite(chain.jacobian(q, frame), f"jacobian {frame}")
    _finite(chain.fk(Q), "batched fk")
    _finite(chain.jacobian(Q, "world"), "batched jacobian")
    from kinematics_node.core import IKOptions

    res = chain.ik(chain.fk(Q[0]), options=IKOptions(timeout=0.002, rng_seed=0))
    _finite(res.q, "IK q")
    _finite([res.position_error, res.orientation_error], "IK errors")


# ====================================================================== 1. URDF text
#: A description using every element and attribute of the URDF specification (wiki.ros.org/urdf/XML).
EVERY_ELEMENT = Path(__file__).resolve().parent / "every_element.urdf"

#: Values an attribute is garbled to: empty, not a number, too few numbers, NaN, overflowing.
GARBLED = ("", "abc", "1 2", "nan", "1e999")

#: A parser's exception passed on instead of a message of ours: a bare key ('name'), Python's
#: wording of a failed conversion or index, or our last-resort wrapper of yourdfpy's errors.
_NOT_OURS = re.compile(
    r"""^'[^']*'$|:\s*'[^']*'$|KeyError|IndexError|TypeError|AttributeError|could not convert|"""
    r"""not subscriptable|has no attribute|out of range|out of bounds|could not broadcast|"""
    r"""URDF could not be parsed"""
)


def refusal_problem(exc: BaseException) -> str | None:
    """What is wrong with the refusal of a URDF, or None: it must be a `RobotDescriptionError` (an
    `UnknownNameError` for a base or tip link asked for) with a one-line message of ours."""
    message = str(exc)
    if not isinstance(exc, (RobotDescriptionError, UnknownNameError)):
        return f"refused with {type(exc).__name__}, not RobotDescriptionError: {message!r}"
    if "\n" in message:
        return f"multi-line error: {message!r}"
    if _NOT_OURS.search(message):
        return f"a parser's exception passed on, not a message naming the element: {message!r}"
    return None


@dataclass(frozen=True)
class Mutation:
    """One single-step change of a description: `text` (the changed URDF), `tag` of the element
    changed, `owner` (the name of the element or of the <link>/<joint>/<material> it sits in, as
    in the original), `change` (what was done) and `kind` ("attribute", "remove", "empty")."""

    text: str
    tag: str
    owner: str
    change: str
    kind: str


def element_mutations(text: str) -> Iterator[Mutation]:
    """Every single-step mutation of `text`: each attribute of each element dropped, then set to
    each of `GARBLED`; each element but the root removed; each element with children emptied."""
    original = ET.fromstring(text)
    parent = {child: el for el in original.iter() for child in el}

    def owner_of(el: ET.Element | None) -> str:
        while el is not None:
            if el.tag in ("robot", "link", "joint", "material", "transmission") and el.get("name"):
                return str(el.get("name"))
            el = parent.get(el)
        return ""

    for index, el in enumerate(original.iter()):
        owner = owner_of(el)
        for attr in el.attrib:
            for value in (None, *GARBLED):
                change = f"{attr} dropped" if value is None else f'{attr}="{value}"'
                yield Mutation(
                    _mutated(text, index, "attribute", attr, value), el.tag, owner, change,
                    "attribute",
                )  # fmt: skip
        if el is not original:
            yield Mutation(_mutated(text, index, "remove"), el.tag, owner, "removed", "remove")
            if len(el):
                yield Mutation(_mutated(text, index, "empty"), el.tag, owner, "emptied", "empty")


def _mutated(
    text: str, index: int, kind: str, attr: str | None = None, value: str | None = None
) -> str:
    """`text` with its `index`-th element (document order) changed: an attribute dropped (value
    None) or set, the element removed from its parent, or its children removed."""
    root = ET.fromstring(text)
    elements = list(root.iter())
    target = elements[index]
    if kind == "attribute" and attr is not None:
        if value is None:
            del target.attrib[attr]
        else:
            target.set(attr, value)
    elif kind == "remove":
        next(el for el in elements if target in list(el)).remove(target)
    else:
        for child in list(target):
            target.remove(child)
    return ET.tostring(root, encoding="unicode")


def names_element(message: str, mutation: Mutation) -> bool:
    """True if a refusal's `message` names the element `mutation` changed: its tag as ``<tag``, or
    the quoted name of the element or of the link or joint it sits in."""
    return f"<{mutation.tag}" in message or (
        bool(mutation.owner) and repr(mutation.owner) in message
    )


def _urdf_surface() -> tuple[Callable[[np.random.Generator], Any], Callable[[Any], str]]:
    bases = [p.read_text(encoding="utf-8") for p in (*sorted(ROBOTS.glob("*.urdf")), EVERY_ELEMENT)]
    number = re.compile(r'(?<=["\s])-?\d+(\.\d*)?(e-?\d+)?(?=["\s])')
    attribute = re.compile(r'\s[a-z_]+="[^"]*"')
    element = re.compile(
        r"<(link|joint|origin|axis|limit|mimic|parent|child)\b[^>]*?(/>|>.*?</\1>)", re.S
    )
    types = ["revolute", "continuous", "prismatic", "fixed", "floating", "planar", "hinge", ""]
    encodings = ["utf-8", "latin-1", "utf-16", "utf-8-sig", "cp1252", "utf-32"]

    def pick(pattern: re.Pattern[str], text: str, rng: np.random.Generator) -> re.Match[str] | None:
        found = list(pattern.finditer(text))
        return found[rng.integers(len(found))] if found else None

    def gen(rng: np.random.Generator) -> tuple[bytes, str | None, str | None]:
        text = bases[rng.integers(len(bases))]
        for _ in range(int(rng.integers(1, 4))):
            op = rng.integers(9)
            if op == 0 and (m := pick(number, text, rng)):
                text = text[: m.start()] + _number_text(rng) + text[m.end() :]
            elif op == 1 and (m := pick(attribute, text, rng)):
                text = text[: m.start()] + text[m.end() :]
            elif op == 2 and (m := pick(element, text, rng)):
                text = text[: m.end()] + m.group(0) + text[m.end() :]
            elif op == 3 and (m := pick(element, text, rng)):
                text = text[: m.start()] + text[m.end() :]
            elif op == 4:
                text = re.sub(r'type="\w*"', f'type="{rng.choice(types)}"', text, count=1)
            elif op == 5:  # (an earlier cut may have left nothing to cut)
                cut = int(rng.integers(len(text))) if text else 0
                text = text[:cut] if rng.random() < 0.5 else text[:cut] + "é\0\x01" + text[cut:]
            elif op == 6:
                text = text.replace("<robot", "<robt", 1).replace("</robot>", "</robt>")
            elif op == 7:  # a <robot> without a name
                text = re.sub(r'(<robot\b[^>]*?)\sname="[^"]*"', r"\1", text, count=1)
            elif op == 8 and (m := pick(attribute, text, rng)):  # any attribute garbled
                name = m.group(0).split("=")[0]
                garbled = f'{name}="{GARBLED[rng.integers(len(GARBLED))]}"'
                text = text[: m.start()] + garbled + text[m.end() :]
        enc = str(rng.choice(encodings))
        if enc not in ("utf-8", "utf-16", "utf-8-sig", "utf-32") and rng.random() < 0.7:
            text = re.sub(
                r"<\?xml[^>]*\?>", f'<?xml version="1.0" encoding="{enc}"?>', text, count=1
            )
        data = text.encode(enc, errors="replace")
        if rng.random() < 0.03:
            data = rng.bytes(int(rng.integers(1, 2000)))
        links = re.findall(r'<link name="([^"]*)"', text)
        base = str(rng.choice(links)) if links and rng.random() < 0.2 else None
        tip = str(rng.choice(links)) if links and rng.random() < 0.3 else None
        return data, base, tip

    def check(item: tuple[bytes, str | None, str | None]) -> str:
        data, base, tip = item
        try:
            chain = SerialChain.from_urdf(data, base, tip)
        except KinematicsError as exc:
            problem = refusal_problem(exc)
            if problem is not None:
                raise Violation(problem) from None
            return "refused"
        _check_chain(chain, np.random.default_rng(len(data)))
        return "ok"

    return gen, check


# ====================================================================== 2. DH tables
def _dh_surface() -> tuple[Callable[[np.random.Generator], Any], Callable[[Any], str]]:
    good = json.loads((ROBOTS / "scara_dh.json").read_text(encoding="utf-8"))["joints"]
    keys = ["a", "alpha", "d", "theta", "type", "name", "lower", "upper", "velocity"]

    def gen(rng: np.random.Generator) -> Any:
        r = rng.random()
        if r < 0.05:
            return [5, "joints", None, {}, [], {"joints": 3}, {"joints": "abc"}, 1.5][
                rng.integers(8)
            ]
        rows = []
        for _ in range(int(rng.integers(0, 8))):
            row = dict(good[rng.integers(len(good))])
            for _ in range(int(rng.integers(0, 3))):
                key = keys[rng.integers(len(keys))]
                if rng.random() < 0.3:
                    row.pop(key, None)
                elif key == "type":
                    row[key] = ["R", "P", "revolute", "prismatic", "X", 3, None][rng.integers(7)]
                elif key == "name":
                    row[key] = [f"j{rng.integers(3)}", "", 7, None, "x" * 300][rng.integers(5)]
                else:
                    row[key] = _weird_float(rng)
            rows.append(row if rng.random() > 0.02 else [1, 2, 3])
        if rng.random() < 0.5:
            return rows
        table: dict[str, Any] = {"joints": rows}
        for key in ("base", "tool"):
            if rng.random() < 0.3:
                table[key] = [
                    np.eye(4).tolist(),
                    np.diag([1.0, 1.0, 1.0, 2.0]).tolist(),
                    np.full((4, 4), math.nan).tolist(),
                    "eye",
                    [[1, 0], [0, 1]],
                    (np.eye(4) * -1 + np.diag([0, 0, 0, 2])).tolist(),
                ][rng.integers(6)]
        return table

    def check(table: Any) -> str:
        try:
            chain = SerialChain.from_dh(table)
        except KinematicsError as exc:
            if "\n" in str(exc):
                raise Violation(f"multi-line error: {exc!s}") from None
            return "refused"
        _check_chain(chain, np.random.default_rng(0))
        return "ok"

    return gen, check


# ====================================================================== 3. CLI argv
def _cli_surface() -> tuple[Callable[[np.random.Generator], Any], Callable[[Any], str]]:
    from kinematics_node.cli.main import main

    scratch = Path(tempfile.mkdtemp(prefix="kinematics_fuzz_"))
    os.environ.setdefault("KINEMATICS_CACHE_DIR", str(scratch / "cache"))
    (scratch / "binary.urdf").write_bytes(bytes(range(256)))
    (scratch / "bad.json").write_text('{"joints": [{"a": NaN}]')
    (scratch / "deep.json").write_text("[" * 100_000)
    robots = ["ur5e", "panda", "iiwa14", "scara", "planar3r", "r2d2", "", "../ur5e", "ur5e.urdf"]
    urdfs = [str(ROBOTS / "ur5e.urdf"), str(scratch / "binary.urdf"), str(scratch), "/nonexistent"]
    dhs = [str(ROBOTS / "scara_dh.json"), str(scratch / "bad.json"), str(scratch / "deep.json")]
    links = ["base_link", "tool0", "wrist_2_link", "panda_link0", "panda_hand_tcp", "nope", ""]

    def vector(rng: np.random.Generator, n: int) -> str:
        items = [
            _number_text(rng) if rng.random() < 0.15 else f"{rng.normal():.4g}" for _ in range(n)
        ]
        return str(rng.choice([",", " ", ";", ", "])).join(items)

    def gen(rng: np.random.Generator) -> tuple[list[str], str]:
        command = str(rng.choice(["info", "fk", "jacobian", "ik", "demo", "fk", "ik", "bogus", ""]))
        argv = [command] if command else []
        stdin = ""
        if command == "demo":
            argv += ["--duration", str(rng.choice(["0", "-1", "inf", "nan", "1e-9", "1e9", "x"]))]
            argv += ["--out", str(rng.choice(["/nonexistent/a.png", "a.unknown", "x"]))]
            return argv, stdin
        r = rng.random()
        if r < 0.6:
            argv += ["--robot", str(rng.choice(robots))]
        elif r < 0.75:
            argv += ["--urdf", str(rng.choice(urdfs))]
        elif r < 0.9:
            argv += ["--dh", str(rng.choice(dhs))]
        if rng.random() < 0.2:
            argv += [str(rng.choice(["--base", "--tip"])), str(rng.choice(links))]
        dof = int(rng.choice([3, 4, 6, 7, 0, 40]))
        if command in ("fk", "jacobian"):
            if rng.random() < 0.7:
                argv += ["--q", vector(rng, dof)]
            else:
                argv += ["--q-file", "-"]
                stdin = "\n".join(vector(rng, dof) for _ in range(int(rng.integers(0, 5))))
        if command == "jacobian" and rng.random() < 0.5:
            argv += ["--frame", str(rng.choice(["world", "space", "body", "tool", ""]))]
        if command == "ik":
            if rng.random() < 0.9:
                argv += ["--target", vector(rng, int(rng.choice([7, 7, 7, 6, 0])))]
            if rng.random() < 0.3:
                argv += ["--seed", vector(rng, dof)]
            argv += ["--timeout", str(rng.choice(["0.002", "0.005", "-1", "nan", "inf", "0", "x"]))]
            for opt in ("--position-tolerance", "--orientation-tolerance"):
                if rng.random() < 0.2:
                    argv += [opt, str(rng.choice(["1e-3", "-1", "nan", "0", "inf"]))]
            if rng.random() < 0.2:
                argv.append("--position-only")
            if rng.random() < 0.2:
                argv += ["--axis-tolerances", vector(rng, int(rng.choice([6, 6, 5])))]
            if rng.random() < 0.2:
                argv += ["--mode", str(rng.choice(["speed", "distance", "fast"]))]
        if rng.random() < 0.5:
            argv.append("--json")
        if rng.random() < 0.1:
            argv.insert(
                int(rng.integers(len(argv) + 1)), str(rng.choice(["--q", "-x", "--", "-1"]))
            )
        return argv, stdin

    def check(item: tuple[list[str], str]) -> str:
        argv, stdin = item
        out, err = io.StringIO(), io.StringIO()
        old_stdin = sys.stdin
        sys.stdin = io.StringIO(stdin)
        try:
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                try:
                    code = main(argv)
                except SystemExit as exc:  # main must return, never exit
                    raise Violation(f"SystemExit({exc.code}) escaped main") from None
        finally:
            sys.stdin = old_stdin
        stdout, stderr = out.getvalue(), err.getvalue()
        if "Traceback" in stderr:
            raise Violation(f"traceback: {stderr[-500:]}")
        if code == 0:
            if "--json" in argv and "--help" not in argv:
                docs = stdout.splitlines() if "--q-file" in argv else [stdout]
                for doc in docs:
                    data = json.loads(doc, parse_constant=_refuse_constant)
                    _finite(_numbers_in(data), "JSON output")
            return "ok"
        if code in (1, 2):
            if stderr.count("\n") != 1 or not stderr.startswith("kinematics"):
                raise Violation(f"exit {code} without a one-line error: {stderr!r}")
            return "refused"
        raise Violation(f"exit status {code}")

    return gen, check


def _refuse_constant(name: str) -> Any:
    raise Violation(f"non-standard JSON constant {name}")


def _numbers_in(data: Any) -> list[float]:
    if isinstance(data, bool) or data is None or isinstance(data, str):
        return []
    if isinstance(data, (int, float)):
        return [float(data)]
    if isinstance(data, dict):
        return [x for v in data.values() for x in _numbers_in(v)]
    return [x for v in data for x in _numbers_in(v)]


# ====================================================================== 4./5. ROS messages
class Messages:
    """rosbags message classes (ROS 2 Humble) plus our srv types, built like test/ros_testing.py does."""

    def __init__(self) -> None:
        from rosbags.typesys import Stores, get_types_from_msg, get_typestore

        from msg_adapters import MessageTypes

        self.store = get_typestore(Stores.ROS2_HUMBLE)
        for path in sorted((ROOT / "srv").glob("*.srv")):
            request, response = path.read_text(encoding="utf-8").split("\n---\n")
            for suffix, text in (("Request", request), ("Response", response)):
                name = f"kinematics_service/srv/{path.stem}_{suffix}"
                self.store.register({name: next(iter(get_types_from_msg(text, name).values()))})
        self.types = MessageTypes.from_typestore(self.store)

    def new(self, msgtype: str, **fields: Any) -> Any:
        _, defs = self.store.fielddefs[msgtype]
        values = {name: self._default(desc) for name, desc in defs}
        values.update(fields)
        return self.store.types[msgtype](**values)

    def _default(self, desc: Any) -> Any:
        kind, detail = int(desc[0]), desc[1]
        if kind == 1:
            t = detail[0]
            return (
                ""
                if t in ("string", "wstring")
                else False
                if t == "bool"
                else 0.0
                if "float" in t
                else 0
            )
        if kind == 2:
            return self.new(detail)
        sub, length = detail
        if int(sub[0]) == 1 and sub[1][0] not in ("string", "wstring"):
            return np.zeros(length if kind == 3 else 0)
        return [self._default(sub) for _ in range(length)] if kind == 3 else []


_UR5E_JOINTS = [
    "shoulder_pan_joint",
    "shoulder_lift_joint",
    "elbow_joint",
    "wrist_1_joint",
    "wrist_2_joint",
    "wrist_3_joint",
]
_UR5E_LINKS = ["base_link", "shoulder_link", "forearm_link", "wrist_3_link", "tool0", "flange"]


def _service() -> Any:
    from kinematics_node.service.kinematics import KinematicsService

    ros = Messages()

    def lookup(target: str, source: str) -> np.ndarray:
        if source == "camera":
            return np.eye(4)
        raise LookupError(f"no frame {source!r}")

    params = {
        "robot_description": (ROBOTS / "ur5e.urdf").read_text(encoding="utf-8"),
        "base_link": "base_link",
        "tip_link": "tool0",
    }
    return ros, KinematicsService(ros.types, params, lookup_transform=lookup, clock=lambda: 0.0)


def _joint_state(ros: Messages, rng: np.random.Generator) -> Any:
    names = list(_UR5E_JOINTS)
    r = rng.random()
    if r < 0.3:
        names = [str(n) for n in rng.permutation(names)[: rng.integers(0, 7)]]
    elif r < 0.4:
        names = names + [str(rng.choice(["gripper", "", "é", "x" * 500, names[0]]))]
    n = len(names) if rng.random() < 0.85 else int(rng.integers(0, 9))

    def values(k: int) -> Any:
        v = rng.uniform(-7, 7, size=k)
        for i in range(k):
            if rng.random() < 0.1:
                v[i] = [math.nan, math.inf, -math.inf, 1e308, -1e308, 1e300][rng.integers(6)]
        form = rng.integers(3)
        return v if form == 0 else v.tolist()

    velocity = (
        values(n if rng.random() < 0.7 else int(rng.integers(0, 9))) if rng.random() < 0.5 else []
    )
    sec = int(rng.choice([0, 1, 100, 2**31 - 1, -1, int(rng.integers(0, 10**6))]))
    nanosec = int(rng.choice([0, 500_000_000, 999_999_999, int(rng.integers(0, 10**9))]))
    return ros.new(
        "sensor_msgs/msg/JointState",
        header=ros.new(
            "std_msgs/msg/Header",
            stamp=ros.new("builtin_interfaces/msg/Time", sec=sec, nanosec=nanosec),
            frame_id=str(rng.choice(["", "base_link", "x"])),
        ),
        name=names,
        position=values(n),
        velocity=velocity,
    )


def _check_numbers(msg: Any, what: str) -> None:
    """Every float in a message (recursively) is finite."""
    if msg is None:
        return
    if isinstance(msg, float):
        _finite(msg, what)
        return
    if isinstance(msg, (list, tuple, np.ndarray)) or type(msg).__name__ == "array":
        for x in msg:
            _check_numbers(x, what)
        return
    if hasattr(msg, "__msgtype__"):
        for name in msg.__dataclass_fields__:
            _check_numbers(getattr(msg, name), f"{what}.{name}")
    elif isinstance(msg, (np.floating, np.integer)):
        _finite(msg, what)


def _joint_state_surface() -> tuple[Callable[[np.random.Generator], Any], Callable[[Any], str]]:
    ros, svc = _service()

    def gen(rng: np.random.Generator) -> list[Any]:
        return [_joint_state(ros, rng) for _ in range(int(rng.integers(1, 4)))]

    def check(msgs: list[Any]) -> str:
        outcome = "refused"
        for msg in msgs:
            out = svc.on_joint_state(msg)
            if out.problem is not None and not isinstance(out.problem, str):
                raise Violation(f"problem is {type(out.problem).__name__}")
            _check_numbers(out.pose, "ee_pose")
            _check_numbers(out.twist, "ee_twist")
            if out.pose is not None:
                outcome = "ok"
        return outcome

    return gen, check


def _request_surface() -> tuple[Callable[[np.random.Generator], Any], Callable[[Any], str]]:
    ros, svc = _service()
    svc.on_joint_state(
        ros.new(
            "sensor_msgs/msg/JointState",
            name=list(_UR5E_JOINTS),
            position=np.array([0.3, -1.1, 1.4, -0.6, 0.8, 0.2]),
        )
    )

    def pose(rng: np.random.Generator) -> Any:
        p = rng.uniform(-1, 1, 3)
        q = rng.normal(size=4)
        if rng.random() < 0.2:
            q = np.zeros(4) if rng.random() < 0.5 else q * 1e200
        for arr in (p, q):
            if rng.random() < 0.1:
                arr[rng.integers(len(arr))] = [math.nan, math.inf, 1e308][rng.integers(3)]
        return ros.new(
            "geometry_msgs/msg/Pose",
            position=ros.new("geometry_msgs/msg/Point", x=p[0], y=p[1], z=p[2]),
            orientation=ros.new("geometry_msgs/msg/Quaternion", x=q[0], y=q[1], z=q[2], w=q[3]),
        )

    def gen(rng: np.random.Generator) -> tuple[str, Any]:
        kind = str(rng.choice(["ComputeFK", "ComputeJacobian", "ComputeIK"]))
        tip = str(rng.choice(_UR5E_LINKS + ["", "nope", "base_link"]))
        if kind == "ComputeFK":
            return kind, ros.new(
                f"kinematics_service/srv/{kind}_Request",
                joint_state=_joint_state(ros, rng),
                tip_link=tip,
            )
        if kind == "ComputeJacobian":
            return kind, ros.new(
                f"kinematics_service/srv/{kind}_Request",
                joint_state=_joint_state(ros, rng),
                tip_link=tip,
                frame=str(rng.choice(["", "world", "body", "space", "tool"])),
            )

        def positive(rng: np.random.Generator) -> float:
            return float(rng.choice([0.0, 1e-3, 1e-5, -1.0, math.nan, math.inf, 1e-300]))

        bounds = rng.choice([0, 6, 6, 5])
        axis = [
            float(rng.choice([1e-3, 1e-4, math.inf, 0.0, -1.0, math.nan])) for _ in range(bounds)
        ]
        return kind, ros.new(
            f"kinematics_service/srv/{kind}_Request",
            target=ros.new(
                "geometry_msgs/msg/PoseStamped",
                header=ros.new(
                    "std_msgs/msg/Header",
                    frame_id=str(
                        rng.choice(["", "base_link", "/base_link", "tool0", "camera", "nowhere"])
                    ),
                ),
                pose=pose(rng),
            ),
            tip_link=tip,
            seed=_joint_state(ros, rng)
            if rng.random() < 0.5
            else ros.new("sensor_msgs/msg/JointState"),
            position_tolerance=positive(rng),
            orientation_tolerance=positive(rng),
            timeout=float(rng.choice([0.0, 0.002, 0.005, -1.0, math.nan, math.inf])),
            position_only=bool(rng.random() < 0.3),
            axis_tolerances=np.array(axis),
        )

    methods = {
        "ComputeFK": svc.compute_fk,
        "ComputeJacobian": svc.compute_jacobian,
        "ComputeIK": svc.compute_ik,
    }

    def check(item: tuple[str, Any]) -> str:
        kind, request = item
        response = methods[kind](request, ros.new(f"kinematics_service/srv/{kind}_Response"))
        if not isinstance(response.success, bool) or not isinstance(response.message, str):
            raise Violation("success/message of the wrong type")
        if response.message.startswith("internal error"):
            raise Violation(f"unexpected exception inside the service: {response.message}")
        _check_numbers(response, kind)
        return "ok" if response.success else "refused"

    return gen, check


SURFACES: dict[
    str, Callable[[], tuple[Callable[[np.random.Generator], Any], Callable[[Any], str]]]
] = {
    "urdf": _urdf_surface,
    "dh": _dh_surface,
    "cli": _cli_surface,
    "joint_state": _joint_state_surface,
    "service": _request_surface,
}
