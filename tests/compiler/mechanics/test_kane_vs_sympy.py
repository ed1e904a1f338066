"""eomc's KanesMethod against sympy.physics.mechanics.KanesMethod, numerically.

Each zoo mechanism is formed twice, once per mechanics module, and
mass_matrix_full, forcing_full and rhs() must agree to 1e-12 (relative) at
random states and parameter values.
"""

import pytest
import sympy as sm
import sympy.physics.mechanics as sme

from helpers import zoo
from helpers.kane_oracle import assert_close, compare_kane, evaluate, random_point

import eomc.mechanics as em
from eomc.compiler.mechanics.kane import KanesMethod


def both(builder):
    ours, _ = builder(em)
    ref, _ = builder(sme)
    assert isinstance(ours, KanesMethod)
    assert not isinstance(ref, KanesMethod)
    return ours, ref


@pytest.mark.parametrize("n", [1, 2, 3, 5, 8])
def test_n_link_pendulum_on_cart(n):
    ours, ref = both(lambda me: zoo.n_link_pendulum_on_cart(n, me, joint_torques=True))
    compare_kane(ours, ref, seeds=(n,), rhs=n <= 3)
    assert ours.fr.shape == ref._fr.shape


def test_heavy_top():
    ours, ref = both(zoo.heavy_top)
    compare_kane(ours, ref, seeds=(3, 4))
    assert ours.formed().inputs == (sme.dynamicsymbols("T"),)


def test_rolling_disc_nonholonomic():
    ours, ref = both(zoo.rolling_disc)
    compare_kane(ours, ref, seeds=(5,), rhs=False)
    # rhs() of the full 6-speed system: compare the solved u' numerically.
    pt = random_point([ours.mass_matrix, ours.forcing, ref.mass_matrix, ref.forcing], 6)
    for km in (ours, ref):
        km._num = evaluate(km.mass_matrix, pt).LUsolve(evaluate(km.forcing, pt))
    assert_close(ours._num, ref._num, what="u'")
    assert ours.mass_matrix.shape == (6, 6)


def test_rolling_disc_auxiliary_speeds():
    ours, ref = both(zoo.rolling_disc_aux)
    compare_kane(ours, ref, seeds=(7, 8))
    pt = random_point([ours.auxiliary_eqs, ref.auxiliary_eqs, ours.fr, ref._fr, ours.frstar, ref._frstar], 9)
    assert_close(evaluate(ours.auxiliary_eqs, pt), evaluate(ref.auxiliary_eqs, pt), what="aux")
    assert_close(evaluate(ours.fr, pt), evaluate(ref._fr, pt), what="fr")
    assert_close(evaluate(ours.frstar, pt), evaluate(ref._frstar, pt), what="frstar")


def test_four_bar_dependent_coordinates_and_speeds():
    ours, ref = both(zoo.four_bar)
    compare_kane(ours, ref, seeds=(10, 11))
    f = ours.formed()
    assert f.n_dependent_coordinates == 2 and f.n_dependent_speeds == 2
    assert f.holonomic_constraints.shape == (2, 1)
    assert f.velocity_constraints.shape == (2, 1)


@pytest.mark.parametrize("n", [1, 4])
def test_spring_damper_chain(n):
    ours, ref = both(lambda me: zoo.spring_damper_chain(n, me))
    compare_kane(ours, ref, seeds=(12,))
    pt = random_point([ours.fr, ref._fr, ours.frstar, ref._frstar], 13)
    assert_close(evaluate(ours.fr, pt), evaluate(ref._fr, pt), what="fr")
    assert_close(evaluate(ours.frstar, pt), evaluate(ref._frstar, pt), what="frstar")


def test_per_body_contributions_sum_to_fr_and_frstar():
    ours, _ = zoo.four_bar(em)
    gaf = ours.generalized_active_forces_by_body()
    gif = ours.generalized_inertia_forces_by_body()
    assert set(gif) == {"Link1", "Link2", "Link3"}
    assert "L1" in gaf and "G1" in gaf
    tot_f = sum(gaf.values(), sm.zeros(*ours.fr.shape))
    tot_s = sum(gif.values(), sm.zeros(*ours.frstar.shape))
    pt = random_point([ours.fr, ours.frstar, tot_f, tot_s], 14)
    assert_close(evaluate(tot_f, pt), evaluate(ours.fr, pt), what="sum GAF")
    assert_close(evaluate(tot_s, pt), evaluate(ours.frstar, pt), what="sum GIF")


def _wheel_without_orientation(me):
    """A body whose frame has an angular velocity but no orientation (SymPy's
    bicycle does this for its wheels); its inertia is written in a carrier frame."""
    q1, q2 = me.dynamicsymbols("q1 q2")
    u1, u2 = me.dynamicsymbols("u1 u2")
    m, d, g = sm.symbols("m d g")
    Ixx, Iyy, Izz, Ixy, Iyz = sm.symbols("Ixx Iyy Izz Ixy Iyz")
    N = me.ReferenceFrame("N")
    A = N.orientnew("A", "Axis", [q1, N.z])
    A.set_ang_vel(N, u1 * N.z)
    W = me.ReferenceFrame("W")
    W.set_ang_vel(A, u2 * A.y)
    O = me.Point("O")
    O.set_vel(N, 0)
    G = O.locatenew("G", d * A.x)
    G.v2pt_theory(O, N, A)
    wheel = me.RigidBody("Wheel", G, W, m, (me.inertia(A, Ixx, Iyy, Izz, Ixy, Iyz), G))
    km = me.KanesMethod(N, [q1, q2], [u1, u2], kd_eqs=[q1.diff() - u1, q2.diff() - u2])
    km.kanes_equations([wheel], [(G, -m * g * N.x), (W, sm.Symbol("T") * A.y)])
    return km, []


def test_body_frame_with_angular_velocity_only():
    ours, ref = both(_wheel_without_orientation)
    compare_kane(ours, ref, seeds=(15, 16))


def _aux_in_constraint(me):
    """A dependent speed whose constraint involves an auxiliary speed."""
    q1, q2 = me.dynamicsymbols("q1 q2")
    u1, u2, u3 = me.dynamicsymbols("u1 u2 u3")
    m, k, c, f = sm.symbols("m k c f")
    N = me.ReferenceFrame("N")
    A = N.orientnew("A", "Axis", [q2, N.z])
    O = me.Point("O")
    P = O.locatenew("P", q1 * N.x)
    P.set_vel(N, u1 * N.x + u2 * A.y + u3 * A.z)
    km = me.KanesMethod(N, [q1, q2], [u1], kd_eqs=[q1.diff() - u1, q2.diff() - u2],
                        u_dependent=[u2], velocity_constraints=[u2 - sm.cos(q2) * u1 - u3],
                        u_auxiliary=[u3])
    km.kanes_equations([me.Particle("Pa", P, m)],
                       [(P, -k * q1 * N.x - c * P.vel(N)), (P, f * A.z)])
    return km, []


def test_auxiliary_speed_inside_a_velocity_constraint():
    ours, ref = both(_aux_in_constraint)
    mats = [ours.auxiliary_eqs, ref.auxiliary_eqs, ours.fr, ref._fr, ours.frstar, ref._frstar]
    pt = random_point(mats, 17)
    for i, name in ((0, "aux"), (2, "fr"), (4, "frstar")):
        assert_close(evaluate(mats[i], pt), evaluate(mats[i + 1], pt), what=name)
