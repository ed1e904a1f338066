"""Every URDF joint type on one small robot written here, against Pinocchio.

A planar base (normal z) carries a continuous joint with a tilted axis, a
prismatic joint, a revolute joint whose origin has rpy, and a fixed joint
welding a massive tool with a rotated inertial frame onto the last link
(merged: mass, centre of mass and inertia combined).  Then the same robot
with a URDF ``floating`` joint in place of the planar one.
"""
import numpy as np
import pytest

import eomc
from eomc.compiler.urdf import from_urdf
from helpers.robots import PinRef, joints_of, relative_error

RNG = np.random.default_rng(99)


def _link(name, mass, xyz, rpy, inertia):
    ixx, iyy, izz, ixy, ixz, iyz = inertia
    return (f'  <link name="{name}"><inertial><origin xyz="{xyz}" rpy="{rpy}"/><mass value="{mass}"/>'
            f'<inertia ixx="{ixx}" iyy="{iyy}" izz="{izz}" ixy="{ixy}" ixz="{ixz}" iyz="{iyz}"/>'
            f'</inertial></link>\n')


def _joint(name, kind, parent, child, xyz, rpy, axis):
    limit = '<limit lower="-3" upper="3" effort="10" velocity="5"/>' if kind in ("revolute", "prismatic") else ""
    return (f'  <joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="{axis}"/>{limit}</joint>\n')


ROBOT = ('<?xml version="1.0"?>\n<robot name="zoo">\n  <link name="world"/>\n'
         + _link("cart", 4.0, "0.1 -0.05 0.02", "0 0 0.3", (0.05, 0.07, 0.09, 0.001, 0.0, -0.002))
         + _link("turret", 1.5, "0.02 0.01 0.15", "0.1 0.2 0.3", (0.02, 0.025, 0.01, 0.0, 0.001, 0.0))
         + _link("slider", 0.8, "0 0 0.1", "0 0 0", (0.004, 0.004, 0.001, 0, 0, 0))
         + _link("forearm", 0.6, "0.15 0 0", "0 0.5 0", (0.0008, 0.006, 0.006, 0, 0, 0))
         + _link("tool", 0.3, "0.02 0.03 0", "0.7 -0.2 1.1", (0.0005, 0.0004, 0.0003, 0, 0, 0))
         + _joint("base_planar", "planar", "world", "cart", "0 0 0.1", "0 0 0", "0 0 1")
         + _joint("turret_spin", "continuous", "cart", "turret", "0.05 0 0.1", "0 0 0", "0.2 0.3 0.9")
         + _joint("lift", "prismatic", "turret", "slider", "0 0.02 0.3", "0 0 0.4", "0 0 1")
         + _joint("elbow", "revolute", "slider", "forearm", "0 0 0.2", "1.5707963267948966 0 0.3", "0 0 1")
         + _joint("tool_weld", "fixed", "forearm", "tool", "0.3 0 0", "0 0.2 0", "1 0 0")
         + "</robot>\n")


def _build(tmp, text, name):
    path = tmp / f"{name}.urdf"
    path.write_text(text)
    system = from_urdf(path)
    model = eomc.compile(system, name, functions=["rhs", "mass_matrix", "inverse_dynamics"],
                         cache_dir=tmp / "cache", progress=False)
    return model, PinRef(path, joints_of(system)), system


@pytest.fixture(scope="module")
def zoo(tmp_path_factory):
    return _build(tmp_path_factory.mktemp("zoo"), ROBOT, "zoo")


def _agree(model, ref):
    worst = 0.0
    for _ in range(10):
        q, v = RNG.uniform(-1.2, 1.2, model.nq), RNG.normal(size=model.nu)
        x, tau, a = np.concatenate([q, v]), RNG.normal(size=3), RNG.normal(size=model.nu)
        worst = max(worst,
                    relative_error(model.rhs(0.0, x, r=tau)[model.nq:], ref.aba(q, v, tau)),
                    relative_error(model.mass_matrix(0.0, x), ref.mass_matrix(q)),
                    relative_error(model.inverse_dynamics(0.0, x, a, r=np.zeros(3)), ref.rnea(q, v, a)))
    return worst


def test_every_joint_type_agrees_with_pinocchio(zoo):
    model, ref, _ = zoo
    assert model.state_names[:3] == ("q_base_planar_x", "q_base_planar_y", "q_base_planar_th")
    assert model.input_names == ("tau_turret_spin", "tau_lift", "tau_elbow")   # the planar base is free
    assert _agree(model, ref) < 1e-10


def test_urdf_floating_joint_agrees_with_pinocchio(tmp_path):
    text = ROBOT.replace('type="planar"', 'type="floating"')
    model, ref, _ = _build(tmp_path, text, "zoo_floating")
    assert model.nq == 6 + 3 and model.state_names[3] == "q_base_planar_rx"
    assert _agree(model, ref) < 1e-10


