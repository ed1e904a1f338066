"""The animation's poses of a robot read into a joint tree (URDF, MJCF), placed along the tree.

``NAME_poses`` of a robot file: each shown frame's world position and rotation.  The bodies
are placed by :class:`.placement.Placement`, the one placement frame outputs and contacts
use; no SymPy frame graph is built (a System's poses still come from its own graphs:
:mod:`eomc.compiler.emit.poses`, which also writes the metadata and lowers either source).

A :class:`TreePoseSource` says which point of each body is placed (``steps``: its offset
from the parent's placed point, parent components -- a URDF link's origin, or the tree
body's own origin for MJCF) and which frames are shown: ``(name, body, rotation, offset)``
fixed to a placed body (-1: the world) by a constant rotation and offset (None: the body's
own).  Each is placed when first asked for, in the order the shown frames are listed, so
the generated C is what the frame-graph lowering gave for the same robot.
"""
from dataclasses import dataclass

import numpy as np
import sympy as sm

from ..emit.poses import Shown
from .placement import Placement, ZERO, to_world
from eomc.compiler import fixed_order as fo

__all__ = ["TreePoseSource", "welded_frames"]


@dataclass(frozen=True, kw_only=True)
class TreePoseSource(Shown):
    """See the module docstring.  ``points``: (name, index into ``frames`` of the frame whose
    origin it is, or None: the world's origin); the rest as :class:`~eomc.compiler.emit.poses.Shown`."""
    tree: object
    steps: tuple

    def placer(self, slot, let):
        """(frame(k) -> (R, p), point(k) -> p) in the program's symbols; ``slot(expr, what)``
        maps mechanics symbols (raises ModelError where it cannot)."""
        bodies = self.tree.bodies
        placement = Placement([b.parent for b in bodies],
                              lambda i: [[slot(bodies[i].rotation[r, c], f"the orientation of body {bodies[i].name}")
                                          for c in range(3)] for r in range(3)],
                              lambda i: [slot(x, f"the position of body {bodies[i].name}") for x in self.steps[i]],
                              let)
        placed = {}

        def frame(k):
            if k not in placed:
                name, body, rotation, offset = self.frames[k]
                R = placement.rotation(body)
                if rotation is not None:
                    D = [[slot(x, f"the orientation of frame {name}") for x in row] for row in rotation]
                    R = [[let(sum((R[a][m] * D[m][c] for m in range(3)), sm.S.Zero)) for c in range(3)]
                         for a in range(3)]
                p = placement.origin(body)
                if offset is not None:
                    o = [slot(x, f"the position of frame {name}") for x in offset]
                    Rb = placement.rotation(body)
                    p = [let(p[a] + x) for a, x in enumerate(to_world(Rb, o))]
                placed[k] = (R, list(p))
            return placed[k]

        def point(k):
            at = self.points[k][1]
            return list(ZERO) if at is None else frame(at)[1]
        return frame, point

    def table(self, slot):
        """(values, shape) of NAME_poses as a loop over the tree (compiler/tree/body_loops.py), or None
        where a value does not map into the program's symbols (then the placement above leaves the
        frame out with a warning).  ``values``: each body's step (3, in body order), then per frame
        its turn D (9, rows) and offset o (3) where it has them; ``shape``: "size" (of ``values``),
        "frames" (body or -1: the world, where its D is in ``values`` or -1, where its o is or -1),
        "points" (the frame whose origin it is, -1: the world's origin)."""
        from eomc.runtime.errors import ModelError
        values, frames = [], []
        try:
            for b, step in zip(self.tree.bodies, self.steps):
                values += [slot(x, f"the position of body {b.name}") for x in step]
            for name, body, rotation, offset in self.frames:
                d = m = -1
                if rotation is not None:
                    d = len(values)
                    values += [slot(x, f"the orientation of frame {name}") for row in rotation for x in row]
                if offset is not None:
                    m = len(values)
                    values += [slot(x, f"the position of frame {name}") for x in offset]
                frames.append((body, d, m))
        except ModelError:
            return None
        points = [-1 if at is None else at for _, at in self.points]
        return values, {"size": len(values), "frames": frames, "points": points}

    def contact_metadata(self):
        """NAME.json ``poses.contacts`` and ``poses.weight`` (:func:`contact_metadata`)."""
        return contact_metadata(self)

    def digest(self):
        """Everything that shapes the generated code, for the generation cache key."""
        out = ["tree poses", str([f[0] for f in self.frames]), str([p[0] for p in self.points]), str(self.lines),
               str(sorted(self.geometry.items()))]
        for b, step in zip(self.tree.bodies, self.steps):
            out += [str(b.parent), b.rotation, *step]
        for name, body, rotation, offset in self.frames:
            out += [name, str(body), str(rotation), str(offset)]
        out += [f"{s}={v!r}" for s, v in sorted(self.defaults.items(), key=lambda kv: str(kv[0]))]
        return out


