"""The inverse-dynamics regressor (compiler/tree/regressor.py) against Pinocchio.

Pinocchio's ``computeJointTorqueRegressor`` on UR5, Panda and Solo12 with a
floating base (example-robot-data, read by eomc's URDF reader): blocks matched
by body name (Pinocchio's joint whose child link it is), parameters in
Pinocchio's order about the link frame.  Also Y·pi against Pinocchio's RNEA
with Pinocchio's own parameters, and, for a System that is not a URDF (pi about
the mass centre), against eomc's inverse dynamics.
"""
import warnings

import numpy as np
import pinocchio as pin
import pytest
import sympy as sm

import eomc
from eomc.compiler.urdf import from_urdf
from eomc.errors import ModelError
from helpers.robots import PinRef, joints_of, relative_error, robot_path
from helpers.trees import cart_joints

RNG = np.random.default_rng(21)
CASES = {"ur5": False, "panda": False, "solo12": True}


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("cache")


@pytest.mark.parametrize("name", list(CASES))
def test_regressor_matches_pinocchio(cache, name):
    floating = CASES[name]
    path = robot_path(name)
    system = from_urdf(path, floating_base=floating, limits=False)
    model = eomc.compile(system, name, functions=["regressor"], formulation="recursive",
                         cache_dir=cache, progress=False)
    assert model.functions == ("regressor",)
    ref = PinRef(path, joints_of(system), floating=floating)
    bodies = model.metadata["regressor_bodies"]
    assert set(model.metadata["regressor_reference"]) == {"link frame"}
    joints = [ref.model.frames[ref.model.getFrameId(b)].parentJoint for b in bodies]
    assert sorted(joints) == list(range(1, ref.model.njoints))      # one block per Pinocchio joint
    assert model.regressor_columns[:2] == (f"m_{bodies[0]}", f"mcx_{bodies[0]}")
    pi = np.concatenate([ref.model.inertias[j].toDynamicParameters() for j in joints])
    for _ in range(3):
        q = RNG.uniform(-np.pi, np.pi, model.nq)
        if floating:
            q[:3] = RNG.normal(size=3)
            q[3:6] = RNG.uniform(-1.2, 1.2, 3)
        v, a = RNG.normal(size=model.nu), RNG.normal(size=model.nu)
        Y = model.regressor(q, v, a)
        full = pin.computeJointTorqueRegressor(ref.model, ref.data, ref.q(q), ref.v(v), ref.v(a))[ref.iv]
        Yp = np.hstack([full[:, 10 * (j - 1):10 * j] for j in joints])
        assert Y.shape == Yp.shape
        assert np.max(np.abs(Y - Yp)) < 1e-12 * np.max(np.abs(Yp))
        assert relative_error(Y @ pi, ref.rnea(q, v, a)) < 1e-12


def test_mass_centre_reference_and_inverse_dynamics(cache):
    """A SymPy System (no link frames): pi about each mass centre, Y·pi = inverse dynamics."""
    system, _ = cart_joints(2, rigid=True)
    with warnings.catch_warnings():  # the defaults-to-1.0 warning (once per process)
        warnings.simplefilter("ignore")
        model = eomc.compile(system, functions=["inverse_dynamics", "regressor"], formulation="recursive",
                             cache_dir=cache, progress=False)
    assert model.metadata["regressor_reference"] == ["mass centre"] * 3
    p = RNG.uniform(0.5, 1.5, model.nparam)
    vals = dict(zip(model.param_names, p))
    pi = []
    for b in model.metadata["regressor_bodies"]:
        k = b[-1] if b.startswith("link") else None
        m = vals["m0"] if k is None else vals["m"]
        # the links turn about z only, so the model keeps izz alone (the tree drops the inertia
        # its motion cannot excite); Y's columns of the others are zero, any value would do
        inertia = [0.0] * 6 if k is None else [vals.get(f"ixx{k}", 0.3), vals.get(f"ixy{k}", 0.1),
                                               vals.get(f"iyy{k}", 0.2), 0.0, 0.0, vals[f"izz{k}"]]
        pi += [m, 0.0, 0.0, 0.0] + inertia
    for _ in range(3):
        x = RNG.uniform(-1, 1, model.nx)
        a = RNG.normal(size=model.nu)
        Y = model.regressor(x[:model.nq], x[model.nq:], a, p=p)
        tau = model.inverse_dynamics(0.0, x, a, p=p, r=np.zeros(model.ninput))
        assert relative_error(Y @ np.array(pi), tau) < 1e-12


def test_regressor_needs_the_recursive_formulation(cache):
    system, _ = cart_joints(1)
    with pytest.raises(ModelError, match="recursive"), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        eomc.compile(system, functions=["regressor"], formulation="kane", cache_dir=cache, progress=False)
