"""Body poses as a generated function: where every body frame and named point is.

``NAME_poses(t, x, p, r, out, work)`` writes, for each body frame, its origin's
position (3) and its rotation matrix (9, row-major: columns are the body's
axes in world components) in the world frame, then the position (3) of each
named point.  An animation needs nothing else from the model.

Why here and not in SymPy: the positions come from the mechanics objects'
own graphs (``ReferenceFrame`` orientations, ``Point`` positions), composed
along them with one temporary per entry (as the recursive formulation does),
so a deep chain costs O(bodies) code instead of SymPy's nested products; the
temporaries go into the same program as rhs, so the optimizer shares sin/cos
and products with the dynamics, while the C function stays separate (rhs is
not slowed).

:func:`pose_source` reads a System, KanesMethod or LagrangesMethod (SymPy's or
eomc's; a URDF robot's System) into a :class:`PoseSource` (plain data:
graphs of expressions in the mechanics symbols, plus names and geometry);
:func:`with_poses` lowers it into a :class:`~.symbolic.Symbolic` program.
The metadata (:func:`pose_metadata`) goes into NAME.json, so the runtime,
which never imports SymPy, can label the numbers.
"""
import warnings
from dataclasses import dataclass, field, replace

import sympy as sm

from eomc.runtime.errors import EomcWarning, ModelError

__all__ = ["Shown", "PoseSource", "pose_source", "welded_links", "with_poses", "pose_metadata", "pose_digest", "POSE_GROUP",
           "POSE_TABLE"]

POSE_GROUP = "pose"
POSE_TABLE = "ptab"     # NAME_poses as a loop over a robot's tree: its table's values (compiler/tree/body_loops.py)


@dataclass(frozen=True)
class Shown:
    """What an animation shows, whatever places it: ``frames`` (name first in each entry),
    ``points`` ((name, ...) each), ``lines``: (i, j) pairs of ``points`` indices drawn as a
    skeleton; ``defaults``: values for symbols the equations do not contain (a URDF's
    numbers that only place things); ``geometry``: JSON-ready shapes (see eomc.geometry)."""
    frames: tuple
    points: tuple
    lines: tuple
    defaults: dict = field(default_factory=dict)
    geometry: dict = field(default_factory=dict)


@dataclass(frozen=True, kw_only=True)
class PoseSource(Shown):
    """What ``NAME_poses`` computes for a System, before lowering (expressions in mechanics
    symbols): its own frame and point graphs.

    ``frame_edges``: (frame, parent frame or None, parent.dcm(frame)) in breadth-first
    order from the world frame; ``point_edges``: (point, parent point or None, vector
    from the parent) from the origin.  ``frames``: (name, frame, origin point) of each
    body; ``points``: (name, point).  (A robot read into a joint tree is placed along the
    tree instead: eomc.compiler.tree.poses.TreePoseSource.)
    """
    frame_edges: tuple
    point_edges: tuple


def _bfs(start, neighbours):
    """Breadth-first tree from ``start``: [(node, parent)] in visiting order."""
    order, seen, queue = [(start, None)], {start}, [start]
    while queue:
        node = queue.pop(0)
        for other in neighbours(node):
            if other not in seen:
                seen.add(other)
                order.append((other, node))
                queue.append(other)
    return order


def _unique(names):
    out, used = [], {}
    for n in names:
        n = str(n)
        k = used.get(n, 0)
        used[n] = k + 1
        out.append(n if k == 0 else f"{n}_{k}")
    return out


def _parts(system):
    """(world frame, fixed point or None, bodies, joint point pairs) of any mechanics object."""
    if hasattr(system, "fixed_point") and hasattr(system, "frame") and hasattr(system, "joints"):
        pairs = [(j.parent_point, j.child_point) for j in system.joints]
        bodies = [b for b in system.bodies if b.masscenter is not system.fixed_point or b.frame is not system.frame]
        return system.frame, system.fixed_point, bodies, pairs
    frame = getattr(system, "_inertial", None) or getattr(system, "inertial", None)
    if frame is None:
        return None
    bodies = getattr(system, "bodies", None) or getattr(system, "_bodylist", None) or ()
    return frame, None, list(bodies), []


