"""The long fuzz run of issue 11: N inputs per surface (default 10,000), counts per outcome.

    python benchmarks/fuzz_long.py [--n 10000] [--seed 1] [--surfaces urdf dh cli joint_state service]

Outcomes: ok (a valid answer, every number finite), refused (a KinematicsError, a one-line CLI
error or success = false with a message), violation (anything else; printed with its input).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "test" / "fuzz")]

import harness  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=10_000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--surfaces", nargs="+", default=list(harness.SURFACES))
    args = ap.parse_args()
    failed = 0
    print(f"{'surface':<12}{'inputs':>8}{'ok':>8}{'refused':>9}{'violations':>11}{'time [s]':>10}")
    for surface in args.surfaces:
        t0 = time.perf_counter()
        report = harness.run(surface, args.n, args.seed)
        c = report.counts
        print(
            f"{surface:<12}{sum(c.values()):>8}{c['ok']:>8}{c['refused']:>9}{c['violation']:>11}"
            f"{time.perf_counter() - t0:>10.1f}",
            flush=True,
        )
        for item, tb in report.violations[:5]:
            print(f"  input: {item[:500]}\n  {tb}")
        failed += c["violation"]
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
