"""Contacts between two shapes on bodies (body–body pairs): the distance of two primitives and the law.

One job: for a pair of primitive shapes -- each fixed in a moving tree body or in the world --
compute, in the generated code, their signed distance, the contact normal and point, and
put the smooth law's force on both bodies (:class:`PairLoad`, lowered with the ground
contacts by :func:`eomc.compiler.contact.tree.lower_contacts`).  Which pairs exist is the
reader's job (MJCF: :func:`eomc.compiler.mjcf.collision.body_pairs`, MuJoCo's filters).

Every pair is reduced to two spheres: the closest points of the shapes' cores (a sphere's
centre, a capsule's segment, a box's solid) with the radii around them --

- sphere–sphere    the centres
- sphere–capsule   the centre and its nearest point on the segment (clamped projection)
- capsule–capsule  the segments' nearest points: s₀ = clamp((b f - c)/(1 - b²)), t = clamp(b s₀ + f),
                   s = clamp(b t - c) (Ericson's clamped solution, written without branches:
                   parallel segments give one of their nearest pairs)
- sphere–box       the centre and its nearest point of the box (the centre clamped to the box
                   in the box frame, radius 0 on the box's side); a centre inside the box has
                   no direction: such a pair (penetration beyond the sphere's radius) pushes
                   with a direction regularised by ``EPS`` instead
- capsule–box      the segment's and the box's nearest points: the nearest of the two ends
                   against the box and the segment against the box's 12 edges (exact for a
                   segment outside the box; :func:`_segment_box`), one contact point

then with d the vector between those points (A to B), |d| = sqrt(d·d + EPS²):

    n = d/|d|,   δ = r_A + r_B + margin - |d|,   p = x_A + (r_A - δ/2) n

and the law of :mod:`.law` (Hunt–Crossley F_n = k δ₊^{3/2}(1 + 3/2 c δ̇), δ̇ = -n·v_rel;
regularised Coulomb on the slip v_rel's tangential part), v_rel = v_B(p) - v_A(p) of the
bodies' material points at p: +F on B at p, -F on A.  Everything is branch-free, so the
generated code's cost is O(pairs); a pair the filters exclude is never emitted.
"""
from dataclasses import dataclass

import numpy as np
import sympy as sm

from .law import EXPONENT, _cross, _dot, _pos, clip_switch, step
from .tree import LoweredLoad

__all__ = ["PAIR_KINDS", "PairShape", "PairLoad", "PairValue", "pair_supported", "closest_points"]

# the kinds whose pairs are modelled (either order)
PAIR_KINDS = {("sphere", "sphere"), ("sphere", "capsule"), ("capsule", "capsule"), ("sphere", "box"),
              ("capsule", "box")}
POINT_KINDS = ("px", "py", "pz")   # a pair's contact point outputs (world), after the ground's kinds
EPS = 1e-12     # m: regularises |d| so that coincident centres give a finite (zero) force


def pair_supported(kind_a, kind_b):
    return (kind_a, kind_b) in PAIR_KINDS or (kind_b, kind_a) in PAIR_KINDS


@dataclass(frozen=True)
class PairShape:
    """A primitive fixed in tree body ``body`` (-1: the world)."""
    body: int
    kind: str                  # sphere, capsule, box
    size: tuple                # MuJoCo's: radius; radius, half length; half sizes
    offset: tuple              # the shape's centre from the body origin (its mass centre), body frame
                               # (numbers, or SymPy expressions of the mass centre's parameters);
                               # in the world: the centre, world frame
    rot: tuple                 # rotation rows: shape -> body components (3x3)
    where: str = ""


class PairValue(sm.Function):
    """Placeholder for a pair's computed quantity in outputs and events: PairValue(pair index,
    kind index into :data:`.tree.OUTPUT_KINDS`, or :data:`.tree.CLIP_KIND`); :meth:`PairLoad.lower`
    returns what replaces it (as :class:`.tree.ContactValue` for ground contacts)."""
    nargs = 2

    def _eval_derivative(self, s):       # never differentiated before it is replaced
        return sm.S.Zero


