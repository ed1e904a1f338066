"""Which body-body pairs passed into each other during a run: a part of the run's verdict.

One job: read the shapes of the model's body-body pairs (NAME.json ``pair_check``, written for an
MJCF model's pairs: per geom its kind, size and place in its body's frame, or in the world;
eomc.compiler.mjcf.model._pair_check), place them along the run's rows with the generated
``NAME_poses``, and name every pair one of whose shapes went deeper into the other than
:data:`PASS_FRACTION` of its own inner size (the radius of the largest ball about its core, below)
-- at a row, or between two rows along the straight path of its centre relative to the other shape.

Why: a pair's law sees the overlap only at the points it samples (box-box: 88, cylinder pairs 33,
capsule-box the nearest of 14 candidates), and every integrator sees it only at the states it
steps to.  So a law that misses an overlap, or a step longer than a thin shape, lets two bodies
pass through each other with status 0 and no warning: session 19's old box-box law dropped a
tower of three boxes yawed 30 deg through each other to the floor, and a box thrown fast at a
thin plate crosses it between two fixed steps (issue 29 item 1).  The ground's own verdict
(runtime/ground_check.py, switching.verdict) never looks at two bodies.

The measure is independent of the law's sampling.  Each shape X has a *core* (a sphere's, box's,
cylinder's and ellipsoid's centre; a capsule's segment) and an inner size ρ_X: the radius of the
largest ball about every point of its core that lies in X (sphere and capsule r, box its smallest
half size, cylinder min(r, h), ellipsoid its smallest semi-axis).  When the core comes within
s < ρ_X of the other shape Y (s = Y's signed distance, exact for a sphere, capsule, box and
cylinder; an upper bound for an ellipsoid), that ball alone overlaps Y by ρ_X − s, so the two
shapes overlap by at least that: more than PASS_FRACTION·ρ_X when s < (1 − PASS_FRACTION)·ρ_X.
That bound never exceeds the true overlap, so a resting or pressed pair within its law is never
named (a sphere resting on a box is named when it sinks more than half its radius, as a ground
sphere is).  Between two rows the centre's path relative to Y is taken as the straight line
between its two places in Y's frame (the rows of a fixed step are its steps; of an adaptive
method, the output grid: ``n_points``/``t_eval``), and its closest approach to Y is found exactly
(a sphere, capsule) or by golden section (box, cylinder: their signed distance is convex along a
line).  A row where the pair's bodies turn far relative to each other bends that path; the chord
then errs by its sagitta, R·θ²/8 -- but for a sphere Y, whose turn changes no distance: its path is
taken in world axes about its centre (:func:`_round_axes`).

Cost: one ``NAME_poses`` call per row and numpy over the pairs, after the run (none in the rhs or
in a step); measured in benchmarks/results/pair_check.md.  A sphere or capsule pair is not placed
along every row: its law's own depth output, which simulate computes along the rows anyway, is the
measure (D = r_a + r_b - depth is the cores' distance, exactly; less the pair's margin, found once
against the placed shapes), and its paths between rows are measured only where the frames' moves
and turns between the two rows allow a crossing (:func:`_round_hits`).
"""
import numpy as np

__all__ = ["passed_through", "pair_overlaps", "PASS_FRACTION", "inner_size", "signed_distance",
           "segment_min_distance", "bounding_radius"]

PASS_FRACTION = 0.5      # of the shape's inner size: the ground's contact spheres' PENETRATION_FRACTION
GOLDEN_STEPS = 48        # golden-section steps on [0, 1]: 0.618^48 = 1e-10 of the segment


def inner_size(kind, size):
    """The radius of the largest ball about each point of the shape's core that lies in it."""
    size = [float(x) for x in size]
    if kind in ("sphere", "capsule"):
        return size[0]
    if kind == "box":
        return min(size[:3])
    if kind == "cylinder":
        return min(size[0], size[1])
    if kind == "ellipsoid":
        return min(size[:3])
    raise ValueError(f"no inner size of a {kind}")


def _norm(v):
    return np.sqrt(np.einsum("...i,...i->...", v, v))


def _sizes(size):
    """A shape's sizes as an array whose last axis is MuJoCo's size (per element when 2-D)."""
    return np.asarray(size, dtype=float)