def pose_source(system, geometry=None, model=None):
    """The :class:`PoseSource` of a mechanics object, or None when it has no bodies to show.
    ``model``: the robot file's :class:`~eomc.compiler.multibody.model.Model` when the object
    is a URDF robot's System, whose welded links and shapes it carries (else they come from
    the document from_urdf parsed)."""
    from sympy.physics.vector import Point
    if system is None:
        return None
    parts = _parts(system)
    if parts is None:
        return None
    N, origin, bodies, pairs = parts
    if not bodies:
        return None
    reading = getattr(system, "reading", None)    # a robot reader's System (from_urdf)
    link_origin = {}
    if reading is not None:   # a link's frame sits at its joint's child point, not at its mass centre
        for joint in reading.joints.values():
            link_origin[joint.child.name] = joint.child_point
    body_points = [b.masscenter for b in bodies] + [p for pair in pairs for p in pair]
    body_points += list(link_origin.values())
    # the point graph: every point connected to the bodies' points by a defined position
    start = origin if origin is not None else body_points[0]
    order = _bfs(start, lambda p: list(p._pos_dict))
    reached = {p for p, _ in order}
    if origin is None:   # no System: the first point whose velocity in N was set to zero
        fixed = [p for p, _ in order if p._vel_dict.get(N) == 0]
        if fixed:
            start = fixed[0]
            order = _bfs(start, lambda p: list(p._pos_dict))
    parent_of = dict(order)
    frames_order = _bfs(N, lambda f: list(f._dcm_dict))
    frame_parent = dict(frames_order)
    frames, points, wanted = [], [], []
    names = _unique(b.name for b in bodies)
    for name, b in zip(names, bodies):
        frame = getattr(b, "frame", None)
        at = link_origin.get(b.name, b.masscenter)
        if at not in reached:
            continue
        if frame is not None and frame in frame_parent:
            frames.append((name, frame, at))
        else:
            points.append((name, b.masscenter))
        wanted.append(at)
    # the skeleton: points on the paths from the origin to the bodies' points and joint points
    skeleton = []
    for p in [pt for pair in pairs for pt in pair] + wanted:
        while p is not None and p in parent_of and p not in skeleton:
            skeleton.append(p)
            p = parent_of[p]
    taken = {pt for _, pt in points}
    extra = [p for p, _ in order if p in skeleton and p not in taken]
    point_names = _unique([n for n, _ in points] + [p.name for p in extra])
    points = [(n, p) for n, (_, p) in zip(point_names, points + [(None, p) for p in extra])]
    # points a `geometry` dict names by object (a pendulum's tip, a marker) join the named points
    named = {p for _, p in points}
    for key in (geometry or {}):
        if isinstance(key, Point) and key not in named and key in parent_of:
            names_now = {n for n, _ in points}
            points.append((key.name if key.name not in names_now else f"{key.name}_{len(points)}", key))
            named.add(key)
    index = {}
    for i, (_, p) in enumerate(points):
        index.setdefault(p, i)
    lines = []
    for p in skeleton:
        q = parent_of.get(p)
        while q is not None and q not in index:   # an unnamed hop: draw to the next named one
            q = parent_of.get(q)
        if q is not None and p in index and index[p] != index[q] and p._pos_dict[parent_of[p]] != 0:
            lines.append((index[q], index[p]))
    extra_frame_edges, extra_point_edges = [], []
    if reading is not None:   # every link frame: those welded to a body or to the ground too
        if model is None:     # the reader's Model of the document it parsed (not read again)
            model = reading.model(poses=True)
        welds, shapes = model.welds, model.shapes
        frames, extra_frame_edges, extra_point_edges = welded_links(welds, frames, N, start)
    needed = set(skeleton) | {pt for _, _, pt in frames if pt in parent_of} | {pt for _, pt in points}
    closure = set()
    for q in needed:   # the needed points and every point on their paths from the origin
        while q is not None and q not in closure:
            closure.add(q)
            q = parent_of.get(q)
    point_edges = [(p, parent, p._pos_dict[parent] if parent is not None else None)
                   for p, parent in order if p in closure]
    frame_edges = [(f, parent, parent.dcm(f) if parent is not None else None)
                   for f, parent in frames_order] + extra_frame_edges
    point_edges += extra_point_edges
    defaults = dict(getattr(reading, "parameters", None) or {})
    geom = {}
    if reading is not None:
        geom = dict(shapes)
    if geometry:
        geom = {**geom, **_checked_geometry(geometry, [n for n, *_ in frames], [n for n, _ in points])}
    return PoseSource(tuple(frames), tuple(points), tuple(sorted(set(lines))), defaults, geom,
                      frame_edges=tuple(frame_edges), point_edges=tuple(point_edges))


