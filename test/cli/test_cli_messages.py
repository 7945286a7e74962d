"""The command line's messages name things as its user named them (issue 22): the options
(`--tip`, `--base`, `--all`, `--method`, `--mode`, `--timeout` ...), never the library's
parameters or API (`tip_link`, `chain.ik`, `IKOptions`, `max_restarts`), and they keep the
library's reason: which leaves there are, how far an unreachable target is and how far the arm
reaches, how long the answer took, why the closed form found nothing.

The CLI runs as a user runs it: `main` in this process (its stdout and stderr), and once as a
separate process. Robots: example-robot-data's Panda with its hand (several leaves), the bundled
ones, and small URDFs written here.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys

import numpy as np
import pytest
from kin_testing import erd_path, ur_hole_target

from kinematics_node.cli.main import cli_words, main
from kinematics_node.core import IKOptions, SerialChain
from kinematics_node.sim.robots import load_robot

# What the library calls things, which a command-line user never typed. A link that is *named*
# like one of them is quoted in messages ('base_link'), so these look for the bare words.
LIBRARY_WORDS = re.compile(
    r"(?<![\w'])(tip_link|base_link|q_seed|T_target|max_restarts|num_solutions|position_only)"
    r"(?![\w'])|IKOptions|chain\.|mode '|ik_all"
)


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def error_line(err: str) -> str:
    assert err.count("\n") == 1 and err.startswith("kinematics: error: "), err
    line = err[len("kinematics: error: ") :].strip()
    assert not LIBRARY_WORDS.search(line), f"library words in {line!r}"
    return line


@pytest.fixture
def panda_hand() -> str:
    """Panda with its hand: leaves panda_hand_tcp and the two fingers."""
    return str(erd_path("panda_description/urdf/panda.urdf"))


LINKS_NAMED_LIKE_PARAMETERS = """<robot name="named">
  <link name="base_link"/><link name="arm"/><link name="tip_link"/><link name="camera"/>
  <joint name="j1" type="revolute"><parent link="base_link"/><child link="arm"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="arm"/><child link="tip_link"/>
    <origin xyz="0.3 0 0"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <joint name="c" type="fixed"><parent link="arm"/><child link="camera"/></joint>