def signed_distance(kind, size, x):
    """(...,) the signed distance of points x (..., 3) in the shape's own frame from its surface
    (< 0 inside); exact but for an ellipsoid, whose value is an upper bound (outside: the distance
    to the surface point on the ray from the centre; inside: minus the radius of the ball about x
    that the ellipsoid holds, smallest semi-axis times 1 - |x/a|).  ``size``: MuJoCo's, or an
    array of them (last axis) broadcast with x's leading axes."""
    x = np.asarray(x, dtype=float)
    size = _sizes(size)
    if kind == "sphere":
        return _norm(x) - size[..., 0]
    if kind == "capsule":
        z = np.clip(x[..., 2], -size[..., 1], size[..., 1])
        return np.sqrt(x[..., 0] ** 2 + x[..., 1] ** 2 + (x[..., 2] - z) ** 2) - size[..., 0]
    if kind == "box":
        q = np.abs(x) - size[..., :3]
        return _norm(np.maximum(q, 0.0)) + np.minimum(np.max(q, axis=-1), 0.0)
    if kind == "cylinder":
        q = np.stack([np.hypot(x[..., 0], x[..., 1]) - size[..., 0], np.abs(x[..., 2]) - size[..., 1]], axis=-1)
        return _norm(np.maximum(q, 0.0)) + np.minimum(np.max(q, axis=-1), 0.0)
    if kind == "ellipsoid":
        a = size[..., :3]
        s = _norm(x / a)
        with np.errstate(divide="ignore", invalid="ignore"):
            out = np.where(s >= 1.0, _norm(x) * (1.0 - 1.0 / np.maximum(s, 1.0)), -np.min(a, axis=-1) * (1.0 - s))
        return out
    raise ValueError(f"no signed distance of a {kind}")


def _segments(p0, p1, q0, q1):
    """(...,) the distance between segments p0-p1 and q0-q1 (Ericson's clamped solution)."""
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    a = np.einsum("...i,...i->...", d1, d1)
    e = np.einsum("...i,...i->...", d2, d2)
    f = np.einsum("...i,...i->...", d2, r)
    c = np.einsum("...i,...i->...", d1, r)
    b = np.einsum("...i,...i->...", d1, d2)
    tiny = 1e-300
    with np.errstate(divide="ignore", invalid="ignore"):
        pa = a > tiny                   # p a segment (else a point)
        qa = e > tiny
        a_, e_ = np.where(pa, a, 1.0), np.where(qa, e, 1.0)
        denom = a * e - b * b
        apart = denom > 1e-14 * np.maximum(a * e, tiny)        # not parallel
        s = np.where(apart, np.clip((b * f - c * e) / np.where(denom > 0, denom, 1.0), 0, 1), 0.0)
        s = np.where(qa, s, np.clip(-c / a_, 0, 1))      # q a point
        s = np.where(pa, s, 0.0)                          # p a point
        t = np.where(qa, (b * s + f) / e_, 0.0)
        s = np.where(t < 0, np.where(pa, np.clip(-c / a_, 0, 1), 0.0), s)
        s = np.where(t > 1, np.where(pa, np.clip((b - c) / a_, 0, 1), 0.0), s)
        t = np.clip(t, 0, 1)
    return _norm(r + d1 * s[..., None] - d2 * t[..., None])


def bounding_radius(kind, size):
    """The radius of the smallest ball about the shape's centre that holds it (per element for an
    array of sizes)."""
    size = _sizes(size)
    if kind == "sphere":
        return size[..., 0]
    if kind == "capsule":
        return size[..., 0] + size[..., 1]
    if kind == "box":
        return _norm(size[..., :3])
    if kind == "cylinder":
        return np.hypot(size[..., 0], size[..., 1])
    if kind == "ellipsoid":
        return np.max(size[..., :3], axis=-1)
    raise ValueError(f"no bounding radius of a {kind}")


def segment_min_distance(kind, size, p0, p1, below=None):
    """(...,) the least signed distance from the shape (its frame) along segments p0-p1 (..., 3):
    exact for a sphere and a capsule, golden section for the others (a box's and a cylinder's signed
    distance is convex along a line; the ellipsoid's bound is taken at the points it evaluates).
    ``size`` as :func:`signed_distance`'s.  ``below`` (a number or per element): only values under
    it are wanted; where the segment's distance from the shape's bounding ball is at least
    ``below``, that lower bound stands in (no golden section there)."""
    p0, p1 = np.asarray(p0, dtype=float), np.asarray(p1, dtype=float)
    size = _sizes(size)
    o = np.zeros(3)
    if kind == "sphere":
        return _segments(p0, p1, o, o) - size[..., 0]
    if kind == "capsule":
        h = size[..., 1, None] * np.array([0.0, 0.0, 1.0])
        return _segments(p0, p1, -h, h) - size[..., 0]
    shape = np.broadcast_shapes(p0.shape[:-1], p1.shape[:-1], size.shape[:-1])
    if below is not None:
        bound = _segments(p0, p1, o, o) - bounding_radius(kind, size)
        near = np.broadcast_to(bound < below, shape)
        if not np.all(near):
            out = np.array(np.broadcast_to(bound, shape), dtype=float)
            if np.any(near):
                grow = lambda v: np.broadcast_to(v, shape + v.shape[-1:])[near]     # noqa: E731
                out[near] = segment_min_distance(kind, grow(size), grow(p0), grow(p1))
            return out
    d = p1 - p0
    f = lambda s: signed_distance(kind, size, p0 + d * s[..., None])      # noqa: E731
    lo, hi = np.zeros(shape), np.ones(shape)
    g = (np.sqrt(5.0) - 1.0) / 2.0
    x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
    f1, f2 = f(x1), f(x2)
    best = np.minimum(np.minimum(f(lo), f(hi)), np.minimum(f1, f2))
    for _ in range(GOLDEN_STEPS):
        left = f1 < f2                  # the minimum lies in [lo, x2]
        hi = np.where(left, x2, hi)
        lo = np.where(left, lo, x1)
        x2n = np.where(left, x1, lo + g * (hi - lo))
        x1n = np.where(left, hi - g * (hi - lo), x2)
        fx = f(np.where(left, x1n, x2n))
        f2, f1 = np.where(left, f1, fx), np.where(left, fx, f2)
        x1, x2 = x1n, x2n
        best = np.minimum(best, np.minimum(f1, f2))
    return best


