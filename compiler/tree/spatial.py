"""Spatial algebra on SymPy lists: transforms, cross products and inertias of the recursions.

Spatial vectors are 6-lists about the body origin in body components: motion [ω; v],
force [n; f].  A body's transform from its parent is E (parent to body components) and r
(body origin from the parent origin, parent components), as a :class:`.lowered.LoweredBody`
holds them.  Sums and products go through :mod:`.construct` (structural zeros dropped).
"""
import sympy as sm

from .construct import _add, _mul, _nz


def cross(a, b):
    """a x b of two 3-vectors (lists of expressions), by the plain operators: what placement,
    loads, frame outputs and the readers' joint axes use (the recursions' :func:`_cross` drops
    structural zeros first)."""
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


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


def _turn(b, rec):
    """(k, i, j, c, s, cos 2q, sin 2q) of a body whose E turns about axis k (``b.axis``)."""
    k, i, j = b.axis
    c, s = b.E[i][i], b.E[i][j]
    return k, i, j, c, s, rec.let(_add((_mul(c, c), -_mul(s, s)))), rec.let(2 * _mul(c, s))


def _turn_vec(t, x, y):
    """(x, y) components i, j of a vector along axis k's plane, turned: Gᵀ (x, y)."""
    _, _, _, c, s, _, _ = t
    return _add((_mul(c, x), -_mul(s, y))), _add((_mul(s, x), _mul(c, y)))


def _turn_pair(t, rec, a, e, b):
    """Gᵀ [[a, b], [b, e]] G (G = [[c, s], [-s, c]]) by the double angle: the mean of a and
    e does not turn, their half difference and b turn by 2q (12 operations, not 21)."""
    _, _, _, _, _, c2, s2 = t
    half = sm.Rational(1, 2)
    mean, h = rec.let(half * rec.let(_add((a, e)))), rec.let(half * rec.let(_add((a, -e))))
    d = rec.let(_add((_mul(c2, h), -_mul(s2, b))))
    return _add((mean, d)), _add((mean, -d)), _add((_mul(s2, h), _mul(c2, b)))


def _turn_sym(t, A, rec):
    """Eᵀ A E of a symmetric 3x3 when E turns about axis k (lower triangle named)."""
    k, i, j = t[:3]
    out = [[None] * 3 for _ in range(3)]
    out[k][k] = A[k][k]
    out[i][i], out[j][j], out[i][j] = _turn_pair(t, rec, A[i][i], A[j][j], A[i][j])
    out[j][i] = out[i][j]
    out[i][k], out[j][k] = _turn_vec(t, A[i][k], A[j][k])
    out[k][i], out[k][j] = out[i][k], out[j][k]
    return [[rec.let(x) for x in row] for row in out]


def _turn_gen(t, B, rec):
    """Eᵀ B E of a general 3x3 when E turns about axis k: its 2x2 block's antisymmetric part
    does not turn (det G = 1), its symmetric part turns as :func:`_turn_pair`."""
    k, i, j = t[:3]
    half = sm.Rational(1, 2)
    out = [[None] * 3 for _ in range(3)]
    out[k][k] = B[k][k]
    sym = rec.let(half * rec.let(_add((B[i][j], B[j][i]))))
    w = rec.let(half * rec.let(_add((B[i][j], -B[j][i]))))
    out[i][i], out[j][j], bs = _turn_pair(t, rec, B[i][i], B[j][j], sym)
    bs = rec.let(bs)
    out[i][j], out[j][i] = _add((bs, w)), _add((bs, -w))
    out[i][k], out[j][k] = _turn_vec(t, B[i][k], B[j][k])
    out[k][i], out[k][j] = _turn_vec(t, B[k][i], B[k][j])
    return [[rec.let(x) for x in row] for row in out]


def xt_inertia_x(b, rec, I):
    """Xᵀ I X: a body-frame 6x6 inertia as seen from the parent (symmetric, named).

    By 3x3 blocks (I = [[A, B], [Bᵀ, C]]): rotate A, B, C into the parent's axes,
    then shift by r: [[A' + r×B'ᵀ - (B' + r×C') r×, B' + r×C'], [.., C']] -- about
    5% fewer operations in the generated rhs than multiplying by the 6x6 X twice.  When E
    turns about one of the body's axes (``b.axis``, most revolute joints) the blocks turn
    by the double angle (:func:`_turn_sym`, :func:`_turn_gen`): 18 + 30 + 18 operations
    instead of 27 + 36 + 27, plus 5 for cos 2q and sin 2q."""
    E, r = b.E, b.r
    A = [[I[i][j] for j in range(3)] for i in range(3)]
    B = [[I[i][j + 3] for j in range(3)] for i in range(3)]
    C = [[I[i + 3][j + 3] for j in range(3)] for i in range(3)]
    if getattr(b, "axis", None) is not None:          # a turn about one axis: the double angle
        t = _turn(b, rec)
        A, C = _turn_sym(t, A, rec), _turn_sym(t, C, rec)
        B = _turn_gen(t, B, rec) if any(_nz(x) for row in B for x in row) else B
    else:
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


def _root_acceleration(gravity):
    return [0, 0, 0] + [-g for g in gravity]