@dataclass(frozen=True)
class PairLoad(LoweredLoad):
    """A contact between shapes ``a`` and ``b``: no force of its own until :meth:`lower`.
    ``body`` is b's tree body (never the world: a pair of static shapes is never made)."""
    name: str
    a: PairShape
    b: PairShape
    params: dict               # "k", "c", "mu", "vs" -> Symbol (or literal when folded)
    margin: float = 0.0
    index: int = 0             # its PairValue placeholders' first argument (outputs, events)

    @property
    def body(self):
        return self.b.body

    @property
    def exprs(self):
        """Everything that defines it, for the generation cache's key."""
        out = [sm.Integer(self.a.body), sm.Integer(self.b.body), sm.Float(self.margin, 17)]
        for s in (self.a, self.b):
            out += [sm.Float(float(x), 17) for x in s.size] + [sm.sympify(x) for x in s.offset]
            out += [sm.Float(float(x), 17) for row in s.rot for x in row]
            out += [sm.Integer(("sphere", "capsule", "box").index(s.kind))]
        return out + [self.params[k] for k in ("k", "c", "mu", "vs")]

    def lower(self, bodies, rec, v, rename, poses):
        """Add the pair's force to both bodies' fext (body components, about their origins);
        return {PairValue placeholder: temporary}: F_n, the friction force on B (world), the
        depth δ and the clip's switching function (:func:`.law.clip_switch`)."""
        what = f"the contact {self.name}"
        params = {k: rename(s, what) for k, s in self.params.items()}
        ren = lambda e: rename(e, what)      # noqa: E731 -- mass-centre parameters -> their slots
        a, b = _placed(self.a, poses, rec, ren), _placed(self.b, poses, rec, ren)
        xa, xb, ra, rb = closest_points(a, b, rec.let)
        d = [rec.let(xb[k] - xa[k]) for k in range(3)]
        dist = rec.let(sm.sqrt(_dot(d, d) + EPS ** 2))
        n = [rec.let(x / dist) for x in d]
        depth = rec.let(ra + rb + sm.Float(self.margin, 17) - dist) if self.margin else rec.let(ra + rb - dist)
        p = [rec.let(xa[k] + (ra - depth / 2) * n[k]) for k in range(3)]
        va, vb = _point_velocity(self.a, p, poses, v, rec), _point_velocity(self.b, p, poses, v, rec)
        vrel = [rec.let(vb[k] - va[k]) for k in range(3)]
        rate = rec.let(-_dot(n, vrel))
        dpos = rec.let((depth + sm.Abs(depth)) / 2)
        elastic = params["k"] * sm.Abs(dpos) ** EXPONENT
        fn = rec.let(_pos(rec.let(elastic * (1 + sm.Rational(3, 2) * params["c"] * rate))))
        vn = rec.let(_dot(n, vrel))
        vt = [rec.let(vrel[k] - vn * n[k]) for k in range(3)]
        scale = rec.let(-params["mu"] * fn / sm.sqrt(_dot(vt, vt) + params["vs"] ** 2))
        ft = [scale * vt[k] for k in range(3)]        # outputs only: the rhs names f (as before)
        f = [rec.let(fn * n[k] + scale * vt[k]) for k in range(3)]      # on B, world components
        _apply(self.b, f, p, poses, bodies, rec)
        _apply(self.a, [-x for x in f], p, poses, bodies, rec)
        # OUTPUT_KINDS, CLIP_KIND, then POINT_KINDS (the contact point, world)
        quantities = [fn, *ft, depth, clip_switch(depth, params["c"], rate), *p]
        return {PairValue(self.index, kind): value for kind, value in enumerate(quantities)}


def _num(x):
    x = float(x)
    return sm.S.Zero if x == 0 else (sm.Integer(int(x)) if x == int(x) and abs(x) < 1e6 else sm.Float(x, 17))


def _placed(shape, poses, rec, rename):
    """{kind, centre (world), axes (3 world vectors: the shape's x, y, z), size} of a shape."""
    rot = np.asarray(shape.rot, dtype=float).reshape(3, 3)
    off = [rename(x) if isinstance(x, sm.Basic) else _num(x) for x in shape.offset]
    if shape.body < 0:                      # in the world: numbers
        centre = off
        axes = [[_num(rot[r, k]) for r in range(3)] for k in range(3)]
    else:
        R = poses.world_to_body(shape.body)   # world -> body components
        o = poses.origin(shape.body)
        centre = [rec.let(o[k] + sum((R[j][k] * off[j] for j in range(3) if off[j] != 0), sm.S.Zero))
                  for k in range(3)]
        axes = []
        for k in range(3):                  # shape axis k in body components: column k of rot
            col = [_num(rot[r, k]) for r in range(3)]
            axes.append([rec.let(sum((R[j][w] * col[j] for j in range(3) if col[j] != 0), sm.S.Zero))
                         for w in range(3)])
    return {"kind": shape.kind, "centre": centre, "axes": axes, "size": [float(x) for x in shape.size]}


def _clamp(x, lo, hi):
    """min(max(x, lo), hi) for numbers lo < hi, without branches: (|x - lo| - |x - hi| + lo + hi)/2."""
    lo, hi = _num(lo), _num(hi)
    return (sm.Abs(x - lo) - sm.Abs(x - hi) + lo + hi) / 2


