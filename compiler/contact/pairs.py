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

Box–box, cylinder (with a sphere, capsule or cylinder) and ellipsoid (with a sphere, capsule or ellipsoid) pairs go through the
solid's signed distance instead (:func:`solid_contact`, :func:`signed_distance`, :func:`_box_box`:
a box pair has 88 contact points: each box's corners, edges' midpoints and 4 points per face
against the other; a cylinder pair 33; bounds in docs/contact.md); box–ellipsoid through the
separating axis (:func:`_box_ellipsoid`), ellipsoid–ellipsoid through Newton on the separating
direction (:func:`_ellipsoid_axis`).  For the others,
then with d the vector between those points (A to B), |d| = sqrt(d·d + EPS²):

    n = d/|d|,   δ = r_A + r_B + margin - |d|,   p = x_A + (r_A - δ/2) n

and the law of :mod:`.law` (Hunt–Crossley F_n = k δ₊^{3/2}(1 + 3/2 c δ̇), δ̇ = -n·v_rel;
regularised Coulomb on the slip v_rel's tangential part), v_rel = v_B(p) - v_A(p) of the
bodies' material points at p: +F on B at p, -F on A.  Everything is branch-free, so the
generated code's cost is O(pairs); a pair the filters exclude is never emitted.
"""
from dataclasses import dataclass

import math

import numpy as np
import sympy as sm

from . import narrow as nw
from .law import EXPONENT, SPIN_KEYS, ContactForces, _cross, _dot, _pos, clip_switch, ground_jacobians, spin_moment, step
from .tree import LoweredLoad

__all__ = ["PAIR_KINDS", "PairShape", "PairLoad", "PairValue", "pair_supported", "closest_points"]

# the kinds whose pairs are modelled (either order)
PAIR_KINDS = {("sphere", "sphere"), ("sphere", "capsule"), ("capsule", "capsule"), ("sphere", "box"),
              ("capsule", "box"), ("box", "box"), ("sphere", "cylinder"), ("capsule", "cylinder"),
              ("cylinder", "cylinder"), ("sphere", "ellipsoid"), ("box", "cylinder"), ("capsule", "ellipsoid"),
              ("ellipsoid", "ellipsoid"), ("box", "ellipsoid")}
# kinds met through the second shape's signed distance (:func:`signed_distance`) rather than two
# cores' nearest points; the pair's contact points ("parts", :func:`pair_parts`) are points or
# spheres of the first shape against the second's solid
SOLIDS = ("box", "cylinder", "ellipsoid")
KIND_INDEX = ("sphere", "capsule", "box", "cylinder", "ellipsoid")
POINT_KINDS = ("px", "py", "pz")   # a pair's contact point outputs (world), after the ground's kinds
# True (the default): each pair's narrow phase inlined as SymPy in the generated code; False: called
# routines (.narrow).  Why inlined still: measured on dm_control's stacker (benchmarks/results/
# narrow.md, session 9) the routines build 1.55x faster (125 -> 81 s CPU, C 10.7 -> 5.2 MB) and
# their rhs is as fast (1.05x, each call inside its pair's broad-phase guard), but jac_x runs
# 0.73x (it has no broad phase: every pair's tape and tangent run at every call).  The flag is in
# the generation and build caches' keys (compiler/build/reuse.generator_switches).
INLINE_NARROW = True
# True: each pair is one call of its kinds' narrow routine and each of its points one call of the
# *law routine* (.narrow: the law and both bodies' wrenches, one C function for every kind), inside
# the point's depth guard; so SymPy lowers and gcc compiles the law once, not each pair (takes
# precedence over INLINE_NARROW).  In the generation and build caches' keys as INLINE_NARROW.
LAW_ROUTINES = False
# True: every pair of a tree in one call of a table-driven C loop (.table: code O(kinds), not
# O(pairs)); takes precedence over LAW_ROUTINES and INLINE_NARROW.  In the caches' keys as those.
# The default, with MJCF self-pairs on: gymnasium's humanoid (109 self-pairs) builds its rhs in
# 8.1 s CPU (6.4 s without them; inlined 32.5 s), rhs 1.98x its no-contact rhs, default function set
# 24.5 vs 19.4 s (jac_x/jac_id on the analytic kernel; benchmarks/results/pair_default_build.md).
PAIR_TABLE = True
# With PAIR_TABLE: the fewest pairs a tree's loads hold for them to go through the table; fewer are
# inlined (INLINE_NARROW / LAW_ROUTINES as set).  Why: the table's call reads one double[] input
# array, which the batch vectoriser took at first for no function (compiler/emit/batch.py), so
# gymnasium's hopper with its 3 self-pairs as a table lost its vectorized implicit_batch (the rollout
# lanes' kernel); inlined, it keeps it, and the few pairs cost little code.  The humanoid's 109 go
# through the table.  Since session 12 NAME_implicit_batch makes the table's call lane by lane (its
# parameters are shared; rhs_batch's per-row parameters still refuse it): G1's 16 foot pairs.
# In the caches' keys when not its default (compiler/build/reuse.generator_switches).
TABLE_FROM_DEFAULT = 8
TABLE_FROM = TABLE_FROM_DEFAULT
# True: the inlined pairs' (fewer than TABLE_FROM) slopes are in NAME_implicit as the table's are
# (compiler/tree/contacts.py); False (the default): only the table's, the inlined pairs' forces are
# in its f and the fixed step takes them explicitly.  Why: measured on gymnasium's hopper (3
# self-pairs on one leg, never pressed in bench_fixedstep's run) NAME_implicit took 1.24 us a call
# with them against 1.09 without, the checked step 0.731 against 0.591 ms per simulated second
# (4.37x -> 3.55x mj_step); the humanoid's 109 table pairs are where the slopes pay
# (benchmarks/results/fixedstep.md).  In the caches' keys when set.
INLINE_SLOPES = False
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
    params: dict               # "k", "c", "mu", "vs" -> Symbol (or literal when folded); with torsional
    #                            and rolling friction (MJCF condim 4, 6) also "mut"/"mur" and "rho"
    #                            (.law.spin_moment): in the table, its law is the spinning law routine
    margin: float = 0.0
    index: int = 0             # its PairValue placeholders' first argument (outputs, events)
    part: int = -1             # which of the pair's contact points (:func:`pair_parts`); -1: the only one

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
            out += [sm.Integer(KIND_INDEX.index(s.kind))]
        out += [self.params[k] for k in ("k", "c", "mu", "vs")]
        out += [x for j, k in enumerate(SPIN_KEYS + ("rho",)) if k in self.params
                for x in (sm.Integer(-1 - j), self.params[k])]
        return out + [sm.Integer(self.part)] if self.part >= 0 else out

    @property
    def stores_energy(self):
        """Is its law's force minus the gradient of k δ₊^(5/2) / (5/2) (the ``energy`` output
        counts it: compiler/tree/contacts._pair_energy)?  :func:`counted_kinds`."""
        return counted_kinds(self.a.kind, self.b.kind)

    @property
    def spins(self):
        """Has torsional or rolling friction (.law.spin_moment): inlined, or in the pairs' table
        whose law is then the spinning law routine (.narrow.LAW_SPIN_RID); never the law routine
        of ``LAW_ROUTINES`` (which has no moment)."""
        return any(k in self.params for k in SPIN_KEYS)

    def narrow(self, a, b, let, called=False):
        """(p, n, δ) of this contact point (world; n from A to B): a call of its kinds' routine
        (:mod:`.narrow`), one per pair whatever its number of points (the call is value-numbered
        by ``let``), or the scheme inlined when ``INLINE_NARROW`` is set and not ``called``."""
        if INLINE_NARROW and not called:
            return scheme(a, b, self.part, self.margin, let)
        rid = nw.routine_index(self.a.kind, self.b.kind)
        uid = self.index - max(self.part, 0)       # the pair's first point: one array per pair
        call = let(nw.NarrowCall(sm.Integer(rid), sm.Integer(uid),
                                 *nw.narrow_inputs(a, b, self.a.size, self.b.size, self.margin)))
        base = nw.PER_PART * max(self.part, 0)
        out = [let(nw.NarrowOut(call, sm.Integer(uid), sm.Integer(base + k))) for k in range(nw.PER_PART)]
        return out[0:3], out[3:6], out[6]

    def lower(self, bodies, rec, v, rename, poses, broad=None, slopes=None):
        """Add the pair's force to both bodies' fext (body components, about their origins);
        return {PairValue placeholder: temporary}: F_n, the friction force on B (world), the
        depth δ and the clip's switching function (:func:`.law.clip_switch`).
        ``broad``: a list to append the pair's broad phase to (:func:`pair_guard`).
        ``slopes``: a list to append NAME_implicit's entry of the point to ({depth, point,
        velocity, K, C}: :func:`law_slopes`; compiler/tree/contacts.py)."""
        what = f"the contact {self.name}"
        params = {k: rename(s, what) for k, s in self.params.items()}
        ren = lambda e: rename(e, what)      # noqa: E731 -- mass-centre parameters -> their slots
        a, b = _placed(self.a, poses, rec, ren), _placed(self.b, poses, rec, ren)
        if LAW_ROUTINES and not self.spins:
            return self._lower_called(a, b, bodies, rec, v, params, poses, broad, slopes)
        p, n, depth = self.narrow(a, b, rec.let)
        va = _velocity_at(_moving(self.a, poses, v), p, rec.let)
        vb = _velocity_at(_moving(self.b, poses, v), p, rec.let)
        fn, ft, f, rate, _ = _law(n, depth, va, vb, params, rec.let)
        wrench = _apply(self.b, f, p, poses, bodies, rec) + _apply(self.a, [-x for x in f], p, poses, bodies, rec)
        if self.spins:      # torsional/rolling friction: B turns relative to A; a pure moment on each
            w = [_omega(shape, poses, v, rec.let) for shape in (self.a, self.b)]
            moment = spin_moment([w[1][k] - w[0][k] for k in range(3)], n, fn, params, rec.let)
            wrench += _apply_moment(self.b, moment, poses, bodies, rec)
            wrench += _apply_moment(self.a, [-x for x in moment], poses, bodies, rec)
        if broad is not None:
            broad.append(((self.a, self.b, self.margin), pair_clearance(self, a, b, poses),
                          tuple(dict.fromkeys(s for s in wrench if isinstance(s, sm.Symbol))), depth,
                          self._slopes(n, p, depth, va, vb, params, rec, slopes)))
        # OUTPUT_KINDS, CLIP_KIND, then POINT_KINDS (the contact point, world)
        quantities = [fn, *ft, depth, clip_switch(depth, params["c"], rate), *p]
        return {PairValue(self.index, kind): value for kind, value in enumerate(quantities)}

    @staticmethod
    def _slopes(n, p, depth, va, vb, params, rec, slopes):
        """Append the point's NAME_implicit entry to ``slopes`` (None: nothing, returns ((), ()));
        return the broad phase's exports for it: (v_rel, K, C -- ±0 out of contact: the point's
        inner guard --, δ and p, which read 0 where the pair's broad phase skips it: NAME_implicit's
        "not in contact")."""
        if slopes is None:
            return (), ()
        vrel, K, C = law_slopes(n, depth, va, vb, params, rec.let)
        # δ, p and v_rel exported as copies (1.0 x: the same bits), read by NAME_implicit's results
        # only: exported themselves, the law and the wrenches that read them made their first
        # reader outside the block, and the guard was dropped (gymnasium's hopper: the 3 pairs'
        # narrow phases ran at every call, +26 % a call)
        one = sm.Float(1.0)
        depth, point, vrel = rec.let(one * depth), [rec.let(one * x) for x in p], [rec.let(one * x) for x in vrel]
        slopes.append({"depth": depth, "point": point, "velocity": vrel, "K": K, "C": C})
        inner = tuple(dict.fromkeys(s for s in (*vrel, *(x for M in (K, C) for row in M for x in row))
                                    if isinstance(s, sm.Symbol)))
        return inner, tuple(s for s in (depth, *point) if isinstance(s, sm.Symbol))

    def _lower_called(self, a, b, bodies, rec, v, params, poses, broad, slopes=None):
        """:meth:`lower` with routines (``LAW_ROUTINES``, .narrow): the pair's narrow routine
        (one call per pair), then this point's call of the law routine, whose wrenches are added
        to the bodies' fext; the broad phase's inner guard (the point's depth) holds the law call,
        as it holds the inlined law."""
        p, n, depth = self.narrow(a, b, rec.let, called=True)
        law = [*p, *n, depth]
        for shape in (self.a, self.b):
            body = _moving(shape, poses, v)
            if body is None:                    # the world: no motion, no wrench (rotation 0)
                law += [sm.S.Zero] * nw.BODY_INPUTS
            else:
                o, R, w, u = body
                law += list(o) + [x for row in R for x in row] + list(w) + list(u)
        law += [params[k] for k in ("k", "c", "mu", "vs")]
        uid = sm.Integer(nw.LAW_UID + self.index)
        call = rec.let(nw.NarrowCall(sm.Integer(nw.LAW_RID), uid, *law))
        out = [rec.let(nw.NarrowOut(call, uid, sm.Integer(k))) for k in range(nw.LAW_OUTPUTS)]
        wrench = []
        for shape, part in ((self.b, out[0:6]), (self.a, out[6:12])):
            if shape.body >= 0:
                old = bodies[shape.body].fext or [0] * 6
                bodies[shape.body].fext = [old[k] + x for k, x in enumerate(part)]
                wrench += part
        kc = ((), ())
        if slopes is not None:      # the slopes inlined (the law routine has none)
            va = _velocity_at(_moving(self.a, poses, v), p, rec.let)
            vb = _velocity_at(_moving(self.b, poses, v), p, rec.let)
            kc = self._slopes(n, p, depth, va, vb, params, rec, slopes)
        if broad is not None:
            broad.append(((self.a, self.b, self.margin), pair_clearance(self, a, b, poses),
                          tuple(dict.fromkeys(s for s in wrench if isinstance(s, sm.Symbol))), depth, kc))
        # OUTPUT_KINDS, CLIP_KIND, then POINT_KINDS (as :meth:`lower`)
        quantities = [out[12], *out[13:16], depth, out[16], *p]
        return {PairValue(self.index, kind): value for kind, value in enumerate(quantities)}


def _moving(shape, poses, v):
    """(origin, world -> body rotation rows, ω, origin velocity (body components)) of the
    shape's body, or None for the world."""
    if shape.body < 0:
        return None
    i = shape.body
    R = poses.world_to_body(i)         # before the origin: the order the placement names them in
    return poses.origin(i), R, v[i][:3], v[i][3:]


def _omega(shape, poses, v, let):
    """The world angular velocity of the shape's body (zero for the world)."""
    if shape.body < 0:
        return [sm.S.Zero] * 3
    R, w_b = poses.world_to_body(shape.body), v[shape.body][:3]
    return [let(sum((R[r][k] * w_b[r] for r in range(3)), sm.S.Zero)) for k in range(3)]


def _apply_moment(shape, moment, poses, bodies, rec):
    """A pure moment (world) on the shape's body: into its fext; returns its body components (named)."""
    if shape.body < 0:
        return []
    i = shape.body
    R = poses.world_to_body(i)
    m_b = [rec.let(sum((R[r][k] * moment[k] for k in range(3)), sm.S.Zero)) for r in range(3)]
    old = bodies[i].fext or [0] * 6
    bodies[i].fext = [old[k] + (m_b[k] if k < 3 else 0) for k in range(6)]
    return m_b


def _law(n, depth, va, vb, params, let):
    """(F_n, friction force on B (world), force on B (world), δ̇, the law's parts for
    :func:`.law.ground_jacobians`) of the smooth law at a contact point: normal ``n`` (A to B),
    depth δ, the bodies' velocities there (module docstring)."""
    vrel = [let(vb[k] - va[k]) for k in range(3)]
    rate = let(-_dot(n, vrel))
    dpos = let((depth + sm.Abs(depth)) / 2)
    elastic = params["k"] * sm.Abs(dpos) ** EXPONENT
    fn = let(_pos(let(elastic * (1 + sm.Rational(3, 2) * params["c"] * rate))))
    vn = let(_dot(n, vrel))
    vt = [let(vrel[k] - vn * n[k]) for k in range(3)]
    scale = let(-params["mu"] * fn / sm.sqrt(_dot(vt, vt) + params["vs"] ** 2))
    ft = [scale * vt[k] for k in range(3)]        # outputs only: the rhs names f (as before)
    f = [let(fn * n[k] + scale * vt[k]) for k in range(3)]      # on B, world components
    parts = {"rate": rate, "dpos": dpos, "slip": vrel, "vt": vt, "scale": scale, "normal": n,
             "k": params["k"], "c": params["c"], "vs": params["vs"], "mu": params["mu"]}
    return fn, ft, f, rate, parts


def law_slopes(n, depth, va, vb, params, let):
    """(v_rel = v_B - v_A (world), K, C: 3x3 of named temporaries) at a contact point: the law's
    force on B as a function of B's point relative to A, K = -dF/dp and C = -dF/dv_rel
    (:func:`.law.ground_jacobians`: this law is the ground's with the plane's normal n and the
    body's velocity v_rel -- δ̇ = -n·v_rel, friction on v_rel's tangential part -- so its slopes
    are too; the normal's turning with p, F_n/|d| across n, is left out as the ground's fixed
    plane has none).  What NAME_implicit exports per pair point (compiler/tree/contacts.py): the
    fixed step puts Jᵀ K J, Jᵀ C J in its matrix with J = J_B - J_A (runtime/c/eomc_fixedstep.c)."""
    fn, ft, f, rate, parts = _law(n, depth, va, vb, params, let)
    K, C = ground_jacobians(ContactForces(depth, fn, ft, f, None, parts), step, let)
    return parts["slip"], [[let(x) for x in row] for row in K], [[let(x) for x in row] for row in C]


def _law_outputs(p, n, depth, body_a, body_b, params, let):
    """The law routine's outputs at one contact point (.narrow, LAW_OUTPUTS): B's and A's
    wrenches (body components, about the origins), F_n, friction (world), the clip's function."""
    fn, ft, f, rate, _ = _law(n, depth, _velocity_at(body_a, p, let), _velocity_at(body_b, p, let), params, let)
    return (_wrench(body_b, f, p, let) + _wrench(body_a, [-x for x in f], p, let)
            + [fn, *ft, clip_switch(depth, params["c"], rate)])


def scheme(a, b, part, margin, let):
    """(p, n, δ) of contact point ``part`` (:func:`pair_parts`) of two placed shapes ({kind,
    centre, axes, size}, world; sizes and margin numbers, or symbols in a routine, .narrow)."""
    if uses_solid(a["kind"], b["kind"]):
        return solid_contact(a, b, part, margin, let)
    xa, xb, ra, rb = closest_points(a, b, let)
    d = [let(xb[k] - xa[k]) for k in range(3)]
    dist = let(sm.sqrt(_dot(d, d) + EPS ** 2))
    n = [let(x / dist) for x in d]
    if isinstance(margin, sm.Basic) and not margin.is_Number:
        depth = let(ra + rb + margin - dist)
    else:
        depth = let(ra + rb + sm.Float(margin, 17) - dist) if margin else let(ra + rb - dist)
    p = [let(xa[k] + (ra - depth / 2) * n[k]) for k in range(3)]
    return p, n, depth


def _scheme_outputs(a, b, margin, let):
    """p, n, δ of every contact point of the pair, in :func:`pair_parts`' order (a routine's outputs)."""
    out = []
    for part in pair_parts(a["kind"], b["kind"]):
        p, n, depth = scheme(a, b, part, margin, let)
        out += list(p) + list(n) + [depth]
    return out


def _num(x):
    if isinstance(x, sm.Basic) and not x.is_Number:
        return x                # a size or margin as a symbol (the narrow phase's routines, .narrow)
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


RIM_POINTS = 16   # a capsule meets a cylinder's rim circle at one of this many points per rim
RIM_NEWTON = 5    # Newton steps from the nearest of them to the segment's point nearest the circle (_rim_nearest)
AXIS_LINE = 1e6   # m: the half length of a cylinder's axis taken as its line (_candidates)
ELLIPSOID_NEWTON = 10   # Newton steps for a point's nearest point on an ellipsoid (signed_distance)
SEGMENT_NEWTON = 6      # Newton steps for a segment's point nearest an ellipsoid (_segment_ellipsoid)
SEGMENT_EPS = 1e-9      # regularises the Newton steps' second derivative (a segment parallel to a flat side)
AXIS_NEWTON = 7         # Newton steps on the sphere for two ellipsoids' separating direction (_ellipsoid_axis)
AXIS_SAFE = 2           # of them, the first with the Hessian made negative (λ ≥ 0): ascent from any start
AXIS_TRIES = (0.25, 0.5, 1.0)   # the fractions of each step tried, in this order, after staying put
AXIS_SLACK = 1e-13      # m: a later try is kept unless its gap is below the best so far by more (rounding)
ARC_SAMPLES = 17        # a box edge's arc of directions: the start of its Newton steps, the best of these
#                         (_box_ellipsoid; 5 missed the narrow window of a long ellipsoid, session 40)
ARC_NEWTON = 6          # Newton steps on the arc
UNREACHED = 1e3         # m: a vertex candidate whose direction leaves its corner's cone drops out by this
SDF_EPS = 1e-15   # m: regularises the lengths inside a solid's signed distance (a normal of 0 where undefined)


def uses_solid(kind_a, kind_b):
    """Is a pair of these kinds met through a solid's signed distance (:func:`solid_contact`):
    box–box and every pair with a cylinder or an ellipsoid."""
    return kind_a == kind_b == "box" or bool({kind_a, kind_b} & {"cylinder", "ellipsoid"})


def counted_kinds(kind_a, kind_b):
    """Is a pair of these kinds' force minus the gradient of its depth's k δ₊^(5/2) / (5/2), so
    that the ``energy`` output may count it (PairLoad.stores_energy; the runtime judges runs by
    that energy)?  Each contact point's depth must be a continuous function of the two poses whose
    gradient is the normal the force acts along (then its power is -d/dt of the energy):

    - the nearest points of two cores (sphere, capsule; with a box while the other core stays
      outside it, a penetration below the capsule's or sphere's radius -- deeper, the runtime's
      penetration verdict speaks): yes;
    - a sphere, capsule, box or cylinder against a cylinder, a sphere or capsule against an
      ellipsoid: yes,
      while the cores stay outside -- each candidate (:func:`solid_contact`) is a point of its
      body against the solid's exact signed distance (the ellipsoid's to 1e-16 by its Newton
      steps), whose gradient is the normal, or a segment's stationary nearest point: to the axis
      line against the side (:func:`_candidates`), to a rim circle (:func:`_rim_nearest`'s Newton
      steps), to a box (:func:`_segment_box`), to an ellipsoid (:func:`_segment_ellipsoid`'s
      Newton steps); the deepest is a max of such depths (continuous).
      Measured (tests/compiler/contact/test_pair_conservation.py): dE/dt / (F |u|) below 1e-5 at
      random shallow states met from outside.  Before session 18's rim candidate, a capsule
      across a rim took the segment's point nearest the axis segment, which slid along the
      segment: up to 0.14-0.38 there;
    - box–box: yes since session 19 -- each of both boxes' sample points (corners, edges'
      midpoints, points inside the faces) against the other's exact signed distance
      (:func:`_box_box`).  Session 18's law (each corner past the face the separating-axis test
      picked, gated by its foot lying on that face) was not: its depth jumped where the pick or
      the gate switched with a corner already past the plane (10 % drift at rtol 1e-8 in
      session 17; the central difference across a jump, 1e6);
    - ellipsoid–ellipsoid: yes, apart and shallow, as far as :func:`_ellipsoid_axis`' Newton
      steps converge (A's point is then the stationary nearest point; pressed in deeper, B's
      normal at the point nearest it turns off the axis);
    - box–ellipsoid: yes, apart and pressed in (:func:`_box_ellipsoid`: each candidate is the
      separating axis' gap where it is stationary, so its gradient is the force: the envelope
      theorem); cylinder–ellipsoid is not modelled (PAIR_KINDS)."""
    return True


def pair_parts(kind_a, kind_b):
    """The parts (contact points) of a pair of these kinds: [-1] (one point) but for
    box–box: 2·BOX_POINTS (A's sample points against B, then B's against A: :func:`_box_box`) and
    cylinder–cylinder: 4·CYLINDER_RIM + 1 (A's rim points against B, B's against A, and the
    capsule inside A about its axis -- radius min(R, h) -- against B: side on side); box–cylinder:
    8 + 2·CYLINDER_RIM + 1 (the box's corners against the cylinder, the cylinder's rim points
    against the box, and the capsule inside the cylinder about its axis against the box: its side
    on a face or an edge; whichever order the pair names them in)."""
    from .geometry import CYLINDER_RIM
    if kind_a == kind_b == "box":
        return list(range(2 * BOX_POINTS))
    if kind_a == kind_b == "cylinder":
        return list(range(4 * CYLINDER_RIM + 1))
    if {kind_a, kind_b} == {"box", "cylinder"}:
        return list(range(8 + 2 * CYLINDER_RIM + 1))
    return [-1]


def _smin(x, y):
    """min of two sizes: numbers, or symbols (the routines' inputs)."""
    if isinstance(x, sm.Basic) and not x.is_Number or isinstance(y, sm.Basic) and not y.is_Number:
        return (x + y - sm.Abs(x - y)) / 2
    return min(x, y)


def _max(x, y):
    return (x + y + sm.Abs(x - y)) / 2


def _sign(x):
    return 2 * step(x) - 1


def signed_distance(x, solid, let=lambda e: e):
    """(sd, outward normal (world)) of the point ``x`` (world) against a solid box, cylinder or
    ellipsoid ({kind, centre, axes, size}): sd > 0 outside, < 0 inside, branch-free.

    Box and cylinder (its (radial, axial) profile is a rectangle): with e_j = |q_j| - h_j the
    excess over each face pair in the solid's frame, sd = |e₊| + min(max_j e_j, 0) (exact); the
    normal is e₊/|e₊| outside and, inside, the nearest face's (the largest e_j, chosen by
    ``step``).  Ellipsoid (semi-axes a_j): the nearest point y_j = a_j² q_j/(a_j² + t) with t the
    root of Σ (a_j q_j/(a_j² + t))² = 1, found by ``ELLIPSOID_NEWTON`` Newton steps from
    t₀ = max_j (a_j |q_j| - a_j²) (a lower bound of the root, where the function is convex and
    decreasing: the steps rise to the root monotonically; 10 steps: 1e-16 for semi-axis ratios up
    to 2.4 in 20 000 random points, see tests); then sd = t·|w|, normal w/|w| with w_j = q_j/(a_j² + t)
    (q - y = t·w).  jac_x differentiates the Newton steps as written (converged: the root's own
    derivative to the same accuracy)."""
    c, axes, size = solid["centre"], solid["axes"], solid["size"]
    rel = [x[k] - c[k] for k in range(3)]
    kind = solid["kind"]
    if kind == "ellipsoid":
        q = [let(_dot(rel, axes[j])) for j in range(3)]
        t, w, wn = _ellipsoid_root(q, size, let)
        return let(t * wn), [let(sum((w[j] / wn * axes[j][k] for j in range(3)), sm.S.Zero)) for k in range(3)]
    if kind == "box":
        return _box_sd([let(_dot(rel, axes[j])) for j in range(3)], solid, let)
    if kind == "cylinder":
        z = let(_dot(rel, axes[2]))
        radial = [let(rel[k] - z * axes[2][k]) for k in range(3)]
        rho = let(sm.sqrt(_dot(radial, radial) + SDF_EPS ** 2))
        e = [let(rho - _num(size[0])), let(sm.Abs(z) - _num(size[1]))]
        dirs = [[radial[k] / rho for k in range(3)], [_sign(z) * axes[2][k] for k in range(3)]]
    else:
        raise ValueError(f"no signed distance to a {kind}")
    return _sd_tail(e, dirs, let)


def _ellipsoid_root(q, size, let):
    """(t, w, |w|) of the point ``q`` (the ellipsoid's frame) against the ellipsoid of semi-axes
    ``size`` (:func:`signed_distance`): t the root of Σ (a_j q_j/(a_j² + t))² = 1 by
    ``ELLIPSOID_NEWTON`` Newton steps, w_j = q_j/(a_j² + t) (sd = t·|w|, outward normal w/|w|)."""
    a2 = [_num(size[j] ** 2) for j in range(3)]
    t = let(_max(_max(*[sm.Abs(q[j]) * _num(size[j]) - a2[j] for j in range(2)]), sm.Abs(q[2]) * _num(size[2]) - a2[2]))
    for _ in range(ELLIPSOID_NEWTON):
        w = [let(q[j] / (a2[j] + t)) for j in range(3)]
        f = sum((a2[j] * w[j] ** 2 for j in range(3)), sm.S.Zero) - 1
        df = -2 * sum((a2[j] * w[j] ** 2 / (a2[j] + t) for j in range(3)), sm.S.Zero)
        t = let(t - f / (df - SDF_EPS))
    w = [let(q[j] / (a2[j] + t)) for j in range(3)]
    return t, w, let(sm.sqrt(_dot(w, w) + SDF_EPS ** 2))


def _segment_ellipsoid(ca, axis, h, ell, let):
    """[point]: the segment ca + s·axis (|s| <= h)'s points where it may first meet a solid
    ellipsoid -- s₀, the point nearest the centre in the ellipsoid's metric (Σ (q_j/a_j)² least:
    the segment's deepest point when it pierces the ellipsoid), and s after ``SEGMENT_NEWTON``
    Newton steps from s₀ on φ'(s) = 0, φ(s) = sd(x(s)) (:func:`signed_distance`), kept in a
    bracket of the least: each step's sign of φ' moves one end of [lo, hi] (first the segment's
    ends) to s, and a Newton step that leaves the bracket is replaced by its midpoint.

    Why: φ is convex along a line (the signed distance to a convex solid is convex), so its least
    on the segment is the clamped root of φ'(s) = n·u (n the outward normal at x(s), u the
    segment's direction in the ellipsoid's frame); φ''(s) = (u·w' - (n·u)(n·w'))/|w| with
    w_j = q_j/(a_j² + t), w_j' = (u_j - w_j t')/(a_j² + t) and t' the root's implicit
    derivative t' = Σ a_j² w_j u_j/(a_j² + t) / Σ a_j² w_j²/(a_j² + t).  Why the bracket
    (session 40): clamped Newton steps alone overshot and cycled where φ'' is small (a flat
    ellipsoid, a long segment): 3 of 170 random segments 2 mm-10 cm from long or flat
    ellipsoids missed their least by up to 8 cm; bracketed, none in 6 steps.  Every candidate is a
    point of the segment, so the depth (the deepest candidate) is never overstated: a Newton step
    that has not converged meets late, never early (measured against mj_geomDistance and a dense
    search in tests/compiler/contact/test_solid_pairs.py)."""
    c, axes, size = ell["centre"], ell["axes"], ell["size"]
    rel = [let(ca[k] - c[k]) for k in range(3)]
    q0 = [let(_dot(rel, axes[j])) for j in range(3)]
    u = [let(_dot(axis, axes[j])) for j in range(3)]
    a2 = [_num(size[j] ** 2) for j in range(3)]
    s0 = let(_clamp(-sum((q0[j] * u[j] / a2[j] for j in range(3)), sm.S.Zero)
                    / sum((u[j] ** 2 / a2[j] for j in range(3)), sm.S.Zero), -h, h))
    s, lo, hi = s0, -h, h
    for _ in range(SEGMENT_NEWTON):
        q = [let(q0[j] + s * u[j]) for j in range(3)]
        t, w, wn = _ellipsoid_root(q, size, let)
        nu = let(_dot(w, u) / wn)
        g = [let(a2[j] * w[j] / (a2[j] + t)) for j in range(3)]
        dt = let(_dot(g, u) / (_dot(g, w) + SDF_EPS))
        dw = [let((u[j] - w[j] * dt) / (a2[j] + t)) for j in range(3)]
        second = let((_dot(u, dw) - nu * _dot(w, dw) / wn) / wn)
        right = let(step(nu))                      # φ' > 0: the least lies left of s
        lo, hi = let(lo + (1 - right) * (s - lo)), let(hi + right * (s - hi))
        newton = let(s - nu / (sm.Abs(second) + SEGMENT_EPS))
        inside = let((1 - step(lo - newton)) * (1 - step(newton - hi)))
        s = let((lo + hi) / 2 + inside * (newton - (lo + hi) / 2))
    return [[let(ca[k] + x * axis[k]) for k in range(3)] for x in (s0, s)]


def _ellipsoid_matrix(ell):
    """A = R diag(a²) Rᵀ of an ellipsoid (world): its support function is h(m) = √(mᵀ A m)."""
    axes, a2 = ell["axes"], [_num(ell["size"][j] ** 2) for j in range(3)]
    return [[sum((a2[j] * axes[j][r] * axes[j][c] for j in range(3)), sm.S.Zero) for c in range(3)] for r in range(3)]


def _ellipsoid_axis(a, b, let):
    """x_A: A's support point along the direction m that maximises the gap
    g(m) = m·(c_B - c_A) - h_A(m) - h_B(m) on the unit sphere (h the support functions): their
    nearest point to B apart, its deepest point along m pressed in (the separating-axis theorem:
    g(m) is the gap along m, its maximum the signed distance, and at the maximum the two support
    points are the nearest points).

    Why this problem: g is smooth and its Hessian ∇²g = -∇²h_A - ∇²h_B is analytic
    (∇²h = (A - A m mᵀ A/h²)/h), so Riemannian Newton steps converge quadratically near the
    maximum; iterating one ellipsoid's support point against the other's normal (session 39's
    first try) cycles or crawls where each ellipsoid is the flatter in one principal direction.
    Apart, g is concave on the ball |m| ≤ 1 and its maximum on the sphere the only one above 0.

    Why this start and these safeguards (session 40): plain Newton from the direction between the
    centres missed the maximum at 224 of 600 random pairs of elongated ellipsoids placed from 30 %
    of the thinner's smallest semi-axis pressed in to apart (50 of them pressed in, reported
    apart: they passed through each other).  That start has g < 0 for long shapes side by side,
    where the Hessian is indefinite and Newton heads for a saddle; and where the support functions
    bend sharply (flat ellipsoids) full steps overshoot and cycle.  So: the start is the normal
    direction (A + B)⁻¹ d of the ellipsoid whose support function is √(h_A² + h_B²), a stand-in
    for the pair's Minkowski sum; the first ``AXIS_SAFE`` steps take max(λ, 0) for λ (the Hessian
    then negative on the tangent plane: an ascent direction); and each step keeps the best of
    ``AXIS_TRIES`` fractions of it and staying put (a choice by :class:`step`, as the pairs'
    candidates), so g never falls by more than ``AXIS_SLACK``: that slack and the order (the full
    step last) let the full Newton step win near the maximum, where its gain, quadratic in the
    step, is below g's rounding (without it m stalled ~1e-9 off and A's point with it).  The same
    600 pairs: 0 misses in 6 steps (1e-9 of the maximum found from 16 starts), all converged to
    rounding in 7 (6 left 10 of 800 poses up to 5e-8 off in m); 3 of 300 random poses deeper
    than 1 cm end at a lesser local maximum (deeper than the true depth).  Its caller measures
    the point against the other ellipsoid's exact signed distance, so an unconverged m meets late,
    never early; a pair pressed in deeper than the thinner's smallest semi-axis can put A's
    support point beyond B (reported apart)."""
    A, B = _ellipsoid_matrix(a), _ellipsoid_matrix(b)
    d = [let(b["centre"][k] - a["centre"][k]) for k in range(3)]
    m = _solve3([[A[r][c] + B[r][c] for c in range(3)] for r in range(3)], d, let)
    mn = let(sm.sqrt(_dot(m, m) + SDF_EPS ** 2))
    m = [let(v / mn) for v in m]

    def gap(m):
        (Am, ha), (Bm, hb) = _support_fn(A, m, let), _support_fn(B, m, let)
        return let(_dot(m, d) - ha - hb), (Am, ha), (Bm, hb)

    g, (Am, ha), (Bm, hb) = gap(m)
    for i in range(AXIS_NEWTON):
        grad = [let(d[k] - Am[k] / ha - Bm[k] / hb) for k in range(3)]
        H = [[let(-(A[r][c] - Am[r] * Am[c] / ha ** 2) / ha - (B[r][c] - Bm[r] * Bm[c] / hb ** 2) / hb)
              for c in range(3)] for r in range(3)]
        v = _sphere_newton_step(m, grad, H, i < AXIS_SAFE, let)
        best = (g, m, Am, ha, Bm, hb)
        for frac in AXIS_TRIES:
            w = [let(m[k] + _num(frac) * v[k]) for k in range(3)]
            wn = let(sm.sqrt(_dot(w, w) + SDF_EPS ** 2))
            w = [let(x / wn) for x in w]
            gw, (Aw, hw), (Bw, hwb) = gap(w)
            take = let(step(gw - best[0] + _num(AXIS_SLACK)))
            best = tuple(_blend(old, new, take, let) for old, new in zip(best, (gw, w, Aw, hw, Bw, hwb)))
        g, m, Am, ha, Bm, hb = best
    return [let(a["centre"][k] + Am[k] / ha) for k in range(3)]


def _blend(old, new, take, let):
    """old + take·(new - old) of a number or a vector: the branch-free choice of the candidates."""
    if isinstance(old, list):
        return [let(o + take * (n - o)) for o, n in zip(old, new)]
    return let(old + take * (new - old))


def _support_fn(E, m, let):
    """(E m, h_E(m) = √(mᵀ E m)): an ellipsoid's support function at m (E its matrix,
    :func:`_ellipsoid_matrix`) and the vector its gradient is E m/h."""
    Em = [let(sum((E[r][c] * m[c] for c in range(3)), sm.S.Zero)) for r in range(3)]
    return Em, let(sm.sqrt(_dot(m, Em) + SDF_EPS ** 2))


def _sphere_newton_step(m, grad, H, safe, let):
    """v: the Riemannian Newton step towards a maximum of a function g on the unit sphere at m,
    given its gradient and Hessian in space there (the next m is (m + v)/|m + v|).  It solves
    (P H P - λ P + m mᵀ) v = -P ∇g (P = I - m mᵀ, λ = m·∇g: the Riemannian Hessian, made regular
    along m) by Cramer's rule; ``safe`` takes max(λ, 0) for λ, so that where H is negative on the
    tangent plane (the ellipsoids' gap) the step ascends from any start."""
    lam = let(_dot(m, grad))
    if safe:
        lam = let((lam + sm.Abs(lam)) / 2)
    P = [[(1 if r == c else 0) - m[r] * m[c] for c in range(3)] for r in range(3)]
    HP = [[let(sum((H[r][k] * P[k][c] for k in range(3)), sm.S.Zero)) for c in range(3)] for r in range(3)]
    M = [[let(sum((P[r][k] * HP[k][c] for k in range(3)), sm.S.Zero) - lam * P[r][c] + m[r] * m[c])
          for c in range(3)] for r in range(3)]
    rhs = [let(-sum((P[r][k] * grad[k] for k in range(3)), sm.S.Zero)) for r in range(3)]
    return _solve3(M, rhs, let)


def _box_ellipsoid(box, ell, let):
    """[(g, m, x_E)]: the separating-axis candidates of a box against an ellipsoid, the pair's
    signed distance the largest g: g(m) = m·(c_E - c_B) - h_B(m) - h_E(m) is the gap between the
    shapes along the unit direction m (box to ellipsoid; h the support functions, h_B(m) =
    Σ h_j |m·u_j|, h_E(m) = √(mᵀ A m)), and by the separating-axis theorem the signed distance is
    its largest value over all m, apart and pressed in (then the least translation that parts them).
    x_E is the ellipsoid's point c_E - A m/h_E(m) (its support along -m), x_E - g m the box's.

    h_B is smooth but on three great circles, so the sphere splits into its corners' open cones
    (octants), the arcs between them (directions across an edge: m ⊥ u_j) and the six face
    normals, and each gives its candidates: a face normal its g (6); an edge's quarter arc
    (12) its largest g by ``ARC_NEWTON`` Newton steps in the arc's angle, from the best of
    ``ARC_SAMPLES`` directions, clamped to the arc (whose ends are the faces' normals); a corner v
    the signed distance of v to the ellipsoid (:func:`signed_distance`: the largest gap of a point),
    while its direction lies in the corner's cone -- else the arcs bounding the cone hold the largest
    value, and the corner drops out by ``UNREACHED``.  Every candidate is a value of g, so the
    largest is never above the true distance, and equal to it when the maximiser's region found it.

    Why the separating axis and not points: each candidate is g at a direction where it is
    stationary (or fixed to the box, a face's normal), so by the envelope theorem its gradient
    along the poses is the force along m at x_E: the force is minus the gradient of the counted
    energy, pressed in too.  Points measured against the other's signed distance (session 39's
    first try: a face's support point against the box) are not stationary once pressed in near an
    edge: a box thrown on an ellipsoid gained 4.8e-5 of its energy."""
    A = _ellipsoid_matrix(ell)
    u, hs = box["axes"], [_num(x) for x in box["size"]]
    d = [let(ell["centre"][k] - box["centre"][k]) for k in range(3)]
    ud = [let(_dot(u[j], d)) for j in range(3)]
    Au = [[let(sum((A[r][c] * u[j][c] for c in range(3)), sm.S.Zero)) for r in range(3)] for j in range(3)]
    uAu = [[let(_dot(u[i], Au[j])) for j in range(3)] for i in range(3)]       # uᵢᵀ A uⱼ

    def point(coef, h):               # x_E for m = Σ coef_j u_j with h = h_E(m)
        return [let(ell["centre"][k] - sum((coef[j] * Au[j][k] for j in range(3) if coef[j] is not None), sm.S.Zero) / h)
                for k in range(3)]

    def direction(coef):
        return [let(sum((coef[j] * u[j][k] for j in range(3) if coef[j] is not None), sm.S.Zero)) for k in range(3)]

    out = []
    for j in range(3):                                   # the faces
        hE = let(sm.sqrt(uAu[j][j] + SDF_EPS ** 2))
        for sg in (-1, 1):
            coef = [sg if i == j else None for i in range(3)]
            out.append((let(sg * ud[j] - hs[j] - hE), direction(coef), point(coef, hE)))
    for j in range(3):                                   # the edges along u_j: m = cos θ s_u u_u + sin θ s_w u_w
        iu, iw = [i for i in range(3) if i != j]
        for su in (-1, 1):
            for sw in (-1, 1):
                al, be = let(su * ud[iu] - hs[iu]), let(sw * ud[iw] - hs[iw])
                P, R, S = uAu[iu][iu], let(su * sw * uAu[iu][iw]), uAu[iw][iw]

                c, s_, h = _arc_max(al, be, P, R, S, [math.pi / 2 * k / (ARC_SAMPLES - 1) for k in range(ARC_SAMPLES)],
                                    (0, math.pi / 2), let)
                coef = [None] * 3
                coef[iu], coef[iw] = let(su * c), let(sw * s_)
                out.append((let(al * c + be * s_ - h), direction(coef), point(coef, h)))
    for i in range(8):                                   # the corners, while in their cones
        signs = ((i >> 2) & 1, (i >> 1) & 1, i & 1)
        v = [let(box["centre"][k] + sum(((2 * sg - 1) * hs[j] * u[j][k] for j, sg in enumerate(signs)), sm.S.Zero))
             for k in range(3)]
        sd, outward = signed_distance(v, ell, let)
        m = [let(-x) for x in outward]                   # from the corner towards the ellipsoid
        inside = sm.Mul(*[step((2 * sg - 1) * _dot(m, u[j])) for j, sg in enumerate(signs)])
        out.append((let(sd - (1 - inside) * UNREACHED), m, [let(v[k] + sd * m[k]) for k in range(3)]))
    return out


def _arc_max(al, be, P, R, S, samples, clamp, let):
    """(cos θ, sin θ, h) at the largest of g(θ) = α cos θ + β sin θ - √Q(θ) on an arc of directions
    m = cos θ a + sin θ b (Q = mᵀ A m = P cos² + 2R cos sin + S sin²: an ellipsoid's support
    function squared): ``ARC_NEWTON`` Newton steps from the best of the angles ``samples``,
    clamped to ``clamp`` (lo, hi) after each.  A box's edge's quarter arc (:func:`_box_ellipsoid`)."""
    def gap(c, s_):
        return al * c + be * s_ - sm.sqrt(P * c * c + 2 * R * c * s_ + S * s_ * s_ + SDF_EPS ** 2)
    theta, best = _num(samples[0]), let(gap(_num(_tidy(math.cos(samples[0]))), _num(_tidy(math.sin(samples[0])))))
    for t in samples[1:]:
        val = let(gap(_num(_tidy(math.cos(t))), _num(_tidy(math.sin(t)))))
        take = let(step(val - best))
        theta, best = let(theta + take * (_num(t) - theta)), let(best + take * (val - best))
    for _ in range(ARC_NEWTON):
        c, s_ = let(sm.cos(theta)), let(sm.sin(theta))
        Q = let(P * c * c + 2 * R * c * s_ + S * s_ * s_ + SDF_EPS ** 2)
        h = let(sm.sqrt(Q))
        dQ = let(2 * (S - P) * s_ * c + 2 * R * (c * c - s_ * s_))
        ddQ = let(2 * (S - P) * (c * c - s_ * s_) - 8 * R * s_ * c)
        g1 = let(-al * s_ + be * c - dQ / (2 * h))
        g2 = let(-al * c - be * s_ - ddQ / (2 * h) + dQ * dQ / (4 * h * Q))
        theta = let(theta + g1 / (sm.Abs(g2) + SDF_EPS))
        theta = let(_clamp(theta, _num(clamp[0]), _num(clamp[1])))
    c, s_ = let(sm.cos(theta)), let(sm.sin(theta))
    return c, s_, let(sm.sqrt(P * c * c + 2 * R * c * s_ + S * s_ * s_ + SDF_EPS ** 2))


def _box_ellipsoid_pair(a, b, margin, let):
    """(p, n from A to B, δ) of a box and an ellipsoid (either order): the largest of
    :func:`_box_ellipsoid`'s gaps, δ = margin - g; p where the cores' pairs put it, δ/2 short of
    A's point along n."""
    box, ell = (a, b) if a["kind"] == "box" else (b, a)
    cands = _box_ellipsoid(box, ell, let)
    g, m, xe = cands[0]
    for g2, m2, xe2 in cands[1:]:                        # the largest gap: step(g_k - g_best)
        take = let(step(g2 - g))
        m, xe, g = _blend(m, m2, take, let), _blend(xe, xe2, take, let), _blend(g, g2, take, let)
    depth = let(_num(margin) - g)
    if box is a:                                         # n = m; A's point the box's, x_E - g m
        return [let(xe[k] - (g + depth / 2) * m[k]) for k in range(3)], m, depth
    return [let(xe[k] + depth / 2 * m[k]) for k in range(3)], [let(-x) for x in m], depth


def _solve3(M, r, let):
    """x with M x = r (3×3) by Cramer's rule, branch-free (M is kept regular by its caller)."""
    def det(c0, c1, c2):
        return (c0[0] * (c1[1] * c2[2] - c1[2] * c2[1]) - c1[0] * (c0[1] * c2[2] - c0[2] * c2[1])
                + c2[0] * (c0[1] * c1[2] - c0[2] * c1[1]))
    cols = [[M[k][c] for k in range(3)] for c in range(3)]
    inv = let(1 / det(*cols))
    out = []
    for j in range(3):
        replaced = [r if c == j else cols[c] for c in range(3)]
        out.append(let(det(*replaced) * inv))
    return out


def _box_sd(q, box, let):
    """(sd, outward normal (world)) of a point at ``q`` in the box's frame (:func:`signed_distance`)."""
    e = [let(sm.Abs(q[j]) - _num(box["size"][j])) for j in range(3)]
    dirs = [[_sign(q[j]) * box["axes"][j][k] for k in range(3)] for j in range(3)]
    return _sd_tail(e, dirs, let)


def _sd_tail(e, dirs, let):
    """(sd, outward normal) of a box or cylinder from the excess e_j over each face pair and the
    faces' outward directions ``dirs`` (:func:`signed_distance`)."""
    o = [let(_pos(x)) for x in e]
    out = let(sm.sqrt(_dot(o, o) + SDF_EPS ** 2))
    top = e[0]
    for x in e[1:]:
        top = let(_max(top, x))
    inside = let(step(-top))
    picks, left = [], sm.S.One             # one-hot: the face pair of the largest e_j
    for j in range(len(e) - 1):
        pick = let(left * sm.Mul(*[step(e[j] - e[i]) for i in range(j + 1, len(e))]))
        picks.append(pick)
        left = let(left - pick)
    picks.append(left)
    weight = [let(o[j] / out + inside * picks[j]) for j in range(len(e))]
    normal = [let(sum((weight[j] * dirs[j][k] for j in range(len(e))), sm.S.Zero)) for k in range(3)]
    return let(out + (top - sm.Abs(top)) / 2), normal


def _corner(box, i):
    """Corner i (0-7) of a box (world)."""
    signs = ((i >> 2) & 1, (i >> 1) & 1, i & 1)
    return [box["centre"][k] + sum(((2 * s - 1) * _num(box["size"][j]) * box["axes"][j][k]
                                    for j, s in enumerate(signs)), sm.S.Zero) for k in range(3)]


def _rim(cyl, i):
    """Rim point i of a cylinder (world): CYLINDER_RIM points on each end's rim, as its ground contact."""
    from .geometry import CYLINDER_RIM, shape_points
    r, h = cyl["size"][0], cyl["size"][1]
    if isinstance(r, sm.Basic) and not r.is_Number:     # a routine's input (.narrow): shape_points' layout
        t = 2 * math.pi * (i % CYLINDER_RIM) / CYLINDER_RIM
        local = [r * _num(_tidy(math.cos(t))), r * _num(_tidy(math.sin(t))), (1 if i >= CYLINDER_RIM else -1) * h]
    else:
        x, y, z = shape_points("cylinder", cyl["size"])[0][i]
        local = [_num(x), _num(y), _num(z)]
    return [cyl["centre"][k] + sum((local[j] * cyl["axes"][j][k] for j in range(3) if local[j] != 0), sm.S.Zero)
            for k in range(3)]


def _candidates(shape, solid, let):
    """[(point, radius)]: where a sphere or capsule may first meet the solid -- a sphere's centre;
    a capsule's two ends and the segment's point nearest a cylinder's axis (exact for the side and
    the caps: a segment meets a flat cap first with an end, unless parallel to it; a capsule
    nearest the rim circle is :func:`solid_contact`'s rim points' job); against an ellipsoid the
    ends and the segment's stationary points of :func:`_segment_ellipsoid`."""
    if shape["kind"] == "sphere":
        return [(shape["centre"], shape["size"][0])]
    ca, axis, h, r = shape["centre"], shape["axes"][2], shape["size"][1], shape["size"][0]
    ends = [[let(ca[k] + sign * h * axis[k]) for k in range(3)] for sign in (-1, 1)]
    if solid["kind"] == "ellipsoid":
        return [(ends[0], r), (ends[1], r)] + [(x, r) for x in _segment_ellipsoid(ca, axis, h, solid, let)]
    # nearest the axis *line* (AXIS_LINE: the segment's least distance from the axis, so its depth
    # against the side is stationary along the segment; outside the side's band the rim's exact
    # candidates, :func:`_rim_nearest`, are at least as deep)
    mid, _ = _segments(ca, axis, h, solid["centre"], solid["axes"][2], AXIS_LINE, let)
    return [(ends[0], r), (ends[1], r), (mid, r)]


def solid_contact(a, b, part, margin=0.0, let=lambda e: e):
    """(p, n, δ) of one contact point of a pair met through a solid's signed distance
    (:func:`uses_solid`; ``part`` from :func:`pair_parts`): the point p the force acts at (midway
    between the surfaces), the unit normal n from A to B, the depth δ (margin included).

    A sphere of radius r at x against a solid S: δ = r + margin - sd_S(x), n = -(S's outward
    normal at x), p = x + (r - δ/2)·n, as the cores' nearest points give it for the other
    pairs.  A capsule is the deepest of its candidate spheres (:func:`_candidates`, chosen by
    ``step`` on δ).  Box–box (:func:`_box_box`: each box's sample points against the other) and
    cylinder–cylinder have several parts: each
    cylinder's rim points against the other and the capsule inside A about its axis against B
    (every candidate lies in its shape, so the depth is never overstated: a contact may start
    late, never early; measured against mj_geomDistance in the tests); box–cylinder likewise with
    the box's corners and the cylinder's rim points (an edge across the curved side, or a rim
    across a face's edge, meets late).  Capsule–cylinder adds
    the cylinder's ``RIM_POINTS`` rim points against the capsule (a capsule lying across the rim)."""
    from .geometry import CYLINDER_RIM
    swap = False
    if a["kind"] == b["kind"] == "box":
        return _box_box(a, b, part, margin, let)
    if {a["kind"], b["kind"]} == {"box", "cylinder"}:      # the box's corners, the cylinder's rim points
        box, cyl = (a, b) if a["kind"] == "box" else (b, a)
        if part == 8 + 2 * CYLINDER_RIM:         # the capsule inside the cylinder: exact nearest points
            rho = _smin(cyl["size"][0], cyl["size"][1])
            xc, xb = _segment_box(cyl["centre"], cyl["axes"][2], cyl["size"][1] - rho, box, let)
            d = [let(xb[k] - xc[k]) for k in range(3)]
            dist = let(sm.sqrt(_dot(d, d) + SDF_EPS ** 2))
            n = [let(x / dist) for x in d]            # cylinder -> box
            depth = let(_num(rho) + _num(margin) - dist)
            p = [let(xc[k] + (_num(rho) - depth / 2) * n[k]) for k in range(3)]
            return p, [let(-x) for x in n] if cyl is b else n, depth
        point, solid = (box, cyl) if part < 8 else (cyl, box)
        swap = point is b
        cands = [([let(x) for x in _corner(box, part)] if part < 8 else _rim(cyl, part - 8), 0.0)]
    elif a["kind"] == b["kind"] == "cylinder":
        if part < 4 * CYLINDER_RIM:
            swap = part >= 2 * CYLINDER_RIM
            point, solid = (b, a) if swap else (a, b)
            cands = [(_rim(point, part % (2 * CYLINDER_RIM)), 0.0)]
        else:
            point, solid = a, b                   # the capsule inside A about its axis, against B
            rho = _smin(a["size"][0], a["size"][1])
            point = {"kind": "capsule", "centre": a["centre"], "axes": a["axes"], "size": [rho, a["size"][1] - rho]}
            cands = _candidates(point, solid, let)
    elif a["kind"] == b["kind"] == "ellipsoid":
        return _ellipsoid_pair(a, b, margin, let)
    elif {a["kind"], b["kind"]} == {"box", "ellipsoid"}:
        return _box_ellipsoid_pair(a, b, margin, let)
    else:
        swap = a["kind"] in SOLIDS
        point, solid = (b, a) if swap else (a, b)
        if point["kind"] in SOLIDS:
            raise ValueError(f"no contact between a {a['kind']} and a {b['kind']}")
        cands = _candidates(point, solid, let)
    options = [_against(x, radius, solid, margin, let) for x, radius in cands]   # n: the point's shape into the solid
    if point["kind"] == "capsule" and solid["kind"] == "cylinder":
        rims = [_rim_capsule(y, point, margin, let, with_t=True) for y in _rim_points(solid, RIM_POINTS)]
        options += [o[:3] for o in rims]
        for side in range(2):          # each rim circle's exact nearest point: RIM_NEWTON steps
            options.append(_rim_nearest(point, solid, 2 * side - 1, rims[side * RIM_POINTS:(side + 1) * RIM_POINTS],
                                        margin, let))
    p, n, depth = options[0]
    for q, m, dep in options[1:]:                 # the deepest: step(δ_k - δ_best)
        take = let(step(dep - depth))
        p = [let(p[k] + take * (q[k] - p[k])) for k in range(3)]
        n = [let(n[k] + take * (m[k] - n[k])) for k in range(3)]
        depth = let(depth + take * (dep - depth))
    return p, [let(-x) for x in n] if swap else n, depth


def _ellipsoid_pair(a, b, margin, let):
    """(p, n from A to B, δ) of two ellipsoids: A's point x_A of :func:`_ellipsoid_axis` against
    B's signed distance (a point of A: the depth is never overstated; apart it is the nearest
    point, so exact).  B's point against A's is not a second candidate: apart the two tie in depth
    exactly, so which one a rounding picks would decide the point's derivative (they agree on the
    rotations, not off them: the narrow routine and the inlined scheme differed by O(1) in the
    tangents of tests/compiler/contact/test_narrow_routines.py)."""
    xa = _ellipsoid_axis(a, b, let)
    return _against(xa, 0.0, b, margin, let)


def _against(x, radius, solid, margin, let):
    """(p, n from the point's shape into the solid, δ) of a sphere of ``radius`` at ``x`` (a point:
    0) against a solid's signed distance."""
    sd, outward = signed_distance(x, solid, let)
    n = [let(-v) for v in outward]
    depth = let(_num(radius) + _num(margin) - sd)
    return [let(x[k] + (_num(radius) - depth / 2) * n[k]) for k in range(3)], n, depth


# A box's sample points (:func:`_box_point`), in units of its half sizes: its 8 corners (as
# :func:`_corner`), its 12 edges' midpoints, and on each of its 6 faces 4 points at half the
# face's half sizes.  Box–box meets each against the other box's exact signed distance.
def _box_local():
    corners = [tuple(2 * ((i >> (2 - j)) & 1) - 1 for j in range(3)) for i in range(8)]
    edges, faces = [], []
    for j in range(3):                     # edges along axis j; faces normal to axis j
        o1, o2 = (j + 1) % 3, (j + 2) % 3
        for u in (-1, 1):
            for v in (-1, 1):
                e, f = [0, 0, 0], [0, 0, 0]
                e[o1], e[o2] = u, v
                f[j], f[o1], f[o2] = u, sm.Rational(v, 2), None
                edges.append(tuple(e))
                for w in (-1, 1):
                    f[o2] = sm.Rational(w, 2)
                    faces.append(tuple(f))
    return tuple(corners + edges + faces)


_BOX_LOCAL = _box_local()
BOX_POINTS = len(_BOX_LOCAL)      # 44


def _box_point(box, i):
    """Sample point i (0..BOX_POINTS-1) of a box's surface (world): 0-7 its corners, 8-19 its
    edges' midpoints, 20-43 four points on each face (_BOX_LOCAL)."""
    local = _BOX_LOCAL[i]
    return [box["centre"][k] + sum((_num(box["size"][j]) * local[j] * box["axes"][j][k]
                                    for j in range(3) if local[j] != 0), sm.S.Zero) for k in range(3)]


def _box_box(a, b, part, margin, let):
    """(p, n, δ) of contact point ``part`` of a box pair (0..BOX_POINTS-1: A's sample points
    against B; then B's against A): the sample point x (:func:`_box_point`: a corner, an edge's
    midpoint or a point inside a face) against the other box's exact signed distance
    (:func:`signed_distance`), as box–cylinder's corners: δ = margin - sd(x), n the other box's
    inward normal at x (from A to B), p midway between x and its foot.

    Why this law: δ is a continuous function of the two poses (a material point against a fixed
    solid's signed distance), whose gradient is the normal the force acts along at p, so the
    force is minus the gradient of the energy counted (:func:`counted_kinds`).  Session 18's law
    (each corner past the face the separating-axis test picked, gated by its foot lying on that
    face) jumped where the pick or the gate switched with a corner already past the plane (a box
    pressed 1 mm and slid 2 µm past an edge lost half its energy), and it missed contacts that
    have no corner inside the other box: equal boxes stacked with a relative yaw (30°: no point
    at all, the upper box fell through), two edges crossing.  Corners alone against the signed
    distance would lose the stack too: equal boxes stacked aligned (dm_control's stacker: same
    size, same y) have their corners and edges on the other's side planes, where sd = 0; the
    points inside the faces carry it, the edges' midpoints meet crossed edges (sampled: exact
    where the crossing is at a midpoint, late elsewhere).  Exact against mj_geomDistance
    whenever the nearest points apart include a corner (a corner's signed distance is exact);
    never early (every sample lies in its box)."""
    point, solid, swap = (a, b, False) if part < BOX_POINTS else (b, a, True)
    loc, hp = _BOX_LOCAL[part % BOX_POINTS], [_num(v) for v in point["size"]]
    x = [let(v) for v in _box_point(point, part % BOX_POINTS)]
    # x in the other box's frame from the pair's relative pose (shared by the 44 points): its centre
    # there and its half axes there, then each point's coordinates are sums of these
    rel = [let(point["centre"][k] - solid["centre"][k]) for k in range(3)]
    t = [let(_dot(rel, solid["axes"][j])) for j in range(3)]
    half = [[let(hp[k] * _dot(point["axes"][k], solid["axes"][j])) for k in range(3)] for j in range(3)]
    q = [let(t[j] + sum((loc[k] * half[j][k] for k in range(3) if loc[k] != 0), sm.S.Zero)) for j in range(3)]
    sd, outward = _box_sd(q, solid, let)
    n = [let(-v) for v in outward]                    # from the point's box into the other
    depth = let(_num(margin) - sd)
    p = [let(x[k] - depth / 2 * n[k]) for k in range(3)]
    return p, [let(-v) for v in n] if swap else n, depth


def _rim_points(cyl, count):
    """``count`` points on each end's rim of a cylinder (world)."""
    out = []
    r, h = cyl["size"][0], cyl["size"][1]
    for z in (-1, 1):
        for i in range(count):
            t = 2 * math.pi * i / count
            if isinstance(r, sm.Basic) and not r.is_Number:     # a routine's input (.narrow)
                local = [r * _num(_tidy(math.cos(t))), r * _num(_tidy(math.sin(t))), z * h]
            else:
                local = [_num(_tidy(r * math.cos(t))), _num(_tidy(r * math.sin(t))), _num(z * h)]
            out.append([cyl["centre"][k] + sum((local[j] * cyl["axes"][j][k] for j in range(3) if local[j] != 0),
                                               sm.S.Zero) for k in range(3)])
    return out


def _tidy(x):
    return 0.0 if abs(x) < 1e-15 else x


def _rim_capsule(y, capsule, margin, let, with_t=False):
    """(p, n from the capsule to the point, δ) of a cylinder's rim point ``y`` against a capsule
    (``with_t``: and the segment's parameter of its nearest point)."""
    ca, axis, h, r = capsule["centre"], capsule["axes"][2], capsule["size"][1], capsule["size"][0]
    t = let(_clamp(_dot([y[k] - ca[k] for k in range(3)], axis), -h, h))
    d = [let(y[k] - ca[k] - t * axis[k]) for k in range(3)]
    dist = let(sm.sqrt(_dot(d, d) + SDF_EPS ** 2))
    n = [let(x / dist) for x in d]
    depth = let(_num(r) + _num(margin) - dist)
    out = [let(ca[k] + t * axis[k] + (r - depth / 2) * n[k]) for k in range(3)], n, depth
    return out + (t,) if with_t else out


def _rim_nearest(capsule, cyl, side, rims, margin, let):
    """(p, n from the capsule to the rim, δ) of the capsule's segment against the rim circle of
    the cylinder's end ``side`` (±1): the segment's point x(s) nearest the circle, by RIM_NEWTON
    projected Newton steps on g(s) = ((ρ - R)² + (z - side·H)²)/2 (ρ, z: x(s)'s distance from the
    axis and along it) from the parameter of the deepest of that rim's ``rims`` (its
    :func:`_rim_capsule` points, within the RIM_POINTS spacing of it); the circle's nearest point
    to x lies at x's azimuth.  Why: the segment's least distance to the circle is a function of the
    two poses whose gradient is the normal between the two nearest points (their parameters are
    stationary), so its force is minus the gradient of the energy counted (:func:`counted_kinds`);
    the discrete rim points alone were up to R(1 - cos(π/RIM_POINTS)) short of it, and the
    segment's point nearest the axis, deepest there, slid along the segment."""
    ca, axis, h, r = capsule["centre"], capsule["axes"][2], capsule["size"][1], capsule["size"][0]
    c, e, R, H = cyl["centre"], cyl["axes"][2], _num(cyl["size"][0]), _num(cyl["size"][1])
    _, _, depth, t = rims[0]
    for _, _, dep, tk in rims[1:]:
        take = let(step(dep - depth))
        t = let(t + take * (tk - t))
        depth = let(depth + take * (dep - depth))
    zs = let(_dot(axis, e))                                    # z'(s)
    ws = [let(axis[k] - zs * e[k]) for k in range(3)]          # the radial part's w'(s)
    wsws = let(_dot(ws, ws))
    rel0 = [let(ca[k] - c[k]) for k in range(3)]
    z0 = let(_dot(rel0, e))
    w0 = [let(rel0[k] - z0 * e[k]) for k in range(3)]
    for _ in range(RIM_NEWTON):
        w = [let(w0[k] + t * ws[k]) for k in range(3)]
        rho = let(sm.sqrt(_dot(w, w) + SDF_EPS ** 2))
        drho = let(_dot(w, ws) / rho)
        ddrho = let((wsws - drho ** 2) / rho)
        slope = let((rho - R) * drho + (z0 + t * zs - side * H) * zs)
        bend = let(drho ** 2 + zs ** 2 + _pos((rho - R) * ddrho) + sm.Float(1e-12))
        t = let(_clamp(t - slope / bend, -h, h))
    x = [let(ca[k] + t * axis[k]) for k in range(3)]
    w = [let(w0[k] + t * ws[k]) for k in range(3)]
    rho = let(sm.sqrt(_dot(w, w) + SDF_EPS ** 2))
    y = [let(c[k] + R * w[k] / rho + side * H * e[k]) for k in range(3)]    # the circle's point at x's azimuth
    d = [let(y[k] - x[k]) for k in range(3)]
    dist = let(sm.sqrt(_dot(d, d) + SDF_EPS ** 2))
    n = [let(v / dist) for v in d]
    depth = let(_num(r) + _num(margin) - dist)
    return [let(x[k] + (r - depth / 2) * n[k]) for k in range(3)], n, depth


def _velocity_at(body, p, let):
    """World velocity of the material point at world position ``p`` of ``body`` ((origin,
    world -> body rotation rows, ω, origin velocity), body components; None: the world)."""
    if body is None:
        return [sm.S.Zero] * 3
    o, R, w_b, v_b = body
    rel = [p[k] - o[k] for k in range(3)]
    rel_b = [let(sum((R[r][k] * rel[k] for k in range(3)), sm.S.Zero)) for r in range(3)]
    vp_b = [v_b[k] + x for k, x in enumerate(_cross(w_b, rel_b))]
    return [let(sum((R[r][k] * vp_b[r] for r in range(3)), sm.S.Zero)) for k in range(3)]


def _wrench(body, f, p, let):
    """The wrench (moment about the origin, force; body components, each named) of force ``f``
    (world) at world point ``p`` on ``body`` (as :func:`_velocity_at`'s)."""
    o, R = body[0], body[1]
    f_b = [let(sum((R[r][k] * f[k] for k in range(3)), sm.S.Zero)) for r in range(3)]
    lever = [sum((R[r][k] * (p[k] - o[k]) for k in range(3)), sm.S.Zero) for r in range(3)]
    return [let(x) for x in _cross(lever, f_b)] + f_b


def _apply(shape, f, p, poses, bodies, rec):
    """Force ``f`` (world) at world point ``p`` on the shape's body: into its fext; returns the
    wrench added (moment and force, body components, each named: the broad phase's exports)."""
    if shape.body < 0:
        return []
    i = shape.body
    R = poses.world_to_body(i)
    wrench = _wrench((poses.origin(i), R), f, p, rec.let)
    old = bodies[i].fext or [0] * 6
    bodies[i].fext = [old[k] + x for k, x in enumerate(wrench)]
    return wrench


BROAD_PAD = 1e-6   # m: added to a pair's bounding radii (covers rounding and the ellipsoid's Newton steps)


def bounding_radius(kind, size):
    """The radius of the smallest ball about a shape's centre holding the whole shape."""
    size = [float(x) for x in size]
    if kind == "sphere":
        return size[0]
    if kind == "capsule":
        return size[0] + size[1]
    if kind == "box":
        return math.sqrt(sum(x * x for x in size[:3]))
    if kind == "cylinder":
        return math.hypot(size[0], size[1])
    if kind == "ellipsoid":
        return max(size[:3])
    raise ValueError(f"no bounding radius of a {kind}")


def pair_clearance(load, a, b, poses):
    """The pair's broad phase: an expression that is positive only when the two shapes are
    further apart than the pair's margin, so that its depth δ < 0 and its force is ±0 (the law
    has no force at δ ≤ 0: δ₊ = 0 exactly).  Each shape lies in a ball fixed at build: about its
    body's origin (the position the recursion has placed already), radius |offset| + the shape's
    bounding radius; about its own centre (``a``/``b``: :func:`_placed`) when the offset holds
    parameters (a mass centre not folded) or the shape is in the world.  Then

        clearance = |c_A - c_B|² - (ρ_A + ρ_B + max(margin, 0) + BROAD_PAD)²

    Every depth this module computes is at most the true overlap of the shapes plus the margin
    (its candidate points lie in the shapes; a solid's signed distance is exact outside it, the
    ellipsoid's to far below BROAD_PAD), so a positive clearance means δ < 0 at every part."""
    centres, reach = [], sm.Float(max(float(load.margin), 0.0) + BROAD_PAD, 17)
    for shape, placed in ((load.a, a), (load.b, b)):
        size = bounding_radius(shape.kind, shape.size)
        off = [sm.sympify(x) for x in shape.offset]
        if shape.body >= 0 and all(x.is_Number for x in off):
            centres.append(poses.origin(shape.body))
            size += math.sqrt(sum(float(x) ** 2 for x in off))
        else:
            centres.append(placed["centre"])
        reach += sm.Float(size, 17)
    d2 = sum(((centres[0][k] - centres[1][k]) ** 2 for k in range(3)), sm.S.Zero)
    return d2 - reach ** 2


def pair_guards(found, slopes=False):
    """[(clearance, exports, inner guards)] (compiler/emit/guards.py) of the pairs' broad phase:
    ``found`` [(pair key, clearance, exports, depth, (slope exports, outer exports))] as
    :meth:`PairLoad.lower` appends them, one per contact point; the points of one pair (box–box:
    88) share its clearance, and inside, each point's law is guarded by its own depth (-δ > 0: its
    force is ±0).  ``slopes`` (NAME_implicit's guards): the points' slopes are exported with their
    forces, and their δ and p by the pair's guard (they read 0 where it skips the pair)."""
    by_pair = {}
    for key, clearance, exports, depth, (kc, outer) in found:
        entry = by_pair.setdefault(key, (clearance, [], []))
        entry[1].append((-depth, exports + (kc if slopes else ()), ()))
        entry[2].extend(outer if slopes else ())
    out = []
    for clearance, inner, outer in by_pair.values():
        inner = [g for g in inner if g[1]]
        exports = tuple(s for _, ex, _ in inner for s in ex) + tuple(outer)
        if exports:
            out.append((clearance, exports, tuple(inner)))
    return out


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
    mut: float = None          # torsional friction (MJCF condim 4, 6), m; None: none (.law.spin_moment)
    mur: float = None          # rolling friction (condim 6), m
    rho: float = None          # their regularisation length (m): ω_s = v_s/rho


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
        spin = {key: value for key, value in (("mut", spec.mut), ("mur", spec.mur)) if value is not None}
        values.update(spin)
        if spin and not (spec.rho and spec.rho > 0):
            raise ModelError(f"contact {spec.name!r}: torsional or rolling friction needs a size rho > 0, "
                             f"not {spec.rho!r}")
        for key, value in values.items():
            try:
                check_value(spec.name, key, value)
            except ValueError as exc:
                raise ModelError(str(exc)) from None
        syms, base = _symbols(spec.name, False, taken, spin)
        params = law_symbols(syms, values, fold, parameters, taken)
        if spin:
            params["rho"] = sm.Float(float(spec.rho), 17)
        a, b = (spec.a, spec.b) if spec.b.body >= 0 else (spec.b, spec.a)     # b moves: the load's body
        for part in pair_parts(a.kind, b.kind):        # several contact points: <name>_<part>, one law
            label = base if part < 0 else f"{base}_{part}"
            loads.append(PairLoad(label, a, b, params, float(spec.margin), index, part))
            for kind, what in enumerate(OUTPUT_KINDS):
                outputs[f"{what}_{label}"] = PairValue(index, kind)
            for k, what in enumerate(POINT_KINDS):
                outputs[f"{what}_{label}"] = PairValue(index, CLIP_KIND + 1 + k)
            events[f"contact_{label}"] = PairValue(index, OUTPUT_KINDS.index("depth"))
            events[f"clip_{label}"] = PairValue(index, CLIP_KIND)
            index += 1
    new = type(built).__new__(type(built))
    new.__dict__.update(built.__dict__)
    new.tree = dataclasses.replace(built.tree, loads=tuple(loads))
    new.parameters = parameters
    return new, outputs, events


def _slope_outputs(p, n, depth, body_a, body_b, params, let):
    """The slopes routine's outputs at one contact point (.narrow, SLOPES_RID): v_rel, K, C (rows)."""
    vrel, K, C = law_slopes(n, depth, _velocity_at(body_a, p, let), _velocity_at(body_b, p, let), params, let)
    return list(vrel) + [x for row in K for x in row] + [x for row in C for x in row]


def _law_spin_outputs(p, n, depth, body_a, body_b, params, let):
    """The spinning law routine's outputs at one contact point (.narrow, LAW_SPIN_RID): those of
    :func:`_law_outputs`, the torsional and rolling friction moment (.law.spin_moment, of B's angular
    velocity relative to A's) added to B's wrench and taken from A's, as :meth:`PairLoad.lower` adds
    it inlined.  A body of zeros (the world's, in the table's loop) turns with ω = 0."""
    fn, ft, f, rate, _ = _law(n, depth, _velocity_at(body_a, p, let), _velocity_at(body_b, p, let), params, let)
    wa, wb = ([let(sum((body[1][r][k] * body[2][r] for r in range(3)), sm.S.Zero)) for k in range(3)]
              for body in (body_a, body_b))
    moment = spin_moment([wb[k] - wa[k] for k in range(3)], n, fn, params, let)
    out = []
    for body, sign, force in ((body_b, 1, f), (body_a, -1, [-x for x in f])):
        wrench = _wrench(body, force, p, let)
        turn = [sum((body[1][r][k] * moment[k] for k in range(3)), sm.S.Zero) for r in range(3)]
        out += [let(wrench[r] + sign * turn[r]) for r in range(3)] + wrench[3:]
    return out + [fn, *ft, clip_switch(depth, params["c"], rate)]


nw.use_schemes(_scheme_outputs, _law_outputs, _slope_outputs, _law_spin_outputs)
