"""from_sympy: SymPy-formed KanesMethod / LagrangesMethod / System -> eomc's, re-formed.

The oracle is SymPy's own result: after conversion, eomc's re-derived
mass_matrix_full and forcing_full must agree numerically with the SymPy
object's, and ``formed()`` must work.
"""

import pytest
import sympy as sm
import sympy.physics.mechanics as sme

from helpers import lagrange_mechanisms as mechs
from helpers import lagrange_numeric as num
from helpers import zoo

import eomc.mechanics as em
from eomc.errors import ModelError
from eomc.compiler.mechanics import FormedSystem, KanesMethod, LagrangesMethod


def assert_converts(theirs, cls, extra=()):
    ours = em.from_sympy(theirs)
    assert isinstance(ours, cls)
    pairs = [("M_full", ours.mass_matrix_full, theirs.mass_matrix_full),
             ("f_full", ours.forcing_full, theirs.forcing_full)]
    pairs += [(name, getattr(ours, name), getattr(theirs, name)) for name in extra]
    num.assert_same_at_seeds(pairs, seeds=(0, 1))
    assert isinstance(ours.formed(), FormedSystem)
    return ours


@pytest.mark.parametrize("build", [
    mechs.particle_on_sphere, mechs.knife_edge, mechs.moving_support_pendulum,
    lambda me: zoo.n_link_pendulum_on_cart_lagrange(2, me)[0],
], ids=["sphere-hol", "knife-nonhol", "moving-support", "cart2"])
def test_lagrange_conversion(build):
    theirs = build(sme)
    ours = assert_converts(theirs, LagrangesMethod, extra=("eom",))
    assert ours.lam_vec == theirs.lam_vec
    assert ours._hol_coneqs == theirs._hol_coneqs
    assert ours.coneqs == theirs.coneqs


@pytest.mark.parametrize("build", [
    lambda me: zoo.n_link_pendulum_on_cart(2, me)[0],
    lambda me: zoo.heavy_top(me)[0],
    lambda me: zoo.four_bar(me)[0],
    lambda me: zoo.spring_damper_chain(3, me)[0],
    lambda me: zoo.rolling_disc(me)[0],
], ids=["cart2", "heavy-top", "four-bar", "chain", "rolling-disc"])
def test_kane_conversion(build):
    theirs = build(sme)
    ours = assert_converts(theirs, KanesMethod)
    assert list(ours.q) == list(theirs.q) and list(ours.u) == list(theirs.u)
    assert ours.kindiffdict().keys() == theirs.kindiffdict().keys()


def test_kane_conversion_with_auxiliary_speeds():
    theirs = zoo.rolling_disc_aux(sme)[0]
    ours = assert_converts(theirs, KanesMethod, extra=("auxiliary_eqs",))
    assert list(ours._uaux) == list(theirs._uaux)


def _prismatic_system(method):
    """SymPy's System docstring example: a damped mass on a spring, on a slider joint."""
    q, qd = sme.dynamicsymbols("q q'")
    m, k, b = sm.symbols("m k b")
    wall = sme.RigidBody("W")
    system = sme.System.from_newtonian(wall)
    bob = sme.Particle("P", mass=m)
    bob.potential_energy = k * q**2 / 2
    system.add_joints(sme.PrismaticJoint("J", wall, bob, q, qd))
    system.add_loads((bob.masscenter, b * qd * system.x))
    if method is not None:
        system.form_eoms(method)
    return system


@pytest.mark.parametrize("method, cls", [(sme.KanesMethod, KanesMethod),
                                         (sme.LagrangesMethod, LagrangesMethod)])
def test_system_conversion(method, cls):
    system = _prismatic_system(method)
    ours = em.from_sympy(system)
    assert isinstance(ours, cls)
    num.assert_same_at_seeds([("M_full", ours.mass_matrix_full, system.mass_matrix_full),
                              ("f_full", ours.forcing_full, system.forcing_full)], seeds=(0,))


def test_eomc_objects_pass_through():
    lm = mechs.knife_edge(em)
    assert em.from_sympy(lm) is lm


def test_bad_objects():
    with pytest.raises(ModelError, match="cannot convert int"):
        em.from_sympy(3)


def test_unformed_sympy_system_is_formed_by_eomc():
    """Issue 7: an unformed SymPy System converts (formed with eomc's Kane), untouched itself."""
    formed = _prismatic_system(sme.KanesMethod)
    unformed = _prismatic_system(None)
    ours = em.from_sympy(unformed)
    assert isinstance(ours, KanesMethod)
    assert unformed.eom_method is None
    num.assert_same_at_seeds([("M_full", ours.mass_matrix_full, formed.mass_matrix_full),
                              ("f_full", ours.forcing_full, formed.forcing_full)], seeds=(0, 1))