def _placed(entry, poses, frames):
    """(centres (n, 3), rotations (n, 3, 3): shape axes in world components) of a shape along the
    rows, or None when its frame is not among the poses'."""
    pos = np.asarray(entry["pos"], dtype=float)
    rot = np.asarray(entry["rot"], dtype=float).reshape(3, 3)
    n = poses.positions.shape[0]
    if entry.get("frame") is None:
        return np.broadcast_to(pos, (n, 3)), np.broadcast_to(rot, (n, 3, 3))
    if entry["frame"] not in frames:
        return None
    i = frames.index(entry["frame"])
    R = poses.rotations[:, i, :, :]
    return poses.positions[:, i, :] + R @ pos, R @ rot


def pair_overlaps(shape_x, shape_y, cx, Rx, cy, Ry, fraction=PASS_FRACTION, pruned=True):
    """How X went into Y along rows of centres c (n, 3) and rotations R (n, 3, 3) (shape axes, world):
    (at rows (n,), between rows (n - 1,)) -- the least signed distance from Y of X's core at each
    row and of X's centre's straight path between rows, less (1 - fraction) of X's inner size:
    < 0 where X overlaps Y by more than ``fraction`` of its inner size (the module docstring); a
    value >= 0 may be a lower bound (segment_min_distance's ``below``) unless ``pruned`` is False."""
    ky, sy = shape_y["kind"], shape_y["size"]
    allow = (1.0 - fraction) * inner_size(shape_x["kind"], shape_x["size"])
    below = allow if pruned else None
    Ry = _round_axes(Ry, ky == "sphere")
    local = np.einsum("nji,nj->ni", Ry, cx - cy)         # X's centre in Y's frame
    if shape_x["kind"] == "capsule":
        h = float(shape_x["size"][1])
        axis = np.einsum("nji,nj->ni", Ry, Rx[:, :, 2])
        rows = segment_min_distance(ky, sy, local - h * axis, local + h * axis, below)
    else:
        rows = signed_distance(ky, sy, local)
    between = segment_min_distance(ky, sy, local[:-1], local[1:], below) if len(local) > 1 else np.zeros(0)
    return rows - allow, between - allow


