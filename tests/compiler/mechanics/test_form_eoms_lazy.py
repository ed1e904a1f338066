"""eomc's ``System.form_eoms()`` records Kane's equations and forms them when first read.

A model file in SymPy's documented style calls ``system.form_eoms()``; when the build then
takes the recursive formulation it must not pay for Kane's equations (issue 19).  SymPy's
API holds: the return value is the equations (a Matrix) as soon as anything reads it, and
SymPy 1.14's own System tests pass with eomc's classes (tests/compiler/mechanics/
test_sympy_suite.py).  Small systems: about ten seconds in all.
"""
import pickle

import numpy as np
import sympy as sm
from sympy.physics import mechanics as sme

import eomc
from eomc import mechanics as me
from eomc.compiler.driver import generate
from eomc.compiler.mechanics.system import EquationsOnUse


def _cart(mech, n):
    """The n-link cart on a slider (cart_rel_joints.py) with ``mech``'s System and joints."""
    q, u = mech.dynamicsymbols(f"q:{n + 1}"), mech.dynamicsymbols(f"u:{n + 1}")
    m0, m, l, g = sm.symbols("m0 m l g", positive=True)
    F = mech.dynamicsymbols("F")
    ground = mech.RigidBody("ground")
    cart = mech.RigidBody("cart", mass=m0)
    cart.inertia = (mech.inertia(cart.frame, 0, 0, 0), cart.masscenter)
    joints = [mech.PrismaticJoint("slider", ground, cart, q[0], u[0], joint_axis=ground.frame.x)]
    parent = cart
    for i in range(1, n + 1):
        link = mech.RigidBody(f"link{i}", mass=m)
        link.inertia = (mech.inertia(link.frame, 0, 0, 0), link.masscenter)
        joints.append(mech.PinJoint(f"pin{i}", parent, link, q[i], u[i], parent_point=parent.masscenter,
                                    child_point=l * link.frame.y, joint_axis=parent.frame.z))
        parent = link
    system = mech.System.from_newtonian(ground)
    system.add_joints(*joints)
    system.apply_uniform_gravity(-g * ground.frame.y)
    system.add_loads(mech.Force(cart.masscenter, F * ground.frame.x))
    return system, {m0: 2.0, m: 0.5, l: 0.75, g: 9.81}, [F]


def _numbers(expr, seed=3):
    rng = np.random.default_rng(seed)
    atoms = sorted(expr.free_symbols | expr.atoms(sm.core.function.AppliedUndef)
                   | expr.atoms(sm.Derivative), key=str)
    values = {a: rng.uniform(0.3, 1.2) for a in atoms if a != sme.dynamicsymbols._t}
    return np.array(sm.Matrix(expr).xreplace(values).evalf(), dtype=float)


def test_form_eoms_returns_the_equations_formed_when_read():
    system, _, _ = _cart(me, 2)
    eoms = system.form_eoms()
    assert isinstance(eoms, sm.Matrix) and isinstance(eoms, EquationsOnUse)
    assert not eoms.is_formed and not system.eom_method.is_formed and system.kane_pending()
    assert eoms.shape == (3, 1)                      # reading it forms it
    assert eoms.is_formed and system.eom_method.is_formed and not system.kane_pending()
    reference, _, _ = _cart(sme, 2)                  # SymPy's own System and KanesMethod
    expected = reference.form_eoms()
    # the same equations (eomc's Kane writes them in its own form): equal at random numbers,
    # accelerations included (Derivative(u, t) are symbols here)
    assert np.allclose(_numbers(eoms - expected), 0, atol=1e-12)
    assert type(eoms + eoms) is sm.MutableDenseMatrix and "Matrix([[" in str(eoms)
    again = pickle.loads(pickle.dumps(eoms))
    assert type(again) is sm.MutableDenseMatrix and again == eoms


def test_each_reading_forms_the_pending_equations():
    for read in (lambda e: e[0], lambda e: list(e), lambda e: e.xreplace({}), lambda e: repr(e),
                 lambda e: e.rows, lambda e: sm.ImmutableMatrix(e)):
        system, _, _ = _cart(me, 1)
        eoms = system.form_eoms()
        read(eoms)
        assert system.eom_method.is_formed and eoms.is_formed


def test_a_system_changed_after_form_eoms_is_not_read_as_pending():
    system, _, _ = _cart(me, 1)
    system.form_eoms()
    assert system.kane_pending()
    system.add_loads(me.Force(system.bodies[1].masscenter, sm.Symbol("k") * system.frame.x))
    assert not system.kane_pending()                 # the recorded equations miss that load


def test_recursive_build_of_a_form_eoms_file_forms_no_kane_and_agrees(tmp_path):
    """auto takes the recursive form from the joints; Kane's equations stay unformed.  Its rhs
    equals the Kane build's of the same System (formed when the kane build reads it)."""
    system, parameters, inputs = _cart(me, 7)          # 8 speeds: past auto's Kane range
    system.form_eoms()
    spec, generated = generate(system, "cart7", parameters=parameters, inputs=inputs,
                               functions=["rhs"], progress=False, use_cache=False)
    assert generated.metadata["formulation"] == "recursive"
    assert not system.eom_method.is_formed, "auto formed Kane's equations it did not use"
    small, parameters, inputs = _cart(me, 2)
    small.form_eoms()
    models = {f: eomc.compile(small, f"cart2{f}", parameters=parameters, inputs=inputs,
                              functions=["rhs"], formulation=f, cache_dir=tmp_path, progress=False)
              for f in ("recursive", "kane")}
    assert small.eom_method.is_formed                # the kane build read them
    rng = np.random.default_rng(5)
    for _ in range(3):
        x, r = rng.normal(size=6), rng.normal(size=1)
        a, b = (models[f].rhs(0.0, x, r=r) for f in ("recursive", "kane"))
        assert np.max(np.abs(a - b)) <= 1e-12 * max(1.0, np.max(np.abs(b)))


def test_a_load_without_a_velocity_is_named_when_the_equations_are_read():
    """form_eoms() leaves the velocities (SymPy's frame-graph search) to forming: a load on a
    point with none is still a ModelError naming it, when the equations are first read."""
    from eomc.errors import ModelError
    import pytest
    system, _, _ = _cart(me, 1)
    loose = me.Point("loose")
    system.add_loads(me.Force(loose, system.frame.x))
    eoms = system.form_eoms()
    with pytest.raises(ModelError, match=r"load #\d+ on point loose: the velocity of point loose"):
        eoms.shape
    with pytest.raises(ModelError, match="point loose"):      # still pending: said again
        system.mass_matrix
