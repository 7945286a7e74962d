"""A seeded sample of the fuzz harness (harness.py), run in CI: every surface, every input a
valid answer or a clear refusal. The long run (≥ 10,000 inputs per surface) is
benchmarks/fuzz_long.py."""

from __future__ import annotations

import harness
import numpy as np
import pytest

from kinematics_node.core import SerialChain

SAMPLE = {"urdf": 300, "dh": 400, "cli": 300, "joint_state": 300, "service": 300}


@pytest.mark.parametrize("surface", list(SAMPLE))
def test_invariant_holds_on_a_seeded_sample(surface):
    if surface in ("joint_state", "service"):
        pytest.importorskip("rosbags", reason="the message surfaces need rosbags ([test] extra)")
    report = harness.run(surface, SAMPLE[surface], seed=11)
    assert sum(report.counts.values()) == SAMPLE[surface]
    assert report.counts["ok"] > 0, "the sample never produced a valid input: generator broken?"
    assert report.violations == [], report.violations[0]


def test_every_single_mutation_of_every_element_loads_or_is_refused_naming_it():
    """Each attribute of each element of a description that uses every URDF element dropped or
    garbled, each element removed or emptied (harness.element_mutations, ~700 descriptions): each
    loads, or is refused with a RobotDescriptionError of ours, one line, that names the element
    (its tag or the name of its link or joint); an element removed may break the tree elsewhere,
    so only its message's form is checked. A chain that loads has finite FK."""
    text = harness.EVERY_ELEMENT.read_text(encoding="utf-8")
    counts = {"ok": 0, "refused": 0}
    problems = []
    for mutation in harness.element_mutations(text):
        where = f"<{mutation.tag}> of {mutation.owner!r}, {mutation.change}"
        try:
            chain = SerialChain.from_urdf(mutation.text)
        except Exception as exc:
            counts["refused"] += 1
            problem = harness.refusal_problem(exc)
            if problem is None and mutation.kind != "remove":
                if not harness.names_element(str(exc), mutation):
                    problem = f"does not name the element: {exc}"
            if problem is not None:
                problems.append(f"{where}: {problem}")
            continue
        counts["ok"] += 1
        assert np.all(np.isfinite(chain.fk(np.zeros(chain.dof)))), where
    assert counts["ok"] > 100 and counts["refused"] > 100, counts  # both outcomes exercised
    assert problems == [], f"{len(problems)} problems, e.g.\n" + "\n".join(problems[:12])