def passed_through(model, t, X, p, fraction=PASS_FRACTION, outputs=None):
    """Notes naming each pair one of whose shapes went into the other by more than ``fraction`` of
    its inner size along the run's rows (t, X), with when and how far; [] when the model has no
    ``pair_check`` or no ``poses``.  A broad phase over all pairs at once (:func:`_candidates`)
    leaves the exact measure (:func:`_hits`, all the pairs it keeps at once) the pairs whose
    bounding balls come that near.  ``outputs`` (the run's {output: values along the rows}, as
    simulate's): a sphere and capsule pair whose law's ``depth_PAIR`` output is there is judged from
    it (:func:`_round_hits`: the law's depth is exact for these shapes), its paths between rows
    measured only where the shapes' moves between the rows allow a crossing."""
    meta = model.metadata.get("pair_check")
    if not isinstance(meta, dict) or not meta.get("pairs") or "poses" not in model.functions:
        return []
    X = np.asarray(X, dtype=float)
    t = np.asarray(t, dtype=float)
    if X.ndim != 2 or len(X) == 0 or not np.all(np.isfinite(X)):
        return []
    from .poses import evaluate_poses
    ready = _prepared(model, meta, fraction)
    if ready is None:
        return []
    pairs, geoms, ga, gb, fi, pos, rot, size, bound, half, allow = ready
    kinds = [s["kind"] for s in geoms]
    p = None if p is None else np.asarray(p, dtype=float)[:model.nparam]
    poses = evaluate_poses(model, t, X, p)
    n = len(t)
    centres = lambda rows: _centres(poses, rows, fi, pos)     # noqa: E731  (shapes' centres where needed)
    hits = [None] * (2 * len(pairs))        # pair k: shape a into b at k, b into a at k + len(pairs)
    cols, depth, known = _round_depths(model, pairs, kinds, ga, gb, outputs, n)
    if cols.size:
        known = known.setdefault(None if p is None else p.tobytes(), {})
        cols, depth = _verified(centres, poses, cols, depth, ga, gb, kinds, size, half, allow, fi, rot, known)
    rest = np.ones(len(pairs), dtype=bool)      # the pairs no law's depth judged (a mask: setdiff1d's sort
    rest[cols] = False                          # cost 30 us of a run's ~1 ms at loose tolerances)
    rest = np.flatnonzero(rest)
    if cols.size:
        _round_hits(hits, len(pairs), centres, poses, cols, depth, ga, gb, kinds, size, half, allow, fi, pos,
                    rot)
    if rest.size:
        C, R = _centres(poses, slice(None), fi, pos, rot)
        near = rest[_candidates(C, R, ga[rest], gb[rest], bound, half, allow)]
        if near.size:
            got = _hits(C, R, np.concatenate([ga[near], gb[near]]), np.concatenate([gb[near], ga[near]]),
                        kinds, size, half, allow)
            for j, k in enumerate(near):
                hits[k], hits[k + len(pairs)] = got[j], got[j + len(near)]
    notes = []
    for k in sorted({e % len(pairs) for e, h in enumerate(hits) if h is not None}):
        pair, worst = pairs[k], None       # worst: (time index, between?, how far, x, y)
        for e, xy in ((k, (0, 1)), (k + len(pairs), (1, 0))):
            if hits[e] is not None and (worst is None or hits[e][0] + 0.5 * hits[e][1] < worst[0] + 0.5 * worst[1]):
                worst = hits[e] + xy
        if worst is not None:
            notes.append(_note(pair, t, worst, fraction))
    return notes


def _centres(poses, rows, fi, pos, rot=None):
    """(len(rows), shapes, 3): each shape's centre in the world at the given rows (index array or
    slice; a world shape's: fixed); with ``rot``, also (len(rows), shapes, 3, 3) its axes."""
    moving = fi >= 0
    f = fi[moving]
    Rf, pm = poses.rotations[rows][:, f], pos[moving]
    C = np.empty(Rf.shape[:1] + (len(fi), 3))
    C[:, moving] = poses.positions[rows][:, f] + Rf[..., 0] * pm[:, 0, None] + Rf[..., 1] * pm[:, 1, None] \
        + Rf[..., 2] * pm[:, 2, None]
    C[:, ~moving] = pos[~moving]
    if rot is None:
        return C
    R = np.empty(Rf.shape[:1] + (len(fi), 3, 3))
    R[:, moving] = Rf @ rot[moving]
    R[:, ~moving] = rot[~moving]
    return C, R


def _axes(poses, rows, fi, rot):
    """(len(rows), shapes, 3, 3): each shape's axes in world components at the given rows."""
    moving = fi >= 0
    R = np.empty((len(rows), len(fi), 3, 3))
    R[:, moving] = poses.rotations[rows][:, fi[moving]] @ rot[moving]
    R[:, ~moving] = rot[~moving]
    return R


ROUND = ("sphere", "capsule")
# the law's depth output (less its margin) and the placed shapes' measure must agree this closely at the
# rows checked (_verified): they agree to ~1e-15 (tests/runtime/test_pair_check.py)
DEPTH_AGREE = 1e-9
MOVED = 1e-6        # m: the least span of a pair's measure over the rows checked that proves its law


def _round_depths(model, pairs, kinds, ga, gb, outputs, n):
    """(pair indices, (n, their count) depth outputs) of the sphere and capsule pairs whose law's
    ``depth_PAIR`` output is among ``outputs``, finite, one value a row."""
    got = getattr(model, "_pair_check_round", None)
    if got is None or got[0] is not pairs:
        got = (pairs, [(k, f"depth_{pair['name']}") for k, pair in enumerate(pairs)
                       if kinds[ga[k]] in ROUND and kinds[gb[k]] in ROUND], {})
        try:
            model._pair_check_round = got
        except AttributeError:
            pass
    cols, values = [], []
    if outputs:
        for k, key in got[1]:
            v = outputs.get(key)
            if isinstance(v, np.ndarray) and v.shape == (n,):
                cols.append(k)
                values.append(v)
    if not cols:
        return np.zeros(0, dtype=int), None, got[2]
    depth = np.array(values, dtype=float).T
    ok = np.all(np.isfinite(depth), axis=0)
    return np.asarray(cols, dtype=int)[ok], depth[:, ok], got[2]


