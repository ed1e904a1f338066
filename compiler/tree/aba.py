"""Featherstone's articulated-body algorithm run once on symbols: u' of every joint speed.

Joints of k > 1 speeds (``LoweredBody.multi``: a free joint, a planar or a
cylindrical one, each with constant body-frame axes) take Featherstone's
general form: U = Iᴬ S (6xk), D = Sᵀ U (kxk), factored D = L diag(d) Lᵀ in
straight-line code and applied by substitution (:class:`.ldl._LDL`; k ≤ 6); the
pivots d play the part of the one-speed D (they must be positive).  Why not
single-axis stages as for a ball joint: a free joint's speeds are body-frame
twist components (Pinocchio's free-flyer, the URDF reader's FloatingJoint), and
no chain of one-axis joints has those as its speeds, while S is constant in the
body frame, so the general form costs no joint-motion derivative terms
(c_J = 0) and keeps the Kane path's state.  One-speed joints keep their own
scalar code path.

Armature (``TreeBody.armature``: an inertia a on a joint's own speed, M_ii += a)
enters each recursion where the joint's inertia about its own axis does: ABA's
D_i = Sᵀ Iᴬ S + a (a k-speed joint: D + diag(a)), RNEA's τ_i += a u'_i (:mod:`.rnea`),
CRBA's M_ii += a (:mod:`.crba`).  The articulated solve of :mod:`.derivatives` reuses
ABA's D, so M⁻¹ includes it too.
"""
from ..emit.linsolve import PIVOT_TOL
from .construct import _add, _mul
from .ldl import _LDL
from .spatial import (_dot, _root_acceleration, _sym6_plus, _times, cross_force, x_motion,
                      xt_force, xt_inertia_x)

__all__ = ["aba", "PIVOT_TOL"]


# A pivot (a one-speed D_i, or a k-speed joint's LDL pivot d_j) not above PIVOT_TOL times the
# sum of all pivots is singular: the Kane path's LDLᵀ test (64·DBL_EPSILON·max diag M,
# compiler/emit/linsolve.py), with the pivots standing in for M's diagonal.  A pivot that is
# zero only by rounding (a ball joint in gimbal lock, whose first and third axes line up:
# its first D is ~1e-16 of the others) is then EOMC_SINGULAR_MASS_MATRIX instead of a
# division by noise (reliability report r3, N9).  PIVOT_TOL (64 * DBL_EPSILON, exactly) is
# defined with the Kane path's solvers (compiler/emit/linsolve.py): one number for both.


