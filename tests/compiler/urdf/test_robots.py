"""Real robots from their URDF files against Pinocchio: forward and inverse dynamics, mass matrix.

UR5 (6-dof arm), Panda (7-dof arm plus two prismatic fingers) and Solo12
(quadruped, four branches, floating base), from the example-robot-data wheel.
Agreement is to 1e-10 relative at random states; what is compared is each
library's own output for the same file (Pinocchio's URDF reader is urdfdom).
"""
import numpy as np
import pytest

import eomc
from eomc.compiler.urdf import from_urdf
from helpers.robots import PinRef, joints_of, relative_error, robot_path

RNG = np.random.default_rng(2026)
FUNCTIONS = ["rhs", "mass_matrix", "inverse_dynamics"]
CASES = {"ur5": False, "panda": False, "solo12": True}   # robot -> floating base


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("cache")


@pytest.fixture(scope="module")
def robots(cache):
    """name -> (compiled model, Pinocchio reference)."""
    built = {}
    for name, floating in CASES.items():
        path = robot_path(name)
        system = from_urdf(path, floating_base=floating, limits=False)
        model = eomc.compile(system, name, functions=FUNCTIONS, cache_dir=cache, progress=False)
        built[name] = model, PinRef(path, joints_of(system), floating=floating)
    return built


def _random_state(model, floating):
    q = RNG.uniform(-np.pi, np.pi, model.nq)
    if floating:
        q[:3] = RNG.normal(size=3)
        q[3:6] = RNG.uniform(-1.2, 1.2, 3)   # away from the Euler singularity at ry = ±pi/2
    return q, RNG.normal(size=model.nu)


@pytest.mark.parametrize("name", list(CASES))
def test_dynamics_agree_with_pinocchio(robots, name):
    model, ref = robots[name]
    worst = 0.0
    for _ in range(10):
        q, v = _random_state(model, CASES[name])
        x = np.concatenate([q, v])
        tau = RNG.normal(size=model.ninput) * 5
        a = RNG.normal(size=model.nu)
        errors = (relative_error(model.rhs(0.0, x, r=tau)[model.nq:], ref.aba(q, v, tau)),
                  relative_error(model.mass_matrix(0.0, x), ref.mass_matrix(q)),
                  relative_error(model.inverse_dynamics(0.0, x, a, r=np.zeros(model.ninput)),
                                 ref.rnea(q, v, a)))
        worst = max(worst, *errors)
    assert worst < 1e-10, f"{name}: worst relative error {worst:.3g}"


def test_names_follow_the_joints(robots):
    ur5, _ = robots["ur5"]
    joints = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
              "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]
    assert ur5.state_names == tuple([f"q_{j}" for j in joints] + [f"u_{j}" for j in joints])
    assert ur5.input_names == tuple(f"tau_{j}" for j in joints)
    assert "g" in ur5.param_names and "m_upper_arm_link" in ur5.param_names
    panda, _ = robots["panda"]
    assert panda.input_names[-2:] == ("tau_panda_finger_joint1", "tau_panda_finger_joint2")
    solo, _ = robots["solo12"]
    assert solo.state_names[:6] == tuple(f"q_base_link_floating_{c}" for c in ("x", "y", "z", "rx", "ry", "rz"))
    assert solo.ninput == 12


def test_parameters_change_the_dynamics_like_the_urdf_values(robots):
    """A mass parameter is live: doubling it changes M as doubling the link's mass in Pinocchio does."""
    model, ref = robots["ur5"]
    q, v = _random_state(model, False)
    x = np.concatenate([q, v])
    p = np.array(model.param_defaults, dtype=float)
    k = model.param_names.index("m_forearm_link")
    p[k] *= 2
    import pinocchio as pin
    body = ref.model.getJointId("elbow_joint")        # moves forearm_link
    original = ref.model.inertias[body].copy()
    ref.model.inertias[body] = pin.Inertia(2 * original.mass, original.lever, original.inertia)
    try:
        assert relative_error(model.mass_matrix(0.0, x, p=p), ref.mass_matrix(q)) < 1e-10
        assert relative_error(model.mass_matrix(0.0, x), ref.mass_matrix(q)) > 1e-3
    finally:
        ref.model.inertias[body] = original
