"""Shared fixtures (helpers live in kin_testing.py, importable because pythonpath includes test/)."""

from __future__ import annotations

import pytest
from kin_testing import REAL_ARMS, erd_path


@pytest.fixture(params=REAL_ARMS, ids=[a[0] for a in REAL_ARMS])
def real_arm(request):
    """(SerialChain, path) for each real arm description."""
    from kinematics_node.core import SerialChain

    name, rel, base, tip = request.param
    path = erd_path(rel)
    return SerialChain.from_urdf(path, base, tip), path


@pytest.fixture(params=["vectorised", "per-target"])
def batch_path(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    """Run a batch test through both implementations of `ik_batch`, whatever the batch size."""
    from kinematics_node.core import ik as ik_module

    monkeypatch.setattr(
        ik_module, "SCALAR_BATCH_BELOW", 0 if request.param == "vectorised" else 10**9
    )
    return str(request.param)


@pytest.fixture(autouse=True)
def _private_chain_cache(tmp_path_factory, monkeypatch):
    """The CLI caches parsed URDFs in the user's cache directory; tests use their own."""
    monkeypatch.setenv("KINEMATICS_CACHE_DIR", str(tmp_path_factory.mktemp("chain_cache")))
