"""The command line as a new user meets it (issue 11): one-line errors, strict JSON, many
configurations per call, honest units and messages, help that documents every option."""

from __future__ import annotations

import io
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from kinematics_node.cli.main import main
from kinematics_node.sim.robots import load_robot

ROOT = Path(__file__).resolve().parents[2]


def run(capsys, *argv, stdin: str | None = None, monkeypatch=None):
    if stdin is not None:
        assert monkeypatch is not None
        monkeypatch.setattr(sys, "stdin", io.StringIO(stdin))
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def one_line_error(err: str) -> str:
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert err.startswith("kinematics")
    return err


def strict_loads(text: str):
    def refuse(name):
        raise ValueError(f"non-standard JSON constant {name}")

    return json.loads(text, parse_constant=refuse)


def test_json_is_strict_infinite_limits_are_null(capsys):
    code, out, _ = run(capsys, "info", "--robot", "planar3r", "--json")
    assert code == 0 and "Infinity" not in out
    data = strict_loads(out)
    chain = load_robot("planar3r")
    for joint, lo in zip(data["joints"], chain.lower, strict=True):
        assert joint["lower"] == (None if np.isinf(lo) else lo)


def test_infinite_figures_become_null():
    from kinematics_node.cli.main import dump_json

    assert dump_json({"condition_number": float("inf"), "w": [float("-inf"), 1.0]}, None) == (
        '{"condition_number": null, "w": [null, 1.0]}'
    )


def test_many_configurations_from_stdin_as_json_lines(capsys, monkeypatch):
    rng = np.random.default_rng(11)
    Q = rng.uniform(-2, 2, size=(5, 6))
    text = "# one per line\n" + "\n".join(" ".join(map(repr, q.tolist())) for q in Q) + "\n\n"
    code, out, _ = run(
        capsys,
        "fk",
        "--robot",
        "ur5e",
        "--q-file",
        "-",
        "--json",
        stdin=text,
        monkeypatch=monkeypatch,
    )
    assert code == 0
    lines = out.splitlines()
    assert len(lines) == 5
    chain = load_robot("ur5e")
    for line, q in zip(lines, Q, strict=True):
        np.testing.assert_allclose(strict_loads(line)["T"], chain.fk(q), atol=1e-15)


def test_many_configurations_from_a_file_bad_line_is_named(capsys, tmp_path):
    f = tmp_path / "q.txt"
    f.write_text("0,0,0\n0.1,0.2,0.3\n0,0\n")
    code, out, err = run(capsys, "jacobian", "--robot", "planar3r", "--q-file", str(f))
    assert code == 1 and out == ""
    assert "--q-file line 3: expected 3 values" in one_line_error(err)


def test_long_input_is_not_echoed(capsys):
    q = ",".join(["0"] * 20000 + ["nan"])
    code, _, err = run(capsys, "fk", "--robot", "ur5e", "--q", q)
    assert code == 1 and len(one_line_error(err)) < 200 and "value 20001" in err


@pytest.mark.parametrize(
    "argv, must, must_not",
    [
        (["info", "--robot", "ur5e", "--q", "0"], "unrecognized arguments: --q 0", "--q=0"),
        (
            ["ik", "--robot", "ur5e", "--target", "0,0,0,0,0,0,1", "--timeout", "-1"],
            "--timeout",
            "IKOptions",
        ),
        (
            ["ik", "--robot", "ur5e", "--target", "0,0,0,0,0,0,1", "--timeout", "nan"],
            "--timeout",
            "IKOptions",
        ),
        (
            ["ik", "--robot", "ur5e", "--target", "0,0,0,nan,0,0,1"],
            "value 4 is 'nan'",
            "np.float64",
        ),
        (["fk", "--robot", "ur5e"], "--q --q-file is required", "Traceback"),
        (["ik", "--robot", "ur5e"], "arguments are required: --target", "Traceback"),
        (["demo", "--duration", "inf"], "--duration", "Traceback"),
        (["demo", "--duration", "0.001"], "gives 0 joint states", "IndexError"),
    ],
)
def test_errors_are_one_line_in_the_user_s_words(capsys, argv, must, must_not):
    code, _, err = run(capsys, *argv)
    assert code in (1, 2)
    assert must in one_line_error(err) and must_not not in err


