"""vjp and hvp (compiler/emit/reverse.py, passes/adjoint.py), both formulations.

References: the transposed jac_x and jac_p (one reverse sweep must equal λᵀJ to rounding,
1e-12), central differences of λᵀ·jac_x along v for the Hessian-vector product (1e-8),
and the Hessian's symmetry.  Models: the pendulum on a cart (joint inputs), a chain with
extra first-order states z (every row block of xdot), random trees with ball and free
joints (recursive); a constrained Kane system is refused with a message.
"""
import warnings

import numpy as np
import pytest
import sympy.physics.mechanics as sme
from hypothesis import HealthCheck, given, settings

import eomc
import eomc.mechanics as em
from eomc.runtime.errors import ModelError
from helpers import zoo
from helpers.random_trees import build, tree
from helpers.state_models import torque_chain
from helpers.trees import cart_joints

FUNCTIONS = ["rhs", "jac_x", "jac_p", "vjp", "hvp"]


def _compile(system, cache, **kw):
    with warnings.catch_warnings():   # parameters defaulting to 1.0
        warnings.simplefilter("ignore")
        return eomc.compile(system, functions=FUNCTIONS, cache_dir=cache, progress=False, **kw)


def _rel(a, b):
    return np.max(np.abs(a - b)) / max(1.0, np.max(np.abs(b)))


def check(model, seed, nstates=3, h=1e-5):
    rng = np.random.default_rng(seed)
    for _ in range(nstates):
        x, r = rng.uniform(-1, 1, model.nx), rng.uniform(-1, 1, model.ninput)
        p = np.asarray(model.param_defaults) * rng.uniform(0.8, 1.2, model.nparam)
        lam, v, w = rng.normal(size=(3, model.nx))
        xdot, gx, gp = model.vjp(0.0, x, lam, p=p, r=r)
        J = model.jacobian(0.0, x, p=p, r=r)
        assert _rel(xdot, model.rhs(0.0, x, p=p, r=r)) < 1e-14, (x, p, r)
        assert _rel(gx, lam @ J) < 1e-12, (x, p, r, gx, lam @ J)
        if model.nparam:
            assert _rel(gp, lam @ model.jac_p(0.0, x, p=p, r=r)) < 1e-12, (x, p, r)
        hv = model.hvp(0.0, x, lam, v, p=p, r=r)
        fd = (lam @ model.jacobian(0.0, x + h * v, p=p, r=r)
              - lam @ model.jacobian(0.0, x - h * v, p=p, r=r)) / (2 * h)
        assert np.max(np.abs(hv - fd)) <= 1e-8 * max(1.0, np.max(np.abs(fd))), (x, p, r, hv, fd)
        hw = model.hvp(0.0, x, lam, w, p=p, r=r)
        assert abs(w @ hv - v @ hw) <= 1e-12 * max(1.0, np.max(np.abs(hv)) * np.max(np.abs(w)) * model.nx), (
            x, p, r, w @ hv, v @ hw)


@pytest.mark.parametrize("formulation", ["kane", "recursive"])
@pytest.mark.parametrize("n", [2, 7])      # 7 links: 16 states, jac_x's looped tangents
def test_cart(formulation, n, tmp_path_factory):
    system, _ = cart_joints(n, rigid=True)
    model = _compile(system, tmp_path_factory.mktemp("c"), formulation=formulation)
    check(model, n)


@pytest.mark.parametrize("formulation", ["kane", "recursive"])
def test_extra_states(formulation, tmp_path_factory):
    d = torque_chain(2, em)
    model = _compile(d["system"], tmp_path_factory.mktemp("c"), parameters=d["parameters"],
                     inputs=d["inputs"], states=d["states"], formulation=formulation)
    assert model.nx > model.nq + model.nu
    check(model, 4)


@settings(max_examples=4, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
@given(tree(max_bodies=3, free=True))
def test_random_floating_trees(tmp_path_factory, spec):
    """Random floating trees; a tree whose acceleration is undefined (a body with no inertia
    about its joint axis, even with everything beyond it) is refused by the build, which
    is the right answer there, so only that refusal is let through."""
    system, inputs = build(spec)
    try:
        model = _compile(system, tmp_path_factory.mktemp("c"), inputs=inputs, formulation="recursive")
    except ModelError as exc:
        assert "has no inertia about its joint axis" in str(exc)
        return
    check(model, 7, nstates=2)


def test_defaults_leave_them_out(tmp_path_factory):
    system, _ = cart_joints(1, rigid=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(system, cache_dir=tmp_path_factory.mktemp("c"), progress=False)
    assert "vjp" not in model.functions and "hvp" not in model.functions


def test_constrained_kane_refused(tmp_path_factory):
    kane, _ = zoo.rolling_disc(sme)
    with pytest.raises(ModelError, match="vjp and hvp need the dynamics' matrix symmetric"):
        eomc.compile(kane, functions=["rhs", "vjp", "hvp"], cache_dir=tmp_path_factory.mktemp("c"),
                     progress=False)
