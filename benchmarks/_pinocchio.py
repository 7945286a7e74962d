"""Pinocchio set-up shared by the benchmarks."""

from __future__ import annotations

from pathlib import Path
from typing import Any


def chain_model(pin: Any, path: Path, joint_names: tuple[str, ...]) -> Any:
    """Pinocchio model of the URDF with every joint off the chain (e.g. fingers) locked at neutral,
    so that Pinocchio computes exactly the chain we compare against."""
    full = pin.buildModelFromUrdf(str(path))
    locked = [full.getJointId(n) for n in full.names[1:] if n not in joint_names]
    return pin.buildReducedModel(full, locked, pin.neutral(full)) if locked else full