def welded_links(welds, frames, N, origin):
    """Frames of the links fixed to a body (or the ground) with the constant transform between
    them (``welds``: {link: (body or "world", 4x4)}, eomc.runtime.geometry.urdf_link_transforms):
    a new frame and point per link, kept out of the user's graphs (edges here only)."""
    from sympy.physics.vector import Point, ReferenceFrame, Vector
    from eomc.runtime.geometry import identifier
    by_name = {name: (frame, at) for name, frame, at in frames}
    taken = set(by_name)
    frame_edges, point_edges, out = [], [], list(frames)
    for link, (body, T) in welds.items():
        name = identifier(link)
        if name in taken:
            continue
        parent_frame, parent_point = (N, origin) if body == "world" else by_name.get(body, (None, None))
        if parent_frame is None:
            continue
        frame, point = ReferenceFrame(f"F_{name}"), Point(f"L_{name}")
        rotation = sm.Matrix(3, 3, [sm.Float(v) if abs(v) > 1e-15 else sm.S.Zero for v in T[:3, :3].ravel()])
        offset = sm.Matrix([sm.Float(v) if abs(v) > 1e-15 else sm.S.Zero for v in T[:3, 3]])
        frame_edges.append((frame, parent_frame, rotation))
        point_edges.append((point, parent_point, Vector([(offset, parent_frame)])))
        out.append((name, frame, point))
        taken.add(name)
    return out, frame_edges, point_edges


def _checked_geometry(geometry, frame_names, point_names):
    """A model file's ``geometry`` dict: {body or point (object or name): shape} -> JSON-ready."""
    if not isinstance(geometry, dict):
        raise ModelError(f"`geometry` must be a dict {{body or point: eomc.geometry shape}}, "
                         f"not {type(geometry).__name__}")
    known = set(frame_names) | set(point_names)
    out = {}
    for key, shape in geometry.items():
        name = key if isinstance(key, str) else getattr(key, "name", None)
        if name not in known:
            raise ModelError(f"`geometry` names {name or key!r}, which is no body or point of the "
                             f"model (bodies: {', '.join(frame_names) or 'none'}; points: "
                             f"{', '.join(point_names) or 'none'})")
        items = list(shape) if isinstance(shape, (list, tuple)) else [shape]
        for item in items:
            if not callable(getattr(item, "as_dict", None)):
                raise ModelError(f"`geometry[{name!r}]` must be a shape made by eomc.geometry "
                                 f"(sphere, box, cylinder, mesh) or a list of them, not {item!r}")
        out[name] = [s.as_dict() for s in items]
    return out


def pose_digest(source):
    """Everything of ``source`` that shapes the generated code, for the generation cache key."""
    if source is None:
        return None
    if hasattr(source, "digest"):
        return source.digest()
    out = [str([n for n, *_ in source.frames]), str([n for n, _ in source.points]), str(source.lines),
           str(sorted(source.geometry.items()))]
    for f, parent, dcm in source.frame_edges:
        out += [f.name, getattr(parent, "name", ""), dcm if dcm is not None else sm.S.Zero]
    for p, parent, vec in source.point_edges:
        out += [p.name, getattr(parent, "name", "")]
        if vec is not None:
            out += [x for comps, frame in vec.args for x in (sm.Symbol(frame.name), comps)]
    return out


class _Let:
    """Fresh temporaries ``_t<k>`` from a program's counter (the IR's registry)."""

    def __init__(self, start):
        self.count, self.assignments, self.seen = start, [], {}

    def __call__(self, expr):
        expr = sm.sympify(expr)
        if expr.is_Atom or (expr.is_Mul and len(expr.args) == 2 and expr.args[0] == -1 and expr.args[1].is_Atom):
            return expr
        hit = self.seen.get(expr)
        if hit is None:
            hit = self.seen[expr] = sm.Symbol(f"_t{self.count}", real=True)
            self.count += 1
            self.assignments.append((hit, expr))
        return hit


def _slot(source, layout):
    """expr -> the program's symbols: the source's default values for symbols the model does
    not have, then the layout (a ModelError where a symbol is none of the model's)."""
    memo = {}
    defaults = {s: sm.Float(v) for s, v in source.defaults.items() if s not in layout.subs}

    def slot(e, what):
        e = sm.sympify(e)
        if defaults:
            e = e.xreplace(defaults)
        return layout.apply(e, what, memo)
    return slot


