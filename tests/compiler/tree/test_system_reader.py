"""The tree read from a System's joint objects (issue 19): the same tree as SymPy's
kinematics give, no frame-graph search, every actuator on every pathway, and a
KanesMethod that is not formed when the tree is read instead.

Cheap by design: the reader is compared with the previous reading (through SymPy's
kinematics) at random numbers without compiling; the actuator x pathway matrix is one
System built once per formulation.
"""
import random

import numpy as np
import pytest
import sympy as sm
from sympy.physics import mechanics as sme

import eomc
from eomc.compiler.multibody import Model
from eomc.compiler.tree import recognize
from eomc.compiler.tree.recognize import tree_from_system, tree_of
from eomc.compiler.urdf.joints import FloatingJoint, PlanarJoint as UrdfPlanarJoint
from helpers import trees
from helpers.zoo import actuators_on_pathways

TOL = 1e-12


def _numbers(tree, seed):
    rng = random.Random(seed)
    vals = {}
    atoms = set()
    for b in tree.bodies:
        for M in (b.rotation, b.position, sm.Matrix(b.motion or ()), b.inertia,
                  sm.Matrix([b.mass]), *[sm.Matrix(m) for m in b.motions]):
            for e in M:
                atoms |= sm.sympify(e).free_symbols | sm.sympify(e).atoms(sm.Function)
    for a in atoms:
        if a != sme.dynamicsymbols._t:
            vals[a] = sm.Float(rng.uniform(0.2, 1.1))
    return vals


def _value(M, vals):
    return np.array([[complex(sm.N(sm.sympify(e).xreplace(vals))) for e in row]
                     for row in sm.Matrix(M).tolist()], dtype=complex)


def _same_tree(a, b):
    """Both readings give the same bodies, parents, speeds and the same E, r, S, mass,
    inertia at random numbers."""
    assert [(x.name, x.parent, x.speed, x.speeds, x.kind) for x in a.bodies] == \
        [(x.name, x.parent, x.speed, x.speeds, x.kind) for x in b.bodies]
    for seed in (1,):
        vals = _numbers(a, seed)
        for x, y in zip(a.bodies, b.bodies):
            pairs = [(x.rotation, y.rotation), (x.position, y.position), (x.inertia, y.inertia),
                     (sm.Matrix([x.mass]), sm.Matrix([y.mass]))]
            if x.motion is not None:
                pairs.append((sm.Matrix(x.motion), sm.Matrix(y.motion)))
            pairs += [(sm.Matrix(m), sm.Matrix(n)) for m, n in zip(x.motions, y.motions)]
            for m, n in pairs:
                assert np.max(np.abs(_value(m, vals) - _value(n, vals))) < TOL, (x.name, m, n)


def _previous_reading(system, monkeypatch):
    """The tree as the reader found it before: every joint through SymPy's kinematics."""
    with monkeypatch.context() as m:
        m.setattr(recognize, "_joint_motion", lambda *a, **k: None)
        return tree_from_system(system)


def _chain(kind):
    """A small System (ground + 2-3 bodies) around one joint kind, with offsets, interframes
    and a turned axis so that the joint-local forms are not trivial."""
    ground = sme.RigidBody("ground")
    N = ground.frame
    a, b, c = sm.symbols("a b c", positive=True)
    bodies = []
    for i in range(3):
        body = sme.RigidBody(f"B{i}", mass=sm.Symbol(f"m{i}"))
        body.central_inertia = sme.inertia(body.frame, *sm.symbols(f"I{i}xx I{i}yy I{i}zz I{i}xy"))
        bodies.append(body)
    B0, B1, B2 = bodies
    joints = [sme.PinJoint("base", ground, B0, parent_point=a * N.x, child_point=-b * B0.y,
                           joint_axis=N.z)]
    q, u = sme.dynamicsymbols("qk1:7"), sme.dynamicsymbols("uk1:7")
    common = dict(parent_point=c * B0.frame.x + a * B0.frame.y, child_point=b * B1.frame.z)
    if kind == "pin":
        joints.append(sme.PinJoint("j", B0, B1, q[0], u[0], joint_axis=B0.frame.x + B0.frame.y,
                                   parent_interframe=B0.frame.z, **common))
    elif kind == "prismatic":
        joints.append(sme.PrismaticJoint("j", B0, B1, q[0], u[0], joint_axis=B0.frame.y - B0.frame.z,
                                         child_interframe=B1.frame.x, **common))
    elif kind == "weld":
        joints.append(sme.WeldJoint("j", B0, B1, **common))
    elif kind == "cylindrical":
        joints.append(sme.CylindricalJoint("j", B0, B1, q[0], q[1], u[0], u[1],
                                           joint_axis=B0.frame.x, **common))
    elif kind == "spherical":
        joints.append(sme.SphericalJoint("j", B0, B1, q[:3], u[:3], rot_type="body",
                                         amounts=None, **common))
    elif kind == "planar":
        joints.append(sme.PlanarJoint("j", B0, B1, q[0], q[1:3], u[0], u[1:3], **common))
    elif kind == "floating":
        joints.append(FloatingJoint("j", B0, B1, q[:6], u[:6], **common))
    elif kind == "urdf_planar":
        joints.append(UrdfPlanarJoint("j", B0, B1, q[:3], u[:3], **common))
    joints.append(sme.PinJoint("tip", B1, B2, q[5] if kind != "floating" else sme.dynamicsymbols("qt"),
                               u[5] if kind != "floating" else sme.dynamicsymbols("ut"),
                               child_point=-a * B2.y, joint_axis=B1.frame.z))
    system = sme.System.from_newtonian(ground)
    system.add_joints(*joints)
    system.apply_uniform_gravity(-sm.Symbol("g") * N.y)
    return system


