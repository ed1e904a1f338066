"""Collision geometry against a ground plane: which points of a shape can touch it.

One job: turn a primitive shape (or a mesh) fixed in a body into contact points of the
smooth law (:mod:`.law`), and those into the Tree's :class:`~.tree.ContactLoad` entries.
The law is written for a sphere (centre, radius) on a plane; every shape here is a set
of such spheres or a support function, so the force is the law's and the generated
code costs O(points):

- sphere     its centre, its radius (exact)
- capsule    its two end spheres (exact for a plane: the deepest point of a capsule is on
             one of the hemispheres; lying flat, both carry half)
- box        its 8 corners, radius 0 (exact for the box's corners; lying on a face, four
             corners share the load)
- cylinder   ``CYLINDER_RIM`` points on each end's rim, radius 0 (upright: the rim points
             of the bottom disk share the load; rolling on its side, the lowest rim point
             is up to R·(1 - cos(π/CYLINDER_RIM)) above the true lowest line)
- ellipsoid  its support point: for the plane's normal n in body components and the
             ellipsoid's A = R·diag(a²)·Rᵀ, the deepest point is c - A·n/sqrt(nᵀ·A·n)
             (exact and smooth: computed in the generated code at each call)
- mesh       the vertices of its convex hull, radius 0 (MuJoCo collides a mesh's hull too); a
             hull of more than ``MESH_POINTS`` vertices is thinned to that many by farthest-point
             sampling (spread over the hull, its extreme points first), and how far the thinned
             hull falls inside the full one is :func:`hull_shortfall` (a warning gives it)

Where the shapes come from is the reader's job (MJCF: :mod:`eomc.compiler.mjcf.collision`;
URDF: ``<collision>``); the parameters are given per shape and shared by its points.
"""
import math
from dataclasses import dataclass

import numpy as np
import sympy as sm

from eomc.runtime.errors import ModelError
from eomc.compiler import fixed_order as fo

__all__ = ["CYLINDER_RIM", "MESH_POINTS", "Shape", "shape_points", "with_shapes", "hull_shortfall", "law_symbols"]

CYLINDER_RIM = 8
MESH_POINTS = 32


@dataclass(frozen=True)
class Shape:
    """A shape fixed in a moving body, touching the plane n·x = height (world)."""
    name: str                  # names the parameters (k_<name>, ...) and the points' outputs
    body: int                  # the Tree body index
    kind: str                  # sphere, capsule, box, cylinder, ellipsoid, mesh
    size: tuple                # MuJoCo's convention: radius; radius, half length; half sizes; ...
    pos: tuple                 # the shape's frame in the body frame: origin (from the body origin)
    rot: tuple                 # rotation rows: shape -> body components
    normal: tuple
    height: float
    k: float
    c: float
    mu: float
    vs: float = 0.01
    vertices: tuple = ()       # a mesh's vertices, shape frame
    # torsional (MJCF condim 4, 6) and rolling (condim 6) friction, lengths in m, and the length
    # that turns v_s into their angular regularisation speed (.law.spin_moment); None: none
    mut: float = None
    mur: float = None
    rho: float = None
    where: str = ""            # for messages: "geom foot_geom", "link base collision 2"
    margin: float = 0.0        # how far ``height`` is above the plane's surface (an MJCF pair's margin)


def shape_points(kind, size, vertices=()):
    """(points in the shape frame, radius of each point's sphere, semi-axes or None).

    The semi-axes are an ellipsoid's (its single point is its centre, and the support
    point is found in the generated code)."""
    s = [float(x) for x in size]
    if kind == "sphere":
        return [(0.0, 0.0, 0.0)], s[0], None
    if kind == "capsule":
        return [(0.0, 0.0, -s[1]), (0.0, 0.0, s[1])], s[0], None
    if kind == "box":
        return [(sx * s[0], sy * s[1], sz * s[2]) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], 0.0, None
    if kind == "cylinder":
        ring = [(s[0] * math.cos(2 * math.pi * i / CYLINDER_RIM), s[0] * math.sin(2 * math.pi * i / CYLINDER_RIM))
                for i in range(CYLINDER_RIM)]
        ring = [(0.0 if abs(x) < 1e-15 else x, 0.0 if abs(y) < 1e-15 else y) for x, y in ring]
        return [(x, y, z * s[1]) for z in (-1, 1) for x, y in ring], 0.0, None
    if kind == "ellipsoid":
        return [(0.0, 0.0, 0.0)], 0.0, tuple(s[:3])
    if kind == "mesh":
        v = np.asarray(vertices, dtype=float).reshape(-1, 3)
        if len(v) < 4:
            return [tuple(x) for x in v], 0.0, None
        from scipy.spatial import ConvexHull
        try:
            hull = ConvexHull(v)
            keep = sorted(set(int(i) for i in hull.vertices))
        except Exception:               # flat or degenerate: every vertex
            keep = list(range(len(v)))
        if len(keep) > MESH_POINTS:
            keep = _farthest(v[keep], MESH_POINTS, keep)
        return [tuple(float(x) for x in v[i]) for i in keep], 0.0, None
    raise ValueError(f"no contact for a {kind} against a plane")


