"""Finding the tree: parents, joint kinds, gravity and loads; clear refusals otherwise."""
import pytest
import sympy as sm
import sympy.physics.mechanics as sme

import eomc.mechanics as em
from eomc.compiler.tree import NotATree, tree_from_system, tree_of
from helpers import zoo
from helpers.trees import cart_joints, cart_relative


def test_hand_built_cart_is_a_chain_with_gravity():
    kane, _ = cart_relative(3, em, torques=True)
    tree = tree_of(kane)
    assert [b.parent for b in tree.bodies] == [-1, 0, 1, 2]
    assert [b.kind for b in tree.bodies] == ["prismatic", "revolute", "revolute", "revolute"]
    assert [b.speed for b in tree.bodies] == [0, 1, 2, 3]
    g = sm.Symbol("g", positive=True)
    assert list(tree.gravity) == [0, -g, 0]
    # F on the cart, T1..T3 on their links, -T2, -T3 on the links before
    assert sorted(ld.body for ld in tree.loads) == [0, 1, 1, 2, 2, 3]
    # each joint's rotation depends on its own coordinate only (sum-of-angles undone)
    for k, body in enumerate(tree.bodies[1:], start=1):
        assert body.rotation.atoms(sm.cos) == {sm.cos(kane._q[k])}


def test_system_of_joints_reads_its_joints():
    system, _ = cart_joints(2, rigid=True)
    tree = tree_from_system(system)
    assert [b.joint for b in tree.bodies] == ["slider", "pin1", "pin2"]
    assert [b.parent for b in tree.bodies] == [-1, 0, 1]
    assert tree.bodies[1].motion[:3] == (0, 0, 1)


def test_absolute_angles_are_not_joint_coordinates():
    kane, _ = zoo.n_link_pendulum_on_cart(2, em)
    with pytest.raises(NotATree, match=r"body Pa2 .*more than its own coordinate q2"):
        tree_of(kane)


def test_three_speed_body_is_refused_naming_it():
    kane, _ = zoo.heavy_top(em)
    with pytest.raises(NotATree, match="body Top moves with speeds u1, u2, u3 relative to the ground"):
        tree_of(kane)


def test_constrained_system_is_not_a_tree():
    kane, _ = zoo.rolling_disc(em)
    with pytest.raises(NotATree, match="2 of its velocity constraints are nonholonomic"):
        tree_of(kane)


def test_spherical_joint_is_three_stages():
    """A ball joint: two massless intermediate frames, then the body, one angle each."""
    ground, ball = sme.RigidBody("ground"), sme.RigidBody("ball")
    joint = sme.SphericalJoint("socket", ground, ball, sme.dynamicsymbols("a b c"),
                               sme.dynamicsymbols("wa wb wc"), child_point=ball.frame.x)
    system = sme.System.from_newtonian(ground)
    system.add_joints(joint)
    tree = tree_from_system(system)
    assert [b.name for b in tree.bodies] == ["socket_stage1", "socket_stage2", "ball"]
    assert [b.parent for b in tree.bodies] == [-1, 0, 1]
    assert [b.speed for b in tree.bodies] == [0, 1, 2]
    assert [b.kind for b in tree.bodies] == ["revolute"] * 3
    assert tree.bodies[0].mass == 0 and tree.bodies[2].mass == ball.mass


def test_multi_speed_joint_is_one_body():
    """A cylindrical joint: one body with two constant axes (turn and slide along one line)."""
    ground, body = sme.RigidBody("ground"), sme.RigidBody("sleeve")
    joint = sme.CylindricalJoint("rod", ground, body)
    system = sme.System.from_newtonian(ground)
    system.add_joints(joint)
    tree = tree_from_system(system)
    assert [(b.name, b.kind, b.speed, b.speeds) for b in tree.bodies] == [("sleeve", "2-speed", None, (0, 1))]
    assert tree.bodies[0].motions == ((1, 0, 0, 0, 0, 0), (0, 0, 0, 1, 0, 0))


def test_closed_loop_is_not_a_tree():
    kane, _ = zoo.four_bar(em)
    with pytest.raises(NotATree, match="depends on more than its own coordinate"):   # absolute angles
        tree_of(kane)


def test_joint_torques_along_axes_are_body_loads():
    """A joint torque written along its axis in the parent's frame turns with the child:
    its child-frame components are constant, so it is a body load (no world rotations are
    built for it); a force along a world direction on a turning body stays a world load."""
    from helpers import random_trees
    spec = [{"parent": -1, "kind": "pin", "rotation": ("BODY", 123), "axis": (1, 0, 1),
             "parent_point": (0, 0, 1), "child_point": (1, 1, 0), "rigid": True, "products": True,
             "load": True},
            {"parent": 0, "kind": "pin", "rotation": ("BODY", 123), "axis": (0, 1, 1),
             "parent_point": (1, 0, 0), "child_point": (0, 1, 0), "rigid": True, "products": False,
             "load": True}]
    system, _ = random_trees.build(spec)
    F = sme.dynamicsymbols("F")
    system.add_loads(sme.Force(system.bodies[2].masscenter, F * system.frame.x))
    tree = tree_from_system(system)
    frames = sorted((load.body, load.frame, tuple(load.force) != (0, 0, 0)) for load in tree.loads)
    assert frames == [(0, "body", False), (0, "body", False), (1, "body", False), (1, "world", True)]
    child_torque = [load for load in tree.loads if load.body == 1 and load.frame == "body"][0]
    assert not any(c.has(*system.q) for c in child_torque.moment)