KINDS = ("pin", "prismatic", "weld", "cylindrical", "spherical", "planar", "floating", "urdf_planar")


@pytest.mark.parametrize("kind", KINDS)
def test_reader_agrees_with_the_previous_reading(kind, monkeypatch):
    system = _chain(kind)
    new = tree_from_system(system)
    assert not new.notes      # every joint was read from its own objects
    _same_tree(new, _previous_reading(_chain(kind), monkeypatch))


def test_a_frame_two_steps_away_is_read_through_kinematics_and_said(monkeypatch):
    """An interframe the user oriented from another frame of the body (not one step from
    the body's frame) falls back to SymPy's kinematics for that joint, with the reason."""
    ground = sme.RigidBody("ground")
    B = sme.RigidBody("B", mass=sm.Symbol("m"))
    B.central_inertia = sme.inertia(B.frame, 1, 2, 3)
    mid = sme.ReferenceFrame("mid")
    mid.orient_axis(ground.frame, ground.frame.x, sm.pi / 3)
    inter = sme.ReferenceFrame("inter")
    inter.orient_axis(mid, mid.y, sm.pi / 5)
    system = sme.System.from_newtonian(ground)
    system.add_joints(sme.PinJoint("p", ground, B, parent_interframe=inter, joint_axis=inter.z,
                                   child_point=-B.y))
    tree = tree_from_system(system)
    assert any("joint p" in note and "not one step" in note for note in tree.notes)
    _same_tree(tree, _previous_reading(system, monkeypatch))


def test_reading_a_40_link_system_searches_no_frame_graph(monkeypatch):
    """The O(n) claim as a count, not a time: reading the 40-link cart never calls SymPy's
    frame-graph or point-graph path search (which made large Systems take minutes)."""
    system = trees.cart_joints(40)[0]
    calls = []
    for cls, name in ((sme.ReferenceFrame, "_dict_list"), (sme.Point, "_pdict_list")):
        original = getattr(cls, name)
        monkeypatch.setattr(cls, name, lambda self, *a, _o=original, _n=name, **k:
                            calls.append(_n) or _o(self, *a, **k))
    tree = tree_from_system(system)
    assert len(tree.bodies) == 41 and not tree.notes
    assert calls == []


@pytest.fixture(scope="module")
def actuator_models(tmp_path_factory):
    """The actuator x pathway System, compiled once per formulation (rhs only), and the
    recursive C source."""
    out = {}
    tmp = tmp_path_factory.mktemp("act_path")
    for formulation in ("recursive", "kane"):
        system, inputs, params, labels = actuators_on_pathways(sme)
        out[formulation] = eomc.compile(system, f"act_path_{formulation[0]}", inputs=inputs,
                                        parameters=params, functions=["rhs"], progress=False,
                                        formulation=formulation, cache_dir=tmp / "cache",
                                        output_dir=tmp / formulation)
    return out, labels, (tmp / "recursive" / "act_path_r.c").read_text()


def test_every_actuator_on_every_pathway_agrees(actuator_models):
    """ForceActuator, LinearSpring, LinearDamper, DuffingSpring and a DeGroote musculotendon
    on LinearPathway, ObstacleSetPathway and WrappingPathway over a cylinder and a sphere,
    each with a TorqueActuator and gravity: the recursive rhs is Kane's to 1e-12, with the
    same parameters (only those the equations use)."""
    models, labels, source = actuator_models
    kane, rec = models["kane"], models["recursive"]
    assert rec.param_names == kane.param_names and rec.input_names == kane.input_names
    rng = np.random.default_rng(19)
    worst = np.zeros(kane.nu)
    for _ in range(3):
        x = rng.uniform(-0.8, 0.8, kane.nq + kane.nu)
        r = rng.uniform(0.1, 0.9, kane.ninput)
        a, b = rec.rhs(0.0, x, r=r), kane.rhs(0.0, x, r=r)
        assert np.all(np.isfinite(b))
        worst = np.maximum(worst, (np.abs(a - b) / np.maximum(1.0, np.abs(b)))[kane.nq:])
    bad = {labels[k]: worst[k] for k in range(kane.nu) if not worst[k] < TOL}
    assert not bad, bad
    assert "NAN" not in source and "INFINITY" not in source


