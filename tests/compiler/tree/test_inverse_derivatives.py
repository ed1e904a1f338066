"""jac_id: d tau / d x of inverse dynamics (compiler/tree/inverse_derivatives.py).

Checked, compiled, against two independent references: central differences of
the compiled ``inverse_dynamics`` (itself checked against Kane's formulation and
Pinocchio elsewhere) on random trees of every joint kind the recursion has
(pins, sliders, balls, free joints, planar and cylindrical joints) in both code
paths (unrolled columns, and one tangent looped over the columns); and
Pinocchio's ``computeRNEADerivatives`` on real robots (example-robot-data),
where on a floating base Pinocchio differentiates along its Lie-group tangent:
its dtau_dq is jac_id's coordinate block times K = dq'/du.
"""
import warnings

import numpy as np
import pinocchio as pin
import pytest
import sympy as sm
import sympy.physics.mechanics as sme
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import eomc
from eomc.compiler.emit.symbolic import TANGENT_MIN_STATES
from eomc.compiler.urdf import from_urdf
from eomc.compiler.urdf.joints import PlanarJoint as UrdfPlanar
from eomc.errors import ModelError
from helpers import random_trees
from helpers.robots import PinRef, joints_of, relative_error, robot_path
from helpers.trees import add_joint_spring, cart_joints


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))


def fd_jac_id(model, x, ud, r=None):
    """Central differences of the compiled inverse dynamics along every state."""
    cols = []
    for k in range(model.nx):
        h = 1e-6 * max(1.0, abs(x[k]))
        up, dn = x.copy(), x.copy()
        up[k] += h
        dn[k] -= h
        cols.append((model.inverse_dynamics(0.0, up, ud, r=r) - model.inverse_dynamics(0.0, dn, ud, r=r)) / (2 * h))
    return np.array(cols).T


def worst_against_fd(model, seed, nstates=3):
    rng = np.random.default_rng(seed)
    worst = 0.0
    for _ in range(nstates):
        x, ud = rng.uniform(-1, 1, model.nx), rng.normal(size=model.nu)
        r = rng.normal(size=model.ninput) if model.ninput else None
        J = model.jac_id(0.0, x, ud, r=r)
        assert J.shape == (model.nu, model.nx)
        ref = fd_jac_id(model, x, ud, r)
        worst = max(worst, np.max(np.abs(J - ref)) / max(1.0, np.max(np.abs(ref))))
    return worst


