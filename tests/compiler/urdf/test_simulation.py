"""Five seconds under gravity: eomc's simulate against Pinocchio's ABA integrated by scipy.

Both integrate with DOP853 at rtol = atol = 1e-10, each with its own
equations and, for the floating base, its own orientation coordinates
(eomc: body XYZ Euler angles; Pinocchio: a unit quaternion), so agreement
of the final states to 1e-6 checks the kinematics too.
"""
import numpy as np
import pinocchio as pin
import pytest
from scipy.integrate import solve_ivp

import eomc
from eomc.compiler.urdf import from_urdf
from eomc.runtime.simulate import simulate
from helpers.robots import PinRef, joints_of, robot_path, rotation_xyz

T_FINAL, TOL = 5.0, 1e-10


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("cache")


def _compile(name, cache, floating=False):
    system = from_urdf(robot_path(name), floating_base=floating, limits=False)
    model = eomc.compile(system, name, functions=["rhs"], cache_dir=cache, progress=False)
    return model, PinRef(robot_path(name), joints_of(system), floating=floating)


def _final(model, x0):
    result = simulate(model, x0, (0.0, T_FINAL), method="dop853", rtol=TOL, atol=TOL, n_points=2)
    return result.x[-1]


def test_arm_under_gravity_matches_pinocchio(cache):
    model, ref = _compile("ur5", cache)
    q0 = np.array([0.3, -1.0, 1.2, -0.5, 0.8, 0.1])
    x0 = np.concatenate([q0, np.zeros(6)])
    pm, pd = ref.model, ref.data
    tau0 = np.zeros(pm.nv)

    def f(t, y):
        q, v = y[:pm.nq], y[pm.nq:]
        return np.concatenate([v, pin.aba(pm, pd, q, v, tau0)])
    y0 = np.concatenate([ref.q(q0), ref.v(np.zeros(6))])
    sol = solve_ivp(f, (0.0, T_FINAL), y0, method="DOP853", rtol=TOL, atol=TOL)
    expected = np.concatenate([sol.y[:pm.nq, -1][ref.iq], sol.y[pm.nq:, -1][ref.iv]])
    final = _final(model, x0)
    assert np.max(np.abs(final - expected)) < 1e-6 * max(1.0, np.max(np.abs(expected)))
    assert np.max(np.abs(final[:6] - q0)) > 0.5      # it moved: the arm fell


def _quaternion_rate(quat, omega):
    """d/dt of (x, y, z, w) for body angular velocity omega."""
    xyz, w = quat[:3], quat[3]
    return np.concatenate([0.5 * (w * omega + np.cross(xyz, omega)), [-0.5 * xyz @ omega]])


def test_floating_quadruped_matches_pinocchio(cache):
    """Solo12 thrown with a spin and moving legs; free flight (URDF has no contacts)."""
    model, ref = _compile("solo12", cache, floating=True)
    rng = np.random.default_rng(5)
    q0 = np.concatenate([[0.0, 0.0, 0.5, 0.2, -0.1, 0.3], rng.uniform(-1, 1, 12)])
    v0 = np.concatenate([[0.5, -0.2, 3.0, 0.4, 0.3, 1.5], rng.uniform(-2, 2, 12)])
    pm, pd = ref.model, ref.data
    tau0 = np.zeros(pm.nv)

    def f(t, y):
        q, v = y[:pm.nq].copy(), y[pm.nq:]
        q[3:7] /= np.linalg.norm(q[3:7])
        qdot = np.empty(pm.nq)
        qdot[:3] = pin.Quaternion(q[3:7]).matrix() @ v[:3]
        qdot[3:7] = _quaternion_rate(q[3:7], v[3:6])
        qdot[7:] = v[6:]
        return np.concatenate([qdot, pin.aba(pm, pd, q, v, tau0)])
    y0 = np.concatenate([ref.q(q0), ref.v(v0)])
    sol = solve_ivp(f, (0.0, T_FINAL), y0, method="DOP853", rtol=TOL, atol=TOL)
    yq, yv = sol.y[:pm.nq, -1], sol.y[pm.nq:, -1]
    final = _final(model, np.concatenate([q0, v0]))
    nq = model.nq
    scale = max(1.0, np.max(np.abs(yq[:3])))
    assert np.max(np.abs(final[:3] - yq[:3])) < 1e-6 * scale                       # position
    rotation = pin.Quaternion(yq[3:7] / np.linalg.norm(yq[3:7])).matrix()
    assert np.max(np.abs(rotation_xyz(*final[3:6]) - rotation)) < 1e-6           # orientation
    assert np.max(np.abs(final[6:nq] - yq[ref.iq])) < 1e-6                        # joints
    assert np.max(np.abs(final[nq:] - yv[ref.iv])) < 1e-6 * max(1.0, np.max(np.abs(yv)))
    assert final[2] < q0[2] - 10.0        # it fell: 5 s of free fall from 3 m/s up is -107 m
