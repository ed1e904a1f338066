"""Featherstone's recursions run once on symbols: ABA (u'), RNEA (inverse dynamics), CRBA (M).

Each function walks the tree and returns SymPy expressions; every vector
component and matrix entry a body produces is handed to a :class:`Recorder`,
which names it with a fresh temporary (value-numbered: the same expression
gets the same name).  So the program stays a flat DAG whose size grows
linearly with the number of bodies -- the trace a numeric ABA would execute,
with structural zeros (planar joints, point masses) already dropped by SymPy.

Spatial vectors are 6-lists about the body origin in body components:
motion [ω; v], force [n; f].  A body's transform from its parent is E (parent
to body components) and r (body origin from the parent origin, parent components).

Joints of k > 1 speeds (``LoweredBody.multi``: a free joint, a planar or a
cylindrical one, each with constant body-frame axes) take Featherstone's
general form: U = Iᴬ S (6xk), D = Sᵀ U (kxk), factored D = L diag(d) Lᵀ in
straight-line code and applied by substitution (:class:`_LDL`; k ≤ 6); the
pivots d play the part of the one-speed D (they must be positive).  Why not
single-axis stages as for a ball joint: a free joint's speeds are body-frame
twist components (Pinocchio's free-flyer, the URDF reader's FloatingJoint), and
no chain of one-axis joints has those as its speeds, while S is constant in the
body frame, so the general form costs no joint-motion derivative terms
(c_J = 0) and keeps the Kane path's state.  One-speed joints keep their own
scalar code path.

Armature (``TreeBody.armature``: an inertia a on a joint's own speed, M_ii += a)
enters each recursion where the joint's inertia about its own axis does: ABA's
D_i = Sᵀ Iᴬ S + a (a k-speed joint: D + diag(a)), RNEA's τ_i += a u'_i, CRBA's
M_ii += a.  The articulated solve of :mod:`.derivatives` reuses ABA's D, so M⁻¹
includes it too.
"""
import sympy as sm
from sympy.core.mul import _args_sortkey

from ..emit.linsolve import PIVOT_TOL

__all__ = ["Recorder", "LoweredBody", "aba", "rnea", "crba"]


class Recorder:
    """Names intermediate values ``_t<k>`` (the IR's registry) and keeps them in order."""

    def __init__(self, start=0):
        self.count = start
        self.assignments = []
        self._seen = {}

    def let(self, expr):
        """A name for ``expr`` (atoms and -atom stay as they are; a repeat gets the same name)."""
        if not isinstance(expr, sm.Basic):
            expr = sm.sympify(expr)
        if expr.is_Atom or (expr.is_Mul and len(expr.args) == 2 and expr.args[0] == -1
                            and expr.args[1].is_Atom):
            return expr
        hit = self._seen.get(expr)
        if hit is not None:
            return hit
        sym = sm.Symbol(f"_t{self.count}", real=True)
        self.count += 1
        self.assignments.append((sym, expr))
        self._seen[expr] = sym
        return sym

    def vec(self, items):
        return [self.let(e) for e in items]

    def sym6(self, M):
        """A symmetric 6x6 (list of lists), lower triangle named, mirrored."""
        out = [[None] * 6 for _ in range(6)]
        for i in range(6):
            for j in range(i + 1):
                out[i][j] = out[j][i] = self.let(M[i][j])
        return out


class LoweredBody:
    """A TreeBody in slot symbols, with its transform's entries named once."""

    def __init__(self, body, rec, E, r, S, mass, inertia, fext, multi=None, armature=None):
        self.parent, self.speed, self.name, self.joint = body.parent, body.speed, body.name, body.joint
        self.multi = multi         # [(speed index, 6-list axis)] of a k > 1 speed joint, else None
        # per speed (S's, or multi's in order): the armature, in slot symbols (zeros when none)
        self.armature = list(armature) if armature else [0] * (1 if S is not None else len(multi or ()))
        self.E = [[rec.let(E[i, j]) for j in range(3)] for i in range(3)]
        self.r = rec.vec(r)
        self.S = list(S) if S is not None else None
        m = mass
        Ic = inertia
        self.I = [[Ic[i, j] if i < 3 and j < 3 else 0 for j in range(6)] for i in range(6)]
        for k in range(3, 6):
            self.I[k][k] = m
        self.fext = fext           # 6-list or None


