"""eomc.gradient (runtime/adjoint.py, runtime/c/eomc_adjoint.c): the adjoint gradient of a
trajectory cost against central differences of whole simulations, both formulations."""
import warnings

import numpy as np
import pytest

import eomc
from eomc.runtime.adjoint import simulate_grid
from eomc.runtime.errors import ModelError
from helpers.trees import cart_joints

T, DT = 0.6, 0.01


@pytest.fixture(scope="module", params=["kane", "recursive"])
def model(request, tmp_path_factory):
    system, _ = cart_joints(2, rigid=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return eomc.compile(system, formulation=request.param, functions=["rhs", "jac_x", "vjp"],
                            cache_dir=tmp_path_factory.mktemp("cache"), progress=False)


def _cost(target, weights):
    """A running least-squares cost on every grid state plus a terminal cost on the last."""
    def cost(t, X):
        d = X - target
        G = weights * d
        G[-1] += np.sin(X[-1])
        return 0.5 * float(np.sum(weights * d * d)) - float(np.sum(np.cos(X[-1]))), G
    return cost


def test_gradient_matches_central_differences(model):
    rng = np.random.default_rng(2)
    x0 = rng.uniform(-0.5, 0.5, model.nx)
    p = np.asarray(model.param_defaults) * rng.uniform(0.8, 1.2, model.nparam)
    r = rng.uniform(-1, 1, model.ninput)
    t, target = simulate_grid(model, x0 * 0.5, T, dt=DT, p=p * 1.1, r=r)
    cost = _cost(target, rng.uniform(0.5, 2.0, target.shape))
    g = eomc.gradient(model, x0, T, dt=DT, cost=cost, p=p, r=r)
    assert np.isclose(g.value, cost(t, g.x)[0])

    def J(x, pp):
        return cost(*simulate_grid(model, x, T, dt=DT, p=pp, r=r))[0]
    h = 1e-6
    fx = np.array([(J(x0 + h * e, p) - J(x0 - h * e, p)) / (2 * h) for e in np.eye(model.nx)])
    fp = np.array([(J(x0, p + h * p[i] * e) - J(x0, p - h * p[i] * e)) / (2 * h * p[i])
                   for i, e in enumerate(np.eye(model.nparam))])
    assert np.max(np.abs(g.dx0 - fx)) <= 1e-6 * np.max(np.abs(fx))
    assert np.max(np.abs(g.dp - fp)) <= 1e-6 * np.max(np.abs(fp))
    assert set(g.dp_named()) == set(model.param_names)


def test_trajectory_is_simulates_rk4(model):
    """The trajectory differentiated is the one simulate(method='rk4', dt=) computes."""
    x0 = np.full(model.nx, 0.3)
    t, X = simulate_grid(model, x0, T, dt=DT)
    res = model.simulate(x0, (0.0, T), method="rk4", dt=DT, t_eval=t)
    assert np.max(np.abs(res.x - X)) < 1e-12


def test_clear_errors(model, tmp_path):
    x0 = np.zeros(model.nx)
    with pytest.raises(ValueError, match="whole number of steps"):
        eomc.gradient(model, x0, 0.105, dt=0.01, cost=lambda t, X: (0.0, X))
    with pytest.raises(ValueError, match="shaped as X"):
        eomc.gradient(model, x0, T, dt=DT, cost=lambda t, X: (0.0, X[:, :2]))
    system, _ = cart_joints(1, rigid=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        plain = eomc.compile(system, functions=["rhs"], cache_dir=tmp_path, progress=False)
    with pytest.raises(ModelError, match="built with 'vjp'"):
        eomc.gradient(plain, np.zeros(plain.nx), T, dt=DT, cost=lambda t, X: (0.0, X))


def test_stored_and_recomputed_stages_agree(model, monkeypatch):
    """The backward run with the forward run's stage states and with them recomputed
    (a long run past KEEP_STAGES_MAX) gives the same gradient."""
    from eomc.runtime import adjoint
    x0 = np.full(model.nx, 0.2)
    cost = lambda t, X: (float(np.sum(X[-1] ** 2)), np.vstack([np.zeros_like(X[:-1]), 2 * X[-1:]]))  # noqa: E731
    a = eomc.gradient(model, x0, T, dt=DT, cost=cost)
    monkeypatch.setattr(adjoint, "KEEP_STAGES_MAX", 0)
    b = eomc.gradient(model, x0, T, dt=DT, cost=cost)
    assert np.max(np.abs(a.dx0 - b.dx0)) <= 1e-13 * np.max(np.abs(a.dx0))
    assert np.max(np.abs(a.dp - b.dp)) <= 1e-13 * np.max(np.abs(a.dp))


def _gradient_against_differences(model, method, tol):
    """The adjoint gradient of a tracking cost from a random start, parameters and inputs,
    checked against simulate's trajectory and central differences of whole runs (x0 and every
    parameter, 1e-6 relative); returns (gradient, cost, x0, p, the runs' keywords)."""
    rng = np.random.default_rng(5)
    x0 = rng.uniform(-0.5, 0.5, model.nx)
    p = np.asarray(model.param_defaults) * rng.uniform(0.8, 1.2, model.nparam)
    r = rng.uniform(-1, 1, model.ninput)
    kw = dict(dt=0.05, r=r, method=method, rtol=tol, atol=tol)
    t, target = simulate_grid(model, x0 * 0.5, T, p=p * 1.1, **kw)
    cost = _cost(target, rng.uniform(0.5, 2.0, target.shape))
    g = eomc.gradient(model, x0, T, cost=cost, p=p, **kw)
    assert np.isclose(g.value, cost(t, g.x)[0])
    res = model.simulate(x0, (0.0, T), p=p, r=r, method=method, rtol=tol, atol=tol, t_eval=t)
    assert np.max(np.abs(res.x - g.x)) < 1e-8      # the same trajectory as simulate's (to tol)

    def J(x, pp):
        return cost(*simulate_grid(model, x, T, p=pp, **kw))[0]
    h = 1e-5
    fx = np.array([(J(x0 + h * e, p) - J(x0 - h * e, p)) / (2 * h) for e in np.eye(model.nx)])
    fp = np.array([(J(x0, p + h * p[i] * e) - J(x0, p - h * p[i] * e)) / (2 * h * p[i])
                   for i, e in enumerate(np.eye(model.nparam))])
    assert np.max(np.abs(g.dx0 - fx)) <= 1e-6 * np.max(np.abs(fx))
    assert np.max(np.abs(g.dp - fp)) <= 1e-6 * np.max(np.abs(fp))
    return g, cost, x0, p, kw


@pytest.mark.parametrize("tol", [1e-10])
def test_dop853_gradient_matches_central_differences(model, tol):
    """method='dop853': the discrete adjoint over the adaptive run's accepted steps (ending on
    the grid) against central differences of whole adaptive runs, x0 and every parameter."""
    _gradient_against_differences(model, "dop853", tol)


def test_dop853_recorded_and_recomputed_stages_agree(model, monkeypatch):
    """method='dop853': the backward run over the forward run's recorded stage derivatives
    (no rhs call) and over stages recomputed from the checkpoints (past KEEP_STAGES_MAX) pulls
    back through the same stage points: the same gradient, bit for bit."""
    from eomc.runtime import adjoint
    x0 = np.full(model.nx, 0.2)
    cost = lambda t, X: (float(np.sum(X[-1] ** 2)), np.vstack([np.zeros_like(X[:-1]), 2 * X[-1:]]))  # noqa: E731
    kw = dict(dt=0.05, method="dop853", rtol=1e-8, atol=1e-8)
    a = eomc.gradient(model, x0, T, cost=cost, **kw)
    monkeypatch.setattr(adjoint, "KEEP_STAGES_MAX", 0)
    b = eomc.gradient(model, x0, T, cost=cost, **kw)
    assert np.any(a.dp != 0.0)
    assert np.array_equal(a.dx0, b.dx0) and np.array_equal(a.dp, b.dp)


def test_radau_gradient_matches_central_differences(model, tmp_path):
    """method='radau': the discrete adjoint of the Radau IIA steps (the transposed collocation
    system with jac_x at the stage points, vjp for the pull-back) against central differences
    of whole Radau runs (steps ending on the grid), x0 and every parameter; and against the
    DOP853 adjoint (both within tol of the exact gradient)."""
    g, cost, x0, p, kw = _gradient_against_differences(model, "radau", 1e-10)
    d = eomc.gradient(model, x0, T, cost=cost, p=p, **dict(kw, method="dop853"))
    assert np.max(np.abs(g.dp - d.dp)) <= 1e-8 * np.max(np.abs(d.dp))
    system, _ = cart_joints(1, rigid=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        no_jac = eomc.compile(system, functions=["rhs", "vjp"], cache_dir=tmp_path, progress=False)
    with pytest.raises(ModelError, match="'jac_x'"):
        eomc.gradient(no_jac, np.zeros(no_jac.nx), T, dt=0.05, cost=lambda t, X: (0.0, X),
                      method="radau")


@pytest.mark.parametrize("tol", [1e-10, 1e-4])
def test_radau_iterative_solve_agrees_with_the_dense_one(model, monkeypatch, tol):
    """method='radau': each step's transposed collocation system solved by the preconditioned
    iteration (one Jacobian for all stages, kept over steps; its residuals are the step's vjp
    calls) and by the dense 3nx LU with the three stage Jacobians (RADAU_DENSE): the same
    gradient to 1e-9, the first with a Jacobian only now and then and three vjp calls an
    iteration (and at most one more round a step: the parameter part is computed only in the
    iteration expected to be the last).  tol 1e-4 takes long steps, where the kept Jacobian is furthest off."""
    from eomc.runtime import adjoint
    rng = np.random.default_rng(11)
    x0 = rng.uniform(-0.5, 0.5, model.nx)
    r = rng.uniform(-1, 1, model.ninput)
    kw = dict(dt=0.05, r=r, method="radau", rtol=tol, atol=tol)
    t, target = simulate_grid(model, x0 * 0.5, T, **kw)
    cost = _cost(target, rng.uniform(0.5, 2.0, target.shape))
    it = eomc.gradient(model, x0, T, cost=cost, **kw)
    monkeypatch.setattr(adjoint, "RADAU_DENSE", True)
    de = eomc.gradient(model, x0, T, cost=cost, **kw)
    steps = de.stats["dense_steps"]
    assert steps >= len(t) - 1 and de.stats["jac_x"] == 3 * steps and de.stats["iterations"] == 0
    s = it.stats
    assert s["dense_steps"] == 0 and s["iterations"] >= steps
    assert 3 * s["iterations"] <= s["vjp"] <= 3 * (s["iterations"] + steps)   # + a mispredicted last round
    assert 0 < s["jac_x"] < steps
    assert np.max(np.abs(it.dp - de.dp)) <= 1e-9 * np.max(np.abs(de.dp))
    assert np.max(np.abs(it.dx0 - de.dx0)) <= 1e-9 * np.max(np.abs(de.dx0))


def test_dop853_bad_method(model):
    with pytest.raises(ValueError, match="'rk4'.*'dop853'"):
        eomc.gradient(model, np.zeros(model.nx), T, dt=DT, cost=_cost(0.0, 1.0), method="bdf")
