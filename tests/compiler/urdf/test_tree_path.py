"""A URDF straight to the tree IR (compiler/urdf/treeir.py) against the System path.

Under the recursive and auto formulations a URDF file never becomes a SymPy
System: its tree is written down from the file's numbers.  It must be the
tree the recognizer reads from the System of ``from_urdf`` -- same states,
parameters, inputs and, at random values of every symbol, the same joint
rotations, offsets, motion axes, inertias, loads and kinematics -- and
compile to the same rhs.  Plus the N7/N8 inputs of the 2026-11 reliability
report: each a clear ``file:line`` message, a deep chain without recursion.
"""
import random

import numpy as np
import pytest
import sympy as sm
from sympy.core.function import AppliedUndef

import eomc
from eomc.compiler.driver import generate
from eomc.compiler.multibody import Model
from eomc.compiler.multibody.formed import model_of_tree, tree_formed
from eomc.compiler.urdf import build_tree, from_urdf, read_urdf, system_from_tree
from eomc.compiler.urdf.joints import FloatingJoint
from eomc.compiler.multibody.joint_kinds import floating_rotation
from eomc.compiler.urdf.treeir import tree_ir
from eomc.errors import ModelFileError
from eomc.runtime.errors import EomcWarning
from helpers.robots import robot_path
from helpers.urdf_arm import ARM

from .test_joint_types import ROBOT as ZOO


def _write(tmp_path, text, name="robot.urdf"):
    path = tmp_path / name
    path.write_text(text)
    return path


class _Values:
    def __init__(self):
        self.rng, self.values = random.Random(7), {}

    def __call__(self, expr):
        expr = sm.sympify(expr)
        for a in expr.atoms(AppliedUndef) | expr.free_symbols:
            self.values.setdefault(a, self.rng.uniform(-1.3, 1.3))
        return float(sm.sympify(expr.xreplace(self.values)))


def _same_trees(path, floating=False, fold=False):
    """The direct tree and the recognized one agree symbol for symbol and number for number."""
    tree = build_tree(read_urdf(path), floating_base=floating)
    mine = tree_ir(tree, fold=fold)
    built = system_from_tree(tree, fold=fold)
    direct, read = model_of_tree(mine.tree), tree_formed(built.system)
    assert (direct.coordinates, direct.speeds) == (read.coordinates, read.speeds)
    assert direct.inputs == read.inputs and list(mine.inputs) == list(built.inputs)
    assert direct.parameters == read.parameters and mine.parameters == built.parameters
    value = _Values()
    pairs = list(zip(direct.kinematics, read.kinematics))
    A, B = mine.tree, read.tree
    # the two routes may list the bodies in different (both topological) orders: compare
    # them by name, each with its parent's name
    def described(tree):
        return sorted((b.name, b.joint, tree.bodies[b.parent].name if b.parent >= 0 else None,
                       b.speed, b.speeds) for b in tree.bodies)
    assert described(A) == described(B)
    by_name = {b.name: b for b in B.bodies}
    for a in A.bodies:
        b = by_name[a.name]
        pairs += list(zip(a.rotation, b.rotation)) + list(zip(a.position, b.position))
        pairs += list(zip(a.inertia, b.inertia)) + [(a.mass, b.mass)]
        pairs += list(zip(a.motion or (), b.motion or ()))
        pairs += [p for m1, m2 in zip(a.motions, b.motions) for p in zip(m1, m2)]
    def loads(tree):
        key = lambda ld: (tree.bodies[ld.body].name, str(ld.frame))
        return sorted(tree.loads, key=key), [key(ld) for ld in sorted(tree.loads, key=key)]
    (la_sorted, ka), (lb_sorted, kb) = loads(A), loads(B)
    assert ka == kb
    for la, lb in zip(la_sorted, lb_sorted):
        pairs += list(zip(la.moment, lb.moment)) + list(zip(la.force, lb.force)) + list(zip(la.offset, lb.offset))
    pairs += list(zip(A.gravity, B.gravity))
    worst = max(abs(value(x) - value(y)) / max(1.0, abs(value(y))) for x, y in pairs)
    assert worst < 1e-12, worst


