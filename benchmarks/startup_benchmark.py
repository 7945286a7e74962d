"""Start-up of `kinematics fk --robot ur5e --q ...` side by side with `python -c "import numpy"`.

Runs each command as a fresh subprocess (as hyperfine does): a few warm-up runs, then `--runs`
timed runs; prints mean, median and min wall time and the ratio of the medians. Three rows:

* numpy:    python -c "import numpy"                (the yardstick)
* fk warm:  kinematics fk with the parsed URDF in the cache (every run after the first)
* fk cold:  the same with the cache off (KINEMATICS_CACHE_DIR=off): yourdfpy parses the URDF
* fk many:  --q-file with 1000 configurations (one call instead of 1000)

    python benchmarks/startup_benchmark.py [--runs 20]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time


def timed(
    cmd: list[str], env: dict[str, str], runs: int, warmup: int, stdin: bytes = b""
) -> list[float]:
    out = []
    for i in range(warmup + runs):
        t0 = time.perf_counter()
        subprocess.run(cmd, env=env, input=stdin, stdout=subprocess.DEVNULL, check=True)
        if i >= warmup:
            out.append(time.perf_counter() - t0)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--warmup", type=int, default=3)
    args = ap.parse_args()
    py = sys.executable
    fk = [py, "-m", "kinematics_node.cli", "fk", "--robot", "ur5e", "--q", "0.1,-1.2,1.4,0,0.5,0"]
    with tempfile.TemporaryDirectory() as cache:
        warm_env = dict(os.environ, KINEMATICS_CACHE_DIR=cache)
        cold_env = dict(os.environ, KINEMATICS_CACHE_DIR="off")
        many = "\n".join("0.1,-1.2,1.4,0,0.5,0" for _ in range(1000)).encode()
        rows = [
            ("numpy", timed([py, "-c", "import numpy"], warm_env, args.runs, args.warmup)),
            ("fk warm", timed(fk, warm_env, args.runs, args.warmup)),
            ("fk cold", timed(fk, cold_env, max(3, args.runs // 4), 1)),
            (
                "fk many (1000 q)",
                timed(
                    fk[:-2] + ["--q-file", "-", "--json"], warm_env, max(3, args.runs // 4), 1, many
                ),
            ),
        ]
    base = statistics.median(rows[0][1])
    print(
        f"{'command':<18}{'runs':>5}{'mean [s]':>10}{'median [s]':>12}{'min [s]':>9}{'× numpy':>9}"
    )
    for name, t in rows:
        med = statistics.median(t)
        print(
            f"{name:<18}{len(t):>5}{statistics.mean(t):>10.3f}{med:>12.3f}{min(t):>9.3f}"
            f"{med / base:>9.2f}"
        )
    print("goal: fk warm within 4 × numpy (issue 11)")


if __name__ == "__main__":
    main()