# Expression construction is most of a large tree's build time (0.1 s a body on a chain).
# The helpers below build the same SymPy expressions as the plain operators and
# sum(..., S.Zero) did, for less: structural zeros are dropped before any SymPy operation
# (``_nz`` answers for ints, Zero and Symbols without SymPy's __ne__), and the commonest
# shapes skip SymPy's flatten altogether: a product of distinct commutative Symbols, and a
# sum of Symbols and such products (a rational coefficient allowed) with no two alike, are
# their arguments in SymPy's canonical order (``_args_sortkey``, the key flatten sorts
# by) -- exactly the objects Mul(...) and Add(...) return.  Anything else is summed or
# multiplied left to right as before (an n-ary Add or Mul is not always the same: Floats
# that are zero, a rational times a sum).  So ``_add(ts)`` is ``t1 + t2 + ...`` of the
# terms that are not 0 / S.Zero, object for object (a Float 0.0 stays; SymPy's Zero + 0.0
# is Zero, so this can differ from sum(ts, S.Zero) in the type of a number, never in its
# value); tests/compiler/tree/test_algorithms_construction.py checks both on random input.
_ZERO = sm.S.Zero
_Add, _Mul, _Symbol = sm.Add, sm.Mul, sm.Symbol


def _plain_mul(f):
    """f is a product of commutative Symbols and at most a leading number."""
    if type(f) is not _Mul:
        return False
    args = f.args
    first = 1 if args[0].is_Rational else 0
    return all(type(a) is _Symbol and a.is_commutative for a in args[first:])


def _term_key(t):
    """What Add.flatten collects ``t`` under (its non-numeric factors), or None when ``t``
    is not a Symbol or a plain product (then SymPy's own flatten decides)."""
    if type(t) is _Symbol:
        return (t,) if t.is_commutative else None
    if _plain_mul(t):
        args = t.args
        return args[1:] if args[0].is_Rational else args
    return None


def _fast_add(terms):
    keys = set()
    for t in terms:
        k = _term_key(t)
        if k is None or k in keys:
            return None
        keys.add(k)
    return _Add._from_args(tuple(sorted(terms, key=_args_sortkey)), True)


def _fast_mul(factors):
    for f in factors:
        if type(f) is not _Symbol or not f.is_commutative:
            return None
    if len(set(factors)) < len(factors):
        return None
    return _Mul._from_args(tuple(sorted(factors, key=_args_sortkey)), True)


def _nz(x):
    """``x != 0``, fast for the common cases (an int, Zero, a Symbol)."""
    t = type(x)
    if t is int:
        return x != 0
    if x is _ZERO:
        return False
    if t is _Symbol:
        return True
    return x != 0


def _add(terms):
    """The terms that are not zero, summed left to right (see above)."""
    terms = [t for t in terms if _nz(t)]
    if not terms:
        return _ZERO
    if len(terms) == 1:
        t = terms[0]
        return t if isinstance(t, sm.Basic) else sm.sympify(t)
    fast = _fast_add(terms)
    if fast is not None:
        return fast
    out = terms[0]
    for t in terms[1:]:
        out = out + t
    return out


def _mul(*factors):
    """The product (zero if a factor is)."""
    for f in factors:
        if not _nz(f):
            return _ZERO
    fast = _fast_mul(factors)
    if fast is not None:
        return fast
    out = factors[0]
    for f in factors[1:]:
        out = out * f
    return out


def _cross(a, b):
    return [_add((_mul(a[1], b[2]), -_mul(a[2], b[1]))), _add((_mul(a[2], b[0]), -_mul(a[0], b[2]))),
            _add((_mul(a[0], b[1]), -_mul(a[1], b[0])))]


def _mat3(E, v):
    return [_add([_mul(E[i][j], v[j]) for j in range(3)]) for i in range(3)]


def _mat3T(E, v):
    return [_add([_mul(E[j][i], v[j]) for j in range(3)]) for i in range(3)]


def _sym6_plus(A, T):
    """A + T of symmetric 6x6s: the lower triangle summed, mirrored (``Recorder.sym6``
    reads no more)."""
    out = [[None] * 6 for _ in range(6)]
    for i in range(6):
        for j in range(i + 1):
            out[i][j] = out[j][i] = _add((A[i][j], T[i][j]))
    return out