def _verified(centres, poses, cols, depth, ga, gb, kinds, size, half, allow, fi, rot, known):
    """The pairs and their depth columns, less a constant (the pair's margin: MuJoCo's law reads
    depth = r_a + r_b + margin - D), whose depth output is the placed shapes' measure at the run's
    ends and at the rows of its least and greatest depth: r_a - depth - (1 - f) rho_a == the signed
    distance of a's core from b less (1 - f) rho_a, with the same constant at every row checked (a
    pair that does not agree is left to the exact search).  ``known`` (kept on the model per
    parameter vector): {pair: (its constant, or None when it did not agree; proven)}: a pair is
    checked on the first run that has its depth, and again on a later run where its depth spans more
    than MOVED if it was still when checked (its measure at the rows checked spanned no more than
    MOVED: such rows prove no law, but serve a run whose depth stays within MOVED)."""
    key = ("all", cols.tobytes())
    fast = known.get(key)           # (constants, agreed, still): these columns checked on a run before
    if fast is not None and not (fast[2].size and np.any(np.ptp(depth[:, fast[2]], axis=0) > MOVED)):
        return cols[fast[1]], depth[:, fast[1]] + fast[0][fast[1]]
    # to check: a pair not seen, or seen still (its constant unproven) and moving in this run
    new = np.array([k not in known or (not known[k][1] and np.ptp(depth[:, i]) > MOVED)
                    for i, k in enumerate(cols.tolist())], dtype=bool)
    if new.any():
        n, j = depth.shape[0], np.flatnonzero(new)
        rr = np.stack([np.zeros(len(j), dtype=int), np.full(len(j), n - 1),          # (4, pairs): the ends
                       np.argmin(depth[:, j], axis=0), np.argmax(depth[:, j], axis=0)])  # and the extremes
        rows = np.unique(rr)
        Cs, Rs = centres(rows), _axes(poses, rows, fi, rot)
        a, b = ga[cols[j]], gb[cols[j]]
        r = np.searchsorted(rows, rr).ravel()
        at, _ = _measure(Cs, Rs, r, np.tile(a, 4), np.tile(b, 4), kinds, size, half, allow, r1=r)
        law = size[a, 0] - depth[rr, j] - allow[a]
        at = at.reshape(4, -1)
        shift = law - at                                       # the margin, at each row checked
        good = np.all(np.abs(shift - shift[0]) <= DEPTH_AGREE * (1.0 + np.abs(law)), axis=0)
        moved = np.ptp(at, axis=0) > MOVED                     # a still pair's rows prove no law
        for k, g, v, m in zip(cols[j].tolist(), good, shift[0], moved):
            known[k] = (float(v) if g else None, bool(m or not g))
    shift = np.array([np.nan if known[k][0] is None else known[k][0] for k in cols.tolist()])
    good = np.isfinite(shift)
    still = np.flatnonzero([not known[k][1] for k in cols.tolist()])
    known[key] = (shift, good, still)
    return cols[good], depth[:, good] + shift[good]