def test_position_only_ik_says_orientation_is_free(capsys):
    target = "-0.5756,-0.3902,0.3512,0,0,0,1"
    code, out, _ = run(capsys, "ik", "--robot", "ur5e", "--target", target, "--position-only")
    assert code == 0 and "orientation free" in out and "orientation error" not in out
    code, out, _ = run(
        capsys, "ik", "--robot", "ur5e", "--target", target, "--position-only", "--json"
    )
    assert strict_loads(out)["orientation_error"] is None


def test_failure_line_says_it_once(capsys):
    code, out, err = run(
        capsys, "ik", "--robot", "ur5e", "--target", "5,0,0,0,0,0,1", "--timeout", "0.01"
    )
    assert code == 1 and "not solved" not in err
    line = one_line_error(err)
    assert line.count("no solution") == 1 and line.count("after") == 0
    # why (how far, how far it reaches), the best residual, and the time the answer took, not
    # the timeout (issue 22: "in 0.01 s" for a 1 ms answer)
    assert "5.000 m" in line and "reaches at most" in line and "residual " in line
    assert "0.01 s" not in line and " ms" in line


def test_quaternion_of_norm_two_is_normalised_zero_is_refused(capsys):
    chain = load_robot("ur5e")
    q = np.array([0.3, -1.1, 1.4, -0.6, 0.8, 0.2])
    T = chain.fk(q)
    from kinematics_node.core.rotations import quaternion_from_matrix

    quat = 2 * quaternion_from_matrix(T[:3, :3])
    target = ",".join(repr(float(v)) for v in (*T[:3, 3], *quat))
    code, out, _ = run(
        capsys,
        "ik",
        "--robot",
        "ur5e",
        "--target",
        target,
        "--seed",
        "0.3,-1,1.3,-0.5,0.7,0.1",
        "--json",
    )
    assert code == 0
    np.testing.assert_allclose(chain.fk(np.array(strict_loads(out)["q"])), T, atol=1e-4)
    code, _, err = run(capsys, "ik", "--robot", "ur5e", "--target", "0,0,0,0,0,0,0")
    assert code == 1 and "non-zero quaternion (it is normalised)" in one_line_error(err)


def test_units_of_the_figures_are_stated(capsys):
    code, out, _ = run(capsys, "jacobian", "--robot", "ur5e", "--q", "0.1,-1,1,0.2,0.5,0")
    assert code == 0
    assert "m³/rad³" in out and "mixes rad and m" in out
    code, out, _ = run(capsys, "jacobian", "--robot", "ur5e", "--q", "0.1,-1,1,0.2,0.5,0", "--json")
    assert strict_loads(out)["manipulability_linear_unit"] == "m³/rad³"


def test_help_documents_every_option_marks_required_and_shows_defaults(capsys):
    for command in ("info", "fk", "jacobian", "ik", "demo"):
        code, out, _ = run(capsys, command, "--help")
        assert code == 0 and "examples:" in out
        if command != "demo":
            assert "exactly one is required" in out
    _, out, _ = run(capsys, "jacobian", "--help")
    assert "--frame {world,space,body}" in out and "(default: world)" in out and "J_b" in out
    _, out, _ = run(capsys, "ik", "--help")
    assert "--mode {speed,distance}" in out and "closest to the seed" in out
    assert "(default: 0.05)" in out
    usage = " ".join(out.split("options:")[0].split())
    assert "--target X,Y,Z,QX,QY,QZ,QW" in usage and "[--target" not in usage  # required
    code, out, _ = run(capsys, "--version")
    assert code == 0 and out.startswith("kinematics ")


def test_demo_checks_the_picture_path_before_the_run(capsys, tmp_path):
    pytest.importorskip("matplotlib")
    for out, message in [
        (str(tmp_path / "missing" / "a.png"), "does not exist"),
        (str(tmp_path / "a.unknown"), "unknown picture format .unknown"),
    ]:
        code, stdout, err = run(capsys, "demo", "--duration", "0.1", "--out", out)
        assert code == 1 and stdout == "" and message in one_line_error(err)


