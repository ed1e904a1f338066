"""A singular mass matrix names the speeds that meet no inertia (eomc.runtime.diagnose)."""
import numpy as np
import pytest
import sympy as sm

import eomc
import eomc.mechanics as em
from eomc.errors import SimulationError


@pytest.fixture(scope="module")
def arm(tmp_path_factory):
    """Two point masses on pins, shoulder then elbow; the tip mass m2 is a parameter."""
    q1, q2, u1, u2 = em.dynamicsymbols("q1 q2 u1 u2")
    m1, m2, l, g = sm.symbols("m1 m2 l g", positive=True)
    ground = em.RigidBody("ground")
    upper = em.RigidBody("upper", mass=m1)
    upper.inertia = (em.inertia(upper.frame, 0, 0, 0), upper.masscenter)
    tip = em.RigidBody("tip", mass=m2)
    tip.inertia = (em.inertia(tip.frame, 0, 0, 0), tip.masscenter)
    system = em.System.from_newtonian(ground)
    system.add_joints(
        em.PinJoint("shoulder", ground, upper, q1, u1, child_point=l * upper.frame.y,
                    joint_axis=ground.frame.z),
        em.PinJoint("elbow", upper, tip, q2, u2, parent_point=-l * upper.frame.y,
                    child_point=l * tip.frame.y, joint_axis=upper.frame.z))
    system.apply_uniform_gravity(-g * ground.frame.y)
    return eomc.compile(system, "arm", functions=["rhs", "mass_matrix"], progress=False,
                        parameters={m1: 1.0, m2: 0.5, l: 0.7, g: 9.81},
                        cache_dir=str(tmp_path_factory.mktemp("cache")))


def _p(model, **values):
    base = dict(zip(model.metadata["param_names"], model.param_defaults))
    base.update(values)
    return np.array([base[k] for k in model.metadata["param_names"]])


def test_a_call_names_the_speed_without_inertia(arm):
    x = np.array([0.3, -0.4, 0.1, 0.2])
    with pytest.raises(SimulationError, match=r"singular at t=0, state .*u2=0.2; nothing resists motion along u2 \(1\)"):
        arm.rhs(0.0, x, p=_p(arm, m2=0.0))
    assert np.all(np.isfinite(arm.rhs(0.0, x, p=_p(arm))))


def test_a_simulation_names_it_too(arm):
    with pytest.raises(SimulationError, match=r"nothing resists motion along u2"):
        arm.simulate([0.3, -0.4, 0.1, 0.2], (0.0, 1.0), p=_p(arm, m2=0.0))


def test_no_diagnosis_without_a_compiled_mass_matrix(arm, monkeypatch):
    """A model built without mass_matrix keeps the plain status: no guess."""
    from eomc.runtime.diagnose import singular_direction
    x = np.array([0.3, -0.4, 0.1, 0.2])
    assert singular_direction(arm, 0.0, x, _p(arm, m2=0.0)).startswith("; nothing resists")
    assert singular_direction(arm, 0.0, x, _p(arm)) == ""      # M regular: nothing to say
    monkeypatch.setattr(arm, "functions", ("rhs",))
    assert singular_direction(arm, 0.0, x, _p(arm, m2=0.0)) == ""
