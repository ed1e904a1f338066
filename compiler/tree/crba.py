"""Composite-rigid-body algorithm run once on symbols: the mass matrix M entry by entry.

Two forms, the same M.  :func:`crba` is Featherstone's in body frames: each column's force
F = Ic S is carried up the tree joint by joint (one force transform per level) and dotted
with each ancestor's axis.  :func:`crba_world` carries each column's force to the world once
and dots it with the ancestors' axes in the world (their screws), where the tree is already
placed in the world (NAME_implicit: the contacts' placement and the screws it outputs
anyway).

Why the world form there: a column's walk up the tree is a chain of dependent transforms
(about 40 operations a level), and every composite inertia is turned through every joint,
massless joint frames included; in the world a massless frame adds nothing and each entry is
one independent 6-dot.  NAME_implicit takes whichever form has fewer operations
(:func:`implicit_mass_matrix`).  Measured (benchmarks/results/world_crba.md, the fixed step's
loop): gymnasium humanoid 6499 -> 4063 operations, 5 % off its simulated second; G1 2 %,
hopper and walker2d 1.5 %; the ant keeps the body-frame form (1965 against 2324).

Armature adds a to its joint's diagonal entry (see :mod:`.aba`).
"""
from ..ir.opcount import count_ops
from ..ir.program import needed_assignments
from .construct import _add, _mul
from .spatial import _cross, _dot, _sym6_plus, _times, xt_force, xt_inertia_x

__all__ = ["crba", "crba_world", "form_operations", "implicit_mass_matrix", "world_screws"]

# An ancestor with at least this many axes on one body (a free joint's six) takes a column's
# force in its own frame (one transform, then each entry a component's product) rather than a
# world 6-dot per axis.
_FRAME_AXES = 3


def _columns(b):
    if b.S is not None:
        return [(b.speed, b.S)]
    return list(b.multi or ())


def _bodies_up(bodies, rec):
    """(i, the body's composite inertia Ic: its subtree's, body frame about its origin, named),
    leaves first; each body's Ic is added into its parent's before the parent is reached."""
    Ic = [[row[:] for row in b.I] for b in bodies]
    for i in reversed(range(len(bodies))):
        b = bodies[i]
        Ii = rec.sym6(Ic[i])
        if b.parent >= 0:
            Ic[b.parent] = _sym6_plus(Ic[b.parent], xt_inertia_x(b, rec, Ii))
        yield i, Ii


def _own_block(H, columns, Ii, b, rec):
    """Each column's force F = Ic S, as it enters the body's own entries (its axes against
    each other, body frame), in the order the entries are named."""
    for col, (speed, S) in enumerate(columns):
        F = rec.vec(_times(Ii, S))
        for s2, S2 in columns[:col]:
            H[(speed, s2)] = H[(s2, speed)] = rec.let(_dot(S2, F))
        H[(speed, speed)] = rec.let(_dot(S, F) + b.armature[col])
        yield speed, F


def crba(bodies, rec):
    """Composite-rigid-body algorithm: {(row speed, column speed): M entry}, lower and upper."""
    H = {}
    for i, Ii in _bodies_up(bodies, rec):
        for speed, F in _own_block(H, _columns(bodies[i]), Ii, bodies[i], rec):
            j = i
            while bodies[j].parent >= 0:
                F = rec.vec(xt_force(bodies[j], F))
                j = bodies[j].parent
                for s2, S2 in _columns(bodies[j]):
                    H[(speed, s2)] = H[(s2, speed)] = rec.let(_dot(S2, F))
    return H


def world_screws(bodies, rec, poses):
    """{speed: its axis as a world screw [ω; v] about the world origin, named}: the body's
    axis S (body frame, about the body origin) turned into the world, its linear part moved to
    the origin (v - ω × o).  NAME_implicit outputs them (the contacts' Jacobians) and
    :func:`crba_world` dots the columns' forces with them."""
    out = {}
    for i, b in enumerate(bodies):
        for speed, S in _columns(b):
            w = rec.vec(poses.to_world(i, S[:3]))
            vo, wxo = poses.to_world(i, S[3:]), _cross(w, poses.origin(i))
            out[speed] = w + rec.vec([vo[a] - wxo[a] for a in range(3)])
    return out


def _world_inertia(b, i, poses, rec):
    """Body i's inertia in the world about the world origin, (m, h = m o, I_O lower triangle)
    named, or None for a massless body.  A lowered body's origin is its centre of mass
    (LoweredBody.I: [[I_c, 0], [0, m 1]]), so I_O = R I_c Rᵀ + m (o·o 1 - o oᵀ)."""
    if all(x == 0 for row in b.I for x in row):
        return None
    m, R, o = b.I[3][3], poses.rotation(i), poses.origin(i)
    Ic = [[b.I[a][c] for c in range(3)] for a in range(3)]
    RI = [[rec.let(_add([_mul(R[a][k], Ic[k][c]) for k in range(3)])) for c in range(3)] for a in range(3)]
    mo = rec.vec([_mul(m, o[a]) for a in range(3)])
    I = {}
    for a in range(3):
        for c in range(a + 1):
            rot = _add([_mul(RI[a][k], R[c][k]) for k in range(3)])
            shift = (_add([_mul(mo[k], o[k]) for k in range(3) if k != a]) if a == c
                     else -_mul(mo[a], o[c]))
            I[(a, c)] = rec.let(_add((rot, shift)))
    return m, mo, I


