"""examples/identify_arm.py on a small version: the three-link arm of tests/helpers/small_arm.py
(30 inertial parameters), 1.5 s of excitation.

What is asserted, each against something independent of the fit:
- the identifiable combinations (regressor SVD over random states) are exactly what the
  trajectory excites (rank of the fit's Jacobian w.r.t. all 30), and the directions called
  unidentifiable change no torque at fresh random states;
- the forward-sensitivity Jacobian equals central differences of the residuals, and the
  adjoint gradient equals Jacobian' residuals;
- Levenberg-Marquardt from a start 30 % off recovers every base parameter to 1e-6 relative,
  leaves the unidentifiable part at the prior, and the consistent point found along the
  unidentifiable directions is physically consistent for every link with the same cost;
- Pinocchio's RNEA with the fitted parameters equals Pinocchio's with the true ones at
  fresh random states (the fitted robot has the true dynamics).
"""
import importlib.util
from pathlib import Path

import numpy as np
import pytest

from helpers.small_arm import small_arm

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "identify_arm.py"


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    spec = importlib.util.spec_from_file_location("identify_arm", EXAMPLE)
    ia = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(ia)
    directory = tmp_path_factory.mktemp("arm")
    path = small_arm(directory)
    ex = ia.Experiment(T=1.5, samples=200, q0=(0.0, -0.5, 1.0))
    return ia, path, ia.setup(path, ex, cache_dir=directory / "cache")


def test_identifiable_combinations_are_what_the_trajectory_excites(case):
    ia, _, (arm, ex, pi_true, pi_prior, data, ident, fit) = case
    assert len(pi_true) == 30
    rank, cond = ia.data_rank(fit)
    assert 10 < ident.rank < 30 and rank == ident.rank, (ident.rank, rank)
    assert ident.singular[ident.rank] < 1e-12 * ident.singular[0] < ident.singular[ident.rank - 1]
    rng = np.random.default_rng(7)
    for _ in range(10):
        Y = arm.model.regressor(rng.uniform(-3, 3, 3), rng.uniform(-3, 3, 3), rng.uniform(-3, 3, 3))
        YD = Y * ident.scale
        assert np.max(np.abs(YD @ ident.V_0)) < 1e-12 * np.max(np.abs(YD))


def test_sensitivities_and_adjoint_are_the_residuals_derivatives(case):
    _, _, (arm, ex, pi_true, pi_prior, data, ident, fit) = case
    z = np.random.default_rng(3).uniform(-0.05, 0.05, ident.rank)
    J, e = fit.jacobian(z), fit.residuals(z)
    fd = np.empty_like(J)
    # the q errors are weighted by 2/tau^2 = 5e5 at the first step: rounding in q (1e-16) makes
    # differences noisy at ~1e-10 / (2 h) absolute (2e-6 of J's largest entry at h = 1e-3); a
    # step in z of 1e-3 moves the scaled pi by at most 1e-3
    for k in range(z.size):
        h = np.zeros(z.size)
        h[k] = 1e-3
        fd[:, k] = (fit.residuals(z + h) - fit.residuals(z - h)) / 2e-3
    assert np.max(np.abs(J - fd)) < 3e-5 * np.max(np.abs(J)), np.max(np.abs(J - fd)) / np.max(np.abs(J))
    value, g = fit.cost_and_gradient(z)
    assert abs(value - 0.5 * e @ e) < 1e-12 * value
    assert np.max(np.abs(g - J.T @ e)) < 1e-9 * np.max(np.abs(g))


def test_fit_recovers_every_identifiable_combination(case):
    ia, path, (arm, ex, pi_true, pi_prior, data, ident, fit) = case
    start = ia.outcome(fit, pi_prior, pi_true)
    assert start.base_error > 0.05                                  # the start is really off
    pi, consistent, moved, _, sol = ia.identify(fit)
    end = ia.outcome(fit, pi, pi_true)
    assert end.base_error < 1e-6 and end.base_error_norm < 1e-6, (end.base_error, end.base_error_norm)
    assert end.null_shift < 1e-12                                     # the unidentifiable part: the prior's
    assert end.null_error > 0.05                                      # ... which is not the truth's
    assert end.cost < 1e-12 * start.cost
    fixed = ia.outcome(fit, consistent, pi_true)
    assert fixed.consistent == len(arm.bodies)
    assert all(row[-1] for row in ia.consistency(consistent, arm.bodies))
    assert fixed.base_error < 1e-6 and fixed.cost < 1e-12 * start.cost
    assert moved == 0.0 or fixed.null_shift == pytest.approx(moved, rel=1e-6)

    import pinocchio as pin
    pm = pin.buildModelFromUrdf(str(path))
    models = []
    for values in (pi_true, consistent):
        m = pin.Model(pm)
        for b, name in enumerate(("j1", "j2", "j3")):
            m.inertias[pm.getJointId(name)] = pin.Inertia.FromDynamicParameters(values[10 * b:10 * b + 10])
        models.append(m)
    rng = np.random.default_rng(11)
    for _ in range(10):
        q, v, a = rng.uniform(-3, 3, 3), rng.uniform(-3, 3, 3), rng.uniform(-3, 3, 3)
        ref, got = (pin.rnea(m, m.createData(), q, v, a).copy() for m in models)
        assert np.max(np.abs(got - ref)) < 1e-6 * np.max(np.abs(ref)), (got, ref)
