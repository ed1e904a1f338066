"""Joints of several speeds in the recursion (ABA, RNEA, CRBA), against Kane's formulation.

A free joint (the URDF reader's FloatingJoint: position + body XYZ Euler
angles, body-frame twist speeds) is one 6-speed joint; a cylindrical joint and
the URDF planar joint are one joint of 2 and 3 speeds with constant axes in the
child; SymPy's PlanarJoint (parent-frame speeds) is two sliders and a pin
through massless stages.  Every case: compiled, recursive = Kane to 1e-12 at
random states (rhs, mass_matrix, inverse_dynamics, jac_x), same state layout.
Solo12 with a floating base: recursive = Pinocchio's ABA, RNEA and CRBA.
"""
import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as sme

import eomc
from eomc.compiler.tree.recognize import tree_from_system
from eomc.compiler.urdf.joints import FloatingJoint, PlanarJoint as UrdfPlanar
from eomc.errors import ModelError
from helpers.tree_agreement import agree

FUNCTIONS = ["rhs", "jac_x", "mass_matrix", "inverse_dynamics"]
TOL = 1e-12


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))


def _rigid(name, products=True):
    body = sme.RigidBody(name, mass=sm.Symbol(f"m_{name}"))
    ixx, iyy, izz, ixy, iyz = sm.symbols(f"ixx_{name} iyy_{name} izz_{name} ixy_{name} iyz_{name}")
    pr = (ixy / 8, iyz / 8, 0) if products else (0, 0, 0)
    body.inertia = (sme.inertia(body.frame, 2 + ixx, 2 + iyy, 2 + izz, *pr), body.masscenter)
    return body


def _system(ground, joints, loads=()):
    system = sme.System.from_newtonian(ground)
    system.add_joints(*joints)
    system.apply_uniform_gravity(-sm.Symbol("g") * ground.frame.z)
    if loads:
        system.add_loads(*loads)
    return system


def _both(build, name, functions=FUNCTIONS):
    """(kane, recursive) compiled models of the System ``build()`` returns (built twice:
    forming Kane's equations changes the System)."""
    system, inputs = build()
    rec = eomc.compile(system, f"{name}_r", inputs=inputs, functions=functions, progress=False,
                       formulation="recursive")
    system, inputs = build()
    kane = eomc.compile(system, f"{name}_k", inputs=inputs, functions=functions, progress=False,
                        formulation="kane")
    return kane, rec


def free_body():
    """One rigid body on a free joint, its joint point off the mass centre, a force and a torque."""
    ground, body = sme.RigidBody("ground"), _rigid("body")
    joint = FloatingJoint("free", ground, body, parent_point=ground.frame.y,
                          child_point=body.frame.x - body.frame.z / 2)
    F, T = sme.dynamicsymbols("F T")
    loads = [sme.Force(body.masscenter, F * ground.frame.x), sme.Torque(body.frame, T * body.frame.y)]
    return _system(ground, [joint], loads), [F, T]


def floating_chain():
    """A floating base with a pin, a slider and a pin in a chain below it (joint torques)."""
    ground, base = sme.RigidBody("ground"), _rigid("base")
    joints = [FloatingJoint("free", ground, base)]
    parent, loads, inputs = base, [], []
    for i, kind in enumerate(("pin", "slider", "pin")):
        link = _rigid(f"link{i}", products=(i != 1))
        P = parent.frame
        axis = (P.x + P.z) if i != 1 else P.y
        cls = sme.PinJoint if kind == "pin" else sme.PrismaticJoint
        joints.append(cls(f"{kind}{i}", parent, link, sme.dynamicsymbols(f"q{i}"),
                          sme.dynamicsymbols(f"u{i}"), parent_point=P.x / 2 - P.z,
                          child_point=link.frame.y, joint_axis=axis))
        T = sme.dynamicsymbols(f"T{i}")
        inputs.append(T)
        if kind == "pin":
            loads += [sme.Torque(link.frame, T * axis), sme.Torque(P, -T * axis)]
        else:
            loads += [sme.Force(link.masscenter, T * axis), sme.Force(parent.masscenter, -T * axis)]
        parent = link
    return _system(ground, joints, loads), inputs


def planar_and_cylindrical():
    """SymPy's CylindricalJoint (2 speeds) from the ground, SymPy's PlanarJoint (3 speeds,
    parent-frame rates) below it, and the URDF planar joint (body-frame speeds) below that."""
    ground, a, b, c = sme.RigidBody("ground"), _rigid("a"), _rigid("b"), _rigid("c")
    N = ground.frame
    joints = [sme.CylindricalJoint("cyl", ground, a, joint_axis=N.x + N.y, child_point=a.frame.z),
              sme.PlanarJoint("plane", a, b, parent_point=a.frame.x, child_point=b.frame.y / 2,
                              parent_interframe=a.frame.y),
              UrdfPlanar("urdf_plane", b, c, parent_point=b.frame.z, child_point=-c.frame.x)]
    T = sme.dynamicsymbols("T")
    loads = [sme.Torque(b.frame, T * a.frame.y), sme.Torque(a.frame, -T * a.frame.y)]
    return _system(ground, joints, loads), [T]


