"""A seeded sample of the fuzz harness (harness.py), run in CI: every surface, every input a
valid answer or a clear refusal. The long run (≥ 10,000 inputs per surface) is
benchmarks/fuzz_long.py."""

from __future__ import annotations

import harness
import pytest

SAMPLE = {"urdf": 300, "dh": 400, "cli": 300, "joint_state": 300, "service": 300}


@pytest.mark.parametrize("surface", list(SAMPLE))
def test_invariant_holds_on_a_seeded_sample(surface):
    if surface in ("joint_state", "service"):
        pytest.importorskip("rosbags", reason="the message surfaces need rosbags ([test] extra)")
    report = harness.run(surface, SAMPLE[surface], seed=11)
    assert sum(report.counts.values()) == SAMPLE[surface]
    assert report.counts["ok"] > 0, "the sample never produced a valid input: generator broken?"
    assert report.violations == [], report.violations[0]