@pytest.mark.parametrize("floating", [False, True])
def test_every_joint_type_gives_the_recognized_tree(tmp_path, floating):
    _same_trees(_write(tmp_path, ZOO), floating)


def test_folded_parameters_give_the_recognized_tree(tmp_path):
    """fold_parameters=True: every URDF value a literal on both routes (no parameters left)."""
    _same_trees(_write(tmp_path, ZOO), floating=True, fold=True)
    tree = build_tree(read_urdf(_write(tmp_path, ZOO)))
    assert model_of_tree(tree_ir(tree, fold=True).tree).parameters == ()


def test_a_real_robot_gives_the_recognized_tree():
    _same_trees(robot_path("solo12"), floating=True)


def test_floating_rotation_is_sympys_body_xyz():
    from sympy.physics.mechanics import ReferenceFrame, dynamicsymbols
    a, b, c = dynamicsymbols("a b c")
    N, B = ReferenceFrame("N"), ReferenceFrame("B")
    B.orient_body_fixed(N, (a, b, c), "xyz")
    assert sm.simplify(N.dcm(B) - floating_rotation(a, b, c)) == sm.zeros(3, 3)
    assert FloatingJoint is not None


def test_compiled_rhs_matches_the_system_path(tmp_path):
    """The zoo robot compiled from its file (tree path) and from its System (recognized):
    identical names, rhs to 1e-12 at random states."""
    path = _write(tmp_path, ZOO, "zoo.urdf")
    cache = tmp_path / "cache"
    direct = eomc.compile(path, functions=["rhs", "poses"], formulation="recursive", cache_dir=cache,
                          progress=False)
    system = eomc.compile(from_urdf(path), "zoo", functions=["rhs", "poses"], formulation="recursive",
                          cache_dir=cache, progress=False)
    assert direct.state_names == system.state_names and direct.input_names == system.input_names
    assert direct.param_names == system.param_names
    assert np.array_equal(direct.param_defaults, system.param_defaults)
    rng = np.random.default_rng(3)
    for _ in range(5):
        x = rng.uniform(-1, 1, direct.nq + direct.nu)
        r = rng.normal(size=direct.ninput)
        a, b = direct.rhs(0.0, x, r=r), system.rhs(0.0, x, r=r)
        assert np.max(np.abs(a - b)) <= 1e-12 * max(1.0, np.max(np.abs(b)))
        # the animation's link frames (built from the tree, no System) are the System's
        pa, pb = direct.poses(0.0, x), system.poses(0.0, x)
        assert pa.frame_names == pb.frame_names and len(pa.frame_names) == 6   # 4 bodies, world, tool
        assert np.max(np.abs(pa.positions - pb.positions)) < 1e-12
        assert np.max(np.abs(pa.rotations - pb.rotations)) < 1e-12


def test_no_system_is_built_under_recursive_and_auto(tmp_path, monkeypatch):
    import eomc.compiler.urdf as urdf
    import eomc.compiler.urdf.model as urdf_model

    def refuse(*args, **kwargs):
        raise AssertionError("a SymPy System was built")
    monkeypatch.setattr(urdf_model, "system_from_tree", refuse, raising=False)
    monkeypatch.setattr(urdf, "system_from_tree", refuse)
    path = _write(tmp_path, ARM, "arm.urdf")
    for formulation in ("recursive", "auto"):
        spec, generated = generate(path, functions=["rhs"], formulation=formulation, use_cache=False)
        assert isinstance(spec.formed, Model) and spec.system is None
    with pytest.raises(AssertionError, match="System was built"):
        generate(path, functions=["rhs"], formulation="kane", use_cache=False)


def test_kane_still_uses_the_system(tmp_path):
    path = _write(tmp_path, ARM, "arm.urdf")
    spec, _ = generate(path, functions=["rhs"], formulation="kane", use_cache=False)
    assert spec.formed.method == "kane" and spec.system is not None