def _farthest(points, count, index):
    """``count`` of ``index`` (the rows of ``points``) by farthest-point sampling, starting from the
    six extreme points along the axes: the sorted chosen indices."""
    chosen = sorted({int(np.argmin(points[:, a])) for a in range(3)} | {int(np.argmax(points[:, a])) for a in range(3)})
    gap = np.min(np.linalg.norm(points[:, None, :] - points[None, chosen, :], axis=2), axis=1)
    while len(chosen) < count:
        k = int(np.argmax(gap))
        chosen.append(k)
        gap = np.minimum(gap, np.linalg.norm(points - points[k], axis=1))
    return sorted(index[k] for k in chosen[:count])


def hull_shortfall(vertices, kept):
    """How far (m) the hull of ``kept`` points falls inside the hull of ``vertices``: the largest
    distance of a vertex outside the kept hull's facet planes (0 when nothing was dropped)."""
    from scipy.spatial import ConvexHull
    v, k = np.asarray(vertices, dtype=float).reshape(-1, 3), np.asarray(kept, dtype=float).reshape(-1, 3)
    try:
        eq = ConvexHull(k).equations
    except Exception:
        return float("nan")
    return float(max(0.0, np.max(fo.matmul(v, eq[:, :3].T) + eq[:, 3])))


def _symbols(name, with_radius, taken, spin=()):
    """The shape's parameters k_, c_, mu_, vs_ (and r_, and ``spin``'s mut_/mur_) <name>; '_geom'
    appended when a name is already a parameter of the model (a joint's stiffness k_<joint> of the
    same name)."""
    keys = ("k", "c", "mu", "vs") + (("r",) if with_radius else ()) + tuple(spin)
    base = name
    while any(f"{key}_{base}" in taken for key in keys):
        base += "_geom"
    return {key: sm.Symbol(f"{key}_{base}", real=True) for key in keys}, base


def law_symbols(syms, values, fold, parameters, taken):
    """{law key: what the generated code uses}: the numbers ``values`` themselves when folded,
    else the symbols ``syms``, each added to ``parameters`` (symbol -> its value) and ``taken``."""
    if fold:
        return {key: sm.Float(values[key], 17) for key in syms}
    for key, symbol in syms.items():
        parameters[symbol] = values[key]
        taken.add(str(symbol))
    return dict(syms)


THINNED_NAMED = 3   # meshes a thinning warning names (the largest shortfalls); the others are counted


def _warn_thinned(thinned):
    """One warning for the meshes whose hulls were thinned to MESH_POINTS points: (where,
    shortfall in m) each.  A robot's meshes are many (example-robot-data's Go2 under --ground:
    eleven or more), and one line per mesh buried the build's other messages; one line naming
    every mesh was 1.3 kB on G1, so it names the THINNED_NAMED largest and counts the rest."""
    if not thinned:
        return
    import warnings
    from eomc.runtime.errors import EomcWarning
    if len(thinned) == 1:
        (where, short), = thinned
        text = (f"{where}: its mesh's convex hull is thinned to {MESH_POINTS} contact points (a contact may "
                f"start up to {short * 1e3:.2g} mm late)")
    else:
        # the THINNED_NAMED largest, then a count: G1 under --ground named all 24 in one 1.3 kB line
        # (first hour s26); the largest bounds every late start, and the rest are smaller
        ranked = sorted(thinned, key=lambda item: -item[1])
        named, rest = ranked[:THINNED_NAMED], ranked[THINNED_NAMED:]
        each = "; ".join(_by_directory([(where, f"{where} ({short * 1e3:.2g} mm)") for where, short in named]))
        more = f"; {len(rest)} more, up to {rest[0][1] * 1e3:.2g} mm each" if rest else ""
        text = (f"{len(thinned)} meshes' convex hulls are thinned to {MESH_POINTS} contact points each (a contact "
                f"may start up to {ranked[0][1] * 1e3:.2g} mm late): {each}{more}")
    warnings.warn(text, EomcWarning, stacklevel=4)


