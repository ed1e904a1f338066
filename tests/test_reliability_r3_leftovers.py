"""Leftovers of the round-3 reliability rerun (benchmarks/reliability_r3, issue 24): each test
reproduces one attempt of reliability-2026-11-r3.md that was still not a clear error or a right
answer after the N1-N14 fixes, and checks the clear error that replaces it."""
import pytest

import eomc
from eomc import mechanics as em
from eomc.errors import ModelError


def test_empty_system_is_refused_naming_the_missing_states(tmp_path, monkeypatch):
    # attempt 'System with no joints/bodies': it built a 0-state model whose simulate() then
    # failed with "bad argument (the model failed at t=nan ...)".
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    ground = em.RigidBody("ground")
    system = em.System.from_newtonian(ground)
    with pytest.raises(ModelError, match="no coordinates, speeds or states.*nothing to integrate"):
        eomc.compile(system, progress=False)
    assert not (tmp_path / "cache").exists() or not any((tmp_path / "cache").rglob("*.so"))
