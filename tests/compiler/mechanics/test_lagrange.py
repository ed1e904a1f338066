"""eomc's LagrangesMethod against sympy.physics.mechanics, numerically (1e-12 relative).

Each mechanism is built twice from the same description -- once with
``eomc.mechanics``, once with ``sympy.physics.mechanics`` -- and the mass
matrices, forcing vectors and equations are evaluated at random states.
"""

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as sme

from helpers import lagrange_mechanisms as mechs
from helpers import lagrange_numeric as num
from helpers import zoo

import eomc.mechanics as em
from eomc.compiler.mechanics import LagrangesMethod


def assert_matches_sympy(ours, theirs, seeds=(0, 1, 2)):
    assert isinstance(ours, LagrangesMethod)
    assert list(ours.q) == list(theirs.q)
    assert list(ours.lam_vec) == list(theirs.lam_vec)
    # mass_matrix/forcing are blocks of the full ones
    assert ours.mass_matrix == ours.mass_matrix_full[len(ours.q):2 * len(ours.q), len(ours.q):]
    num.assert_same_at_seeds([("M_full", ours.mass_matrix_full, theirs.mass_matrix_full),
                              ("f_full", ours.forcing_full, theirs.forcing_full),
                              ("eom", ours.eom, theirs.eom)], seeds)


@pytest.mark.parametrize("n", [1, 3])
def test_n_link_pendulum_on_cart(n):
    ours, spec = zoo.n_link_pendulum_on_cart_lagrange(n, em)
    theirs, _ = zoo.n_link_pendulum_on_cart_lagrange(n, sme)
    assert_matches_sympy(ours, theirs)
    assert ours.formed().inputs == tuple(spec)


def test_particle_on_sphere_with_multiplier():
    ours, theirs = mechs.particle_on_sphere(em), mechs.particle_on_sphere(sme)
    assert_matches_sympy(ours, theirs)
    assert ours.mass_matrix_full.shape == (7, 7)


def test_knife_edge_nonholonomic():
    ours, theirs = mechs.knife_edge(em), mechs.knife_edge(sme)
    assert_matches_sympy(ours, theirs)
    # the seed's coneqs= is the same thing as nonhol_coneqs=
    seed_style = mechs.knife_edge(em, use_seed_coneqs=True)
    assert_matches_sympy(seed_style, theirs, seeds=(3,))


def test_spring_damper_chain():
    ours, theirs = mechs.spring_damper_chain(4, em), mechs.spring_damper_chain(4, sme)
    assert_matches_sympy(ours, theirs)


def test_explicit_time_dependence():
    """L depends on t and on a specified h(t): the d2L/dq'dt term (h'', cos(w t))."""
    ours, theirs = mechs.moving_support_pendulum(em), mechs.moving_support_pendulum(sme)
    assert_matches_sympy(ours, theirs)
    h = sme.dynamicsymbols("h")
    assert ours.forcing.has(h.diff(sme.dynamicsymbols._t, 2))


def test_rigid_body_lagrangian():
    ours = mechs.spherical_pendulum_body(em)
    theirs = mechs.spherical_pendulum_body(sme)
    assert_matches_sympy(ours, theirs)
    vals = num.random_values([theirs._L], seed=5)
    num.assert_same(ours._L, theirs._L, vals, what="Lagrangian")


def test_seed_examples_match_sympy():
    q1, q2 = sme.dynamicsymbols("q1 q2")
    q1d, q2d = sme.dynamicsymbols("q1 q2", 1)
    L = q1d**2 + q2d**2
    ours = em.LagrangesMethod(L, [q1, q2], coneqs=[q1d - q2d])
    theirs = sme.LagrangesMethod(L, [q1, q2], nonhol_coneqs=[q1d - q2d])
    ours.form_lagranges_equations()
    theirs.form_lagranges_equations()
    assert ours.mass_matrix_full == theirs.mass_matrix_full
    assert ours.forcing_full == theirs.forcing_full
    assert ours.eom == theirs.eom


def test_rhs_matches_sympy():
    ours, theirs = mechs.knife_edge(em), mechs.knife_edge(sme)
    vals = num.random_values([theirs.mass_matrix_full, theirs.forcing_full], seed=7)
    num.assert_same(ours.rhs(), theirs.rhs(), vals, what="rhs")
    inv = ours.rhs(inv_method="LU")
    num.assert_same(inv, theirs.rhs(), vals, what="rhs(inv_method)")