def test_planar_kinematics_are_body_frame(zoo):
    """x' = R(th) [vx, vy]: the planar speeds are in the moving frame, like Pinocchio's."""
    model, _, _ = zoo
    q, v = RNG.normal(size=model.nq), RNG.normal(size=model.nu)
    qdot = model.rhs(0.0, np.concatenate([q, v]), r=np.zeros(3))[:model.nq]
    c, s = np.cos(q[2]), np.sin(q[2])
    np.testing.assert_allclose(qdot[:3], [c * v[0] - s * v[1], s * v[0] + c * v[1], v[2]], rtol=1e-13)


def test_floating_euler_rates_give_the_body_angular_velocity():
    """The FloatingJoint's closed-form Euler rates: with them, SymPy's angular velocity of the
    body XYZ orientation is the speeds (ωx, ωy, ωz) in the child frame, at random states."""
    import sympy as sm
    import sympy.physics.mechanics as sme
    from eomc.compiler.urdf.joints import FloatingJoint
    ground, body = sme.RigidBody("ground"), sme.RigidBody("body")
    joint = FloatingJoint("free", ground, body)
    q, u = joint.coordinates, joint.speeds
    rates = {q[i].diff(): -joint.kdes[i].subs(q[i].diff(), 0) for i in range(6)}
    omega = body.frame.ang_vel_in(ground.frame).to_matrix(body.frame).xreplace(rates)
    for _ in range(3):
        values = dict(zip(list(q) + list(u), RNG.uniform(-1.2, 1.2, 12)))
        np.testing.assert_allclose(np.array(omega.xreplace(values), dtype=float).ravel(),
                                   [values[w] for w in u[3:]], rtol=1e-13, atol=1e-14)
    assert sm.Matrix(joint.kdes).jacobian([qi.diff() for qi in q]) == sm.eye(6)


def test_fixed_link_is_merged_into_its_parent(zoo):
    _, _, system = zoo
    tree = system.urdf.tree
    assert list(tree.bodies) == ["cart", "turret", "slider", "forearm"]
    forearm = tree.bodies["forearm"]
    assert forearm.links == ["forearm", "tool"] and forearm.mass == pytest.approx(0.9)
    # the tool's centre of mass pulls the body's towards x = 0.3 + ...
    assert 0.15 < forearm.com[0] < 0.3
    params = {str(k): v for k, v in system.urdf.parameters.items()}
    assert params["m_forearm"] == pytest.approx(0.9) and "m_tool" not in params


def test_mimic_joint_is_a_constraint(tmp_path):
    """<mimic> with mimic=True: q_twin = -0.5 q_lift + 0.1, against Pinocchio's dynamics reduced by hand."""
    twin = (_link("twin", 0.4, "0.01 0 0.05", "0 0 0", (0.002, 0.002, 0.001, 0, 0, 0))
            + '  <joint name="twin" type="prismatic"><parent link="turret"/><child link="twin"/>'
              '<origin xyz="0.1 0 0.2"/><axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/>'
              '<mimic joint="lift" multiplier="-0.5" offset="0.1"/></joint>\n')
    path = tmp_path / "mimic.urdf"
    path.write_text(ROBOT.replace("</robot>", twin + "</robot>"))
    system = from_urdf(path, mimic=True)
    model = eomc.compile(system, "mimic", functions=["rhs"], cache_dir=tmp_path / "cache", progress=False)
    names = [n[2:] for n in model.state_names[:model.nq]]
    assert names[-1] == "twin" and "tau_twin" not in model.input_names     # dependent, unactuated
    ref = PinRef(path, joints_of(system))
    lift, twin_i = names.index("lift"), names.index("twin")
    n = model.nu
    G = np.delete(np.eye(n), twin_i, axis=1)       # full speeds from the independent ones
    G[twin_i, lift - (lift > twin_i)] = -0.5
    for _ in range(3):
        q, v = RNG.uniform(-1, 1, n), RNG.normal(size=n)
        q[twin_i], v[twin_i] = -0.5 * q[lift] + 0.1, -0.5 * v[lift]
        tau = RNG.normal(size=model.ninput)
        full_tau = np.zeros(n)
        full_tau[[names.index(r.removeprefix("tau_")) for r in model.input_names]] = tau
        M, b = ref.mass_matrix(q), ref.rnea(q, v, np.zeros(n))
        expected = np.linalg.solve(G.T @ M @ G, G.T @ (full_tau - b))
        udot = model.rhs(0.0, np.concatenate([q, v]), r=tau)[model.nq:]
        assert relative_error(np.delete(udot, twin_i), expected) < 1e-10
        assert abs(udot[twin_i] + 0.5 * udot[lift]) < 1e-10 * max(1.0, abs(udot[lift]))
