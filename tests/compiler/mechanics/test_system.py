"""eomc's System and JointsMethod (issue 7): SymPy 1.14's modelling API on eomc's formulation.

Oracles: SymPy 1.14 itself (the same script with SymPy's import forms its own
System; the state derivatives must agree at random states to 1e-12) and the
clear-error standard for bad joint trees and actuators.
"""
import pathlib
import warnings

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as sme

import eomc
import eomc.mechanics as em
from eomc.errors import ModelError, ModelFileError

EXAMPLES = pathlib.Path(__file__).resolve().parents[3] / "examples"
SYSTEM_EXAMPLES = ["cart_pole_system", "four_bar_system"]


def _run_example(name, mechanics, speeds_are_rates=False):
    src = (EXAMPLES / f"{name}.py").read_text()
    if speeds_are_rates:      # Lagrange's method needs u = q'
        old = 'u_cart, u_pole = dynamicsymbols("u_cart u_pole")'
        assert old in src
        src = src.replace(old, 'u_cart, u_pole = dynamicsymbols("q_cart q_pole", 1)')
        src = src.replace("system.validate_system()", "system.validate_system(LagrangesMethod)")
        src = src.replace("from eomc.mechanics import (", "from eomc.mechanics import (LagrangesMethod, ")
    if mechanics == "sympy":
        src = src.replace("from eomc.mechanics import", "from sympy.physics.mechanics import")
    ns = {"__name__": f"example_{name}"}
    exec(compile(src, str(EXAMPLES / f"{name}.py"), "exec"), ns)
    return ns


def _sympy_xdot(ns, x, r):
    """SymPy's own M_full \\ f_full at state x (SymPy's q, u order) and inputs r."""
    system = ns["system"]
    system.form_eoms(constraint_solver="CRAMER")
    states = list(system.q) + list(system.u)
    args = states + list(ns["inputs"])
    subs = {k: v for k, v in ns["parameters"].items()}
    M = sm.lambdify(args, system.mass_matrix_full.xreplace(subs), "numpy")
    f = sm.lambdify(args, system.forcing_full.xreplace(subs), "numpy")
    return states, np.linalg.solve(np.array(M(*x, *r), float), np.array(f(*x, *r), float).ravel())


def test_all_of_sympys_public_names_are_offered():
    assert set(sme.__all__) <= set(em.__all__)
    for name in ("PinJoint", "LinearPathway", "WrappingCylinder", "Inertia", "SymbolicSystem"):
        assert getattr(em, name) is getattr(sme, name)   # kinematic objects: SymPy's own
    assert em.System is not sme.System and issubclass(em.System, sme.System)
    assert em.JointsMethod is not sme.JointsMethod


@pytest.mark.parametrize("name", SYSTEM_EXAMPLES)
def test_example_builds_and_agrees_with_sympy(name, tmp_path):
    ours = _run_example(name, "eomc")
    assert isinstance(ours["system"], em.System)
    model = eomc.compile(EXAMPLES / f"{name}.py", cache_dir=tmp_path, progress=False)
    theirs = _run_example(name, "sympy")
    rng = np.random.default_rng(7)
    by_name = dict(zip(model.state_names, range(model.nx)))
    for _ in range(4):
        if name == "four_bar_system":       # consistent states: the parallelogram's closed form
            a, w = rng.uniform(-2.5, -0.6), rng.normal()
            x_sympy = [a, np.pi - a, a, w, -w, w]
        else:
            x_sympy = list(rng.normal(size=4))
        r = list(rng.normal(size=len(theirs["inputs"])))
        states, want = _sympy_xdot(theirs, x_sympy, r)
        x = np.zeros(model.nx)
        for s, v in zip(states, x_sympy):
            x[by_name[s.name]] = v
        got = model.rhs(0.0, x, r=np.array(r))
        got = np.array([got[by_name[s.name]] for s in states])
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12 * max(1.0, abs(want).max()))