def _hanging(formed):
    """The report's hanging arm, reduced: a carriage on a vertical slider hung from a
    LinearSpring and a LinearDamper on one LinearPathway (length sqrt(q0**2)), a pin below."""
    q0, q1, u0, u1 = sme.dynamicsymbols("q0 q1 u0 u1")
    M, m1, L1, k, c, h, g = sm.symbols("M m1 L1 k c h g", positive=True)
    ceiling = sme.RigidBody("ceiling")
    carriage = sme.RigidBody("carriage", mass=M)
    carriage.central_inertia = sme.inertia(carriage.frame, 0, 0, M / 10)
    link = sme.RigidBody("link", mass=m1)
    link.central_inertia = sme.inertia(link.frame, 0, 0, m1 * L1 ** 2 / 12)
    system = sme.System.from_newtonian(ceiling)
    system.add_joints(sme.PrismaticJoint("slider", ceiling, carriage, q0, u0, joint_axis=-ceiling.y),
                      sme.PinJoint("shoulder", carriage, link, q1, u1, child_point=L1 / 2 * link.y,
                                   joint_axis=carriage.z))
    path = sme.LinearPathway(ceiling.masscenter, carriage.masscenter)
    system.add_actuators(sme.LinearSpring(k, path, equilibrium_length=h), sme.LinearDamper(c, path))
    system.apply_uniform_gravity(-g * ceiling.y)
    if formed:
        system.form_eoms()
    return system, {M: 2.0, m1: 1.0, L1: 0.6, k: 150.0, c: 2.0, h: 0.8, g: 9.81}


def test_spring_on_a_linear_pathway_is_no_nan(tmp_path):
    """Once `xdot[3] = NAN;` and 7 more: the spring's direction q0/sqrt(q0**2) set to q0 = 0
    looked 'constant' to a check that let NaN compare equal.  Now the load is read in world
    components and the C agrees with Kane; formed and unformed Systems alike."""
    system, params = _hanging(formed=True)
    kane = eomc.compile(system, "hang_k", parameters=params, functions=["rhs"], progress=False,
                        cache_dir=tmp_path)
    for formed in (True, False):
        system, params = _hanging(formed)
        tree = tree_of(system)
        for load in tree.loads:
            for e in list(load.force) + list(load.moment):
                assert not sm.sympify(e).has(sm.nan, sm.zoo)
        rec = eomc.compile(system, f"hang_r{int(formed)}", parameters=params, functions=["rhs"],
                           progress=False, formulation="recursive", cache_dir=tmp_path,
                           output_dir=tmp_path / f"out{int(formed)}")
        source = (tmp_path / f"out{int(formed)}" / f"hang_r{int(formed)}.c").read_text()
        assert "NAN" not in source
        rng = np.random.default_rng(5)
        for _ in range(3):
            x = rng.uniform(0.3, 1.2, 4)
            a, b = rec.rhs(0.0, x), kane.rhs(0.0, x)
            assert np.max(np.abs(a - b) / np.maximum(1.0, np.abs(b))) < TOL


def test_kanes_method_forms_on_first_use():
    """kanes_equations records; fr/frstar/mass_matrix form on first use and equal what
    forming at once gives (the unpacked return value)."""
    lazy = trees.cart_relative(3, eomc.mechanics)[0]
    assert not lazy.is_formed
    eager, _ = trees.cart_relative(3, eomc.mechanics)
    fr, frstar = eager.kanes_equations(eager.bodies, eager.loads)
    assert eager.is_formed
    assert lazy.fr == fr and lazy.frstar == frstar and lazy.is_formed
    assert lazy.mass_matrix == eager.mass_matrix and lazy.forcing == eager.forcing
    pair = trees.cart_relative(2, eomc.mechanics)[0].kanes_equations()
    assert isinstance(pair, tuple) and len(pair) == 2 and pair[0].shape == (3, 1)


def test_a_pending_kanes_method_is_read_as_a_tree_without_forming(monkeypatch):
    """The classic frames-and-points file: auto/recursive read the tree from the recorded
    bodies and loads; Kane's equations are never formed (a spy on forming)."""
    from eomc.compiler.mechanics.kane import KanesMethod
    from eomc.compiler.model.spec import formed_system
    from eomc.compiler.mechanics.unformed import PENDING_KANE_MIN_BODIES
    kane, _ = trees.cart_relative(PENDING_KANE_MIN_BODIES, eomc.mechanics)
    formed_calls = []
    original = KanesMethod._form
    monkeypatch.setattr(KanesMethod, "_form", lambda self, *a: formed_calls.append(1) or
                        original(self, *a))
    for formulation in ("recursive", "auto"):
        fs = formed_system(kane, formulation)
        assert isinstance(fs, Model) and len(fs.tree.bodies) == PENDING_KANE_MIN_BODIES + 1
    assert formed_calls == [] and not kane.is_formed
    fs = formed_system(kane, "kane")          # Kane's formulation forms it, once
    assert fs.method == "kane" and formed_calls == [1] and kane.is_formed
    # a small one is read as a tree too; auto then forms Kane's equations as well and keeps
    # the cheaper form (tests/compiler/formulations/test_select.py checks that choice)
    small, _ = trees.cart_relative(2, eomc.mechanics)
    assert isinstance(formed_system(small, "auto"), Model)
    assert formed_system(small, "kane").method == "kane"
