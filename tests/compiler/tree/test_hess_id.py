"""hess_id (compiler/emit/reverse.py): ∂²τ/∂x² of inverse dynamics by forward over reverse,
against central differences of the first-order jac_id, on the cart and a floating tree;
Kane's formulation refuses it with a message."""
import warnings

import numpy as np
import pytest

import eomc
from eomc.runtime.errors import ModelError
from helpers.random_trees import build
from helpers.trees import cart_joints

FLOATING = [{'parent': -1, 'kind': 'free', 'rotation': ('SPACE', 123), 'axis': (0, 1, 0),
             'parent_point': (1, -1, -1), 'child_point': (0, -1, 0), 'rigid': False, 'products': True,
             'load': True},
            {'parent': 0, 'kind': 'ball', 'rotation': ('SPACE', 123), 'axis': (-1, 0, -1),
             'parent_point': (-1, -1, -1), 'child_point': (0, 1, -1), 'rigid': True, 'products': True,
             'load': True}]


def _model(system, cache, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return eomc.compile(system, functions=["rhs", "inverse_dynamics", "jac_id", "hess_id"],
                            formulation="recursive", cache_dir=cache, progress=False, **kw)


@pytest.mark.parametrize("case", ["cart", "floating"])
def test_against_central_differences_of_jac_id(case, tmp_path):
    if case == "cart":
        system, _ = cart_joints(3, rigid=True)
        model = _model(system, tmp_path)
    else:
        system, inputs = build(FLOATING)
        model = _model(system, tmp_path, inputs=inputs)
    ops = model.metadata["op_counts"]      # counted as the loops run: above first order's
    assert ops["hess_id"]["muls"] > ops["jac_id"]["muls"] > 0
    rng = np.random.default_rng(3)
    h = 1e-5
    for _ in range(2):
        x, ud = rng.uniform(-1, 1, model.nx), rng.uniform(-1, 1, model.nu)
        r = rng.uniform(-1, 1, model.ninput)
        H = model.hess_id(0.0, x, ud, r=r)
        assert H.shape == (model.nu, model.nx, model.nx)
        fd = np.stack([(model.jac_id(0.0, x + h * e, ud, r=r) - model.jac_id(0.0, x - h * e, ud, r=r)) / (2 * h)
                       for e in np.eye(model.nx)], axis=2)
        assert np.max(np.abs(H - fd)) <= 1e-8 * max(1.0, np.max(np.abs(fd)))
        assert np.max(np.abs(H - H.transpose(0, 2, 1))) <= 1e-12 * max(1.0, np.max(np.abs(H)))


def test_kane_refuses(tmp_path):
    system, _ = cart_joints(1, rigid=True)
    with pytest.raises(ModelError, match="hess_id .* recursive formulation only"):
        eomc.compile(system, functions=["rhs", "hess_id"], formulation="kane", cache_dir=tmp_path,
                     progress=False)