def _chain(n, axes=("1 0 0", "0 1 0")):
    links = ['<link name="base"/>'] + [
        f'<link name="l{k}"><inertial><origin xyz="0 0 0.05"/><mass value="0.1"/>'
        f'<inertia ixx="1e-4" iyy="1e-4" izz="1e-5" ixy="0" ixz="0" iyz="0"/></inertial></link>'
        for k in range(n)]
    joints = [f'<joint name="j{k}" type="revolute"><parent link="{"base" if k == 0 else f"l{k - 1}"}"/>'
              f'<child link="l{k}"/><origin xyz="0 0 0.1"/><axis xyz="{axes[k % len(axes)]}"/></joint>'
              for k in range(n)]
    return '<?xml version="1.0"?>\n<robot name="chain">\n' + "\n".join(links + joints) + "\n</robot>\n"


def test_a_1000_link_chain_reads_into_a_tree(tmp_path):
    """No recursion anywhere between the file and the tree IR (N7: 498 links used to overflow)."""
    tree = build_tree(read_urdf(_write(tmp_path, _chain(1000), "chain.urdf")))
    ir = tree_ir(tree).tree
    assert len(ir.bodies) == 1000 and ir.bodies[-1].parent == 998
    assert len(model_of_tree(ir).coordinates) == 1000


def _refused(tmp_path, text, *needles, line=None, **options):
    path = _write(tmp_path, text)
    with pytest.raises(ModelFileError) as info:
        build_tree(read_urdf(path), **options)
    message = str(info.value)
    assert message.startswith(f"{path}:") and all(n in message for n in needles), message
    if line is not None:
        assert info.value.lineno == line, message
    return message


LINK = ('<link name="{0}"><inertial><mass value="1"/>'
        '<inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>')


def _robot(*joints, links=("b", "c", "d")):
    body = [LINK.format(n) for n in links]
    body += [f'<joint name="{name}" type="{kind}"><parent link="{p}"/><child link="{c}"/>{extra}</joint>'
             for name, kind, p, c, extra in joints]
    return '<?xml version="1.0"?>\n<robot name="r">\n' + "\n".join(body) + "\n</robot>\n"


def test_reliability_n8_inputs_are_clear_errors(tmp_path):
    _refused(tmp_path, '<?xml version="1.0"?>\n<robot name="e"/>\n', "no <link>", line=2)
    _refused(tmp_path, _robot(("w", "fixed", "b", "c", ""), links=("b", "c")), "no moving joint", "without states")
    # a nameless robot is named after its file with a warning (test_errors), so this one-link
    # robot is refused for what it lacks that matters: something to move
    with pytest.warns(EomcWarning, match="<robot> has no name attribute"):
        _refused(tmp_path, '<?xml version="1.0"?>\n<robot>\n' + LINK.format("b") + "\n</robot>\n",
                 "robot 'robot' has no moving joint", line=2)
    text = _robot(("a-b", "revolute", "b", "c", '<axis xyz="0 0 1"/>'),
                  ("a_b", "revolute", "c", "d", '<axis xyz="0 0 1"/>'))
    _refused(tmp_path, text, "joint 'a_b'", "joint 'a-b'", "q_a_b", line=7)
    text = _robot(("p", "planar", "b", "c", '<axis xyz="0 0 1"/>'),
                  ("p_x", "revolute", "c", "d", '<axis xyz="0 0 1"/>'))
    _refused(tmp_path, text, "joint 'p_x'", "joint 'p'", "q_p_x")
    text = _robot(("j", "revolute", "b", "c", '<axis xyz="0 0 1"/><limit upper="abc" lower="0" effort="1" '
                                              'velocity="1"/>'), links=("b", "c"))
    _refused(tmp_path, text, '<limit upper="abc">', "joint 'j'", "expected a number", line=5)
    text = _robot(("j", "revolute", "b", "c", '<axis xyz="0 0 1"/>'), links=("b", "c")).replace(
        'ixx="0.1"', 'ixx="1e308"', 1)
    _refused(tmp_path, text, "link 'b'")
    text = _robot(("j", "revolute", "b", "c", '<axis xyz="0 0 1"/>'), links=("b", "c")).replace(
        '<link name="c"><inertial><mass value="1"/><inertia ixx="0.1"', '<link name="c"><inertial><mass '
        'value="1"/><inertia ixx="1e308"')
    _refused(tmp_path, text, "link 'c'")