def aba(bodies, rec, speeds, gravity, v, c, keep=None, part=None):
    """Articulated-body algorithm: [(u'_k expression, pivot margin, body)] per joint with a speed.

    The pivot margin is D_i - PIVOT_TOL·(sum of all pivots): the rhs is singular unless every
    margin is > 0 (see PIVOT_TOL).

    ``keep``: a dict that receives {body index: (U_i, 1/D_i)} (for a k-speed joint:
    (the k rows of U_i, D_i factored)), the articulated quantities that M⁻¹ needs (see :mod:`.derivatives`).

    ``part``: ABA on a part of a tree (:mod:`.limbs`), a dict of
    - "inject": {body: (T, f)}, a 6x6 inertia and a 6-force handed on by bodies outside the
      part (a limb's Xᵀ Iᵃ X and Xᵀ pᵃ), added to the body's Iᴬ and pᴬ;
    - "pivots": a term added to the pivots' sum (the other bodies' pivots);
    - "root_a": the acceleration of a root's parent (a limb's), instead of gravity's;
    - "hand": {}, receives "T" and "f", what the part's root hands on to its parent;
    - "a": {}, receives every body's acceleration {body: 6-list};
    - "D": {}, receives every one-speed body's pivot {body: D_i};
    - "thr": receives the singularity threshold PIVOT_TOL·(sum of the pivots)."""
    part = part or {}
    n = len(bodies)
    IA = [[row[:] for row in b.I] for b in bodies]
    pA = []
    for i, b in enumerate(bodies):
        p = cross_force(v[i], _times(b.I, v[i]))
        if b.fext is not None:
            p = [_add((p[k], -b.fext[k])) for k in range(6)]
        pA.append(p)
    for i, (T, f) in part.get("inject", {}).items():
        IA[i] = _sym6_plus(IA[i], T)
        pA[i] = [_add((pA[i][k], f[k])) for k in range(6)]
    U, Dinv, uu, D = [None] * n, [None] * n, [None] * n, [None] * n
    ldl = {}                   # k-speed joints: their factored D
    for i in reversed(range(n)):
        b = bodies[i]
        Ii = rec.sym6(IA[i])
        pi = rec.vec(pA[i])
        if b.S is not None:
            U[i] = rec.vec(_times(Ii, b.S))
            D[i] = rec.let(_dot(b.S, U[i]) + b.armature[0])
            if D[i] == 0:
                from .model import NotATree
                raise NotATree(f"body {b.name} (joint {b.joint}) has no inertia about its joint "
                               f"axis, even with everything beyond it: its acceleration is undefined")
            Dinv[i] = rec.let(1 / D[i])
            if "D" in part:
                part["D"][i] = D[i]
            if keep is not None:
                keep[i] = (U[i], Dinv[i])
            uu[i] = rec.let(-_dot(b.S, pi))
            W = rec.vec([_mul(x, Dinv[i]) for x in U[i]])          # U/D once: 33 products, not 54
            Ia = [[_add((Ii[r][s], -_mul(W[r], U[i][s]))) if s <= r else None
                   for s in range(6)] for r in range(6)]      # sym6 reads the lower triangle
            Ia = rec.sym6(Ia)
            Iac = _times(Ia, c[i])
            pa = [_add((pi[k], Iac[k], _mul(W[k], uu[i]))) for k in range(6)]
        elif b.multi:
            U[i], ldl[i], uu[i] = _multi_articulate(b, rec, Ii, pi)
            D[i] = ldl[i].d
            if keep is not None:
                keep[i] = (U[i], ldl[i])
            if b.parent < 0:
                continue          # a root (a floating base): nothing to hand on
            Ut = U[i]
            W = [ldl[i].solve([Ut[m][r] for m in range(len(Ut))]) for r in range(6)]   # U D⁻¹, 6xk
            Ia = rec.sym6([[_add((Ii[r][s], -_add([_mul(W[r][m], Ut[m][s]) for m in range(len(Ut))])))
                            if s <= r else None for s in range(6)] for r in range(6)])
            Iac = _times(Ia, c[i])
            pa = [_add((pi[k], Iac[k], _add([_mul(W[k][m], uu[i][m]) for m in range(len(Ut))])))
                  for k in range(6)]
        else:
            Ia = Ii
            pa = pi
        if b.parent >= 0:
            pa = rec.vec(pa)
            T = xt_inertia_x(b, rec, Ia)
            IA[b.parent] = _sym6_plus(IA[b.parent], T)
            f = xt_force(b, pa)
            pA[b.parent] = [_add((pA[b.parent][k], f[k])) for k in range(6)]
        elif "hand" in part:
            pa = rec.vec(pa)
            part["hand"]["T"] = xt_inertia_x(b, rec, Ia)
            part["hand"]["f"] = xt_force(b, pa)
    pivots = [d for Di in D if Di is not None for d in (Di if isinstance(Di, list) else [Di])]
    threshold = rec.let(PIVOT_TOL * _add(pivots + ([part["pivots"]] if "pivots" in part else [])))
    if "thr" in part:
        part["thr"] = threshold
    a, out = [None] * n, []
    for i, b in enumerate(bodies):
        ap = a[b.parent] if b.parent >= 0 else part.get("root_a") or _root_acceleration(gravity)
        ai = [_add((x, y)) for x, y in zip(x_motion(b, ap), c[i])]
        if b.S is not None:
            ai = rec.vec(ai)
            udd = rec.let((uu[i] - _dot(U[i], ai)) * Dinv[i])
            ai = [_add((ai[k], _mul(b.S[k], udd))) for k in range(6)]
            out.append((b.speed, udd, rec.let(D[i] - threshold)))
        elif b.multi:
            ai = rec.vec(ai)
            k = len(b.multi)
            rhs = [_add((uu[i][m], -_dot(U[i][m], ai))) for m in range(k)]
            rhs = rec.vec(rhs)
            udd = ldl[i].solve(rhs)
            for m, (s, S) in enumerate(b.multi):
                ai = [_add((ai[j], _mul(S[j], udd[m]))) for j in range(6)]
                out.append((s, udd[m], rec.let(D[i][m] - threshold)))
        a[i] = rec.vec(ai)
    if "a" in part:
        part["a"].update(enumerate(a))
    return out


def _multi_articulate(b, rec, Ii, pi):
    """U = Iᴬ S, u = -Sᵀ pᴬ and D = Sᵀ Iᴬ S factored (:class:`_LDL`) for a k-speed joint."""
    Ss = [S for _, S in b.multi]
    k = len(Ss)
    U = [rec.vec(_times(Ii, S)) for S in Ss]
    Dm = [[None] * k for _ in range(k)]
    for r in range(k):
        for s in range(r + 1):
            Dm[r][s] = Dm[s][r] = rec.let(_dot(Ss[r], U[s]) + (b.armature[r] if r == s else 0))
    uu = [rec.let(-_dot(S, pi)) for S in Ss]
    return U, _LDL(Dm, rec, b), uu