def _world_force(Y, S):
    """Y S: the momentum [n; f] of an inertia Y = (m, h, I_O) moving with the screw S = [ω; v],
    both about the world origin in world components: n = I_O ω + h × v, f = m v - h × ω."""
    m, h, I = Y
    w, v = S[:3], S[3:]
    hv, hw = _cross(h, v), _cross(h, w)
    n = [_add([_mul(I[(max(a, k), min(a, k))], w[k]) for k in range(3)] + [hv[a]]) for a in range(3)]
    return n + [_add((_mul(m, v[a]), -hw[a])) for a in range(3)]


def _to_body(poses, j, Fw, rec):
    """A world force about the world origin in body j's frame, about its origin."""
    f, o = Fw[3:], poses.origin(j)
    oxf = _cross(o, f)
    return (rec.vec(poses.to_body(j, [_add((Fw[a], -oxf[a])) for a in range(3)]))
            + rec.vec(poses.to_body(j, f)))


def crba_world(bodies, rec, poses, screws):
    """:func:`crba`'s M from the composite inertias summed in the world (``poses``: the tree's
    :class:`.placement.Placement`; ``screws``: :func:`world_screws`): each column's force
    Ic S in the world, dotted with its own body's and its ancestors' screws -- or, for an
    ancestor with many axes on one body (a free joint), carried into that body's frame once.
    A massless body (a joint's intermediate frame) adds nothing: its composite is its child's,
    where :func:`crba` turns every composite through every joint."""
    n = len(bodies)
    comp = [_world_inertia(b, i, poses, rec) for i, b in enumerate(bodies)]
    children = [[] for _ in range(n)]
    for i, b in enumerate(bodies):
        if b.parent >= 0:
            children[b.parent].append(i)
    zero = (0, [0, 0, 0], {(a, c): 0 for a in range(3) for c in range(a + 1)})
    H = {}
    for i in reversed(range(n)):         # leaves first: each composite from its children's
        Ys = [Y for Y in [comp[i]] + [comp[k] for k in children[i]] if Y is not None]
        if len(Ys) > 1:
            comp[i] = (rec.let(_add([Y[0] for Y in Ys])), rec.vec([_add([Y[1][a] for Y in Ys]) for a in range(3)]),
                       {k: rec.let(_add([Y[2][k] for Y in Ys])) for k in Ys[0][2]})
        else:
            comp[i] = Ys[0] if Ys else None
        columns = _columns(bodies[i])
        if not columns:
            continue
        m, h, I = comp[i] if comp[i] is not None else zero
        ancestors = []
        j = bodies[i].parent
        while j >= 0:
            if _columns(bodies[j]):
                ancestors.append(j)
            j = bodies[j].parent
        for col, (speed, _) in enumerate(columns):
            Fw = rec.vec(_world_force((m, h, I), screws[speed]))
            for s2, _ in columns[:col]:
                H[(speed, s2)] = H[(s2, speed)] = rec.let(_dot(screws[s2], Fw))
            H[(speed, speed)] = rec.let(_dot(screws[speed], Fw) + bodies[i].armature[col])
            for j in ancestors:
                cj = _columns(bodies[j])
                if len(cj) >= _FRAME_AXES:      # many axes on one body: the force in its frame
                    Fj = _to_body(poses, j, Fw, rec)
                    for s2, S2 in cj:
                        H[(speed, s2)] = H[(s2, speed)] = rec.let(_dot(S2, Fj))
                else:
                    for s2, _ in cj:
                        H[(speed, s2)] = H[(s2, speed)] = rec.let(_dot(screws[s2], Fw))
    return H


def implicit_mass_matrix(bodies, rec, poses, screws):
    """NAME_implicit's M by the form whose code has fewer operations: each is made on a fork of
    the recorder (and placement), and the operations M's entries read beyond what the screws read
    (NAME_implicit outputs those anyway) are counted -- the whole cone, since temporaries another
    function recorded first (ABA's) are not NAME_implicit's.  The fewer one is recorded.  Why not
    always the world form: on a shallow tree whose bodies all have mass the world inertias cost
    more than the short walks they save (gymnasium's ant: 4 % slower in its fixed step); the
    humanoid (23 speeds, ten massless joint frames) is 5 % faster (benchmarks/results/world_crba.md)."""
    body, world = form_operations(bodies, rec, poses, screws)
    if world < body:
        return crba_world(bodies, rec, poses, screws)
    return crba(bodies, rec)


def form_operations(bodies, rec, poses, screws):
    """(body-frame, world) operations M's entries read beyond what the screws read, each form
    made on a fork of ``rec`` and ``poses`` (both left as they were)."""
    counts = []
    for make in (lambda r, p: crba(bodies, r), lambda r, p: crba_world(bodies, r, p, screws)):
        fork = rec.fork()
        H = make(fork, poses.fork(fork.let))
        screw_reads = {t for t, _ in needed_assignments(fork.assignments, [x for s in screws.values() for x in s])}
        counts.append(sum(sum(count_ops(e).values()) for t, e in needed_assignments(fork.assignments, H.values())
                          if t not in screw_reads))
    return tuple(counts)
