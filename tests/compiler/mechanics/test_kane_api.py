"""SymPy 1.14 / seed API surface of eomc's KanesMethod."""

import pytest
import sympy as sm
import sympy.physics.mechanics as sme

from helpers import zoo
from helpers.kane_oracle import assert_close, evaluate, random_point

import eomc.mechanics as em
from eomc.errors import ModelError


def _cart(me):
    parts = zoo.n_link_pendulum_on_cart_kinematics(2, me)
    return parts


def test_argument_orders_and_construction_time_lists_agree():
    p = _cart(em)
    args = (p["frame"],)
    kw = dict(q_ind=p["q"], u_ind=p["u"], kd_eqs=p["kd_eqs"])
    a = em.KanesMethod(*args, **kw)
    a.kanes_equations(p["bodies"], p["loads"])               # SymPy 1.14 order
    b = em.KanesMethod(*args, **kw)
    b.kanes_equations(p["loads"], p["bodies"])               # the seed's order
    c = em.KanesMethod(*args, bodies=p["bodies"], forcelist=p["loads"], **kw)
    fr, frstar = c.kanes_equations()                         # given at construction
    d = em.KanesMethod(*args, **kw)
    d.kanes_equations(loads=p["loads"], bodies=p["bodies"])  # keywords
    for km in (b, c, d):
        assert km.mass_matrix_full == a.mass_matrix_full
        assert km.forcing_full == a.forcing_full
    assert (fr, frstar) == (c.fr, c.frstar)
    assert c.bodies == p["bodies"] and c.loads == p["loads"] and c.forcelist == p["loads"]


def test_force_and_torque_objects_are_loads():
    p = _cart(em)
    loads = [em.Force(pt, v) if isinstance(pt, em.Point) else em.Torque(pt, v)
             for pt, v in p["loads"]]
    a = em.KanesMethod(p["frame"], p["q"], p["u"], p["kd_eqs"])
    a.kanes_equations(p["bodies"], p["loads"])
    b = em.KanesMethod(p["frame"], p["q"], p["u"], p["kd_eqs"])
    b.kanes_equations(p["bodies"], loads)
    assert a.forcing == b.forcing


def test_implicit_kinematics_match_sympy():
    ours, _ = zoo.heavy_top(em)
    ref, _ = zoo.heavy_top(sme)
    for km in (ours, ref):
        km.explicit_kinematics = False
    mats = [ours.mass_matrix_full, ref.mass_matrix_full, ours.forcing_full, ref.forcing_full]
    pt = random_point(mats, 21)
    assert_close(evaluate(mats[0], pt), evaluate(mats[1], pt), what="implicit M_full")
    assert_close(evaluate(mats[2], pt), evaluate(mats[3], pt), what="implicit f_full")


def test_formed_system_contents():
    km, (F,) = zoo.spring_damper_chain(3, em)
    f = km.formed()
    assert f.method == "kane" and f.multipliers == ()
    assert f.coordinates == tuple(km.q) and f.speeds == tuple(km.u)
    assert f.kinematics == sm.Matrix(km.u)
    assert f.dynamics_matrix == km.mass_matrix and f.dynamics_rhs == km.forcing
    assert f.inputs == (F,)
    assert [s.name for s in f.parameters] == sorted(s.name for s in f.parameters)
    assert {s.name for s in f.parameters} == {"c1", "c2", "c3", "k1", "k2", "k3", "m1", "m2", "m3"}
    assert f.holonomic_constraints.shape == (0, 1) and f.velocity_constraints.shape == (0, 1)


def test_formed_system_drops_auxiliary_speeds():
    km, _ = zoo.rolling_disc_aux(em)
    f = km.formed()
    aux = set(sme.dynamicsymbols("u4:7"))
    for mat in (f.dynamics_matrix, f.dynamics_rhs, f.kinematics):
        assert not (sme.find_dynamicsymbols(mat) & aux)
    assert f.inputs == ()


def test_kindiffdict_heavy_top_is_not_identity():
    km, _ = zoo.heavy_top(em)
    kd = km.kindiffdict()
    assert set(kd) == {q.diff() for q in km.q}
    assert any(v not in km.u for v in kd.values())


def test_bare_linearize_rejects_inputs_in_the_mass_matrix():
    N = em.ReferenceFrame("N")
    q, u, k = em.dynamicsymbols("q u k")
    P = em.Point("P")
    P.set_vel(N, u * N.x)
    km = em.KanesMethod(N, [q], [u], [q.diff() - u])
    km.kanes_equations([em.Particle("Pa", P, k)], [(P, N.x)])
    with pytest.raises(ModelError, match="input.*k.*mass"):
        km.linearize()


def test_auxiliary_eqs_need_auxiliary_speeds():
    km, _ = zoo.spring_damper_chain(1, em)
    with pytest.raises(ModelError, match="no auxiliary speeds"):
        km.auxiliary_eqs


def test_speeds_only_system_needs_no_kinematic_equations():
    N = em.ReferenceFrame("N")
    u = em.dynamicsymbols("u")
    P = em.Point("P")
    P.set_vel(N, u * N.x)
    km = em.KanesMethod(N, [], [u])
    km.kanes_equations([em.Particle("Pa", P, 2)], [(P, 3 * N.x)])
    assert km.rhs() == sm.Matrix([sm.Rational(3, 2)])
    f = km.formed()
    assert f.kinematics.shape == (0, 1) and f.nq == 0 and f.nu == 1
