"""jac_p = d xdot / d p in both formulations, against three references.

* symbolic: SymPy differentiates xdot = [kinematics; M⁻¹ f] of SymPy's own
  KanesMethod and lambdify evaluates it (an independent derivation);
* central differences of the compiled rhs along each parameter;
* the other formulation (recursive against Kane, column by column by name).

Also: jac_p is generated only on request, linearize(parameters=True), folded
parameters have no column, and a model built without it says what to build.
"""
import warnings

import numpy as np
import pytest
import sympy as sm
from sympy.physics import mechanics as sme

import eomc
from eomc.errors import ModelError
from helpers import zoo
from helpers.trees import cart_joints
from helpers.module_cache import cache  # noqa: F401 -- the module's own build cache (a fixture)

FUNCTIONS = ["rhs", "jac_x", "jac_r", "jac_p", "linearize"]


def _fd_p(model, x, p, r):
    cols = []
    for k in range(p.size):
        h = 1e-6 * max(1.0, abs(p[k]))
        up, dn = p.copy(), p.copy()
        up[k] += h
        dn[k] -= h
        cols.append((model.rhs(0.0, x, p=up, r=r) - model.rhs(0.0, x, p=dn, r=r)) / (2 * h))
    return np.array(cols).T


def _scaled(a, b):
    return np.max(np.abs(a - b)) / max(1.0, np.max(np.abs(b)))


@pytest.fixture(scope="module")
def cart(cache):
    """PyDy's 2-link cart by SymPy's KanesMethod, compiled by eomc, and SymPy's symbolic d xdot/dp."""
    kane, specified = zoo.n_link_pendulum_on_cart(2, sme)
    params = sorted((kane.mass_matrix_full.free_symbols | kane.forcing_full.free_symbols)
                    - {sme.dynamicsymbols._t}, key=str)
    defaults = {s: 0.5 + 0.25 * i for i, s in enumerate(params)}
    model = eomc.compile(kane, parameters=defaults, inputs=specified, functions=FUNCTIONS)
    xdot = kane.mass_matrix_full.LUsolve(kane.forcing_full)
    states = list(kane.q) + list(kane.u)
    P = [sm.Symbol(n) for n in model.param_names]
    by_name = {str(s): s for s in params}
    dxdp = xdot.jacobian([by_name[str(s)] for s in P])
    f = sm.lambdify([states, [by_name[str(s)] for s in P], specified], dxdp, "numpy")
    return model, f


def test_kane_jac_p_matches_sympy_and_differences(cart):
    model, symbolic = cart
    rng = np.random.default_rng(1)
    for _ in range(3):
        x = rng.uniform(-1, 1, model.nx)
        p = rng.uniform(0.5, 1.5, model.nparam)
        r = rng.uniform(-1, 1, model.ninput)
        J = model.jac_p(0.0, x, r=r, p=p)
        assert J.shape == (model.nx, model.nparam)
        assert _scaled(J, np.array(symbolic(x, p, r), dtype=float)) < 1e-12
        assert _scaled(J, _fd_p(model, x, p, r)) < 1e-7
        # the kinematic rows q' = u do not depend on any parameter
        assert np.all(J[:model.nq] == 0.0)


def test_linearize_with_parameters(cart):
    model, _ = cart
    x = np.linspace(-0.5, 0.5, model.nx)
    A, B, P = model.linearize(0.0, x, parameters=True)
    A0, B0 = model.linearize(0.0, x)
    assert np.array_equal(A, A0) and np.array_equal(B, B0)
    assert np.array_equal(P, model.jac_p(0.0, x))
    # keywords in either order, dict parameters
    pd = dict(zip(model.param_names, model.param_defaults * 1.1))
    assert np.allclose(model.jac_p(0.0, x, p=pd), model.jac_p(0.0, x, p=model.param_defaults * 1.1), rtol=0,
                       atol=0)


def test_not_generated_by_default_and_clear_error(cache):
    kane, specified = zoo.n_link_pendulum_on_cart(1, sme)
    model = eomc.compile(kane, inputs=specified, parameters={s: 1.0 for s in sm.symbols("g l0 m0 m1")},
                         functions=["rhs", "jac_x"])
    assert "jac_p" not in model.functions
    with pytest.raises(ModelError, match="jac_p"):
        model.jac_p(0.0, np.zeros(model.nx))
    with pytest.raises(ModelError, match="jac_p"):
        model.linearize(0.0, np.zeros(model.nx), parameters=True)
    default = eomc.compile(kane, inputs=specified, parameters={s: 1.0 for s in sm.symbols("g l0 m0 m1")})
    assert "jac_p" not in default.functions and "jac_x" in default.functions