def _by_directory(items):
    """(where, text) items -> their texts with each directory named once: a URDF's "DIR/NAME:LINE: ..."
    wheres become "files under DIR: NAME:LINE: ...; NAME:LINE: ..." (example-robot-data's Go2 under
    --ground repeated its long path 19-24 times on one line); wheres without a directory as given."""
    import os
    import re
    groups = {}
    for where, text in items:
        m = re.match(r"(.+?):\d+: ", where)
        head = os.path.dirname(m.group(1)) if m else ""
        prefix = os.path.join(head, "")
        groups.setdefault(head, []).append(text[len(prefix):] if head and text.startswith(prefix) else text)
    return [f"files under {head}: " + "; ".join(texts) if head else "; ".join(texts) for head, texts in groups.items()]


def with_shapes(built, shapes, com_of, fold=False):
    """(built with the shapes' contacts in its tree's loads and their parameters, outputs,
    events).  ``built``: a reader's tree record (``.tree``, ``.parameters``); ``com_of(i)``:
    Tree body ``i``'s origin (its mass centre) in its frame, as the tree writes it (symbols
    or numbers).  Each point's outputs ``Fn_``/``Ftx_``/``Fty_``/``Ftz_``/``depth_<point>``
    and event ``contact_<point>``: <point> is the shape's name, with ``_<i>`` when it has several."""
    import dataclasses
    from .law import check_value
    from .tree import CLIP_KIND, OUTPUT_KINDS, ContactLoad, ContactValue
    tree = built.tree
    loads = list(tree.loads)
    first = sum(1 for ld in loads if isinstance(ld, ContactLoad))
    parameters = dict(built.parameters)
    taken = {str(s) for s in parameters}
    outputs, events, seen, thinned = {}, {}, set(), []
    for shape in shapes:
        try:
            points, radius, axes = shape_points(shape.kind, shape.size, shape.vertices)
        except ValueError as exc:
            raise ModelError(f"{shape.where or shape.name}: {exc}") from None
        if not points:
            continue
        if shape.kind == "mesh" and len(points) == MESH_POINTS:
            short = hull_shortfall(shape.vertices, points)
            if short > 0:
                thinned.append((shape.where or shape.name, short))
        values = {"k": shape.k, "c": shape.c, "mu": shape.mu, "vs": shape.vs}
        spin = {key: value for key, value in (("mut", shape.mut), ("mur", shape.mur)) if value is not None}
        values.update(spin)
        if spin and not (shape.rho and shape.rho > 0):
            raise ModelError(f"{shape.where or shape.name}: torsional or rolling friction needs a size rho > 0, "
                             f"not {shape.rho!r}")
        for key, value in values.items():
            try:
                check_value(shape.name, key, value, shape.where or None)
            except ValueError as exc:
                raise ModelError(str(exc)) from None
        syms, base = _symbols(shape.name, radius > 0, taken, spin)
        if base in seen:
            raise ModelError(f"{shape.where or shape.name}: contact name {base!r} is used twice")
        seen.add(base)
        values["r"] = radius
        params = law_symbols(syms, values, fold, parameters, taken)
        if "r" not in params:
            params["r"] = sm.S.Zero
        if spin:
            params["rho"] = sm.Float(float(shape.rho), 17)
        R = np.asarray(shape.rot, dtype=float).reshape(3, 3)
        origin = np.asarray(shape.pos, dtype=float)
        com = com_of(shape.body)
        shape_matrix = None
        if axes is not None:
            A = fo.matmul(R, np.diag(np.square(axes)), R.T)
            shape_matrix = tuple(tuple(sm.Float(float(A[r, k]), 17) if abs(A[r, k]) > 1e-300 else sm.S.Zero
                                       for k in range(3)) for r in range(3))
        n = [sm.Integer(int(x)) if float(x) == int(x) else sm.Float(float(x), 17) for x in shape.normal]
        height = sm.Float(float(shape.height), 17) if shape.height else sm.S.Zero
        for i, p in enumerate(points):
            point = origin + fo.matmul(R, p)
            label = base if len(points) == 1 else f"{base}_{i}"
            offset = sm.Matrix([(sm.Float(float(point[r]), 17) if point[r] != 0 else sm.S.Zero) - com[r]
                                for r in range(3)])
            j = first + len(loads) - len(tree.loads)
            loads.append(ContactLoad(shape.body, label, offset, params, tuple(n), height, shape=shape_matrix,
                                     margin=float(shape.margin)))
            for kind, what in enumerate(OUTPUT_KINDS):
                outputs[f"{what}_{label}"] = ContactValue(j, kind)
            events[f"contact_{label}"] = ContactValue(j, OUTPUT_KINDS.index("depth"))
            events[f"clip_{label}"] = ContactValue(j, CLIP_KIND)
    _warn_thinned(thinned)
    new = type(built).__new__(type(built))
    new.__dict__.update(built.__dict__)
    new.tree = dataclasses.replace(tree, loads=tuple(loads))
    new.parameters = parameters
    return new, outputs, events
