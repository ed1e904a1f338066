"""TreeFrame: SymPy's shortest frame path, found breadth-first instead of by listing every path.

The Talos full-body build through from_urdf never finished (74 min) and G1's took 64 s in
system_from_tree alone: the world frame is linked to every body (urdf.system._set_velocities),
and SymPy's ReferenceFrame._dict_list lists every simple path through it."""
import random

import pytest
from sympy.physics.vector import ReferenceFrame, dynamicsymbols

from eomc.compiler.multibody.frames import TreeFrame
from eomc.compiler.urdf import from_urdf


def _hub_graph(n, seed):
    """n frames oriented along a random tree from N, each one's angular velocity also set in N
    directly (the hub eomc's URDF Systems have), some set relative to its parent as well."""
    rng = random.Random(seed)
    N = TreeFrame("N")
    frames = [N]
    for i in range(n):
        parent = rng.choice(frames)
        q = dynamicsymbols(f"q{i}")
        child = TreeFrame(f"F{i}")
        child.orient_axis(parent, [parent.x, parent.y, parent.z][rng.randrange(3)], q)
        if rng.random() < 0.7:
            child.set_ang_vel(N, child.ang_vel_in(N))
        frames.append(child)
    return frames


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_same_path_as_sympys(seed):
    """Every pair of frames, orientation and angular velocity graphs: the path SymPy's own
    search returns (ties broken the same way, so the expressions built along it are the same)."""
    frames = _hub_graph(7, seed)
    for a in frames:
        for b in frames:
            for num in (0, 1):
                assert a._dict_list(b, num) == ReferenceFrame._dict_list(a, b, num), (a, b, num)


def test_no_path_is_a_clear_error():
    a, b = TreeFrame("A"), TreeFrame("B")
    with pytest.raises(ValueError, match="No connecting orientation path found between A and B"):
        a.dcm(b)


def _limbed_urdf(limbs, links):
    """A floating torso with ``limbs`` chains of ``links`` revolute links, each ending in a
    fixed 'hand' link (the shape of a humanoid: many branches off one base, welded ends)."""
    def link(name):
        return (f'<link name="{name}"><inertial><mass value="1"/><origin xyz="0 0 0.1"/>'
                f'<inertia ixx="0.01" iyy="0.02" izz="0.03" ixy="0" ixz="0" iyz="0"/></inertial></link>')
    parts = [link("torso")]
    for k in range(limbs):
        parent = "torso"
        for i in range(links):
            name = f"l{k}_{i}"
            parts += [link(name), f'<joint name="j{k}_{i}" type="revolute"><parent link="{parent}"/>'
                      f'<child link="{name}"/><origin xyz="0.1 {k * 0.1} 0.2"/>'
                      f'<axis xyz="{"100"[i % 3]} {"010"[i % 3]} {"001"[i % 3]}"/>'
                      f'<limit lower="-1" upper="1" effort="10" velocity="1"/></joint>']
            parent = name
        parts += [link(f"hand{k}"), f'<joint name="wrist{k}" type="fixed"><parent link="{parent}"/>'
                  f'<child link="hand{k}"/><origin xyz="0 0 0.1"/></joint>']
    return '<robot name="limbed">' + "".join(parts) + "</robot>"


def test_a_limbed_robots_system_never_lists_all_paths(tmp_path, monkeypatch):
    """A floating base with 3 limbs of 3 links (SymPy's search took minutes on such trees
    of 30 bodies, hours on 45): building its System never runs SymPy's listing of all paths --
    every search starts from one of eomc's frames -- and a leaf's angular velocity in N is
    made of its own limb's speeds."""
    path = tmp_path / "limbed.urdf"
    path.write_text(_limbed_urdf(3, 3))
    listed = []
    original = ReferenceFrame._dict_list

    def spy(self, other, num):
        listed.append((self.name, other.name))
        return original(self, other, num)
    monkeypatch.setattr(ReferenceFrame, "_dict_list", spy)
    system = from_urdf(path, floating_base=True)
    assert listed == []
    assert all(isinstance(b.frame, TreeFrame) for b in system.bodies)
    N = system.frame
    leaf = system.urdf.bodies["l2_2"]
    w = leaf.frame.ang_vel_in(N)      # the torso's ω plus the three joint rates about their axes
    speeds = {u.name for u in w.free_dynamicsymbols(N)}
    assert {f"u_j2_{i}" for i in range(3)} <= speeds and "u_j0_0" not in speeds
    assert listed == []