def _round_hits(hits, npairs, centres, poses, cols, depth, ga, gb, kinds, size, half, allow, fi, pos, rot):
    """Fill ``hits`` (as :func:`_hits`' entries) for sphere and capsule pairs ``cols`` from their laws'
    depth (n, len(cols)).  At a row: a's core is within (1 - f) rho_a of b where r_a - depth <
    (1 - f) rho_a (exact).  Between rows k and k + 1: the cores' distance D = r_a + r_b - depth,
    so a's centre is at least D - r_b from b at both rows; its path in b's frame is at most
    L = m_a + m_b + |R_b,k+1 - R_b,k|_F |d_k| long (m: a bound on a centre's move in the world, its
    frame origin's move plus the frame's turn times the centre's distance from it; d_k = c_a - c_b,
    |d_k| <= D_k + h_a + h_b), and a signed distance changes by at most the move, so the path
    keeps (D_k + D_k+1 - 2 r_b - L)/2 from b: the exact path measure (:func:`_measure`) runs only
    where that falls below (1 - f) rho_a (either way round) -- first per pair with the run's extremes,
    then per row."""
    n = depth.shape[0]
    a, b = ga[cols], gb[cols]
    ra, rb = size[a, 0], size[b, 0]
    top = depth.max(axis=0)
    for j in np.flatnonzero(top > np.minimum(ra - allow[a], rb - allow[b])):
        for x, r, e in ((a[j], ra[j], cols[j]), (b[j], rb[j], cols[j] + npairs)):
            m = r - depth[:, j] - allow[x]
            bad = np.flatnonzero(m < 0)
            if bad.size:
                hits[e] = (int(bad[0]), False, float(m[bad[0]]))
    if n < 2:
        return
    rsum, hsum = ra + rb, half[a] + half[b]
    need = 2.0 * np.maximum(allow[a] + rb, allow[b] + ra) * (1.0 + 1e-9) + 1e-12
    # per frame between rows: its origin's move and its turn |R_k+1 - R_k|_F; a shape's centre (at pos in
    # its frame) moves at most the origin's move plus the turn times |pos|
    dp = poses.positions[1:] - poses.positions[:-1]
    shift = np.sqrt(dp[..., 0] ** 2 + dp[..., 1] ** 2 + dp[..., 2] ** 2)        # (n - 1, frames)
    rf = poses.rotations.reshape(n, -1, 9)
    dr = rf[1:] - rf[:-1]
    spin = np.sqrt(np.einsum("nfk,nfk->nf", dr, dr))
    moving, f = fi >= 0, np.maximum(fi, 0)
    lever = np.sqrt(np.sum(pos ** 2, axis=1))
    mt = np.where(moving, shift.max(axis=0)[f] + spin.max(axis=0)[f] * lever, 0.0)     # per shape, the run's most
    tt = np.where(moving, spin.max(axis=0)[f], 0.0)
    near_min, near_max = rsum - top, rsum - depth.min(axis=0)           # D's extremes per pair
    wide = 2.0 * near_min - (mt[a] + mt[b]) - np.maximum(tt[a], tt[b]) * (near_max + hsum)
    js = np.flatnonzero(wide < need)
    if not js.size:
        return
    aj, bj = a[js], b[js]
    g = np.unique(np.concatenate([aj, bj]))                              # the shapes of the pairs kept
    move = np.zeros((n - 1, len(fi)))
    turn = np.zeros((n - 1, len(fi)))
    gm = g[moving[g]]
    turn[:, gm] = spin[:, fi[gm]]
    move[:, gm] = shift[:, fi[gm]] + turn[:, gm] * lever[gm]
    D = rsum[js] - depth[:, js]                                          # (n, pairs kept)
    keep = (D[:-1] + D[1:] - (move[:, aj] + move[:, bj])
            - np.maximum(turn[:, aj], turn[:, bj]) * (D[:-1] + hsum[js]) < need[js])
    k, jj = np.nonzero(keep)
    if not k.size:
        return
    rows = np.unique(np.concatenate([k, k + 1]))
    Cs, Rs = centres(rows), _axes(poses, rows, fi, rot)
    rk, rk1 = np.searchsorted(rows, k), np.searchsorted(rows, k + 1)
    xs, ys = np.concatenate([aj[jj], bj[jj]]), np.concatenate([bj[jj], aj[jj]])
    _, path = _measure(Cs, Rs, np.concatenate([rk, rk]), xs, ys, kinds, size, half, allow,
                       r1=np.concatenate([rk1, rk1]))
    e = np.concatenate([cols[js][jj], cols[js][jj] + npairs])
    kk = np.concatenate([k, k])
    for i in np.flatnonzero(path < 0):
        got, old = (int(kk[i]), True, float(path[i])), hits[e[i]]
        if old is None or got[0] + 0.5 < old[0] + 0.5 * old[1]:
            hits[e[i]] = got


def _prepared(model, meta, fraction):
    """(pairs, their shapes once each (geoms) and per pair its two shapes' indices, and per shape:
    its poses frame index (-1: the world), centre and axes in that frame, MuJoCo size (3), bounding
    radius, a capsule's half length (else 0) and (1 - fraction) of its inner size), kept on the
    model; None when no pair's frames are among the poses'."""
    key = ("pair_check", fraction)
    got = getattr(model, "_pair_check_prepared", None)
    if got is not None and got[0] == key:
        return got[1]
    from .poses import pose_layout
    frames = list(pose_layout(model)[0])
    pairs = [pair for pair in meta["pairs"]
             if all(s.get("frame") is None or s["frame"] in frames for s in pair["shapes"])]
    out = None
    if pairs:
        index, geoms = {}, []
        for pair in pairs:
            for s in pair["shapes"]:
                key_s = (s["geom"], s.get("frame"))
                if key_s not in index:
                    index[key_s] = len(geoms)
                    geoms.append(s)
        ga = np.array([index[(pr["shapes"][0]["geom"], pr["shapes"][0].get("frame"))] for pr in pairs], dtype=int)
        gb = np.array([index[(pr["shapes"][1]["geom"], pr["shapes"][1].get("frame"))] for pr in pairs], dtype=int)
        fi = np.array([-1 if s.get("frame") is None else frames.index(s["frame"]) for s in geoms], dtype=int)
        pos = np.array([s["pos"] for s in geoms], dtype=float).reshape(-1, 3)
        rot = np.array([s["rot"] for s in geoms], dtype=float).reshape(-1, 3, 3)
        size = np.array([(list(s["size"]) + [0.0, 0.0, 0.0])[:3] for s in geoms], dtype=float)
        half = np.array([float(s["size"][1]) if s["kind"] == "capsule" else 0.0 for s in geoms])
        bound = np.array([bounding_radius(s["kind"], s["size"]) for s in geoms])
        allow = np.array([(1.0 - fraction) * inner_size(s["kind"], s["size"]) for s in geoms])
        out = (pairs, geoms, ga, gb, fi, pos, rot, size, bound, half, allow)
    try:
        model._pair_check_prepared = (key, out)
    except AttributeError:
        pass
    return out


