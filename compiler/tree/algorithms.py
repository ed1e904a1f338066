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
"""
import sympy as sm

__all__ = ["Recorder", "LoweredBody", "aba", "rnea", "crba"]


class Recorder:
    """Names intermediate values ``_t<k>`` (the IR's registry) and keeps them in order."""

    def __init__(self, start=0):
        self.count = start
        self.assignments = []
        self._seen = {}

    def let(self, expr):
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

    def __init__(self, body, rec, E, r, S, mass, inertia, fext):
        self.parent, self.speed, self.name, self.joint = body.parent, body.speed, body.name, body.joint
        self.E = [[rec.let(E[i, j]) for j in range(3)] for i in range(3)]
        self.r = rec.vec(r)
        self.S = list(S) if S is not None else None
        m = mass
        Ic = inertia
        self.I = [[Ic[i, j] if i < 3 and j < 3 else 0 for j in range(6)] for i in range(6)]
        for k in range(3, 6):
            self.I[k][k] = m
        self.fext = fext           # 6-list or None


def _cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _mat3(E, v):
    return [sum((E[i][j] * v[j] for j in range(3)), sm.S.Zero) for i in range(3)]


def _mat3T(E, v):
    return [sum((E[j][i] * v[j] for j in range(3)), sm.S.Zero) for i in range(3)]


def x_motion(b, m):
    """Parent motion vector -> body components about the body origin."""
    w, v = m[:3], m[3:]
    rw = _cross(b.r, w)
    return _mat3(b.E, w) + _mat3(b.E, [v[i] - rw[i] for i in range(3)])


def xt_force(b, f):
    """Body force vector -> parent components about the parent origin."""
    n, fo = f[:3], f[3:]
    fp = _mat3T(b.E, fo)
    rf = _cross(b.r, fp)
    nb = _mat3T(b.E, n)
    return [nb[i] + rf[i] for i in range(3)] + fp


def _x_matrix(b):
    """X as a 6x6 list: [[E, 0], [-E r×, E]]."""
    E, r = b.E, b.r
    rx = [[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]]
    X = [[0] * 6 for _ in range(6)]
    for i in range(3):
        for j in range(3):
            X[i][j] = E[i][j]
            X[i + 3][j + 3] = E[i][j]
            X[i + 3][j] = -sum(E[i][k] * rx[k][j] for k in range(3))
    return X


def xt_inertia_x(b, rec, I):
    """Xᵀ I X: a body-frame 6x6 inertia as seen from the parent (symmetric, named)."""
    X = _x_matrix(b)
    Xn = [[rec.let(e) for e in row] for row in X]
    IX = [[rec.let(sum((I[i][k] * Xn[k][j] for k in range(6) if I[i][k] != 0 and Xn[k][j] != 0),
                       sm.S.Zero)) for j in range(6)] for i in range(6)]
    out = [[None] * 6 for _ in range(6)]
    for i in range(6):
        for j in range(i + 1):
            out[i][j] = sum((Xn[k][i] * IX[k][j] for k in range(6) if Xn[k][i] != 0 and IX[k][j] != 0),
                            sm.S.Zero)
            out[j][i] = out[i][j]
    return rec.sym6(out)


def cross_motion(v, m):
    """v ×ₘ m."""
    w, vv = v[:3], v[3:]
    a, b = m[:3], m[3:]
    t1, t2 = _cross(w, b), _cross(vv, a)
    return _cross(w, a) + [t1[i] + t2[i] for i in range(3)]


def cross_force(v, f):
    """v ×f f."""
    w, vv = v[:3], v[3:]
    n, fo = f[:3], f[3:]
    t1, t2 = _cross(w, n), _cross(vv, fo)
    return [t1[i] + t2[i] for i in range(3)] + _cross(w, fo)


def _times(I, v):
    return [sum((I[i][k] * v[k] for k in range(6) if I[i][k] != 0 and v[k] != 0), sm.S.Zero)
            for i in range(6)]


def _dot(a, b):
    return sum((x * y for x, y in zip(a, b) if x != 0 and y != 0), sm.S.Zero)


def velocities(bodies, rec, speeds):
    """Body spatial velocities v_i and velocity-product accelerations c_i."""
    v, c = [], []
    for b in bodies:
        vp = v[b.parent] if b.parent >= 0 else [0] * 6
        vi = x_motion(b, vp)
        if b.S is not None:
            vj = [s * speeds[b.speed] for s in b.S]
            vi = [vi[k] + vj[k] for k in range(6)]
            vi = rec.vec(vi)
            c.append(rec.vec(cross_motion(vi, vj)))
        else:
            vi = rec.vec(vi)
            c.append([0] * 6)
        v.append(vi)
    return v, c


def _root_acceleration(gravity):
    return [0, 0, 0] + [-g for g in gravity]


def aba(bodies, rec, speeds, gravity, v, c, keep=None):
    """Articulated-body algorithm: [(u'_k expression, D_i, body)] per joint with a speed.

    ``keep``: a dict that receives {body index: (U_i, 1/D_i)}, the articulated
    quantities that M⁻¹ needs (see :mod:`.derivatives`)."""
    n = len(bodies)
    IA = [[row[:] for row in b.I] for b in bodies]
    pA = []
    for i, b in enumerate(bodies):
        p = cross_force(v[i], _times(b.I, v[i]))
        if b.fext is not None:
            p = [p[k] - b.fext[k] for k in range(6)]
        pA.append(p)
    U, Dinv, uu, D = [None] * n, [None] * n, [None] * n, [None] * n
    for i in reversed(range(n)):
        b = bodies[i]
        Ii = rec.sym6(IA[i])
        pi = rec.vec(pA[i])
        if b.S is not None:
            U[i] = rec.vec(_times(Ii, b.S))
            D[i] = rec.let(_dot(b.S, U[i]))
            if D[i] == 0:
                from .model import NotATree
                raise NotATree(f"body {b.name} (joint {b.joint}) has no inertia about its joint "
                               f"axis, even with everything beyond it: its acceleration is undefined")
            Dinv[i] = rec.let(1 / D[i])
            if keep is not None:
                keep[i] = (U[i], Dinv[i])
            uu[i] = rec.let(-_dot(b.S, pi))
            Ia = [[Ii[r][s] - U[i][r] * U[i][s] * Dinv[i] for s in range(6)] for r in range(6)]
            Ia = rec.sym6(Ia)
            Iac = _times(Ia, c[i])
            pa = [pi[k] + Iac[k] + U[i][k] * uu[i] * Dinv[i] for k in range(6)]
        else:
            Ia = Ii
            pa = pi
        if b.parent >= 0:
            pa = rec.vec(pa)
            T = xt_inertia_x(b, rec, Ia)
            IA[b.parent] = [[IA[b.parent][r][s] + T[r][s] for s in range(6)] for r in range(6)]
            f = xt_force(b, pa)
            pA[b.parent] = [pA[b.parent][k] + f[k] for k in range(6)]
    a, out = [None] * n, []
    for i, b in enumerate(bodies):
        ap = a[b.parent] if b.parent >= 0 else _root_acceleration(gravity)
        ai = [x + y for x, y in zip(x_motion(b, ap), c[i])]
        if b.S is not None:
            ai = rec.vec(ai)
            udd = rec.let((uu[i] - _dot(U[i], ai)) * Dinv[i])
            ai = [ai[k] + b.S[k] * udd for k in range(6)]
            out.append((b.speed, udd, D[i]))
        a[i] = rec.vec(ai)
    return out


def rnea(bodies, rec, speed_accels, gravity, v, c):
    """Recursive Newton-Euler: {speed index: generalized force} for given accelerations."""
    n = len(bodies)
    f = [None] * n
    a = [None] * n
    for i, b in enumerate(bodies):
        ap = a[b.parent] if b.parent >= 0 else _root_acceleration(gravity)
        ai = [x + y for x, y in zip(x_motion(b, ap), c[i])]
        if b.S is not None:
            ai = [ai[k] + b.S[k] * speed_accels[b.speed] for k in range(6)]
        a[i] = rec.vec(ai)
        fi = [x + y for x, y in zip(_times(b.I, a[i]), cross_force(v[i], _times(b.I, v[i])))]
        if b.fext is not None:
            fi = [fi[k] - b.fext[k] for k in range(6)]
        f[i] = fi
    tau = {}
    for i in reversed(range(n)):
        b = bodies[i]
        fi = rec.vec(f[i])
        if b.S is not None:
            tau[b.speed] = rec.let(_dot(b.S, fi))
        if b.parent >= 0:
            fp = xt_force(b, fi)
            f[b.parent] = [f[b.parent][k] + fp[k] for k in range(6)]
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
            Ic[b.parent] = [[Ic[b.parent][r][s] + T[r][s] for s in range(6)] for r in range(6)]
        if b.S is None:
            continue
        F = rec.vec(_times(Ii, b.S))
        H[(b.speed, b.speed)] = rec.let(_dot(b.S, F))
        j = i
        while bodies[j].parent >= 0:
            F = rec.vec(xt_force(bodies[j], F))
            j = bodies[j].parent
            if bodies[j].S is not None:
                H[(b.speed, bodies[j].speed)] = H[(bodies[j].speed, b.speed)] = rec.let(_dot(bodies[j].S, F))
    return H
