"""`kinematics bag --plot`: the tool's path, and its speed and conditioning over time with the
episodes near a singularity marked, from a run's sampled series (`report.Findings`). Needs
matplotlib (the `demo` extra)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np


def draw(result: Any, path: Path) -> None:
    """Draw `result` (a `job.BagResult`) into the picture file `path`."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    findings = result.findings
    t_ns, p, speed, cond = findings.series_arrays()
    origin = findings.first_ns or 0
    t = (t_ns - origin) * 1e-9
    chain = result.chain
    fig = plt.figure(figsize=(12, 7), constrained_layout=True)
    grid = fig.add_gridspec(2, 2, width_ratios=(1, 1.3))
    ax3 = fig.add_subplot(grid[:, 0], projection="3d")
    if len(p):
        ax3.plot(p[:, 0], p[:, 1], p[:, 2], lw=1.0, color="tab:blue")
        ax3.scatter(*p[0], color="tab:green", label="start")
        ax3.scatter(*p[-1], color="tab:red", label="end")
        ax3.legend(loc="upper left")
    ax3.set_title(f"{chain.tip_link} in {chain.base_link} [m]")
    ax3.set_xlabel("x")
    ax3.set_ylabel("y")
    ax3.set_zlabel("z")
    ax_v = fig.add_subplot(grid[0, 1])
    ax_v.plot(t, speed, lw=0.8, color="tab:blue")
    ax_v.set_ylabel("tool speed [m/s]")
    ax_c = fig.add_subplot(grid[1, 1], sharex=ax_v)
    ax_c.semilogy(t, np.where(np.isfinite(cond), cond, np.nan), lw=0.8, color="tab:purple")
    ax_c.axhline(findings.singular_condition, color="tab:red", ls="--", lw=0.8)
    ax_c.set_ylabel("condition number of J")
    ax_c.set_xlabel("time [s]")
    for e in findings.episodes:
        for ax in (ax_v, ax_c):
            ax.axvspan(
                (e.start_ns - origin) * 1e-9,
                (e.end_ns - origin) * 1e-9,
                color="tab:red",
                alpha=0.15,
            )
    fig.suptitle(
        f"{result.output.name}: {len(findings.episodes)} episode(s) near a singularity (shaded)"
    )
    fig.savefig(path, dpi=110)
    plt.close(fig)