def _candidates(C, R, ga, gb, bound, half, allow):
    """The pairs (indices into ga, gb) whose shapes come near enough for the exact measure to name
    them, all pairs at once: a shape lies in its bounding ball (radius b), so Y's signed distance at
    x is at least |x - c_Y| - b_Y; X's core lies within its half length h_X of c_X.  At a row X's
    core is within (1 - f) rho_X of Y only if |d| < b_Y + h_X + (1 - f) rho_X (d = c_X - c_Y);
    between rows k and k + 1 its centre's path in Y's frame, from P_k = R_k^T d_k to P_k+1, keeps
    |P| >= (|d_k| + |d_k+1| - |P_k+1 - P_k|)/2, and |P_k+1 - P_k| <= |d_k+1 - d_k| + |R_k+1 - R_k|_F |d_k|."""
    d = C[:, ga] - C[:, gb]                            # (n, pairs, 3): first shape's centre less the second's
    dist = _norm(d)
    b0, b1, h0, h1, a0, a1 = bound[ga], bound[gb], half[ga], half[gb], allow[ga], allow[gb]
    near = np.any(dist < np.maximum(b1 + h0 + a0, b0 + h1 + a1), axis=0)
    if len(dist) > 1:
        step = _norm(d[1:] - d[:-1])
        turn = np.sqrt(np.sum((R[1:] - R[:-1]) ** 2, axis=(-2, -1)))      # (n - 1, shapes)
        mid = 0.5 * (dist[:-1] + dist[1:] - step)
        in1 = mid - 0.5 * turn[:, gb] * dist[:-1] < b1 + a0     # the first's centre's path in the second
        in0 = mid - 0.5 * turn[:, ga] * dist[:-1] < b0 + a1     # and the other way
        near |= np.any(in1 | in0, axis=0)
    return np.flatnonzero(near)


def _round_axes(R, ball):
    """Y's axes R (..., 3, 3), the world's where ``ball`` (a sphere Y, (...,) or a bool): a sphere's
    turn changes no distance from it, so X's path between two rows is the straight line in world axes
    about its centre.  Why: in a spinning ball's own frame the straight path is a chord across the
    ball (its sagitta R·θ²/8 is the turn's, not the motion's): dm_control's manipulator, its ball
    spinning at 50.6 rad/s, 2.5 rad between `eomc check`'s rows 0.05 s apart, was named as passing
    through the pommel, whose law's depth shows 0.14 mm at most (first hour s33)."""
    ball = np.asarray(ball, dtype=bool)
    if not ball.any():
        return R
    return np.where(ball[..., None, None], np.eye(3), R)


def _tdot(R, v):
    """R^T v for R (..., 3, 3), v (..., 3), by components (numpy's reductions over an axis of 3 are slow)."""
    return np.stack([R[..., 0, i] * v[..., 0] + R[..., 1, i] * v[..., 1] + R[..., 2, i] * v[..., 2]
                     for i in range(3)], axis=-1)


# rows a block of the coarse-to-fine search (_hits) spans (the humanoid's 335 rows: 2.3 ms at 8, 2.4 at
# 16, 3.0 at 4, 3.3 at 32)
BLOCK = 8


def _hits(C, R, xs, ys, kinds, size, half, allow):
    """For each shape xs[e] into ys[e]: (row, between?, measure) of the first row (or path from a row
    to the next) where the measure (:func:`pair_overlaps`') is < 0, or None.  Coarse to fine: the
    measure at every BLOCK-th row, and within a block only where it may fall below 0 -- a point of X's
    core, c_X + s h_X a_X, moves in Y's frame from a row to the next by at most the move of X's centre
    there plus h_X times the move of its axis a_X there, and a signed distance changes by at most what
    its point moves, so a block whose start's measure exceeds its rows' moves summed (the paths between
    them lie within the same reach) holds no hit."""
    n, K = C.shape[0], len(xs)
    out = [None] * K
    starts = np.arange(0, n, BLOCK)
    g0, _ = _measure(C, R, np.repeat(starts, K), np.tile(xs, len(starts)), np.tile(ys, len(starts)), kinds,
                     size, half, allow)
    g0 = g0.reshape(len(starts), K)
    if n > 1:
        Ry = R[:, ys]
        local = _tdot(Ry, C[:, xs] - C[:, ys])                      # X's centre in Y's frame
        axis = _tdot(Ry, R[..., 2][:, xs]) * half[xs][:, None]      # X's core about it
        move = _norm(local[1:] - local[:-1]) + _norm(axis[1:] - axis[:-1])
        total = np.concatenate([np.zeros((1, K)), np.cumsum(move, axis=0)])
        ends = np.minimum(starts + BLOCK, n - 1)
        reach = total[ends] - total[starts]                                    # (blocks, K)
    else:
        reach = np.zeros_like(g0)
    b, e = np.nonzero(g0 - reach <= 0.0)
    if b.size:
        first = starts[b]
        count = np.minimum(first + BLOCK, n) - first
        r = np.repeat(first, count) + (np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count))
        ee = np.repeat(e, count)
        at, path = _measure(C, R, r, xs[ee], ys[ee], kinds, size, half, allow)
        for bad, mid in ((at, False), (path, True)):
            for k in np.flatnonzero(bad < 0):
                got = (int(r[k]), mid, float(bad[k]))
                old = out[ee[k]]
                if old is None or got[0] + 0.5 * mid < old[0] + 0.5 * old[1]:
                    out[ee[k]] = got
    return out