@pytest.mark.parametrize("n", [2, 8])
def test_cart_both_code_paths(n):
    """The tangent paths, kept where a load depends on the state (here a joint spring; without
    it the analytic path, tests/compiler/tree/test_analytic_derivatives.py): n = 2: 6 states,
    columns unrolled; n = 8: 18 states, the tangent looped in C."""
    system, _ = cart_joints(n, rigid=True)
    add_joint_spring(system, 1, *sm.symbols("k_s c_s"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(system, f"cid{n}", functions=["inverse_dynamics", "jac_id"],
                             formulation="recursive", progress=False)
    assert model.functions == ("inverse_dynamics", "jac_id")
    assert "_rnea_derivs(" not in model.source_path.read_text()
    looped = "for (k = " in model.source_path.read_text()
    assert looped == (model.nx > TANGENT_MIN_STATES)
    assert worst_against_fd(model, seed=n) < 1e-7


@settings(max_examples=5, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(spec=random_trees.tree(max_bodies=4, free=True), seed=st.integers(0, 2**32 - 1))
def test_random_trees_with_free_and_ball_joints(spec, seed):
    system, inputs = random_trees.build(spec)
    try:
        model = eomc.compile(system, "rid", inputs=inputs, functions=["inverse_dynamics", "jac_id"],
                             formulation="recursive", progress=False)
    except ModelError as exc:       # a speed nothing resists: refused (test_agreement)
        assert "no inertia" in str(exc)
        return
    assert worst_against_fd(model, seed) < 1e-6


def _rigid(name):
    body = sme.RigidBody(name, mass=sm.Symbol(f"m_{name}"))
    body.inertia = (sme.inertia(body.frame, 2, 3, 4, sm.Rational(1, 8), sm.Rational(1, 9), 0), body.masscenter)
    return body


def test_planar_and_cylindrical_joints():
    """SymPy's CylindricalJoint (2 speeds), its PlanarJoint (stages) and the URDF planar joint (3
    body-frame speeds) below each other, a torque between two of them."""
    ground, a, b, c = sme.RigidBody("ground"), _rigid("a"), _rigid("b"), _rigid("c")
    N = ground.frame
    joints = [sme.CylindricalJoint("cyl", ground, a, joint_axis=N.x + N.y, child_point=a.frame.z),
              sme.PlanarJoint("plane", a, b, parent_point=a.frame.x, child_point=b.frame.y / 2,
                              parent_interframe=a.frame.y),
              UrdfPlanar("urdf_plane", b, c, parent_point=b.frame.z, child_point=-c.frame.x)]
    system = sme.System.from_newtonian(ground)
    system.add_joints(*joints)
    system.apply_uniform_gravity(-sm.Symbol("g") * N.z)
    T = sme.dynamicsymbols("T")
    system.add_loads(sme.Torque(b.frame, T * a.frame.y), sme.Torque(a.frame, -T * a.frame.y))
    model = eomc.compile(system, "planar_id", inputs=[T], functions=["inverse_dynamics", "jac_id"],
                         formulation="recursive", progress=False)
    assert model.nx > TANGENT_MIN_STATES
    assert worst_against_fd(model, seed=3) < 1e-7


ROBOTS = {"ur5": False, "panda": False, "solo12": True}


@pytest.mark.parametrize("name", list(ROBOTS))
def test_against_pinocchio_rnea_derivatives(name):
    floating = ROBOTS[name]
    path = robot_path(name)
    system = from_urdf(path, floating_base=floating, limits=False)
    model = eomc.compile(system, f"{name}_id", functions=["jac_x", "inverse_dynamics", "jac_id"],
                         formulation="recursive", progress=False)
    ref = PinRef(path, joints_of(system), floating=floating)
    nq, nu = model.nq, model.nu
    rng = np.random.default_rng(30)
    for _ in range(4):
        q = rng.uniform(-np.pi, np.pi, nq)
        if floating:
            q[:3], q[3:6] = rng.normal(size=3), rng.uniform(-1.2, 1.2, 3)
        v, a = rng.normal(size=nu), rng.normal(size=nu)
        x = np.concatenate([q, v])
        J = model.jac_id(0.0, x, a)
        pin.computeRNEADerivatives(ref.model, ref.data, ref.q(q), ref.v(v), ref.v(a))
        iv = ref.iv
        dq, dv = ref.data.dtau_dq[np.ix_(iv, iv)], ref.data.dtau_dv[np.ix_(iv, iv)]
        K = model.jac_x(0.0, x)[:nq, nq:nq + nu]         # q' = K(q) u
        if not floating:
            assert np.array_equal(K, np.eye(nq))
        assert relative_error(J[:, nq:nq + nu], dv) < 1e-12
        assert relative_error(J[:, :nq] @ K, dq) < 1e-12
        assert relative_error(model.inverse_dynamics(0.0, x, a), ref.rnea(q, v, a)) < 1e-12


def test_generated_names_in_python():
    """Every generated function is reachable under its C name: jac_x, jac_r, constraints_jac
    (the older names stay)."""
    system, _ = cart_joints(2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(system, "names", functions=["jac_x", "jac_r"], progress=False)
    x = np.linspace(0.1, 0.6, model.nx)
    assert np.array_equal(model.jac_x(0.0, x), model.jacobian(0.0, x))
    assert np.array_equal(model.jac_r(0.0, x), model.input_jacobian(0.0, x))
    assert model.jac_r.__func__ is type(model).input_jacobian
    assert type(model).constraints_jac is type(model).constraints_jacobian
    with pytest.raises(ModelError, match="built without `jac_id`"):
        model.jac_id(0.0, x, np.zeros(model.nu))


def test_kane_refuses_naming_the_formulation():
    system, _ = cart_joints(2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(ModelError, match="jac_id .* recursive formulation only"):
            eomc.compile(system, "kid", functions=["jac_id"], formulation="kane", progress=False)
        system, _ = cart_joints(2)    # auto keeps the recursive form, which has it
        model = eomc.compile(system, "aid", functions=["rhs", "jac_id"], progress=False)
    assert model.metadata["formulation"] == "recursive" and "jac_id" in model.functions


def test_cython_backend_has_it():
    system, _ = cart_joints(2, rigid=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(system, "cyid", functions=["inverse_dynamics", "jac_id"],
                             formulation="recursive", backend="cython", progress=False)
    assert model.backend == "cython"
    assert worst_against_fd(model, seed=5) < 1e-7
