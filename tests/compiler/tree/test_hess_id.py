"""hess_id: ∂²τ/∂x² of inverse dynamics, against central differences of the first-order jac_id,
on the cart (the analytic kernel, compiler/tree/second_order.py) and a floating tree (forward
over reverse, compiler/emit/reverse.py), and UR10 against Pinocchio; Kane's formulation
refuses it with a message."""
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
    path = model.metadata["hess_id"]      # which algorithm, and why not the kernel
    if case == "cart":
        assert path.startswith("analytic second-order RNEA kernel")
    else:
        assert path.startswith("forward over reverse on RNEA")     # the reason follows
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


def test_against_central_differences_of_pinocchio_first_order(tmp_path):
    """UR10 (example-robot-data; the analytic kernel): hess_id against central differences of Pinocchio's own
    computeRNEADerivatives (its Python bindings do not export the second-order RNEA
    derivatives; benchmarks/bench_second_order.py compares with those in C++, to 1e-12)."""
    import pinocchio as pin
    from eomc.compiler.urdf import from_urdf
    from helpers.robots import PinRef, joints_of, robot_path
    path = robot_path("ur_description/urdf/ur10_robot.urdf")
    system = from_urdf(path, limits=False)
    model = _model(system, tmp_path)
    assert model.metadata["hess_id"].startswith("analytic second-order RNEA kernel")
    ref = PinRef(path, joints_of(system))
    nq, nu, iv = model.nq, model.nu, ref.iv
    rng = np.random.default_rng(5)
    h = 1e-6

    def first(q, v, a):     # Pinocchio's (dtau/dq, dtau/dv) in eomc's order
        pin.computeRNEADerivatives(ref.model, ref.data, ref.q(q), ref.v(v), ref.v(a))
        return ref.data.dtau_dq[np.ix_(iv, iv)].copy(), ref.data.dtau_dv[np.ix_(iv, iv)].copy()

    for _ in range(2):
        q, v, a = rng.uniform(-np.pi, np.pi, nq), rng.normal(size=nu), rng.normal(size=nu)
        H = model.hess_id(0.0, np.concatenate([q, v]), a)
        fd = np.zeros((nu, nq + nu, nq + nu))     # [i, j, k] = d/dx_k of Pinocchio's d tau_i/dx_j
        for k in range(nq + nu):
            up, dn = [q.copy(), v.copy()], [q.copy(), v.copy()]
            part, at = (0, k) if k < nq else (1, k - nq)
            up[part][at] += h
            dn[part][at] -= h
            (qp, vp), (qm, vm) = first(*up, a), first(*dn, a)
            fd[:, :nq, k] = (qp - qm) / (2 * h)
            fd[:, nq:, k] = (vp - vm) / (2 * h)
        assert np.max(np.abs(H)) > 1.0                      # not a vanishing tensor
        assert np.max(np.abs(H - fd)) <= 1e-7 * np.max(np.abs(fd))


def test_a_long_cart_builds_beside_the_shared_inputs(tmp_path):
    """hess_id on the kernel beside inverse_dynamics and jac_id (which share NAME_dyn_inputs):
    the 40-link cart builds (it did not: RNEA's trace, added for hess_id's reverse path only,
    put udot into NAME_dyn_inputs) and its hess_id matches differences of jac_id along one column."""
    system, _ = cart_joints(40, rigid=True)
    model = _model(system, tmp_path)
    assert model.metadata["hess_id"].startswith("analytic second-order RNEA kernel")
    rng = np.random.default_rng(4)
    x, ud = rng.uniform(-1, 1, model.nx), rng.uniform(-1, 1, model.nu)
    H, h, e = model.hess_id(0.0, x, ud), 1e-5, np.eye(model.nx)[5]
    fd = (model.jac_id(0.0, x + h * e, ud) - model.jac_id(0.0, x - h * e, ud)) / (2 * h)
    assert np.max(np.abs(H[:, :, 5] - fd)) <= 1e-7 * max(1.0, np.max(np.abs(fd)))