def test_readme_cli_examples_run(capsys, monkeypatch, tmp_path):
    """Every `kinematics` line of the README's command-line section works as printed."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    section = readme.split("## Command line", 1)[1].split("\n## ", 1)[0]
    lines = [
        ln.split("#")[0].split()
        for ln in section.splitlines()
        if ln.startswith("kinematics ") and "demo" not in ln and "[" not in ln
    ]
    assert len(lines) >= 5
    monkeypatch.chdir(ROOT)
    for argv in lines:
        if "--urdf" in argv:
            argv[argv.index("--urdf") + 1] = str(ROOT / "config/robots/ur5e.urdf")
        if "--q-file" in argv and argv[argv.index("--q-file") + 1] == "-":
            monkeypatch.setattr(sys, "stdin", io.StringIO("0,0,0,0,0,0\n"))
        code, _, err = run(capsys, *argv[1:])
        assert code == 0, (argv, err)


def test_broken_pipe_is_quiet():
    """`kinematics ... --json | head` must not end in a BrokenPipeError traceback."""
    env = dict(os.environ)
    proc = subprocess.Popen(
        [sys.executable, "-m", "kinematics_node.cli", "info", "--robot", "panda", "--json"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=env,
    )
    assert proc.stdout is not None and proc.stderr is not None
    proc.stdout.close()  # the reader is gone before the first write
    err = proc.stderr.read().decode()
    proc.wait(timeout=60)
    assert "Traceback" not in err and "BrokenPipe" not in err and err == ""


# ---- found by an adversarial hunt: each printed a traceback or quietly ignored an option


@pytest.mark.parametrize(
    ("extra", "named"),
    [
        (["--position-only"], "--position-only"),
        (["--axis-tolerances", "inf,1,1,1,1,1"], "--axis-tolerances"),
        (["--method", "numeric"], "--method numeric"),
        (["--mode", "distance"], "--mode distance"),
    ],
)
def test_ik_all_refuses_the_options_it_would_ignore(capsys, extra, named):
    argv = ["ik", "--robot", "ur5e", "--target", "0.3,0.2,0.4,1,0,0,0", "--all", *extra]
    code, out, err = run(capsys, *argv)
    assert code == 2 and out == "" and f"does not combine with {named}" in err


def test_q_file_from_a_closed_stdin_is_one_line(capsys, monkeypatch):
    monkeypatch.setattr(sys, "stdin", None)  # what Python gives a process started with stdin closed
    code, _, err = run(capsys, "fk", "--robot", "ur5e", "--q-file", "-")
    assert code == 1 and "standard input is closed" in one_line_error(err)


def test_a_robot_name_too_long_for_a_file_name_is_an_unknown_robot(capsys):
    code, _, err = run(capsys, "info", "--robot", "x" * 300)
    assert code == 1 and "unknown robot" in one_line_error(err) and len(err) < 400


def test_interrupted_is_one_line_and_status_130(capsys, monkeypatch):
    def interrupted(args):
        raise KeyboardInterrupt

    monkeypatch.setattr("kinematics_node.cli.main.load_chain", interrupted)
    code, _, err = run(capsys, "info", "--robot", "ur5e")
    assert code == 130 and err == "kinematics: interrupted\n"


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs Linux's /dev/full")
def test_output_to_a_full_disk_is_one_line():
    with open("/dev/full", "w") as full:
        out = subprocess.run(
            [sys.executable, "-m", "kinematics_node.cli", "info", "--robot", "ur5e"],
            stdout=full,
            stderr=subprocess.PIPE,
            text=True,
            cwd=ROOT,
        )
    assert out.returncode == 1 and out.stderr == "kinematics: error: No space left on device\n"


def test_a_huge_but_finite_target_prints_no_numpy_warning():
    # (a subprocess: pytest would catch the warning before it reached stderr)
    argv = ["ik", "--robot", "ur5e", "--target", "1e200,0,0,0,0,0,1", "--position-only"]
    out = subprocess.run(
        [sys.executable, "-m", "kinematics_node.cli", *argv],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert out.returncode == 1 and out.stderr.startswith("kinematics: error: no solution")
    assert out.stderr.count("\n") == 1, out.stderr


def test_every_rotation_axis_free_reports_the_orientation_as_free(capsys):
    # the solver's 0 covers the bounded rotation components only: with none, "free", not "0 rad"
    bounds = "inf,inf,inf,1e-5,1e-5,1e-5"
    argv = [
        "ik",
        "--robot",
        "panda",
        "--target",
        "0.4,0.1,0.5,1,0,0,0",
        "--axis-tolerances",
        bounds,
    ]
    code, out, _ = run(capsys, *argv, "--json")
    data = json.loads(out)
    assert code == 0 and data["success"] and data["orientation_error"] is None
    code, out, _ = run(capsys, *argv)
    assert code == 0 and "orientation free" in out and "orientation error" not in out