def x_motion(b, m):
    """Parent motion vector -> body components about the body origin."""
    w, v = m[:3], m[3:]
    rw = _cross(b.r, w)
    return _mat3(b.E, w) + _mat3(b.E, [_add((v[i], -rw[i])) for i in range(3)])


def xt_force(b, f):
    """Body force vector -> parent components about the parent origin."""
    n, fo = f[:3], f[3:]
    fp = _mat3T(b.E, fo)
    rf = _cross(b.r, fp)
    nb = _mat3T(b.E, n)
    return [_add((nb[i], rf[i])) for i in range(3)] + fp


def _rot_sym(E, A, rec):
    """Eᵀ A E of a symmetric 3x3 (lower triangle named)."""
    AE = [[rec.let(_add([_mul(A[i][k], E[k][j]) for k in range(3)])) for j in range(3)] for i in range(3)]
    out = [[None] * 3 for _ in range(3)]
    for i in range(3):
        for j in range(i + 1):
            out[i][j] = out[j][i] = rec.let(_add([_mul(E[k][i], AE[k][j]) for k in range(3)]))
    return out


def _rot_gen(E, B, rec):
    """Eᵀ B E of a general 3x3 (named)."""
    BE = [[rec.let(_add([_mul(B[i][k], E[k][j]) for k in range(3)])) for j in range(3)] for i in range(3)]
    return [[rec.let(_add([_mul(E[k][i], BE[k][j]) for k in range(3)])) for j in range(3)] for i in range(3)]


def xt_inertia_x(b, rec, I):
    """Xᵀ I X: a body-frame 6x6 inertia as seen from the parent (symmetric, named).

    By 3x3 blocks (I = [[A, B], [Bᵀ, C]]): rotate A, B, C into the parent's axes,
    then shift by r: [[A' + r×B'ᵀ - (B' + r×C') r×, B' + r×C'], [.., C']] -- about
    5% fewer operations in the generated rhs than multiplying by the 6x6 X twice."""
    E, r = b.E, b.r
    A = [[I[i][j] for j in range(3)] for i in range(3)]
    B = [[I[i][j + 3] for j in range(3)] for i in range(3)]
    C = [[I[i + 3][j + 3] for j in range(3)] for i in range(3)]
    A, C = _rot_sym(E, A, rec), _rot_sym(E, C, rec)
    B = _rot_gen(E, B, rec) if any(_nz(x) for row in B for x in row) else B
    rx = [[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]]

    def mul(P, Q, lower=False):
        return [[_add([_mul(P[i][k], Q[k][j]) for k in range(3)]) if j <= i or not lower else None
                 for j in range(3)] for i in range(3)]
    rC = mul(rx, C)
    Bn = [[rec.let(_add((B[i][j], rC[i][j]))) for j in range(3)] for i in range(3)]     # B' + r×C'
    Bt = [[B[j][i] for j in range(3)] for i in range(3)]
    rB = mul(rx, Bt, lower=True)
    Bnr = mul(Bn, rx, lower=True)
    out = [[None] * 6 for _ in range(6)]
    for i in range(3):
        for j in range(i + 1):
            out[i][j] = out[j][i] = _add((A[i][j], rB[i][j], -Bnr[i][j]))
    for i in range(3):
        for j in range(3):
            out[i][j + 3] = out[j + 3][i] = Bn[i][j]
        for j in range(i + 1):
            out[i + 3][j + 3] = out[j + 3][i + 3] = C[i][j]
    return rec.sym6(out)


def cross_motion(v, m):
    """v ×ₘ m."""
    w, vv = v[:3], v[3:]
    a, b = m[:3], m[3:]
    t1, t2 = _cross(w, b), _cross(vv, a)
    return _cross(w, a) + [_add((t1[i], t2[i])) for i in range(3)]


def cross_force(v, f):
    """v ×f f."""
    w, vv = v[:3], v[3:]
    n, fo = f[:3], f[3:]
    t1, t2 = _cross(w, n), _cross(vv, fo)
    return [_add((t1[i], t2[i])) for i in range(3)] + _cross(w, fo)


def _times(I, v):
    nzv = [k for k in range(6) if _nz(v[k])]
    return [_add([_mul(I[i][k], v[k]) for k in nzv]) for i in range(6)]


def _dot(a, b):
    return _add([_mul(x, y) for x, y in zip(a, b)])