def closest_points(a, b, let=lambda e: e):
    """(x_A, x_B, r_A, r_B): the nearest points of the two shapes' cores and their radii (the
    module docstring); ``a``, ``b``: {kind, centre, axes, size} in world components."""
    if a["kind"] == "box" or (a["kind"] == "capsule" and b["kind"] == "sphere"):
        xb, xa, rb, ra = closest_points(b, a, let)
        return xa, xb, ra, rb
    ka, kb = a["kind"], b["kind"]
    ca, cb = a["centre"], b["centre"]
    if ka == "sphere" and kb == "sphere":
        return ca, cb, a["size"][0], b["size"][0]
    if ka == "sphere" and kb == "capsule":
        axis, h = b["axes"][2], b["size"][1]
        t = let(_clamp(_dot([ca[k] - cb[k] for k in range(3)], axis), -h, h))
        return ca, [let(cb[k] + t * axis[k]) for k in range(3)], a["size"][0], b["size"][0]
    if ka == "capsule" and kb == "capsule":
        xa, xb = _segments(ca, a["axes"][2], a["size"][1], cb, b["axes"][2], b["size"][1], let)
        return xa, xb, a["size"][0], b["size"][0]
    if ka == "sphere" and kb == "box":
        return ca, _in_box(ca, b, let), a["size"][0], 0.0
    if ka == "capsule" and kb == "box":
        return (*_segment_box(ca, a["axes"][2], a["size"][1], b, let), a["size"][0], 0.0)
    raise ValueError(f"no contact between a {ka} and a {kb}")


def _segments(ca, a1, h1, cb, a2, h2, let):
    """Nearest points of the segments ca + s a1 (|s| <= h1) and cb + t a2 (|t| <= h2), unit a1, a2."""
    r = [let(ca[k] - cb[k]) for k in range(3)]
    bb, c, f = let(_dot(a1, a2)), let(_dot(a1, r)), let(_dot(a2, r))
    # den = 0 for parallel segments (then bf - c = 0 too): (bf - c)·den/(den² + 1e-24) is 0 there
    # and finite with its derivatives (jac_x: (den² + ε)² must not underflow, so ε = 1e-24, not
    # smaller); it is 1/den to 1e-8 relative once den > 1e-8
    den = let(1 - bb * bb)
    s0 = let(_clamp((bb * f - c) * den / (den ** 2 + sm.Float(1e-24)), -h1, h1))
    t = let(_clamp(bb * s0 + f, -h2, h2))
    s = let(_clamp(bb * t - c, -h1, h1))
    return [let(ca[k] + s * a1[k]) for k in range(3)], [let(cb[k] + t * a2[k]) for k in range(3)]


def _in_box(x, box, let):
    """The point of the solid box nearest to ``x`` (x clamped in the box frame)."""
    cb = box["centre"]
    rel = [x[k] - cb[k] for k in range(3)]
    local = [let(_clamp(_dot(rel, box["axes"][j]), -box["size"][j], box["size"][j])) for j in range(3)]
    return [let(cb[k] + sum((local[j] * box["axes"][j][k] for j in range(3)), sm.S.Zero)) for k in range(3)]


def _segment_box(ca, axis, h, box, let):
    """Nearest points of the segment ca + s·axis (|s| <= h) and a solid box, for a segment outside
    the box: the nearest of 14 candidates -- each end against the box, the segment against each of
    the box's 12 edges.  Why these suffice: if the nearest box point lies inside a face, the
    segment's nearest point is an end or the segment runs parallel to the face, where its
    distance is constant up to an end or the face's edge; else the box point is on an edge.
    A segment that passes through the box (penetration deeper than the capsule's radius) has no
    nearest points: the candidates then give a distance > 0 (the law weakens, as a sphere's
    centre inside a box; the module docstring).  The choice is branch-free: candidate k replaces
    the best so far when step(d²_best - d²_k) = 1 (a choice whose derivative is taken as 0,
    right away from ties, where the distance is continuous)."""
    ends = [[let(ca[k] + sign * h * axis[k]) for k in range(3)] for sign in (-1, 1)]
    candidates = [(e, _in_box(e, box, let)) for e in ends]
    cb, axes, size = box["centre"], box["axes"], box["size"]
    for j in range(3):
        u, w = [i for i in range(3) if i != j]
        for su in (-1, 1):
            for sw in (-1, 1):
                centre = [let(cb[k] + su * size[u] * axes[u][k] + sw * size[w] * axes[w][k]) for k in range(3)]
                candidates.append(_segments(ca, axis, h, centre, axes[j], size[j], let))
    best_a, best_b = candidates[0]
    best = let(sum(((best_b[k] - best_a[k]) ** 2 for k in range(3)), sm.S.Zero))
    for xa, xb in candidates[1:]:
        d2 = let(sum(((xb[k] - xa[k]) ** 2 for k in range(3)), sm.S.Zero))
        take = let(step(best - d2))
        best_a = [let(best_a[k] + take * (xa[k] - best_a[k])) for k in range(3)]
        best_b = [let(best_b[k] + take * (xb[k] - best_b[k])) for k in range(3)]
        best = let(best + take * (d2 - best))
    return best_a, best_b


