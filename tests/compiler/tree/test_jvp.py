"""The recursive formulation's jvp (compiler/tree/jvp.py): xdot and J·[dx; dp] along given
directions, against its own jac_x and jac_p, and sensitivities of a tree through it."""
import warnings

import numpy as np
import pytest

import eomc
from helpers.trees import cart_joints


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    system, _ = cart_joints(2, rigid=True)
    with warnings.catch_warnings():  # the defaults-to-1.0 warning (once per process)
        warnings.simplefilter("ignore")
        return eomc.compile(system, formulation="recursive", functions=["rhs", "jac_x", "jac_p", "jvp"],
                            cache_dir=tmp_path_factory.mktemp("cache"), progress=False)


def test_jvp_matches_jacobians(model):
    assert model.metadata["formulation"] == "recursive"
    rng = np.random.default_rng(5)
    for _ in range(3):
        p = rng.uniform(0.5, 1.5, model.nparam)
        x, r = rng.uniform(-1, 1, model.nx), rng.uniform(-1, 1, model.ninput)
        D = rng.normal(size=(4, model.nx + model.nparam))
        D[0, model.nx:] = 0.0
        xdot, out = model.jvp(0.0, x, D, p=p, r=r)
        ref = D[:, :model.nx] @ model.jacobian(0.0, x, p=p, r=r).T + D[:, model.nx:] @ model.jac_p(0.0, x, p=p, r=r).T
        assert np.max(np.abs(xdot - model.rhs(0.0, x, p=p, r=r))) < 1e-14 * max(1.0, np.max(np.abs(xdot)))
        assert np.max(np.abs(out - ref)) < 1e-12 * max(1.0, np.max(np.abs(ref)))
    # the directions forward sensitivities pass: [S_j; e_j], one parameter entry each
    # (the C computes only that parameter's column), and one with two entries
    x, r = rng.uniform(-1, 1, model.nx), rng.uniform(-1, 1, model.ninput)
    p0 = np.asarray(model.param_defaults, dtype=float)
    nx, npar = model.nx, model.nparam
    D = np.zeros((npar + 1, nx + npar))
    D[:, :nx] = rng.normal(size=(npar + 1, nx))
    D[np.arange(npar), nx + np.arange(npar)] = rng.uniform(0.5, 2.0, npar)
    D[npar, nx] = D[npar, nx + npar - 1] = 0.7
    _, out = model.jvp(0.0, x, D, r=r)
    ref = D[:, :nx] @ model.jacobian(0.0, x, r=r).T + D[:, nx:] @ model.jac_p(0.0, x, r=r).T
    assert np.max(np.abs(out - ref)) < 1e-12 * max(1.0, np.max(np.abs(ref)))
    h = 1e-6
    for d, row in zip(D, out):
        fd = (model.rhs(0.0, x + h * d[:nx], p=p0 + h * d[nx:], r=r)
              - model.rhs(0.0, x - h * d[:nx], p=p0 - h * d[nx:], r=r)) / (2 * h)
        assert np.max(np.abs(row - fd)) < 1e-7 * max(1.0, np.max(np.abs(fd)))


def test_jvp_directions_together_equal_each_alone(model):
    """k directions in one call (the tangent four at a time, a lone one scalar:
    emit.bodies.lane_directions) against each direction alone, k = 1 .. 9."""
    rng = np.random.default_rng(7)
    x, r = rng.uniform(-1, 1, model.nx), rng.uniform(-1, 1, model.ninput)
    nx, npar = model.nx, model.nparam
    D = rng.normal(size=(9, nx + npar))
    D[::2, nx:] = 0.0
    D[np.arange(0, 9, 2), nx + np.arange(0, 9, 2) % npar] = 1.0
    for k in range(1, 10):
        _, out = model.jvp(0.0, x, D[:k], r=r)
        alone = np.concatenate([model.jvp(0.0, x, D[i:i + 1], r=r)[1] for i in range(k)])
        assert np.max(np.abs(out - alone)) <= 1e-14 * max(1.0, np.max(np.abs(alone))), k


def test_tree_sensitivities_through_jvp_and_jacobian_agree(model):
    from eomc.runtime import sensitivity
    x0 = np.zeros(model.nx)
    x0[1:model.nq] = 0.4
    names = ["q1", "m", "l"]
    runs = []
    for prefer in (True, False):
        old = sensitivity.PREFER_JVP
        sensitivity.PREFER_JVP = prefer
        try:
            runs.append(model.simulate(x0, (0, 1), t_eval=[0.5, 1.0], rtol=1e-10, atol=1e-10,
                                       sensitivities=names))
        finally:
            sensitivity.PREFER_JVP = old
    a, b = runs
    S = np.concatenate([b.dx_dx0, b.dx_dp], axis=2)
    assert np.max(np.abs(np.concatenate([a.dx_dx0, a.dx_dp], axis=2) - S)) < 1e-7 * np.max(np.abs(S))
