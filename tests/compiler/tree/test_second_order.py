"""hess_id's analytic second-order kernel (compiler/tree/second_order.py): on a branching
tree of pins and sliders with joint inputs, against the forward-over-reverse path it
replaces (exact to rounding) and central differences of jac_id; its finiteness check;
which path a model gets, in its metadata.  (UR10 against Pinocchio: test_hess_id.py.)"""
import warnings

import numpy as np
import pytest

import eomc
import eomc.compiler.tree.second_order as second_order
from eomc.runtime.errors import SimulationError
from helpers.random_trees import build

# two branches from body 0 (a pin): a slider then a pin, and a point mass on a pin then a slider;
# most joints carry an input (a load pair on child and parent)
TREE = [
    {'parent': -1, 'kind': 'pin', 'rotation': ('SPACE', 123), 'axis': (0, 1, 1), 'parent_point': (1, -1, 0),
     'child_point': (0, -1, 1), 'rigid': True, 'products': True, 'load': True},
    {'parent': 0, 'kind': 'slider', 'rotation': ('BODY', 313), 'axis': (1, 0, -1), 'parent_point': (-1, 1, 1),
     'child_point': (0, 1, -1), 'rigid': True, 'products': True, 'load': True},
    {'parent': 0, 'kind': 'pin', 'rotation': ('BODY', 123), 'axis': (1, 1, 0), 'parent_point': (0, 1, 1),
     'child_point': (1, 0, 0), 'rigid': False, 'products': False, 'load': False},
    {'parent': 1, 'kind': 'pin', 'rotation': ('SPACE', 231), 'axis': (0, 0, 1), 'parent_point': (1, 0, -1),
     'child_point': (1, 1, 1), 'rigid': True, 'products': True, 'load': True},
    {'parent': 2, 'kind': 'slider', 'rotation': ('SPACE', 123), 'axis': (1, 1, 1), 'parent_point': (0, 0, 1),
     'child_point': (1, 0, 1), 'rigid': True, 'products': False, 'load': True},
]


def _compile(cache, reverse=False):
    system, inputs = build(TREE)
    orig = second_order.second_order_plan
    if reverse:     # force the path the kernel replaces
        second_order.second_order_plan = lambda plan: (None, "forced by the test")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return eomc.compile(system, functions=["rhs", "inverse_dynamics", "jac_id", "hess_id"],
                                inputs=inputs, formulation="recursive", cache_dir=cache, progress=False)
    finally:
        second_order.second_order_plan = orig


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    return _compile(tmp_path_factory.mktemp("kernel")), _compile(tmp_path_factory.mktemp("reverse"), reverse=True)


def test_metadata_names_the_path(models):
    kernel, reverse = models
    assert kernel.metadata["hess_id"].startswith("analytic second-order RNEA kernel")
    assert reverse.metadata["hess_id"].startswith("forward over reverse") and "forced by the test" in reverse.metadata["hess_id"]
    assert "rnea_hess" in (kernel.directory / f"{kernel.name}.c").read_text()
    assert "rnea_hess" not in (reverse.directory / f"{reverse.name}.c").read_text()


def test_against_reverse_path_and_differences_of_jac_id(models):
    kernel, reverse = models
    rng = np.random.default_rng(11)
    h = 1e-5
    for _ in range(3):
        x, ud = rng.uniform(-1.5, 1.5, kernel.nx), rng.uniform(-1, 1, kernel.nu)
        r = rng.uniform(-1, 1, kernel.ninput)
        H, ref = kernel.hess_id(0.0, x, ud, r=r), reverse.hess_id(0.0, x, ud, r=r)
        scale = np.max(np.abs(ref))
        assert scale > 1.0
        assert np.max(np.abs(H - ref)) <= 1e-12 * scale
        fd = np.stack([(kernel.jac_id(0.0, x + h * e, ud, r=r) - kernel.jac_id(0.0, x - h * e, ud, r=r)) / (2 * h)
                       for e in np.eye(kernel.nx)], axis=2)
        assert np.max(np.abs(H - fd)) <= 1e-8 * scale


def test_overflow_is_an_error_not_a_silent_inf(models):
    """The kernel's own finiteness check (v * 0 sums): speeds of 1e200 overflow v x* (I v)."""
    kernel, _ = models
    x = np.zeros(kernel.nx)
    x[kernel.nq:] = 1e200
    with pytest.raises(SimulationError, match="hess_id"):
        kernel.hess_id(0.0, x, np.zeros(kernel.nu), r=np.zeros(kernel.ninput))