</robot>
"""


# =========================================================================== robot options
def test_several_leaves_name_the_tip_option_and_list_the_leaves(capsys, panda_hand):
    code, out, err = run(capsys, "info", "--urdf", panda_hand)
    line = error_line(err)
    assert code == 1 and out == ""
    assert "--tip" in line
    for leaf in ("panda_hand_tcp", "panda_leftfinger", "panda_rightfinger"):
        assert repr(leaf) in line  # the reason kept: which tips there are
    # and the option it names works
    code, out, _ = run(capsys, "info", "--urdf", panda_hand, "--tip", "panda_hand_tcp", "--json")
    assert code == 0 and json.loads(out)["tip_link"] == "panda_hand_tcp"


@pytest.mark.parametrize(
    ("options", "flag"),
    [
        (["--tip", "nope"], "--tip"),
        (["--base", "nope"], "--base"),
        (["--base", "panda_link0", "--tip", "nope"], "--tip"),
        (["--base", "nope", "--tip", "nope"], "--base"),  # the base is looked up first
    ],
)
def test_an_unknown_link_names_the_option_that_gave_it(capsys, panda_hand, options, flag):
    code, _, err = run(capsys, "fk", "--urdf", panda_hand, *options, "--q", "0")
    line = error_line(err)
    assert code == 1 and line.startswith(f"{flag}: unknown link 'nope'")
    assert "'panda_link0'" in line and "'panda_hand_tcp'" in line  # the valid names kept


def test_a_base_without_links_below_and_a_tip_not_below_name_the_options(capsys, panda_hand):
    code, _, err = run(capsys, "info", "--urdf", panda_hand, "--base", "panda_hand_tcp")
    line = error_line(err)
    assert code == 1 and "'panda_hand_tcp'" in line and "choose another --base" in line
    argv = ["info", "--urdf", panda_hand, "--base", "panda_link5", "--tip", "panda_link2"]
    code, _, err = run(capsys, *argv)
    line = error_line(err)
    assert code == 1 and "--tip 'panda_link2' is not below --base 'panda_link5'" in line


def test_links_named_like_the_library_s_parameters_keep_their_names(capsys, tmp_path):
    urdf = tmp_path / "named.urdf"
    urdf.write_text(LINKS_NAMED_LIKE_PARAMETERS)
    code, _, err = run(capsys, "info", "--urdf", str(urdf))  # leaves tip_link and camera
    line = error_line(err)
    assert code == 1 and "['tip_link', 'camera']" in line and "choose one with --tip" in line
    code, _, err = run(capsys, "info", "--urdf", str(urdf), "--base", "tip_link")
    line = error_line(err)
    assert code == 1 and "no link below 'tip_link'" in line and "choose another --base" in line
    code, out, _ = run(capsys, "info", "--urdf", str(urdf), "--tip", "tip_link", "--json")
    assert code == 0 and json.loads(out)["base_link"] == "base_link"


def test_the_message_names_the_option_in_a_separate_process(panda_hand):
    done = subprocess.run(
        [sys.executable, "-m", "kinematics_node.cli", "info", "--urdf", panda_hand],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 1 and done.stdout == ""
    line = error_line(done.stderr)
    assert "choose one with --tip" in line and "'panda_leftfinger'" in line


# =========================================================================== ik
def test_all_without_a_closed_form_names_the_options(capsys):
    code, _, err = run(capsys, "ik", "--robot", "planar3r", "--target", "0.5,0,0,0,0,0,1", "--all")
    line = error_line(err)
    assert code == 1 and "--all" in line and "numerically" in line
    assert "3 joints" in line  # the library's reason
    # and what it says to do works
    code, out, _ = run(capsys, "ik", "--robot", "planar3r", "--target", "0.5,0,0,0,0,0,1")
    assert code == 0 and out.startswith("solved")


def _time_in(line: str) -> float:
    """The one duration a message reports [s] ("in 0.92 ms", "after 20.1 ms", "in 1.20 s")."""
    found = re.findall(r"(?:in|after) ([0-9.]+) (ms|s)\b", line)
    assert len(found) == 1, line
    value, unit = found[0]
    return float(value) * (1e-3 if unit == "ms" else 1.0)


def test_an_unreachable_target_keeps_its_distance_and_reach_and_the_time_taken(capsys):
    chain = load_robot("ur5e")
    _, radius = chain.reach_sphere
    argv = ["ik", "--robot", "ur5e", "--target", "3,0,0,0,0,0,1", "--timeout", "5"]
    code, out, err = run(capsys, *argv, "--json")
    line = error_line(err)
    data = json.loads(out)
    assert code == 1 and not data["success"] and data["message"] == line
    assert line.count("no solution") == 1
    assert "3.000 m from the first joint" in line and f"reaches at most {radius:.3f} m" in line
    # the time it took (one descent from the seed), not the 5 s timeout
    took = _time_in(line)
    assert 0 < took <= data["time_ms"] / 1e3 * 1.01 + 1e-5 and took < 5
    assert f"residual {data['position_error']:.3g} m" in line
    # the same, as text
    code, out, err = run(capsys, *argv)
    line = error_line(err)
    assert code == 1 and out.startswith(line) and "3.000 m" in line


def test_all_on_an_unreachable_target_says_how_far(capsys):
    code, _, err = run(capsys, "ik", "--robot", "ur5e", "--target", "3,0,0,0,0,0,1", "--all")
    line = error_line(err)
    assert code == 1 and "unreachable" in line and "3.000 m" in line and "at most" in line


def test_a_search_that_runs_out_of_time_says_so_once_with_the_option(capsys):
    hole = ur_hole_target()  # inside the reach sphere, reached by no configuration
    target = ",".join(f"{x:g}" for x in (*hole[:3, 3], 0, 0, 0, 1))
    code, out, err = run(capsys, "ik", "--urdf", str(erd_path("ur_description/urdf/ur5_robot.urdf")),
                         "--tip", "tool0", "--target", target, "--timeout", "0.02", "--json")  # fmt: skip
    line = error_line(err)
    data = json.loads(out)
    assert code == 1 and line.count("no solution") == 1
    assert line.count("timeout") == 1 and "the --timeout of 20 ms ran out" in line
    took = _time_in(line)
    assert 0.02 <= took <= data["time_ms"] / 1e3 * 1.01 + 1e-5
    assert "restarts" in line  # how hard it tried, in words; the user never set max_restarts
    # the closed form's reason is kept too
    assert "closed form: unreachable: the wrist centre" in line


@pytest.mark.parametrize(
    ("robot", "extra", "named"),
    [
        ("planar3r", [], ["--method closed_form", "3 joints"]),
        ("panda", ["--mode", "distance"], ["--method closed_form", "--mode speed", "--all"]),
        ("ur5e", ["--position-only"], ["--method closed_form", "--position-only"]),
        (
            "ur5e",
            ["--axis-tolerances", "1e-3,1e-3,inf,1e-4,1e-4,1e-4"],
            ["--method closed_form", "--axis-tolerances"],
        ),
    ],
)
def test_closed_form_refusals_name_the_options(capsys, robot, extra, named):
    argv = ["ik", "--robot", robot, "--target", "0.3,0.2,0.4,1,0,0,0", "--method", "closed_form"]
    code, _, err = run(capsys, *argv, *extra)
    line = error_line(err)
    assert code == 1 and "does not apply" in line
    for words in named:
        assert words in line


def test_closed_form_finding_nothing_keeps_its_reason_and_time(capsys):
    argv = ["ik", "--robot", "panda", "--target", "0,0,0.3,1,0,0,0", "--method", "closed_form"]
    code, out, err = run(capsys, *argv, "--json")
    line = error_line(err)
    data = json.loads(out)
    assert code == 1 and "none lies within the joint limits" in line and "panda_joint7" in line
    assert 0 < _time_in(line) <= data["time_ms"] / 1e3 * 1.01 + 1e-5


def test_a_solved_target_reports_the_measured_time_in_fitting_units(capsys):
    code, out, _ = run(capsys, "ik", "--robot", "ur5e", "--target", "0.3,0.2,0.4,1,0,0,0", "--json")
    data = json.loads(out)
    assert code == 0 and data["success"]
    took = _time_in(data["message"])
    assert abs(took - data["time_ms"] / 1e3) <= 0.006 * took + 1e-5  # rounding to 3 figures
    assert data["message"].endswith(" ms")  # a sub-second answer in ms


# =========================================================================== the translation
@pytest.mark.parametrize(
    ("library", "cli"),
    [
        ("several leaf links below 'a': ['b', 'c']", "several leaf links below 'a': ['b', 'c']"),
        (
            "IKOptions.method='closed_form' does not apply: on a 7R arm it gives one solution in "
            "mode 'speed' (chain.ik_all sweeps the held joint for sets)",
            "--method closed_form does not apply: on a 7R arm it gives one solution with "
            "--mode speed (--all sweeps the held joint and gives sets)",
        ),
        (
            "no closed-form IK for chain 'a' → 'b': it has 3 joints; use chain.ik (numeric) instead",
            "no closed-form IK for chain 'a' → 'b': it has 3 joints; without --all, ik searches "
            "numerically",
        ),
        (
            "no solution: the 50 ms timeout ran out after 50.1 ms, 3 restarts",
            "no solution: the --timeout of 50 ms ran out after 50.1 ms, 3 restarts",
        ),
        (
            "no solution: max_restarts=100000 reached after 2.00 s",
            "no solution: gave up after 100000 restarts after 2.00 s",
        ),
        ("q_seed must have shape (6,)", "--seed must have shape (6,)"),
        ("first joint of 'base_link' → 'tool0'", "first joint of 'base_link' → 'tool0'"),
    ],
)
def test_library_words_become_the_options(library, cli):
    assert cli_words(library) == cli


def test_the_core_says_why_a_search_stopped_once_and_in_its_own_words():
    """The library's own messages, which the CLI passes on (no "timeout after 50.0 ms after
    50.1 ms", no "max_restarts=0 reached" that nobody set)."""
    chain = SerialChain.from_urdf(erd_path("ur_description/urdf/ur5_robot.urdf"), None, "tool0")
    res = chain.ik(ur_hole_target(), options=IKOptions(timeout=0.02, method="numeric"))
    assert not res.success and res.message.count("after") == 1
    assert res.message.startswith("no solution: the 20 ms timeout ran out after ")
    far = np.eye(4)
    far[:3, 3] = (3.0, 0.0, 0.0)
    res = chain.ik(far)
    assert not res.success and "max_restarts" not in res.message
    assert res.message.startswith("unreachable: the target is 3.0") and "best effort" in res.message
    res = chain.ik(ur_hole_target(), options=IKOptions(method="numeric", max_restarts=2))
    assert "max_restarts=2 reached" in res.message  # the library user's own setting, named