def _lowering(source, slot, let):
    """(frame(k) -> (R, p) or None, point(k) -> p or None) of a System's frame graphs in slot
    symbols, memoized; None where unmappable."""
    frames, points = {}, {}
    frame_edge = {f: (parent, dcm) for f, parent, dcm in source.frame_edges}
    point_edge = {p: (parent, vec) for p, parent, vec in source.point_edges}

    def rotation(f):
        if f not in frames:
            frames[f] = None
            parent, dcm = frame_edge[f]
            if parent is None:
                frames[f] = [[sm.S.One if i == j else sm.S.Zero for j in range(3)] for i in range(3)]
            else:
                R = rotation(parent)
                if R is not None:
                    try:
                        D = [[slot(dcm[i, j], f"the orientation of frame {f.name}") for j in range(3)]
                             for i in range(3)]
                    except ModelError:
                        return None
                    frames[f] = [[let(sum((R[i][k] * D[k][j] for k in range(3)), sm.S.Zero))
                                  for j in range(3)] for i in range(3)]
        return frames[f]

    def position(p):
        if p not in points:
            points[p] = None
            if p not in point_edge:
                return None
            parent, vec = point_edge[p]
            if parent is None:
                points[p] = [sm.S.Zero] * 3
            else:
                base = position(parent)
                if base is None:
                    return None
                out = list(base)
                for comps, frame in vec.args:
                    R = rotation(frame) if frame in frame_edge else None
                    if R is None:
                        return None
                    try:
                        c = [slot(comps[k], f"the position of point {p.name}") for k in range(3)]
                    except ModelError:
                        return None
                    out = [out[i] + sum((R[i][k] * c[k] for k in range(3)), sm.S.Zero) for i in range(3)]
                points[p] = [let(v) for v in out]
        return points[p]

    def frame(k):
        _, f, at = source.frames[k]
        R, r = rotation(f), position(at)
        return None if R is None or r is None else (R, r)
    return frame, lambda k: position(source.points[k][1])


def _tree_lowering(source, slot, let):
    """As :func:`_lowering` for a robot's :class:`~eomc.compiler.tree.poses.TreePoseSource`
    (its own placement along the tree); None where unmappable."""
    frame_at, point_at = source.placer(slot, let)

    def guarded(place):
        def call(k):
            try:
                return place(k)
            except ModelError:
                return None
        return call
    return guarded(frame_at), guarded(point_at)


def with_poses(sym, source, layout, loops=False):
    """``sym`` with the pose results ("pose", k) and their temporaries appended.

    Frames or points whose placement uses something the model does not have (a symbol
    that is no parameter, a derivative) are left out with one warning naming them.
    Returns (Symbolic, metadata dict).

    ``loops``: the formulation places the bodies itself and loops over them (a robot's tree,
    compiler/tree/body_loops.py): where the source gives a table (``source.table``), the results
    are that table's values (group :data:`POSE_TABLE`) and the metadata's "table" its shape.
    """
    program = sym.program
    made = source.table(_slot(source, layout)) if loops and hasattr(source, "table") else None
    if made is not None:
        values, shape = made
        frames, points = [f[0] for f in source.frames], [pt[0] for pt in source.points]
        results = tuple(((POSE_TABLE, k), v) for k, v in enumerate(values))
        meta = {"frames": frames, "points": points, "lines": [[i, j] for i, j in source.lines],
                "size": 12 * len(frames) + 3 * len(points),
                "geometry": {k: v for k, v in source.geometry.items() if k in frames or k in points or k == "world"},
                **(source.contact_metadata() if hasattr(source, "contact_metadata") else {}), "table": shape}
        return replace(sym, program=program.with_(results=program.results + results)), meta
    let = _Let(program.ntemp)
    lowering = _tree_lowering if hasattr(source, "placer") else _lowering
    frame_at, point_at = lowering(source, _slot(source, layout), let)
    values, frames, points, dropped, kept = [], [], [], [], {}
    for k, (name, *_) in enumerate(source.frames):
        placed = frame_at(k)
        if placed is None:
            dropped.append(name)
            continue
        R, r = placed
        values += list(r) + [R[i][j] for i in range(3) for j in range(3)]
        frames.append(name)
    for i, (name, _) in enumerate(source.points):
        r = point_at(i)
        if r is None:
            dropped.append(name)
            continue
        kept[i] = len(points)
        values += list(r)
        points.append(name)
    if dropped:
        warnings.warn(f"poses: {', '.join(dropped)} left out of the animation (their placement "
                      f"uses symbols that are not parameters, coordinates or inputs of the model)",
                      EomcWarning, stacklevel=2)
    results = tuple(((POSE_GROUP, k), v) for k, v in enumerate(values))
    program = program.with_(assignments=program.assignments + tuple(let.assignments),
                            results=program.results + results, ntemp=let.count)
    lines = [[kept[i], kept[j]] for i, j in source.lines if i in kept and j in kept]
    meta = {"frames": frames, "points": points, "lines": lines, "size": len(values),
            "geometry": {k: v for k, v in source.geometry.items() if k in frames or k in points
                         or k == "world"},
            **(source.contact_metadata() if hasattr(source, "contact_metadata") else {})}
    return replace(sym, program=program), meta


def pose_metadata(meta):
    """The NAME.json entry (a copy: JSON-ready lists and dicts only)."""
    return {"frames": list(meta["frames"]), "points": list(meta["points"]),
            "lines": [list(x) for x in meta["lines"]], "size": int(meta["size"]),
            "geometry": meta["geometry"],
            **({"contacts": meta["contacts"], "weight": float(meta["weight"])} if meta.get("contacts") else {})}