def test_folded_parameters_have_no_column(cache):
    kane, specified = zoo.n_link_pendulum_on_cart(1, sme)
    g, l0, m0, m1 = sm.symbols("g l0 m0 m1")
    model = eomc.compile(kane, inputs=specified, parameters={g: 9.81, l0: 1.0, m0: 1.0, m1: 0.5},
                         functions=["rhs", "jac_p"], fold_parameters=True)
    assert model.nparam == 0
    assert model.jac_p(0.0, np.zeros(model.nx)).shape == (model.nx, 0)


def test_constrained_kane_jac_p_matches_differences(cache):
    """The rolling disc: dependent coordinate and speeds (A holds the constraint rows)."""
    kane, _ = zoo.rolling_disc(sme)
    r, m, g = sm.symbols("r m g")
    model = eomc.compile(kane, parameters={r: 0.5, m: 2.0, g: 9.81},
                         functions=["rhs", "jac_p", "constraints", "constraints_jac"])
    x = model.consistent_state({"q2": 0.3, "u1": 0.4, "u2": -0.2, "u3": 3.0})
    J = model.jac_p(0.0, x)
    assert _scaled(J, _fd_p(model, x, model.param_defaults.copy(), None)) < 1e-7
    assert np.max(np.abs(J)) > 0.1


@pytest.fixture(scope="module")
def tree_pair(cache):
    system, inputs = cart_joints(2, rigid=True)
    out = {}
    for form in ("kane", "recursive"):
        with warnings.catch_warnings():  # the defaults-to-1.0 warning (once per process)
            warnings.simplefilter("ignore")
            out[form] = eomc.compile(system, formulation=form, functions=["rhs", "jac_p"])
    return out


def test_recursive_jac_p_matches_kane_and_differences(tree_pair):
    kane, rec = tree_pair["kane"], tree_pair["recursive"]
    assert rec.metadata["formulation"] == "recursive" and kane.metadata["formulation"] == "kane"
    rng = np.random.default_rng(3)
    for _ in range(3):
        vals = {n: rng.uniform(0.5, 1.5) for n in rec.param_names}
        x = rng.uniform(-1, 1, rec.nx)
        r = rng.uniform(-1, 1, rec.ninput)
        pr = np.array([vals[n] for n in rec.param_names])
        pk = np.array([vals[n] for n in kane.param_names])
        Jr, Jk = rec.jac_p(0.0, x, r=r, p=pr), kane.jac_p(0.0, x, r=r, p=pk)
        for j, n in enumerate(rec.param_names):
            if n in kane.param_names:
                col = Jk[:, kane.param_names.index(n)]
                assert np.max(np.abs(Jr[:, j] - col)) < 1e-12 * max(1.0, np.max(np.abs(Jk)))
            else:      # an inertia the planar motion never uses (Kane's equations lack it)
                assert np.all(Jr[:, j] == 0.0), n
        assert _scaled(Jr, _fd_p(rec, x, pr, r)) < 1e-7


@pytest.mark.parametrize("n", [2, 6])     # 2: unrolled columns; 6 (14 states): looped tangents
def test_jvp_is_jacobian_times_direction(cache, n):
    """jvp's J·[dx; dp] against jac_x·dx + jac_p·dp, and its xdot against rhs."""
    kane, specified = zoo.n_link_pendulum_on_cart(n, sme)
    params = sorted((kane.mass_matrix_full.free_symbols | kane.forcing_full.free_symbols)
                    - {sme.dynamicsymbols._t}, key=str)
    model = eomc.compile(kane, parameters={s: 0.7 + 0.1 * i for i, s in enumerate(params)},
                         inputs=specified, functions=["rhs", "jac_x", "jac_p", "jvp"])
    rng = np.random.default_rng(n)
    x, r = rng.uniform(-1, 1, model.nx), rng.uniform(-1, 1, model.ninput)
    D = rng.normal(size=(3, model.nx + model.nparam))
    D[1, model.nx:] = 0.0
    xdot, out = model.jvp(0.0, x, D, r=r)
    ref = D[:, :model.nx] @ model.jacobian(0.0, x, r=r).T + D[:, model.nx:] @ model.jac_p(0.0, x, r=r).T
    assert np.array_equal(xdot, model.rhs(0.0, x, r=r)) or _scaled(xdot, model.rhs(0.0, x, r=r)) < 1e-14
    assert _scaled(out, ref) < 1e-12
    _, only_x = model.jvp(0.0, x, D[:, :model.nx], r=r)      # state directions alone
    assert _scaled(only_x, D[:, :model.nx] @ model.jacobian(0.0, x, r=r).T) < 1e-12
    _check_sensitivity_directions(model, x, r, rng)
    _check_lanes(model, x, r, rng)
    if n == 6:     # the looped tangent (Gtx) through whole runs: S against central differences
        _check_whole_run_sensitivities(model, r)


