"""A URDF robot's ``<collision>`` geometry as ground contacts, when the user asks for a ground.

One job: every ``<collision>`` (box, cylinder, sphere, mesh) of a link that moves becomes a
:class:`eomc.compiler.contact.geometry.Shape` on its tree body, placed in the body frame (a
link welded into a body through its fixed joints); the shapes touch the plane z = 0.  URDF has
no contact parameters: each shape takes the law's parameters MuJoCo's default contact would
have on this robot (solref 0.02 1, solimp 0.9 0.95 0.001, sliding friction 1; the rule of
:mod:`eomc.compiler.contact.mujoco_law`: k = W/δ_ref^1.5 with W the robot's weight, so a robot
resting on one shape sinks as deep as MuJoCo's default contact lets it).  Meshes are read
with trimesh (their convex hull's vertices), STL and OBJ without it too (the base install); one
that cannot be read is left out with a warning.
"""
import warnings

import numpy as np

from eomc.runtime.errors import EomcWarning, ModelError

from ..contact.mujoco_law import MUJOCO_DEFAULTS, law_parameters
from eomc.compiler import fixed_order as fo

__all__ = ["collision_shapes", "ground_check", "MUJOCO_DEFAULTS"]


def _plain_vertices(path):
    """A mesh file's vertices (n x 3) read without trimesh: binary or ASCII STL, or OBJ ('v' lines);
    None for any other format.  Duplicates are merged, as trimesh merges them (a triangle soup's
    STL repeats each vertex ~6 times); the shape is the same point set, so its bounding box and
    hull are trimesh's."""
    import os
    ext = os.path.splitext(str(path))[1].lower()
    with open(path, "rb") as f:
        data = f.read()
    if ext == ".stl":
        count = int(np.frombuffer(data[80:84], dtype="<u4")[0]) if len(data) >= 84 else -1
        if len(data) == 84 + 50 * count:                    # binary: 50 bytes a triangle
            rec = np.frombuffer(data[84:], dtype=np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")]))
            v = rec["v"].reshape(-1, 3).astype(float)
        else:                                               # ASCII: "vertex x y z" lines
            v = np.array([[float(x) for x in line.split()[1:4]] for line in data.decode("ascii", "replace").splitlines()
                          if line.strip().startswith("vertex")], dtype=float).reshape(-1, 3)
    elif ext == ".obj":
        v = np.array([[float(x) for x in line.split()[1:4]] for line in data.decode("utf-8", "replace").splitlines()
                      if line.startswith("v ")], dtype=float).reshape(-1, 3)
    else:
        return None
    if len(v) == 0 or not np.all(np.isfinite(v)):
        raise ValueError(f"no finite vertices in {os.path.basename(str(path))}")
    return np.unique(v, axis=0)


def _mesh_vertices(filename, directory, scale, where, missing, needed):
    from eomc.runtime.geometry import quiet_mesh_loggers
    from eomc.runtime.readable import check_regular_file
    import os
    plain = filename[len("file://"):] if filename.startswith("file://") else filename
    resolved = plain if os.path.isabs(plain) else os.path.join(str(directory), plain)
    looked = resolved if not filename.startswith("package://") else filename
    if not os.path.exists(resolved):          # package://...: yourdfpy's search
        try:
            from yourdfpy.urdf import filename_handler_magic
            with quiet_mesh_loggers():
                resolved = filename_handler_magic(filename, dir=str(directory))
        except Exception:
            pass
    if not os.path.exists(resolved):          # without yourdfpy (the base install): the same search,
        from eomc.runtime.urdf_scene import resolve_filename     # and the package folders
        resolved = resolve_filename(filename, str(directory))
    if not os.path.lexists(resolved):     # said once per directory (_warn_missing), not trimesh's per link
        missing.append((where, filename, looked))
        return None
    try:
        check_regular_file(resolved, what="mesh")
        try:
            import trimesh
        except ImportError:
            v = _plain_vertices(resolved)     # STL and OBJ without trimesh (the base install)
            if v is None:
                raise
        else:
            with quiet_mesh_loggers():
                mesh = trimesh.load(str(resolved), force="mesh")
            v = np.asarray(mesh.vertices, dtype=float)
    except ImportError:               # a DAE (or another format) in the base install: say the extra
        needed.append((where, filename))
        return None
    except Exception as exc:      # not a regular file, unreadable, no trimesh: left out, said so
        warnings.warn(f"{where}: its mesh {filename} cannot be read ({type(exc).__name__}: {exc}); it does not "
                      f"touch the ground", EomcWarning, stacklevel=4)
        return None
    return v * np.asarray(scale if scale is not None else (1.0, 1.0, 1.0), dtype=float)


def _warn_needed(needed):
    """One warning for the collision meshes the base install cannot read (DAE without trimesh and
    pycollada), naming the extra that reads them."""
    if needed:
        links = "; ".join(f"{name} ({where.replace(' <collision>', '')})" for where, name in needed)
        warnings.warn(f"{len(needed)} collision mesh{'es' * (len(needed) > 1)} need{'s' * (len(needed) == 1)} "
                      f"trimesh and pycollada to be read, which are not installed, so "
                      f"{'their links do' if len(needed) > 1 else 'its link does'} not touch the ground: "
                      f"pip install \"eomc[mesh]\" (from a clone of eomc: pip install \".[mesh]\"): {links}",
                      EomcWarning, stacklevel=4)


def _warn_missing(missing):
    """One warning per directory for the collision meshes that do not exist: (where, filename as
    written, path looked for) each.  trimesh's "string is not a file" once per link (13 times for
    solo12 without its meshes) said less, longer."""
    import os
    by_dir = {}
    for where, filename, resolved in missing:
        by_dir.setdefault(os.path.dirname(resolved), []).append((where, os.path.basename(resolved)))
    for directory, items in by_dir.items():
        links = "; ".join(f"{name} ({where.replace(' <collision>', '')})" for where, name in items)
        warnings.warn(f"{len(items)} collision mesh{'es' * (len(items) > 1)} under {directory} "
                      f"do{'es' * (len(items) == 1)} not exist, so {'their links do' if len(items) > 1 else 'its link does'} "
                      f"not touch the ground: {links}", EomcWarning, stacklevel=4)


def _bounding_box(vertices):
    """(centre, half sizes) of the vertices' axis-aligned box in their own frame."""
    lo, hi = np.min(vertices, axis=0), np.max(vertices, axis=0)
    return 0.5 * (lo + hi), 0.5 * (hi - lo)


NEAR = 2.0      # a named sphere's radii within which a body's other geometry is left to it (boxes)


def _boxed(points, near):
    """(centre, half sizes) in the shape frame of the bounding box of ``points`` (shape frame,
    with ``to_body(points)`` in the body frame) that lie farther than NEAR radii from every
    named sphere ``near`` [(centre, radius)] of the body, or None when none do."""
    pts, body = points
    keep = np.ones(len(pts), dtype=bool)
    for centre, radius in near:
        keep &= np.linalg.norm(body - centre, axis=1) > NEAR * radius
    return _bounding_box(pts[keep]) if keep.any() else None


def collision_shapes(built, collisions, placements, height=0.0, skip=(), boxes=False, near=None):
    """[Shape] of the robot's collision geometry on its moving bodies, touching the plane z =
    ``height``: ``built``, the URDF's UrdfTree; ``collisions``, the reader's records
    (eomc.compiler.multibody.Collision, in file order); ``placements``: {link: (body key or
    "world", 4x4 pose in that body's frame)} (:func:`eomc.compiler.contact.tree.link_frame`).
    ``skip``: links left out.  ``boxes``: a mesh, box or cylinder becomes the 8 corners of its
    bounding box in its own frame (the default ground of a robot with named contacts): never
    inside the shape, so no part of the body goes deeper than its deepest corner, at a fixed 8
    points per shape where a hull takes up to 32 (Go2's trunk, hips, thighs and calves: 88
    points).  ``near``: {tree body index: [(centre (body link frame), radius)]} of the named
    contact spheres: with ``boxes``, the shape's points within NEAR radii of one are left to
    it before the box is taken (Go2's calf mesh reaches 8 mm past its foot sphere's centre; its
    box would stand the robot on its shins)."""
    from eomc.compiler.contact.geometry import Shape
    from eomc.compiler.contact.tree import link_frame
    from .tree import identifier
    source = built.source
    path = source.path
    by_body = {b.name: i for i, b in enumerate(built.tree.bodies)}
    mass = sum(float(getattr(b, "mass", 0.0) or 0.0) for b in source.bodies.values())
    g = 9.81
    k, c, mu = law_parameters(MUJOCO_DEFAULTS["solref"], MUJOCO_DEFAULTS["solimp"], MUJOCO_DEFAULTS["friction"],
                              3, g, max(mass, 1e-9) * g)
    shapes, names, missing, needed = [], set(), [], []
    by_link = {}
    for col in collisions:
        by_link.setdefault(col.frame, []).append(col)
    for link, cols in by_link.items():
        found = link_frame(source, link, placements)
        if found is None or found[0] == "world" or found[0] not in by_body:
            continue                       # welded to the ground, or not a moving body
        key, T = found
        if link in skip:
            continue
        T = np.asarray(T, dtype=float)
        for n, col in enumerate(cols):
            where = f"{path}:{col.line}: link {link!r} <collision>"
            origin = np.asarray(col.origin, dtype=float)
            R = fo.matmul(T[:3, :3], origin[:3, :3])
            pos = fo.matmul(T[:3, :3], origin[:3, 3]) + T[:3, 3]
            if col.geometry is None:
                continue
            try:
                vertices = ()
                if col.geometry == "box":
                    kind, size = "box", tuple(0.5 * float(x) for x in col.attribute("size").split())
                elif col.geometry == "cylinder":
                    kind, size = "cylinder", (float(col.attribute("radius")), 0.5 * float(col.attribute("length")))
                elif col.geometry == "sphere":
                    kind, size = "sphere", (float(col.attribute("radius")),)
                elif col.geometry == "capsule":
                    kind, size = "capsule", (float(col.attribute("radius")), 0.5 * float(col.attribute("length")))
                elif col.geometry == "mesh":
                    scale = col.attribute("scale")
                    v = _mesh_vertices(col.attribute("filename"), path.parent,
                                       [float(x) for x in scale.split()] if scale else None, where, missing,
                                       needed)
                    if v is None or len(v) == 0:
                        continue
                    kind, size, vertices = "mesh", (), tuple(map(tuple, v))
                else:
                    warnings.warn(f"{where}: <{col.geometry}> is not a shape eomc can put on the ground; left out",
                                  EomcWarning, stacklevel=3)
                    continue
            except (TypeError, ValueError, AttributeError):
                raise ModelError(f"{where}: <{col.geometry}> with missing or bad sizes") from None
            if boxes and kind in ("mesh", "box", "cylinder"):
                from eomc.compiler.contact.geometry import shape_points
                pts = np.asarray(vertices if kind == "mesh" else shape_points(kind, size)[0], dtype=float)
                box = _boxed((pts, fo.matmul(pts, R.T) + pos), (near or {}).get(by_body[key], ()))
                if box is None:
                    continue
                centre, half = box
                corners = np.unique(np.array([centre + half * (sx, sy, sz) for sx in (-1, 1) for sy in (-1, 1)
                                              for sz in (-1, 1)]), axis=0)    # a flat box: 4 points
                kind, size, vertices = "mesh", (), tuple(tuple(float(x) for x in c) for c in corners)
            name = identifier(link) + (f"_col{n}" if len(cols) > 1 else "_col")
            while name in names:
                name += "_"
            names.add(name)
            shapes.append(Shape(name=name, body=by_body[key], kind=kind, size=size, pos=tuple(pos),
                                rot=tuple(map(tuple, R)), normal=(0.0, 0.0, 1.0), height=float(height),
                                k=k, c=c, mu=mu, vertices=vertices, where=where))
    _warn_missing(missing)
    _warn_needed(needed)
    return shapes


def ground_check(built, collisions, placements, shapes=None):
    """{"normal", "height", "bodies": {body frame: [[x, y, z, r], ...]}}: for the run's verdict
    (eomc.runtime.ground_check), the points of each moving body that must stay above the
    ground, in its link frame (the poses' body frame): its collision geometry's (a mesh's hull
    vertices, thinned as the ground contacts thin them; a primitive's points of
    eomc.compiler.contact.geometry.shape_points with their radius), or its origin when it has
    none.  ``shapes``: collision_shapes' result when already made (without ``boxes``)."""
    import warnings as _w
    from eomc.compiler.contact.geometry import shape_points
    if shapes is None:
        with _w.catch_warnings():
            _w.simplefilter("ignore")          # unreadable meshes were warned about by the ground
            shapes = collision_shapes(built, collisions, placements)
    names = [b.name for b in built.tree.bodies]
    bodies = {name: [] for name in names}
    for shape in shapes:
        try:
            points, radius, axes = shape_points(shape.kind, shape.size, shape.vertices)
        except ValueError:
            continue
        R, pos = np.asarray(shape.rot, dtype=float), np.asarray(shape.pos, dtype=float)
        r = radius if axes is None else float(max(axes))
        bodies[names[shape.body]] += [[float(x) for x in pos + fo.matmul(R, pt)] + [float(r)]
                                      for pt in points]
    for name in names:
        bodies[name] = bodies[name] or [[0.0, 0.0, 0.0, 0.0]]
    return {"normal": [0.0, 0.0, 1.0], "height": 0.0, "bodies": bodies}
