"""examples/identify_cartpole.py runs and recovers its parameters within their 95 % intervals.

The fit uses dx_dp from simulate(..., sensitivities=...) as least_squares'
Jacobian; the test also checks that Jacobian against central differences of
the residuals (so a wrong sensitivity would fail here, not just fit slowly).
"""
import importlib.util
from pathlib import Path

import numpy as np
import pytest

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "identify_cartpole.py"


@pytest.fixture(scope="module")
def example(tmp_path_factory):
    import os
    old = os.environ.get("EOMC_CACHE_DIR")
    os.environ["EOMC_CACHE_DIR"] = str(tmp_path_factory.mktemp("cache"))
    spec = importlib.util.spec_from_file_location("identify_cartpole", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    module.MODEL = module.build()
    yield module
    if old is None:
        del os.environ["EOMC_CACHE_DIR"]
    else:
        os.environ["EOMC_CACHE_DIR"] = old


def test_jacobian_is_the_residuals_derivative(example, monkeypatch):
    """At the initial guess, against central differences of runs at rtol 1e-13 (at the fit's
    1e-10 the differences themselves are off by ~10 %: the measurements are scaled by 1/sigma)."""
    monkeypatch.setattr(example, "TOL", 1e-13)
    problem = example.Problem(example.MODEL, [0.0, 0.2, 0.0, 0.0])
    theta = problem.theta(example.GUESS)
    J = problem.jacobian(theta)
    fd = np.empty_like(J)
    for k in range(theta.size):
        h = 1e-4 * max(1.0, abs(theta[k]))
        up, dn = theta.copy(), theta.copy()
        up[k] += h
        dn[k] -= h
        fd[:, k] = (problem.residuals(up) - problem.residuals(dn)) / (2 * h)
    assert np.max(np.abs(J - fd)) < 1e-5 * np.max(np.abs(fd))


def test_fit_recovers_parameters_within_intervals(example):
    problem = example.Problem(example.MODEL, [0.0, 0.2, 0.0, 0.0])
    sol, cov, _, sims = example.fit(problem, "sensitivities")
    assert sol.success
    rows = example.report(problem, sol, cov)
    for name, true, est, half, inside in rows:
        assert inside, (name, true, est, half)
        assert half < 0.05 * max(abs(true), 0.1), (name, half)       # the data determine it
    # noise-level residuals: cost ~ half the number of residuals
    assert sol.cost < 2 * problem.y.size
    assert sims < 40