def test_multiplier_sign_convention_on_a_resting_particle():
    """Particle resting at the bottom of the sphere: the constraint carries m g.

    C = d(constraint')/dq' = 2 (x, y, z) = (0, 0, -2R).  The rhs solves
    [m_d, -C^T; C, 0] [q''; mu] = [f_d; f_cd], so m_d q'' = f_d + C^T mu and
    C^T mu = (0, 0, m g) gives mu = -m g / (2 R); eom's lam (and
    solve_multipliers) is +m g / (2 R).
    """
    lm = mechs.particle_on_sphere(em)
    x, y, z = sme.dynamicsymbols("x y z")
    F = sme.dynamicsymbols("F")
    m, g, R, c = sm.symbols("m g R c", positive=True)
    t = sme.dynamicsymbols._t
    rest = {x: 0, y: 0, z: -R, F: 0}
    rest.update({s.diff(t): 0 for s in (x, y, z)})
    sol = lm.rhs().xreplace(rest)
    mu = sm.simplify(sol[-1])
    assert sm.simplify(mu + m * g / (2 * R)) == 0
    assert all(sm.simplify(e) == 0 for e in sol[:6])
    lam = lm.solve_multipliers(rest)
    assert sm.simplify(lam[lm.lam_vec[0]] - m * g / (2 * R)) == 0
    theirs = mechs.particle_on_sphere(sme).solve_multipliers(rest)
    assert sm.simplify(lam[lm.lam_vec[0]] - theirs[lm.lam_vec[0]]) == 0
    assert lm.solve_multipliers(rest, sol_type="Matrix").shape == (1, 1)


def test_formed_system():
    lm = mechs.particle_on_sphere(em)
    fs = lm.formed()
    x, y, z = sme.dynamicsymbols("x y z")
    t = sme.dynamicsymbols._t
    assert fs.method == "lagrange"
    assert fs.coordinates == (x, y, z)
    assert fs.speeds == (x.diff(t), y.diff(t), z.diff(t))
    assert fs.kinematics == sm.Matrix(fs.speeds)
    assert fs.dynamics_matrix == lm.mass_matrix_full[3:, 3:]
    assert fs.dynamics_rhs == lm.forcing_full[3:, :]
    assert fs.multipliers == tuple(lm.lam_vec)
    assert fs.holonomic_constraints == lm._hol_coneqs
    assert fs.velocity_constraints.shape == (1, 1)
    assert fs.inputs == (sme.dynamicsymbols("F"),)
    assert [p.name for p in fs.parameters] == ["R", "c", "g", "m"]
    assert fs.n_dependent_coordinates == fs.n_dependent_speeds == 0


def test_formed_system_accelerations_match_rhs():
    """Solving the FormedSystem numerically gives the same [q''; mu] as rhs()."""
    lm = mechs.knife_edge(em)
    fs = lm.formed()
    vals = num.random_values([lm.mass_matrix_full, lm.forcing_full], seed=11)
    A, b = num.evaluate(fs.dynamics_matrix, vals), num.evaluate(fs.dynamics_rhs, vals)
    full = num.evaluate(lm.rhs(), vals).ravel()
    assert np.allclose(np.linalg.solve(A, b).ravel(), full[3:], rtol=1e-12, atol=1e-12)


def test_attributes_like_sympy():
    lm = mechs.spring_damper_chain(2, em)
    assert lm.u == lm.q.diff(sme.dynamicsymbols._t)
    assert lm.forcelist is lm.loads
    assert lm.bodies is None
    assert lm.lam_vec == sm.Matrix()
    assert lm.coneqs == sm.Matrix()
    body = mechs.spherical_pendulum_body(em)
    assert len(body.bodies) == 1


def test_kinetic_energy_matches_sympy_without_orientation_path():
    """Velocity given in a frame with no DCM to the energy frame: SymPy's pairing is used."""
    v = sme.dynamicsymbols("v")
    m = sm.Symbol("m")
    N, B = sme.ReferenceFrame("N"), sme.ReferenceFrame("B")
    P = sme.Point("P")
    P.set_vel(N, v * B.x + 2 * v * B.y)
    pa = sme.Particle("pa", P, m)
    assert sm.expand(em.kinetic_energy(N, pa) - sme.kinetic_energy(N, pa)) == 0
    with pytest.raises(TypeError):
        em.kinetic_energy(N, P)
    with pytest.raises(TypeError):
        em.Lagrangian("N", pa)