def _point_velocity(shape, p, poses, v, rec):
    """World velocity of body ``shape.body``'s material point at world position ``p``."""
    if shape.body < 0:
        return [sm.S.Zero] * 3
    i = shape.body
    R, o = poses.world_to_body(i), poses.origin(i)
    rel = [p[k] - o[k] for k in range(3)]
    rel_b = [rec.let(sum((R[r][k] * rel[k] for k in range(3)), sm.S.Zero)) for r in range(3)]
    w_b, v_b = v[i][:3], v[i][3:]
    vp_b = [v_b[k] + x for k, x in enumerate(_cross(w_b, rel_b))]
    return [rec.let(sum((R[r][k] * vp_b[r] for r in range(3)), sm.S.Zero)) for k in range(3)]


def _apply(shape, f, p, poses, bodies, rec):
    """Force ``f`` (world) at world point ``p`` on the shape's body: into its fext."""
    if shape.body < 0:
        return
    i = shape.body
    R, o = poses.world_to_body(i), poses.origin(i)
    f_b = [rec.let(sum((R[r][k] * f[k] for k in range(3)), sm.S.Zero)) for r in range(3)]
    lever = [sum((R[r][k] * (p[k] - o[k]) for k in range(3)), sm.S.Zero) for r in range(3)]
    moment = _cross(lever, f_b)
    old = bodies[i].fext or [0] * 6
    bodies[i].fext = [old[k] + x for k, x in enumerate(moment + f_b)]


@dataclass(frozen=True)
class PairSpec:
    """A pair as a reader gives it: its shapes and the law's parameters."""
    name: str
    a: PairShape
    b: PairShape
    k: float
    c: float
    mu: float
    vs: float = 0.01
    margin: float = 0.0


def with_pairs(built, specs, fold=False):
    """(``built`` (a reader's tree record: ``.tree``, ``.parameters``) with a :class:`PairLoad` per
    :class:`PairSpec` in its tree's loads and the parameters ``k_``/``c_``/``mu_``/``vs_<name>``,
    outputs, events).

    Each pair has the ground contacts' outputs ``Fn_``/``Ftx_``/``Fty_``/``Ftz_``/``depth_<name>``
    (normal force, friction force on the second geom B in world components, depth), the point the
    force acts at ``px_``/``py_``/``pz_<name>`` (world: midway between the two surfaces' nearest
    points; where to draw the force), and events
    ``contact_<name>`` (touch-down: the runtime ends steps there and judges the depth,
    runtime/switching.py) and ``clip_<name>`` (the damped law's lift-off in contact).  Why: a pair
    without them let Radau step across its law's kinks (dm_control's manipulator stalled at
    t = 0.2212 s with a 2e-16 step in its pommel–slot contact)."""
    import dataclasses
    from .tree import CLIP_KIND, OUTPUT_KINDS
    from eomc.runtime.errors import ModelError
    from .geometry import _symbols, law_symbols
    from .law import check_value
    if not specs:
        return built, {}, {}
    outputs, events = {}, {}
    index = sum(1 for ld in built.tree.loads if isinstance(ld, PairLoad))
    loads = list(built.tree.loads)
    parameters = dict(built.parameters)
    taken = {str(s) for s in parameters}
    for spec in specs:
        values = {"k": spec.k, "c": spec.c, "mu": spec.mu, "vs": spec.vs}
        for key, value in values.items():
            try:
                check_value(spec.name, key, value)
            except ValueError as exc:
                raise ModelError(str(exc)) from None
        syms, base = _symbols(spec.name, False, taken)
        params = law_symbols(syms, values, fold, parameters, taken)
        a, b = (spec.a, spec.b) if spec.b.body >= 0 else (spec.b, spec.a)     # b moves: the load's body
        loads.append(PairLoad(base, a, b, params, float(spec.margin), index))
        for kind, what in enumerate(OUTPUT_KINDS):
            outputs[f"{what}_{base}"] = PairValue(index, kind)
        for k, what in enumerate(POINT_KINDS):
            outputs[f"{what}_{base}"] = PairValue(index, CLIP_KIND + 1 + k)
        events[f"contact_{base}"] = PairValue(index, OUTPUT_KINDS.index("depth"))
        events[f"clip_{base}"] = PairValue(index, CLIP_KIND)
        index += 1
    new = type(built).__new__(type(built))
    new.__dict__.update(built.__dict__)
    new.tree = dataclasses.replace(built.tree, loads=tuple(loads))
    new.parameters = parameters
    return new, outputs, events