@pytest.mark.parametrize("build", [free_body, floating_chain, planar_and_cylindrical])
def test_agrees_with_kane(build):
    kane, rec = _both(build, build.__name__)
    assert rec.state_names == kane.state_names
    assert agree(kane, rec, seed=11) < TOL


def test_tree_shapes():
    """What each joint becomes: one k-speed body, or single-axis stages."""
    tree = tree_from_system(planar_and_cylindrical()[0])
    assert [(b.name, b.kind) for b in tree.bodies] == [
        ("a", "2-speed"), ("plane_stage1", "prismatic"), ("plane_stage2", "prismatic"),
        ("b", "revolute"), ("c", "3-speed")]
    assert [b.parent for b in tree.bodies] == [-1, 0, 1, 2, 3]
    assert tree.bodies[0].speeds == (0, 1) and tree.bodies[4].speeds == (5, 6, 7)
    tree = tree_from_system(floating_chain()[0])
    assert tree.bodies[0].kind == "free" and tree.bodies[0].speeds == tuple(range(6))
    # body-frame twist speeds (v, then ω) about the mass centre: constant unit axes, [ω; v] order
    unit = [tuple(int(i == k) for i in range(6)) for k in range(6)]
    assert tree.bodies[0].motions == tuple(unit[3:] + unit[:3])


class WorldVelocityJoint(FloatingJoint):
    """A free joint whose linear speeds are the parent-frame velocity: its axes turn with the child."""

    def _generate_kdes(self):
        t = sme.dynamicsymbols._t
        kdes = super()._generate_kdes()
        return sm.Matrix([self.coordinates[i].diff(t) - self.speeds[i] for i in range(3)]
                         + list(kdes[3:]))

    def _set_linear_velocity(self):
        super()._set_linear_velocity()
        P, u = self.parent_interframe, self.speeds
        self.child_point.set_vel(self._parent_frame, u[0] * P.x + u[1] * P.y + u[2] * P.z)
        self.child.masscenter.v2pt_theory(self.child_point, self._parent_frame, self._child_frame)


def test_multi_speed_joint_the_recursion_cannot_take():
    """Refused naming the body and joint; auto falls back to Kane and says why."""
    def build():
        ground, body = sme.RigidBody("ground"), _rigid("drone")
        return _system(ground, [WorldVelocityJoint("hover", ground, body)]), []
    with pytest.raises(ModelError, match=r"recursive formulation: body drone \(joint hover\): its "
                                         r"velocity relative to its parent is not constant axes"):
        eomc.compile(build()[0], "hover_r", functions=["rhs"], progress=False, formulation="recursive")
    auto = eomc.compile(build()[0], "hover_a", functions=["rhs"], progress=False, formulation="auto")
    assert auto.metadata.get("formulation", "kane") == "kane"
    assert "joint hover" in auto.metadata["formulation_note"]


def test_solo12_floating_base_agrees_with_pinocchio(tmp_path):
    """Solo12 (example-robot-data) with --floating-base through the recursion: ABA, RNEA and
    CRBA equal Pinocchio's with its free-flyer root (same body-frame speeds) to 1e-12."""
    from eomc.compiler.urdf import from_urdf
    from helpers.robots import PinRef, joints_of, relative_error, robot_path
    path = robot_path("solo12")
    system = from_urdf(path, floating_base=True, limits=False)
    model = eomc.compile(system, "solo12_r", functions=["rhs", "mass_matrix", "inverse_dynamics"],
                         progress=False, formulation="recursive")
    assert model.metadata["formulation"] == "recursive" and model.nq == model.nu == 18
    ref = PinRef(path, joints_of(system), floating=True)
    rng = np.random.default_rng(12)
    worst = 0.0
    for _ in range(5):
        q = rng.uniform(-np.pi, np.pi, model.nq)
        q[:3], q[3:6] = rng.normal(size=3), rng.uniform(-1.2, 1.2, 3)
        v, a, tau = rng.normal(size=model.nu), rng.normal(size=model.nu), 5 * rng.normal(size=model.ninput)
        x = np.concatenate([q, v])
        worst = max(worst, relative_error(model.rhs(0.0, x, r=tau)[model.nq:], ref.aba(q, v, tau)),
                    relative_error(model.mass_matrix(0.0, x), ref.mass_matrix(q)),
                    relative_error(model.inverse_dynamics(0.0, x, a, r=np.zeros(model.ninput)),
                                   ref.rnea(q, v, a)))
    assert worst < 1e-12, worst