def test_system_forms_with_eomcs_methods_and_lagrange_agrees():
    kane_ns = _run_example("cart_pole_system", "eomc")
    kane_ns["system"].form_eoms()
    assert isinstance(kane_ns["system"].eom_method, em.KanesMethod)
    lag_ns = _run_example("cart_pole_system", "eomc", speeds_are_rates=True)
    lag_ns["system"].form_eoms(eom_method=sme.LagrangesMethod)      # SymPy's class selects eomc's
    assert isinstance(lag_ns["system"].eom_method, em.LagrangesMethod)
    values = [0.1, 0.4, 0.7, -0.4]
    results = []
    for ns in (kane_ns, lag_ns):
        system = ns["system"]
        sub = dict(zip(list(system.q) + list(system.u), values))
        sub.update({**ns["parameters"], ns["inputs"][0]: 1.5, ns["inputs"][1]: -0.5})
        results.append(np.array(system.rhs().xreplace(sub).evalf(), float).ravel())
    np.testing.assert_allclose(results[0], results[1], rtol=1e-12)


def test_system_linearize_matches_sympys():
    ours = _run_example("cart_pole_system", "eomc")["system"]
    theirs = _run_example("cart_pole_system", "sympy")["system"]
    ours.form_eoms()
    theirs.form_eoms()
    op = {s: 0 for s in list(ours.q) + list(ours.u)}
    A1, B1, r1 = ours.eom_method.linearize(op_point=op, A_and_B=True)
    A2, B2, r2 = theirs.eom_method.linearize(op_point=op, A_and_B=True)
    assert list(r1) == list(r2)
    for X, Y in ((A1, A2), (B1, B2)):
        assert sm.simplify(X - Y) == sm.zeros(*X.shape)


def test_unformed_sympy_system_compiles(tmp_path):
    theirs = _run_example("four_bar_system", "sympy")
    model = eomc.compile(theirs["system"], parameters=theirs["parameters"], cache_dir=tmp_path,
                         progress=False)
    assert theirs["system"].eom_method is None          # the user's object is not touched
    assert model.nx == 6 and model.input_names == ("T",)


def test_joints_method_uses_eomcs_kane():
    q, u = sme.dynamicsymbols("q u")
    m, k = sm.symbols("m k")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        wall, bob = em.Body("W"), em.Body("B", mass=m)
        joint = em.PrismaticJoint("J", wall, bob, q, u)
        bob.apply_force(-k * q * wall.x)
        method = em.JointsMethod(wall, joint)
    method.form_eoms()
    assert isinstance(method.method, em.KanesMethod)
    assert method.rhs()[1] == -k * q / m


# -- bad input: clear errors naming the joint / body / actuator --------------------------

def _links(n):
    return [em.RigidBody(f"b{i}", mass=1) for i in range(n)]


def test_body_attached_twice_is_named():
    g, a, b = _links(3)
    system = em.System.from_newtonian(g)
    system.add_joints(em.PinJoint("J1", g, a))
    with pytest.raises(ModelError, match=r"joint J2: body b1 is already attached as the child "
                                         r"of joint J1"):
        system.add_joints(em.PinJoint("J2", b, a))


def test_loop_of_joints_is_named():
    g, a, b, c = _links(4)
    system = em.System.from_newtonian(g)
    system.add_joints(em.PinJoint("J1", g, a), em.PinJoint("J2", a, b))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")     # SymPy warns of the frames' loop, then goes on
        closing = em.PinJoint("J3", b, g)
    with pytest.raises(ModelError, match=r"joint J3: its child b0 is the system's Newtonian"):
        system.add_joints(closing)
    other = em.System()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")     # SymPy warns of the frames' loop, then goes on
        ring = [em.PinJoint("K1", a, b), em.PinJoint("K2", b, c), em.PinJoint("K3", c, a)]
    with pytest.raises(ModelError, match=r"joint K3: attaching b1 to b3 closes a loop of joints"):
        other.add_joints(*ring)


def test_shared_coordinate_is_named():
    g, a, b = _links(3)
    q, u1, u2 = sme.dynamicsymbols("q u1 u2")
    system = em.System.from_newtonian(g)
    system.add_joints(em.PinJoint("J1", g, a, q, u1))
    with pytest.raises(ModelError, match=r"joint J2: its coordinate q is already the coordinate "
                                         r"of joint J1"):
        system.add_joints(em.PinJoint("J2", a, b, q, u2))