def test_overflowing_axis_is_normalized(tmp_path):
    text = _robot(("j", "revolute", "b", "c", '<axis xyz="1e200 1e200 0"/>'), links=("b", "c"))
    tree = build_tree(read_urdf(_write(tmp_path, text)))
    assert np.allclose(tree.joints[0].axis, [2 ** -0.5, 2 ** -0.5, 0])


def test_mimic_multiplier_zero_is_refused_naming_the_joint(tmp_path):
    text = _robot(("a", "revolute", "b", "c", '<axis xyz="0 0 1"/>'),
                  ("m", "revolute", "c", "d", '<axis xyz="0 0 1"/><mimic joint="a" multiplier="0" offset="0.3"/>'))
    path = _write(tmp_path, text)
    with pytest.raises(ModelFileError, match=r"joint 'm' mimics 'a' with multiplier 0") as info:
        from_urdf(path, mimic=True)
    assert info.value.lineno == 7
    assert len(from_urdf(path).q) == 2             # ignored without mimic=True, as in Pinocchio


def test_joint_order_is_depth_first_in_file_order(tmp_path):
    """The walk without recursion keeps the recursive walk's order (the state order of
    every earlier build): a branch's whole subtree before the next sibling."""
    text = _robot(("a", "revolute", "b", "c", '<axis xyz="0 0 1"/>'),
                  ("s", "revolute", "b", "e", '<axis xyz="0 1 0"/>'),
                  ("a1", "revolute", "c", "d", '<axis xyz="1 0 0"/>'), links=("b", "c", "d", "e"))
    tree = build_tree(read_urdf(_write(tmp_path, text)))
    assert [j.name for j in tree.joints] == ["a", "a1", "s"]


def test_mimic_true_falls_back_to_the_system_with_the_reason(tmp_path):
    """mimic=True makes a constraint, which the tree cannot carry: the System path, said."""
    from eomc.compiler.urdf.model import UrdfModel
    from eomc.runtime.errors import EomcWarning
    text = ARM.replace('<axis xyz="0 1 0"/>\n  </joint>\n</robot>',
                       '<axis xyz="0 1 0"/>\n    <mimic joint="shoulder" multiplier="2"/>\n  </joint>\n</robot>')
    path = _write(tmp_path, text, "arm.urdf")
    with pytest.warns(EomcWarning, match="mimic joints \\(elbow\\) are constraints"):
        spec, _ = generate(UrdfModel(path, mimic=True), "arm", functions=["rhs"], formulation="auto",
                           use_cache=False)
    # the System's holonomic constraint closes its joint tree: auto takes the closed tree
    # (compiler/tree/constrained.py) or Kane, whichever is cheaper, with both speeds in the state
    assert (isinstance(spec.formed, Model) or spec.formed.method == "kane") and len(spec.formed.speeds) == 2
    assert spec.formed.n_dependent_speeds == 1


@pytest.mark.parametrize("which", ["zoo", "solo12"])
def test_the_direct_reader_reads_what_yourdfpy_reads(tmp_path, which):
    """eomc reads the checked lxml elements itself; yourdfpy (the former parser) is the reference."""
    path = _write(tmp_path, ZOO, "zoo.urdf") if which == "zoo" else robot_path("solo12")
    a, b = read_urdf(path), read_urdf(path, parser="yourdfpy")
    assert list(a.links) == list(b.links) and a.name == b.name
    for name in a.links:
        la, lb = a.links[name], b.links[name]
        assert (la.line, la.mass, la.has_inertial, sorted(la.meshes)) == (lb.line, lb.mass, lb.has_inertial,
                                                                           sorted(lb.meshes))
        assert np.array_equal(la.com, lb.com) and np.allclose(la.inertia, lb.inertia, rtol=1e-15, atol=0)
    for ja, jb in zip(a.joints, b.joints):
        assert (ja.name, ja.line, ja.type, ja.parent, ja.child, ja.mimic) == \
               (jb.name, jb.line, jb.type, jb.parent, jb.child, jb.mimic)
        assert np.allclose(ja.origin, jb.origin, rtol=0, atol=1e-15) and np.array_equal(ja.axis, jb.axis)
    assert len(a.joints) == len(b.joints)