def velocities(bodies, rec, speeds):
    """Body spatial velocities v_i and velocity-product accelerations c_i."""
    v, c = [], []
    for b in bodies:
        vp = v[b.parent] if b.parent >= 0 else [0] * 6
        vi = x_motion(b, vp)
        if b.S is not None:
            vj = [_mul(s, speeds[b.speed]) for s in b.S]
            vi = [_add((vi[k], vj[k])) for k in range(6)]
            vi = rec.vec(vi)
            c.append(rec.vec(cross_motion(vi, vj)))
        elif b.multi:
            vj = [_add([_mul(S[k], speeds[s]) for s, S in b.multi]) for k in range(6)]
            vi = rec.vec([_add((vi[k], vj[k])) for k in range(6)])
            c.append(rec.vec(cross_motion(vi, vj)))
        else:
            vi = rec.vec(vi)
            c.append([0] * 6)
        v.append(vi)
    return v, c


def _root_acceleration(gravity):
    return [0, 0, 0] + [-g for g in gravity]


# A pivot (a one-speed D_i, or a k-speed joint's LDL pivot d_j) not above PIVOT_TOL times the
# sum of all pivots is singular: the Kane path's LDLᵀ test (64·DBL_EPSILON·max diag M,
# compiler/emit/linsolve.py), with the pivots standing in for M's diagonal.  A pivot that is
# zero only by rounding (a ball joint in gimbal lock, whose first and third axes line up:
# its first D is ~1e-16 of the others) is then EOMC_SINGULAR_MASS_MATRIX instead of a
# division by noise (reliability report r3, N9).  PIVOT_TOL (64 * DBL_EPSILON, exactly) is
# defined with the Kane path's solvers (compiler/emit/linsolve.py): one number for both.


def aba(bodies, rec, speeds, gravity, v, c, keep=None):
    """Articulated-body algorithm: [(u'_k expression, pivot margin, body)] per joint with a speed.

    The pivot margin is D_i - PIVOT_TOL·(sum of all pivots): the rhs is singular unless every
    margin is > 0 (see PIVOT_TOL).

    ``keep``: a dict that receives {body index: (U_i, 1/D_i)} (for a k-speed joint:
    (the k rows of U_i, D_i factored)), the articulated quantities that M⁻¹ needs (see :mod:`.derivatives`)."""
    n = len(bodies)
    IA = [[row[:] for row in b.I] for b in bodies]
    pA = []
    for i, b in enumerate(bodies):
        p = cross_force(v[i], _times(b.I, v[i]))
        if b.fext is not None:
            p = [_add((p[k], -b.fext[k])) for k in range(6)]
        pA.append(p)
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
            if keep is not None:
                keep[i] = (U[i], Dinv[i])
            uu[i] = rec.let(-_dot(b.S, pi))
            Ia = [[_add((Ii[r][s], -_mul(U[i][r], U[i][s], Dinv[i]))) if s <= r else None
                   for s in range(6)] for r in range(6)]      # sym6 reads the lower triangle
            Ia = rec.sym6(Ia)
            Iac = _times(Ia, c[i])
            pa = [_add((pi[k], Iac[k], _mul(U[i][k], uu[i], Dinv[i]))) for k in range(6)]
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
    pivots = [d for Di in D if Di is not None for d in (Di if isinstance(Di, list) else [Di])]
    threshold = rec.let(PIVOT_TOL * _add(pivots))
    a, out = [None] * n, []
    for i, b in enumerate(bodies):
        ap = a[b.parent] if b.parent >= 0 else _root_acceleration(gravity)
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
    return out