def _measure(C, R, r, xs, ys, kinds, size, half, allow, r1=None):
    """:func:`pair_overlaps`' measure of shape xs[m] into ys[m] at row r[m] and on its centre's path
    from row r[m] to r[m] + 1 (inf past the last row), for flat index arrays (C, R (n, G, 3[, 3]): the
    shapes' centres and axes along the rows), grouped by Y's kind (a sphere as a capsule of half length
    0: one segment-segment distance for the row and the path).  ``r1``: the rows the paths end at
    (default r + 1; a path with r1 == r is none: inf)."""
    n, M = C.shape[0], len(r)
    at, path = np.empty(M), np.full(M, np.inf)
    r1 = np.minimum(r + 1, n - 1) if r1 is None else np.asarray(r1)
    ykind = np.array(["capsule" if kinds[y] == "sphere" else kinds[y] for y in ys])
    for ky in np.unique(ykind):
        m = np.flatnonzero(ykind == ky)
        x, y, k, k1 = xs[m], ys[m], r[m], r1[m]
        sy, a = size[y], allow[x]
        ball = np.array([kinds[j] == "sphere" for j in y], dtype=bool)
        Ryk, Ryk1 = _round_axes(R[k, y], ball), _round_axes(R[k1, y], ball)
        local = _tdot(Ryk, C[k, x] - C[k, y])                  # X's centre in Y's frame, at r and at r + 1
        local1 = _tdot(Ryk1, C[k1, x] - C[k1, y])
        axis = _tdot(Ryk, R[k, x][..., 2]) * half[x][:, None]          # X's core: local -/+ axis (0: a point)
        last = k1 == k
        if ky == "capsule":
            hy = half[y][:, None] * np.array([0.0, 0.0, 1.0])
            got = _segments(np.concatenate([local - axis, local]), np.concatenate([local + axis, local1]),
                            np.concatenate([-hy, -hy]), np.concatenate([hy, hy])) - np.concatenate([sy[:, 0] + a] * 2)
            at[m], path[m] = got[:len(m)], np.where(last, np.inf, got[len(m):])
            continue
        g = signed_distance(ky, sy, local)
        cap = half[x] > 0                               # a capsule's core: its segment
        if cap.any():
            g[cap] = segment_min_distance(ky, sy[cap], local[cap] - axis[cap], local[cap] + axis[cap], a[cap])
        at[m] = g - a
        path[m] = np.where(last, np.inf, segment_min_distance(ky, sy, local, local1, a) - a)
    return at, path


def _note(pair, t, worst, fraction):
    k, mid, excess, x, y = worst
    sx, sy = pair["shapes"][x], pair["shapes"][y]
    rho = inner_size(sx["kind"], sx["size"])
    depth = (1.0 - fraction) * rho - excess         # how near Y's surface X's core came (< 0: inside)
    other = f"{sy['kind']} {sy['geom']}"
    where = f"{-depth:.3g} m inside {other}" if depth < 0 else f"within {depth:.3g} m of the surface of {other}"
    if mid:
        what = (f"between t = {float(t[k]):.4g} and {float(t[k + 1]):.4g}: the centre of {sx['kind']} {sx['geom']}, "
                f"on its straight path relative to {other} between these two rows, came {where}")
    else:
        core = "axis" if sx["kind"] == "capsule" else "centre"
        what = f"at t = {float(t[k]):.4g}: the {core} of {sx['kind']} {sx['geom']} came {where}"
    return (f"bodies {sx['body']} and {sy['body']} passed into each other (pair {pair['name']}) {what}, so they "
            f"overlapped by more than {fraction:g} of {sx['geom']}'s inner size {rho:.3g} m: the pair's contact is "
            f"too soft for the load, or its law or the run's steps missed the overlap (a step too long for the "
            f"speed: a shorter dt or a tighter rtol)")
