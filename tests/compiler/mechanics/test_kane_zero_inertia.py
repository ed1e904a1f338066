"""Issue 8, bad input: a joint whose speed meets no inertia is a ModelError naming the joint.

(a massless link with nothing beyond it, a point mass on its own pin axis, a slider of
zero mass carrying nothing) -- before any C is compiled, in the Kane and the recursive
formulation; a mass that is zero only at run time gives a "singular" status.
"""
import numpy as np
import pytest
import sympy as sm

import eomc
import eomc.mechanics as em
from eomc.compiler.driver import generate
from eomc.errors import ModelError
from helpers.trees import cart_joints


def _massless_tip():
    q1, q2, u1, u2 = em.dynamicsymbols("q1 q2 u1 u2")
    m, l, g = sm.symbols("m l g", positive=True)
    ground = em.RigidBody("ground")
    upper = em.RigidBody("upper", mass=m)
    upper.inertia = (em.inertia(upper.frame, 0, 0, 0), upper.masscenter)
    tip = em.RigidBody("tip", mass=0)
    tip.inertia = (em.inertia(tip.frame, 0, 0, 0), tip.masscenter)
    j1 = em.PinJoint("shoulder", ground, upper, q1, u1, child_point=l * upper.frame.y,
                     joint_axis=ground.frame.z)
    j2 = em.PinJoint("elbow", upper, tip, q2, u2, parent_point=-l * upper.frame.y,
                     child_point=l * tip.frame.y, joint_axis=upper.frame.z)
    system = em.System.from_newtonian(ground)
    system.add_joints(j1, j2)
    system.apply_uniform_gravity(-g * ground.frame.y)
    return system, "elbow", "tip"


def _mass_on_its_axis():
    q, u = em.dynamicsymbols("q u")
    m, g = sm.symbols("m g", positive=True)
    ground = em.RigidBody("ground")
    bob = em.RigidBody("bob", mass=m)
    bob.inertia = (em.inertia(bob.frame, 0, 0, 0), bob.masscenter)
    system = em.System.from_newtonian(ground)
    system.add_joints(em.PinJoint("pin", ground, bob, q, u, joint_axis=ground.frame.z))
    system.apply_uniform_gravity(-g * ground.frame.y)
    return system, "pin", "bob"


def _massless_slider():
    q, u = em.dynamicsymbols("q u")
    k = sm.symbols("k", positive=True)
    ground = em.RigidBody("ground")
    cart = em.RigidBody("cart", mass=0)
    cart.inertia = (em.inertia(cart.frame, 0, 0, 0), cart.masscenter)
    system = em.System.from_newtonian(ground)
    system.add_joints(em.PrismaticJoint("slider", ground, cart, q, u, joint_axis=ground.frame.x))
    system.add_loads(em.Force(cart.masscenter, -k * q * ground.frame.x))
    return system, "slider", "cart"


CASES = [_massless_tip, _mass_on_its_axis, _massless_slider]

pytestmark = pytest.mark.filterwarnings("ignore::eomc.errors.EomcWarning")   # no parameters dicts


@pytest.mark.parametrize("make", CASES)
@pytest.mark.parametrize("formulation", ["kane", "recursive", "auto"])
def test_no_inertia_about_a_free_axis_names_the_joint(make, formulation):
    system, joint, body = make()
    with pytest.raises(ModelError) as info:
        generate(system, "m", functions=["rhs"], formulation=formulation, use_cache=False,
                 progress=False)
    msg = str(info.value)
    assert f"joint {joint}" in msg and body in msg and "no inertia" in msg


def test_kane_names_the_speed_and_bodies_without_joints():
    """A hand-built KanesMethod has no joints: the message names the speed and the body."""
    q1, q2, u1, u2 = em.dynamicsymbols("q1 q2 u1 u2")
    m, l = sm.symbols("m l", positive=True)
    N = em.ReferenceFrame("N")
    O = em.Point("O")
    O.set_vel(N, 0)
    A = N.orientnew("A", "Axis", [q1, N.z])
    A.set_ang_vel(N, u1 * N.z)
    B = N.orientnew("B", "Axis", [q1 + q2, N.z])
    B.set_ang_vel(N, (u1 + u2) * N.z)
    P1 = O.locatenew("P1", l * A.x)
    P1.v2pt_theory(O, N, A)
    P2 = P1.locatenew("P2", l * B.x)
    P2.v2pt_theory(P1, N, B)
    km = em.KanesMethod(N, [q1, q2], [u1, u2], kd_eqs=[q1.diff() - u1, q2.diff() - u2])
    km.kanes_equations([em.Particle("heavy", P1, m), em.Particle("ghost", P2, 0)], [])
    with pytest.raises(ModelError, match=r"speed u2 has no inertia: body ghost moves with it"):
        km.formed()
    assert km.mass_matrix[0, 0] != 0    # the equations themselves are still SymPy's to inspect


def test_zero_mass_at_run_time_is_a_singular_status_in_kane(tmp_path, monkeypatch):
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    system, _ = cart_joints(2)
    model = eomc.compile(system, "massless_kane", functions=["rhs"], formulation="kane",
                         parameters={"m0": 2.0, "m": 0.5, "l": 0.75, "g": 9.81}, progress=False)
    names = model.metadata["param_names"]
    p = {"m0": 0.0, "m": 0.0, "l": 0.75, "g": 9.81}
    with pytest.raises(Exception, match="singular"):
        model.rhs(0.0, np.zeros(6), p=np.array([p[k] for k in names]), r=[0.0])
    p.update(m0=2.0, m=0.5)
    assert np.all(np.isfinite(model.rhs(0.0, np.zeros(6), p=np.array([p[k] for k in names]), r=[0.0])))
