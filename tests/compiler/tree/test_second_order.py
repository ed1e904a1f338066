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
from helpers.urdf_arm import LAW_ARM

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
    """The kernel's own finiteness check (a bound, then v * 0 sums): speeds of 1e200 overflow v x* (I v)."""
    kernel, _ = models
    x = np.zeros(kernel.nx)
    x[kernel.nq:] = 1e200
    with pytest.raises(SimulationError, match="hess_id"):
        kernel.hess_id(0.0, x, np.zeros(kernel.nu), r=np.zeros(kernel.ninput))


# a URDF arm whose three joints all carry a law (soft limits, damping, Coulomb friction): the
# kernel adds the laws' own curvature to their rows' (q, u) entries (with_law_hessians)
ARM = LAW_ARM.replace('<robot name="arm">', '<robot name="lawarm">')
WIDTH = 3e-4    # joint_laws.WIDTH: the limit law's curvature lives within a few widths of a limit


def _compile_urdf(path, cache, reverse=False):
    orig = second_order.second_order_plan
    if reverse:
        second_order.second_order_plan = lambda plan: (None, "forced by the test")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return eomc.compile(str(path), functions=["rhs", "inverse_dynamics", "jac_id", "hess_id"],
                                cache_dir=cache, progress=False)
    finally:
        second_order.second_order_plan = orig


@pytest.fixture(scope="module")
def law_models(tmp_path_factory):
    d = tmp_path_factory.mktemp("laws")
    (d / "lawarm.urdf").write_text(ARM)
    return _compile_urdf(d / "lawarm.urdf", d / "kernel"), _compile_urdf(d / "lawarm.urdf", d / "reverse", True)


def test_joint_laws_take_the_kernel_and_match_reverse_path_and_differences(law_models):
    """Limits on (the URDF default), damping and friction: the kernel path, equal to the reverse
    path to rounding (1e-12 of the tensor's scale; measured <= 1.1e-15) and to central
    differences of jac_id (1e-6; measured <= 8e-8 with steps of 1e-7, 5e-10 with 1e-5), at a
    state inside the ranges and at states a fraction of a width to ten widths past the limits (where the law's curvature is
    ~1e7 and changes over a width: steps of 1e-7 there)."""
    kernel, reverse = law_models
    assert kernel.metadata["hess_id"].startswith("analytic second-order RNEA kernel")
    nq, nx = kernel.nq, kernel.nx
    rng = np.random.default_rng(3)
    law = np.zeros((kernel.nu, nx, nx), bool)     # entries d/dx of jac_id's law columns (q_i, u_i of row i)
    for i in range(kernel.nu):
        law[i, [i, nq + i], :] = True
    zone = [None, (0.5, 1.0, 0.3), (2.0, 0.3, 1.0), (10.0, 5.0, 0.5)]   # widths past j1 upper, j2 lower, j3 upper
    for past in zone:
        x, ud = rng.uniform(-0.3, 0.3, nx), rng.uniform(-1, 1, kernel.nu)
        if past is None:    # inside the three ranges
            x[:3] = rng.uniform([-0.5, -1.0, -0.1], [0.8, 1.2, 0.05])
        else:
            x[:3] = 0.8 + past[0] * WIDTH, -1.0 - past[1] * WIDTH, 0.05 + past[2] * WIDTH
        H, ref = kernel.hess_id(0.0, x, ud), reverse.hess_id(0.0, x, ud)
        scale = np.max(np.abs(ref))
        assert np.max(np.abs(H - ref)) <= 1e-12 * scale
        for h, mask in ((1e-7, law), (1e-5, ~law)):
            fd = np.stack([(kernel.jac_id(0.0, x + h * e, ud) - kernel.jac_id(0.0, x - h * e, ud)) / (2 * h)
                           for e in np.eye(nx)], axis=2)
            part = np.max(np.abs(H[mask]))
            assert part > 0.1
            assert np.max(np.abs(H - fd)[mask]) <= 1e-6 * part, (past, h)
    # the laws' curvature is there: ten widths past j1's limit, its entry dwarfs the rigid-body ones
    assert abs(H[0, 0, 0]) > 1e3 * np.max(np.abs(H[~law]))


def _nan_filled_call(model, x, ud, r=None):
    """hess_id's C into an output filled with NaN first: (status, output)."""
    t, x, p, r = model._args(0.0, x, None, r)
    out = np.full(model.nu * model.nx * model.nx, np.nan)
    status = model._kernel("hess_id")(t, x, np.asarray(ud, float), p, r, out, model._work()[1])
    return status, out.reshape(model.nu, model.nx, model.nx)


def test_every_entry_is_written(models, law_models):
    """The output is zeroed first unless the triple loop writes every entry itself (the dofs on
    one path, _covers_all): the branching tree is zeroed, the 3-joint arm (a chain) is not, and
    from an output filled with NaN both give every entry, equal to hess_id's."""
    tree, arm = models[0], law_models[0]
    c_tree = (tree.directory / f"{tree.name}.c").read_text()
    c_arm = (arm.directory / f"{arm.name}.c").read_text()
    assert f"out[k] = 0.0;" in c_tree.split("_rnea_hess(const double")[1].split("\n}\n")[0]
    assert f"out[k] = 0.0;" not in c_arm.split("_rnea_hess(const double")[1].split("\n}\n")[0]
    rng = np.random.default_rng(5)
    for model, r in ((tree, rng.uniform(-1, 1, tree.ninput)), (arm, None)):
        x, ud = rng.uniform(-1, 1, model.nx), rng.uniform(-1, 1, model.nu)
        status, out = _nan_filled_call(model, x, ud, r)
        assert status == 0 and np.all(np.isfinite(out))
        assert np.array_equal(out, model.hess_id(0.0, x, ud, r=r))


def test_large_finite_outputs_pass_the_bound_by_the_full_check(models):
    """The kernel's finiteness test is a bound on the numbers its outputs are made of (1e150);
    past it (speeds of 1e90: outputs ~1e180, finite) the output is checked entry by entry, and
    a finite one is returned, equal to the reverse path's."""
    kernel, reverse = models
    x = np.zeros(kernel.nx)
    x[kernel.nq:] = 1e90
    ud, r = np.zeros(kernel.nu), np.zeros(kernel.ninput)
    H, ref = kernel.hess_id(0.0, x, ud, r=r), reverse.hess_id(0.0, x, ud, r=r)
    scale = np.max(np.abs(ref))
    assert 1e170 < scale < 1e200 and np.all(np.isfinite(H))
    assert np.max(np.abs(H - ref)) <= 1e-12 * scale