# =========================================================================== descriptions
def test_a_description_without_links_is_refused_in_one_line_for_what_it_lacks(capsys):
    """example-robot-data's ur3.urdf, an empty <robot> without a name: exit 1 and one line that
    says what is missing (it was yourdfpy's KeyError passed on: "URDF could not be parsed:
    'name'"), in this process and in a process of its own."""
    ur3 = str(erd_path("ur_description/urdf/ur3.urdf"))
    code, out, err = run(capsys, "info", "--urdf", ur3)
    assert code == 1 and out == ""
    assert error_line(err) == "the robot description has no <link>"
    done = subprocess.run(
        [sys.executable, "-m", "kinematics_node.cli", "info", "--urdf", ur3],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 1 and done.stdout == ""
    assert error_line(done.stderr) == "the robot description has no <link>"


def test_a_robot_without_a_name_is_loaded_and_the_note_printed_once(capsys, tmp_path):
    urdf = tmp_path / "nameless.urdf"
    urdf.write_text(LINKS_NAMED_LIKE_PARAMETERS.replace('<robot name="named">', "<robot>"))
    code, out, err = run(capsys, "info", "--urdf", str(urdf), "--tip", "tip_link")
    assert code == 0 and err == ""
    assert out.count("the <robot> element has no name attribute, which URDF requires") == 1
    code, out, _ = run(capsys, "info", "--urdf", str(urdf), "--tip", "tip_link", "--json")
    data = json.loads(out)
    assert code == 0 and data["notes"][0].startswith("the <robot> element has no name")


@pytest.mark.parametrize(
    "old, new, expected",
    [
        ('<origin xyz="0.3 0 0"/>', '<origin xyz="0.3 0"/>',
         'joint \'j2\': <origin xyz="0.3 0"> must hold 3 numbers, got 2'),
        ('<parent link="arm"/>', "", 'joint \'j2\' needs a <parent link="..."/> element'),
        ('<link name="camera"/>', "<link/>", "<link> number 4 has no name attribute"),
        ('lower="-1" upper="1" effort="1" velocity="1"/></joint>', 'lower="abc" upper="1"/></joint>',
         'joint \'j1\': <limit lower="abc"> must be a number'),
        ('<joint name="j2" type="revolute">', '<joint name="j2">',
         "joint 'j2' has no type attribute; expected one of revolute, continuous, prismatic, "
         "fixed, floating, planar"),
    ],
)  # fmt: skip
def test_a_malformed_element_is_refused_in_one_line_naming_it(capsys, tmp_path, old, new, expected):
    urdf = tmp_path / "malformed.urdf"
    assert old in LINKS_NAMED_LIKE_PARAMETERS
    urdf.write_text(LINKS_NAMED_LIKE_PARAMETERS.replace(old, new, 1))
    code, out, err = run(capsys, "info", "--urdf", str(urdf), "--tip", "tip_link")
    assert code == 1 and out == ""
    assert error_line(err) == expected