def rnea(bodies, rec, speed_accels, gravity, v, c):
    """Recursive Newton-Euler: {speed index: generalized force} for given accelerations."""
    n = len(bodies)
    f = [None] * n
    a = [None] * n
    for i, b in enumerate(bodies):
        ap = a[b.parent] if b.parent >= 0 else _root_acceleration(gravity)
        ai = [_add((x, y)) for x, y in zip(x_motion(b, ap), c[i])]
        if b.S is not None:
            ai = [_add((ai[k], _mul(b.S[k], speed_accels[b.speed]))) for k in range(6)]
        elif b.multi:
            for s, S in b.multi:
                ai = [_add((ai[k], _mul(S[k], speed_accels[s]))) for k in range(6)]
        a[i] = rec.vec(ai)
        fi = [_add((x, y)) for x, y in zip(_times(b.I, a[i]), cross_force(v[i], _times(b.I, v[i])))]
        if b.fext is not None:
            fi = [_add((fi[k], -b.fext[k])) for k in range(6)]
        f[i] = fi
    tau = {}
    for i in reversed(range(n)):
        b = bodies[i]
        fi = rec.vec(f[i])
        if b.S is not None:
            tau[b.speed] = rec.let(_dot(b.S, fi) + b.armature[0] * speed_accels[b.speed])
        elif b.multi:
            for (s, S), arm in zip(b.multi, b.armature):
                tau[s] = rec.let(_dot(S, fi) + arm * speed_accels[s])
        if b.parent >= 0:
            fp = xt_force(b, fi)
            f[b.parent] = [_add((f[b.parent][k], fp[k])) for k in range(6)]
    return tau


def crba(bodies, rec):
    """Composite-rigid-body algorithm: {(row speed, column speed): M entry}, lower and upper."""
    n = len(bodies)
    Ic = [[row[:] for row in b.I] for b in bodies]
    H = {}
    for i in reversed(range(n)):
        b = bodies[i]
        Ii = rec.sym6(Ic[i])
        if b.parent >= 0:
            T = xt_inertia_x(b, rec, Ii)
            Ic[b.parent] = _sym6_plus(Ic[b.parent], T)
        if b.S is not None:
            columns = [(b.speed, b.S)]
        elif b.multi:
            columns = b.multi
        else:
            continue
        for col, (speed, S) in enumerate(columns):
            F = rec.vec(_times(Ii, S))
            for s2, S2 in columns[:col]:
                H[(speed, s2)] = H[(s2, speed)] = rec.let(_dot(S2, F))
            H[(speed, speed)] = rec.let(_dot(S, F) + b.armature[col])
            j = i
            while bodies[j].parent >= 0:
                F = rec.vec(xt_force(bodies[j], F))
                j = bodies[j].parent
                if bodies[j].S is not None:
                    H[(speed, bodies[j].speed)] = H[(bodies[j].speed, speed)] = rec.let(_dot(bodies[j].S, F))
                elif bodies[j].multi:
                    for s2, S2 in bodies[j].multi:
                        H[(speed, s2)] = H[(s2, speed)] = rec.let(_dot(S2, F))
    return H


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


class _LDL:
    """D = L diag(d) Lᵀ of a symmetric kxk (k ≤ 6), unrolled and named; ``solve`` applies D⁻¹
    by forward and back substitution (cheaper than forming D⁻¹: a root's D is solved once).

    A pivot that is zero as an expression means nothing resists some motion of the
    joint: refused here naming the body, as the one-speed D = 0."""

    def __init__(self, Dm, rec, b):
        k = self.k = len(Dm)
        self.rec = rec
        L = self.L = [[sm.S.Zero] * k for _ in range(k)]
        d, dinv = self.d, self.dinv = [None] * k, [None] * k
        for j in range(k):
            d[j] = rec.let(Dm[j][j] - sum((L[j][m] ** 2 * d[m] for m in range(j) if L[j][m] != 0),
                                          sm.S.Zero))
            if d[j] == 0:
                from .model import NotATree
                raise NotATree(f"body {b.name} (joint {b.joint}) has no inertia against one of its "
                               f"joint's motions, even with everything beyond it: its acceleration "
                               f"is undefined")
            dinv[j] = rec.let(1 / d[j])
            L[j][j] = sm.S.One
            for i in range(j + 1, k):
                L[i][j] = rec.let((Dm[i][j] - sum((L[i][m] * L[j][m] * d[m] for m in range(j)
                                                   if L[i][m] != 0 and L[j][m] != 0), sm.S.Zero)) * dinv[j])

    def solve(self, rhs):
        """D⁻¹ rhs (a k-list), each step named."""
        k, L, rec = self.k, self.L, self.rec
        y = [None] * k
        for j in range(k):
            y[j] = rec.let(rhs[j] - sum((L[j][m] * y[m] for m in range(j) if L[j][m] != 0), sm.S.Zero))
        x = [None] * k
        for j in reversed(range(k)):
            x[j] = rec.let(y[j] * self.dinv[j] - sum((L[m][j] * x[m] for m in range(j + 1, k)
                                                      if L[m][j] != 0), sm.S.Zero))
        return x
