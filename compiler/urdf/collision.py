"""A URDF robot's ``<collision>`` geometry as ground contacts, when the user asks for a ground.

One job: every ``<collision>`` (box, cylinder, sphere, mesh) of a link that moves becomes a
:class:`eomc.compiler.contact.geometry.Shape` on its tree body, placed in the body frame (a
link welded into a body through its fixed joints); the shapes touch the plane z = 0.  URDF has
no contact parameters: each shape takes the law's parameters MuJoCo's default contact would
have on this robot (solref 0.02 1, solimp 0.9 0.95 0.001, sliding friction 1; the rule of
:mod:`eomc.compiler.mjcf.collision`: k = W/δ_ref^1.5 with W the robot's weight, so a robot
resting on one shape sinks as deep as MuJoCo's default contact lets it).  Meshes are read
with trimesh (their convex hull's vertices); one that cannot be read is left out with a warning.
"""
import warnings

import numpy as np

from eomc.runtime.errors import EomcWarning, ModelError

__all__ = ["collision_shapes", "MUJOCO_DEFAULTS"]

MUJOCO_DEFAULTS = {"solref": (0.02, 1.0), "solimp": (0.9, 0.95, 0.001, 0.5, 2.0), "friction": (1.0, 0.005, 1e-4)}


def _rpy(r, p, y):
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def _mesh_vertices(filename, directory, scale, where):
    from eomc.runtime.geometry import _quiet_mesh_loggers
    from eomc.runtime.readable import check_regular_file
    import os
    plain = filename[len("file://"):] if filename.startswith("file://") else filename
    resolved = plain if os.path.isabs(plain) else os.path.join(str(directory), plain)
    if not os.path.exists(resolved):          # package://...: yourdfpy's search
        try:
            from yourdfpy.urdf import filename_handler_magic
            with _quiet_mesh_loggers():
                resolved = filename_handler_magic(filename, dir=str(directory))
        except Exception:
            pass
    try:
        check_regular_file(resolved, what="mesh")
        import trimesh
        with _quiet_mesh_loggers():
            mesh = trimesh.load(str(resolved), force="mesh")
        v = np.asarray(mesh.vertices, dtype=float)
    except Exception as exc:      # not a regular file, unreadable, no trimesh: left out, said so
        warnings.warn(f"{where}: its mesh {filename} cannot be read ({type(exc).__name__}: {exc}); it does not "
                      f"touch the ground", EomcWarning, stacklevel=4)
        return None
    return v * np.asarray(scale if scale is not None else (1.0, 1.0, 1.0), dtype=float)


def collision_shapes(built, height=0.0):
    """[Shape] of the robot's collision geometry on its moving bodies (``built``: the URDF's
    UrdfTree), touching the plane z = ``height``."""
    from lxml import etree
    from eomc.compiler.contact.geometry import Shape
    from eomc.compiler.mjcf.collision import law_parameters
    from eomc.compiler.contact.tree import _link_frames
    from .tree import identifier
    source = built.source
    path = source.path
    root = etree.parse(str(path)).getroot()
    by_body = {b.name: i for i, b in enumerate(built.tree.bodies)}
    mass = sum(float(getattr(b, "mass", 0.0) or 0.0) for b in source.bodies.values())
    g = 9.81
    k, c, mu = law_parameters(MUJOCO_DEFAULTS["solref"], MUJOCO_DEFAULTS["solimp"], MUJOCO_DEFAULTS["friction"],
                              3, g, max(mass, 1e-9) * g)
    shapes, names = [], set()
    for link in root.iter("link"):
        cols = link.findall("collision")
        if not cols:
            continue
        found = _link_frames(source, link.get("name"))
        if found is None or found[0] == "world" or found[0] not in by_body:
            continue                       # welded to the ground, or not a moving body
        key, T = found
        T = np.asarray(T, dtype=float)
        for n, col in enumerate(cols):
            where = f"{path}:{col.sourceline}: link {link.get('name')!r} <collision>"
            origin = col.find("origin")
            try:
                xyz = np.array([float(x) for x in ((origin.get("xyz") if origin is not None else None) or "0 0 0").split()])
                rpy = [float(x) for x in ((origin.get("rpy") if origin is not None else None) or "0 0 0").split()]
            except ValueError:
                raise ModelError(f"{where}: a bad origin") from None
            R = T[:3, :3] @ _rpy(*rpy)
            pos = T[:3, :3] @ xyz + T[:3, 3]
            geometry = col.find("geometry")
            item = geometry[0] if geometry is not None and len(geometry) else None
            if item is None or not isinstance(item.tag, str):
                continue
            try:
                vertices = ()
                if item.tag == "box":
                    kind, size = "box", tuple(0.5 * float(x) for x in item.get("size").split())
                elif item.tag == "cylinder":
                    kind, size = "cylinder", (float(item.get("radius")), 0.5 * float(item.get("length")))
                elif item.tag == "sphere":
                    kind, size = "sphere", (float(item.get("radius")),)
                elif item.tag == "capsule":
                    kind, size = "capsule", (float(item.get("radius")), 0.5 * float(item.get("length")))
                elif item.tag == "mesh":
                    scale = item.get("scale")
                    v = _mesh_vertices(item.get("filename"), path.parent,
                                       [float(x) for x in scale.split()] if scale else None, where)
                    if v is None or len(v) == 0:
                        continue
                    kind, size, vertices = "mesh", (), tuple(map(tuple, v))
                else:
                    warnings.warn(f"{where}: <{item.tag}> is not a shape eomc can put on the ground; left out",
                                  EomcWarning, stacklevel=3)
                    continue
            except (TypeError, ValueError, AttributeError):
                raise ModelError(f"{where}: <{item.tag}> with missing or bad sizes") from None
            name = identifier(link.get("name")) + (f"_col{n}" if len(cols) > 1 else "_col")
            while name in names:
                name += "_"
            names.add(name)
            shapes.append(Shape(name=name, body=by_body[key], kind=kind, size=size, pos=tuple(pos),
                                rot=tuple(map(tuple, R)), normal=(0.0, 0.0, 1.0), height=float(height),
                                k=k, c=c, mu=mu, vertices=vertices, where=where))
    return shapes