def test_actuator_on_point_without_velocity_is_named():
    g, a = _links(2)
    system = em.System.from_newtonian(g)
    system.add_joints(em.PinJoint("J1", g, a))
    free = em.Point("free")                       # attached to nothing with a velocity
    tip = free.locatenew("tip", sm.Symbol("l") * g.x)
    system.add_actuators(em.LinearSpring(sm.Symbol("k"), em.LinearPathway(free, tip)))
    with pytest.raises(ModelError, match=r"actuator LinearSpring\(.*\) acts on point free, whose "
                                         r"velocity in the inertial frame .* is undefined"):
        system.form_eoms()
    unconnected = em.System.from_newtonian(g)
    unconnected.add_joints(em.PinJoint("J1", g, a))
    unconnected.add_actuators(em.ForceActuator(sm.Symbol("F"), em.LinearPathway(free, a.masscenter)))
    with pytest.raises(ModelError, match=r"actuator ForceActuator\(.*\): its loads cannot be formed "
                                         r"\(ValueError: No Connecting Path"):
        unconnected.form_eoms()


def test_model_file_system_errors_point_at_the_file(tmp_path):
    path = tmp_path / "bad.py"
    path.write_text(
        "from eomc.mechanics import *\n"
        "g, a, b = RigidBody('g'), RigidBody('a', mass=1), RigidBody('b', mass=1)\n"
        "system = System.from_newtonian(g)\n"
        "system.add_joints(PinJoint('J1', g, a))\n"
        "system.add_joints(PinJoint('J2', b, a))\n")
    with pytest.raises(ModelFileError, match=r"bad.py:5: joint J2: body a is already attached"):
        eomc.compile(path, cache_dir=tmp_path, progress=False)


def test_cli_simulates_a_system_model_file(tmp_path, capsys, monkeypatch):
    """`eomc simulate` on a model file whose `system` is a System (closed loop: residual shown)."""
    from eomc.cli import main
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    out = tmp_path / "traj.csv"
    code = main(["simulate", str(EXAMPLES / "four_bar_system.py"), "--t-final", "0.5", "-o", str(out)])
    assert code == 0
    text = capsys.readouterr().out
    assert "four_bar_system:" in text and "constraint residual" in text
    header = out.read_text().splitlines()[0].split(",")
    assert header[:7] == ["t", "q1", "q2", "q3", "u1", "u2", "u3"]


def _wrapped_pendulum(me):
    """A rotor about z whose bob is tied to a fixed anchor by a Duffing spring and a damper
    wrapping around a cylinder (WrappingPathway), plus a ForceActuator input on the same path."""
    q, u, F = me.dynamicsymbols("q u F")
    r, m, k1, k3, c, L0 = sm.symbols("r m k1 k3 c L0", positive=True)
    ground = me.RigidBody("ground")
    rotor = me.RigidBody("rotor", mass=m)
    rotor.inertia = me.Inertia.from_inertia_scalars(rotor.masscenter, rotor.frame, 0, 0, m * r**2 / 2)
    system = me.System.from_newtonian(ground)
    system.add_joints(me.PinJoint("hinge", ground, rotor, q, u, joint_axis=ground.z))
    bob = me.Particle("bob", mass=m)
    bob.masscenter.set_pos(rotor.masscenter, r * rotor.x)
    bob.masscenter.v2pt_theory(rotor.masscenter, ground.frame, rotor.frame)
    system.add_bodies(bob)
    anchor = ground.masscenter.locatenew("anchor", r * ground.x)
    anchor.set_vel(ground.frame, 0)
    path = me.WrappingPathway(anchor, bob.masscenter,
                              me.WrappingCylinder(r, ground.masscenter, ground.z))
    system.add_actuators(me.DuffingSpring(k1, k3, path, L0), me.LinearDamper(c, path),
                         me.ForceActuator(F, path))
    return system, {r: 0.5, m: 1.3, k1: 4.0, k3: 0.7, c: 0.2, L0: 0.1, q: 0.9, u: 0.4, F: 0.3}


def test_wrapping_pathway_duffing_spring_and_damper_agree_with_sympy():
    values = []
    for me in (em, sme):
        system, point = _wrapped_pendulum(me)
        system.form_eoms()
        assert isinstance(system.eom_method, em.KanesMethod if me is em else sme.KanesMethod)
        values.append(np.array(sme.msubs(system.rhs(), point).evalf(), float).ravel())
    np.testing.assert_allclose(values[0], values[1], rtol=1e-12)
    assert abs(values[0][1]) > 1e-3      # the actuators do act