def _check_whole_run_sensitivities(model, r):
    x0 = np.zeros(model.nx)
    x0[1:model.nq] = 0.3
    names = [model.state_names[2], model.param_names[0], model.param_names[-1]]
    kw = dict(r=r, method="dop853", t_eval=[0.25, 0.5])
    res = model.simulate(x0, (0, 0.5), rtol=1e-10, atol=1e-10, sensitivities=names, **kw)
    S = np.concatenate([res.dx_dx0, res.dx_dp], axis=2)
    p0 = np.asarray(model.param_defaults, dtype=float)
    for k, name in enumerate(names):
        if name in model.state_names:
            j, h = model.state_names.index(name), 1e-6
            runs = [model.simulate(x0 + s * h * np.eye(model.nx)[j], (0, 0.5), rtol=1e-12, atol=1e-12, **kw).x
                    for s in (1, -1)]
        else:
            j = model.param_names.index(name)
            h = 1e-6 * max(1.0, abs(p0[j]))
            runs = [model.simulate(x0, (0, 0.5), p=p0 + s * h * np.eye(model.nparam)[j], rtol=1e-12,
                                   atol=1e-12, **kw).x for s in (1, -1)]
        fd = (runs[0] - runs[1]) / (2 * h)
        assert np.max(np.abs(S[:, :, k] - fd)) < 1e-6 * np.max(np.abs(fd)), name


def _check_lanes(model, x, r, rng):
    """k directions in one call (the looped tangent carries four at a time, a lone one
    scalar; emit.bodies.lane_directions) against each direction alone, for every group
    size and remainder up to k = 9, sensitivity-shaped and dense directions."""
    nx, npar = model.nx, model.nparam
    D = rng.normal(size=(9, nx + npar))
    D[::2, nx:] = 0.0
    D[np.arange(0, 9, 2), nx + np.arange(0, 9, 2) % npar] = 1.0
    for k in range(1, 10):
        _, out = model.jvp(0.0, x, D[:k], r=r)
        alone = np.concatenate([model.jvp(0.0, x, D[i:i + 1], r=r)[1] for i in range(k)])
        assert _scaled(out, alone) < 1e-14, k


def _check_sensitivity_directions(model, x, r, rng):
    """The directions forward sensitivities pass, [S_j; e_j] (one nonzero parameter entry,
    computed column by column in the C), every parameter, and a two-entry one: against
    jac_x·S + jac_p and central differences of rhs along the direction."""
    nx, npar = model.nx, model.nparam
    p0 = np.asarray(model.param_defaults, dtype=float)
    D = np.zeros((npar + 1, nx + npar))
    D[:, :nx] = rng.normal(size=(npar + 1, nx))
    D[np.arange(npar), nx + np.arange(npar)] = rng.uniform(0.5, 2.0, npar)
    D[npar, nx + npar - 1] = D[npar, nx] = 0.7
    _, out = model.jvp(0.0, x, D, r=r)
    ref = D[:, :nx] @ model.jacobian(0.0, x, r=r).T + D[:, nx:] @ model.jac_p(0.0, x, r=r).T
    assert _scaled(out, ref) < 1e-12
    h = 1e-6
    for d, row in zip(D[[0, npar - 1, npar]], out[[0, npar - 1, npar]]):
        fd = (model.rhs(0.0, x + h * d[:nx], p=p0 + h * d[nx:], r=r)
              - model.rhs(0.0, x - h * d[:nx], p=p0 - h * d[nx:], r=r)) / (2 * h)
        assert _scaled(row, fd) < 1e-7