def welded_frames(welds, frames):
    """``frames`` with the links fixed to a body or the ground (``welds``: {link: (body key or
    "world", 4x4)}, eomc.runtime.geometry.urdf_link_transforms) added after them, as
    (name, body, rotation, offset) entries; a link named like a frame already there is not."""
    from eomc.runtime.geometry import identifier
    by_name = {f[0]: f[1] for f in frames}
    out = list(frames)
    for link, (body, T) in welds.items():
        name = identifier(link)
        if name in by_name:
            continue
        index = -1 if body == "world" else by_name.get(body)
        if index is None:
            continue
        rotation = tuple(tuple(sm.Float(v) if abs(v) > 1e-15 else sm.S.Zero for v in row) for row in T[:3, :3])
        offset = tuple(sm.Float(v) if abs(v) > 1e-15 else sm.S.Zero for v in T[:3, 3])
        out.append((name, index, rotation, offset))
        by_name[name] = index
    return out


def _number(x, defaults):
    """``x`` (a number or an expression in the model's parameters) as a float, or None."""
    try:
        return float(sm.sympify(x).xreplace(defaults))
    except (TypeError, ValueError):
        return None


def contact_metadata(source):
    """What the animation page needs of a robot's contacts (NAME.json ``poses.contacts``, read
    by eomc.runtime.animate): per contact its name (the outputs ``Fn_<name>``, ``Ft*_<name>``),
    the shown frame it is fixed in, the sphere's centre in that frame, its radius (the
    parameter ``r_<name>`` the run may change, and its default), the plane's normal and height
    (the plane the law acts at: an MJCF pair's margin raises it, and ``margin`` says by how
    much, so the drawing puts the surface at height - margin), and an
    ellipsoid's A = R diag(a²) Rᵀ (frame components: the touching point is its support point);
    and the robot's weight m·g, the arrows' scale.  Empty for a model with no joint tree (a
    SymPy model's contacts are loads the poses cannot see) or without contacts.

    The numbers are the build's (parameter defaults folded in): a contact whose centre depends
    on a parameter the page cannot evaluate is left out of the drawing, not of the model."""
    tree = source.tree
    from ..contact.tree import ContactLoad
    loads = [ld for ld in tree.loads if isinstance(ld, ContactLoad)]
    if not loads:
        return {}
    defaults = {k if isinstance(k, sm.Basic) else sm.Symbol(str(k), real=True): v
                for k, v in dict(getattr(source, "defaults", {}) or {}).items()}
    shown = {}
    for name, body, rotation, offset in source.frames:
        shown.setdefault(body, (name, rotation, offset))
    contacts = []
    for load in loads:
        if load.body not in shown:
            continue
        frame, D, o = shown[load.body]
        centre = [_number(x, defaults) for x in load.offset]
        o = [0.0] * 3 if o is None else [_number(x, defaults) for x in o]
        D = np.eye(3) if D is None else np.array([[_number(x, defaults) for x in row] for row in D], dtype=float)
        if None in centre or None in o or not np.all(np.isfinite(D)):
            continue
        # the point in the shown frame's axes: the frame is the body's turned by D, moved by o
        point = fo.matmul(D.T, np.array(centre) - np.array(o))
        r = load.params.get("r", 0)
        item = {"name": load.name, "frame": frame, "point": [float(v) for v in point],
                "radius": _number(r, defaults) or 0.0,
                "radius_parameter": str(r) if isinstance(r, sm.Symbol) else None,
                "normal": [float(v) for v in load.normal], "height": _number(load.height, defaults)}
        if load.margin:     # the surface is at height - margin (only where there is one: the others' metadata as before)
            item["margin"] = float(load.margin)
        if load.shape is not None:
            A = np.array([[_number(x, defaults) for x in row] for row in load.shape], dtype=float)
            item["ellipsoid"] = [float(v) for v in fo.matmul(D.T, A, D).reshape(9)]
        contacts.append(item)
    try:
        mass = sum(_number(b.mass, defaults) or 0.0 for b in tree.bodies)
        g = fo.norm([_number(x, defaults) for x in tree.gravity])
    except (TypeError, ValueError, AttributeError):
        mass, g = 0.0, 0.0
    return {"contacts": contacts, "weight": mass * g} if contacts else {}
