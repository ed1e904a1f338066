"""The animation's poses of an MJCF model: MuJoCo's body frames placed by the tree, its geoms as shapes.

Why from the tree: an MJCF model has no SymPy System (it goes straight to the
recursive formulation's Tree, :mod:`.treeir`), so the PoseSource
(eomc.compiler.emit.poses) is built from the tree's own joint transforms, as
the URDF reader's :func:`eomc.compiler.urdf.treeir.pose_source` does.  A tree
body's origin is its mass centre and its axes are the MuJoCo body's, so each
MuJoCo body frame is that point minus the mass centre offset (``body_ipos``):
the frames are MuJoCo's ``xpos``/``xmat`` exactly (the tests check it).  Bodies
with several joints pass through massless tree bodies, which are chained but not
shown.

Geoms become eomc.geometry shapes in their body's frame (``geom_pos``/``geom_quat``):
sphere, box, cylinder; a capsule as a cylinder with a sphere at each end; an
ellipsoid and a mesh as a box of their bounding size (MuJoCo's ``geom_aabb``),
since eomc's shapes have neither an ellipsoid nor MuJoCo's compiled meshes;
planes (an infinite floor) and invisible geoms (alpha 0) are left out.
"""
import numpy as np
import sympy as sm

from .treeir import quat_matrix
from eomc.compiler import fixed_order as fo

__all__ = ["mjcf_pose_source", "mjcf_geometry"]


def mjcf_pose_source(built, m):
    """The poses (eomc.compiler.tree.poses.TreePoseSource) of an :class:`~.treeir.MjcfTree`
    ``built`` read from the MjModel ``m``: each MuJoCo body's frame its tree body's origin
    (the mass centre) less the mass-centre offset, in the body's axes."""
    from eomc.compiler.tree.poses import TreePoseSource
    frames, points, lines = [], [("O", None)], []
    shown = {0: 0}         # MuJoCo body -> index into points of its frame origin (0: the world's O)
    for i, (body, owner) in enumerate(zip(built.tree.bodies, built.owners)):
        if owner is None:
            continue
        b, c = owner
        frames.append((body.name, i, None, tuple(-sm.sympify(x) for x in c)))
        points.append((body.name, len(frames) - 1))
        shown[b] = len(points) - 1
        lines.append((shown[int(m.body_parentid[b])], len(points) - 1))
    steps = tuple(tuple(body.position) for body in built.tree.bodies)
    return TreePoseSource(tuple(frames), tuple(points), tuple(lines), dict(built.parameters), mjcf_geometry(built, m),
                          tree=built.tree, steps=steps)


def _transform(R, p):
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, p
    return T


def mjcf_geometry(built, m):
    """{body name or "world": [shape dicts]} of the model's visible geoms (see the module docstring)."""
    import mujoco
    from eomc.runtime.geometry import shape
    names = {0: "world"}
    names.update({owner[0]: body.name for body, owner in zip(built.tree.bodies, built.owners) if owner})
    G = mujoco.mjtGeom
    out = {}
    for g in range(m.ngeom):
        b = int(m.geom_bodyid[g])
        mat = int(m.geom_matid[g])
        rgba = m.mat_rgba[mat] if mat >= 0 else m.geom_rgba[g]
        kind, size = int(m.geom_type[g]), [float(x) for x in m.geom_size[g]]
        if rgba[3] == 0 or kind == int(G.mjGEOM_PLANE) or b not in names:
            continue
        T = _transform(quat_matrix(m.geom_quat[g]), m.geom_pos[g])
        color = [float(x) for x in rgba[:3]]
        items = []
        if kind == int(G.mjGEOM_SPHERE):
            items.append(shape("sphere", size[:1], origin=T, color=color))
        elif kind == int(G.mjGEOM_BOX):
            items.append(shape("box", [2 * x for x in size], origin=T, color=color))
        elif kind in (int(G.mjGEOM_CYLINDER), int(G.mjGEOM_CAPSULE)):
            r, half = size[0], size[1]
            items.append(shape("cylinder", (r, 2 * half), origin=T, color=color))
            if kind == int(G.mjGEOM_CAPSULE):
                items += [shape("sphere", (r,), origin=fo.matmul(T, _transform(np.eye(3), (0, 0, z))), color=color)
                          for z in (-half, half)]
        else:   # ellipsoid, mesh, hfield, sdf: a box of the bounding size
            centre, half = m.geom_aabb[g][:3], m.geom_aabb[g][3:]
            if np.all(half > 0):
                items.append(shape("box", [2 * float(x) for x in half],
                                   origin=fo.matmul(T, _transform(np.eye(3), centre)), color=color))
        if items:
            out.setdefault(names[b], []).extend(items)
    return out
