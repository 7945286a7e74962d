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


def chain_setup(pin: Any, path: Path, chain: Any) -> tuple[Any, Any, int, list[int]]:
    """(model, data, frame id of the tip, index in q of each chain joint) for `chain`."""
    model = chain_model(pin, path, chain.joint_names)
    idx = [model.joints[model.getJointId(n)].idx_q for n in chain.joint_names]
    return model, model.createData(), model.getFrameId(chain.tip_link), idx
