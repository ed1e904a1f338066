"""The algebra of Kane's method on vector components, in plain symbols.

For every body and load we take its velocity (and angular velocity) as
components in one frame, read the partial velocities v_r, ω_r off as the
linear coefficients of the generalized speeds, and form

    F_r  = Σ v_r·R + ω_r·T                                  (loads)
    F_r* = −Σ [ v_r·m a + ω_r·(α·I + ω×I·ω) ]               (bodies)
         = −( Σ_s M_rs u_s' + nonM_r ),
    M_rs  = Σ m v_r·v_s + ω_r·I·ω_s                           (no d/du' needed)
    nonM_r = Σ v_r·(m a0 + m' v) + ω_r·(I α0 + I' ω + ω×I·ω)

where a0, α0 are the accelerations with every u' = 0.  Translational
quantities are taken in one frame F per body or load (the body's frame, else
the inertial frame N, else the frame most terms are in; see
:func:`component_frame`), so a = d/dt of the F components + ω_F × v;
rotational ones in the body frame B (α = d/dt of ω's B components, because
ᴺdω/dt = ᴮdω/dt).  Bodies or loads that share a partial velocity are summed
before the dot product (a chain's links share most of theirs), which keeps
the expressions short.
"""
from dataclasses import dataclass, field

import sympy as sm

from eomc.runtime.errors import ModelError

from .measure_numbers import tidy
from .kane_inputs import frame_ang_vel, point_velocity
from .plain import linear_coefficients

__all__ = ["VectorReader", "BodyTerms", "LoadTerms", "read_bodies", "read_loads", "to_dynamic",
           "assemble", "dot", "fewer_trig_squares", "FOLD_OPS"]

_ZERO3 = (sm.S.Zero, sm.S.Zero, sm.S.Zero)
FOLD_OPS = 300   # fewer_trig_squares is tried on expressions up to this many operations


def dot(a, b):
    return _pythagoras(sm.Add(*[x * y for x, y in zip(a, b) if x != 0 and y != 0]))


def _pythagoras(expr):
    """Merge c·sin(x)² + c·cos(x)² into c in a sum (cheap, exact).

    Components taken in the inertial frame turn v_r·v_r of a link into
    l²(sin² + cos²); folding it back keeps the mass matrix as short as
    a frame-wise dot product would make it.
    """
    if not expr.is_Add:
        return expr
    found, keep = {}, []
    for term in expr.args:
        coeff, factors = term.as_coeff_mul()
        for k, f in enumerate(factors):
            if f.is_Pow and f.exp == 2 and isinstance(f.base, (sm.sin, sm.cos)):
                rest = coeff * sm.Mul(*(factors[:k] + factors[k + 1:]))
                found.setdefault((rest, f.base.args[0]), {})[f.base.func] = term
                break
        else:
            keep.append(term)
    if not found:
        return expr
    for (rest, _), kinds in found.items():
        if len(kinds) == 2:
            keep.append(rest)
        else:
            keep.extend(kinds.values())
    return sm.Add(*keep)


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def matvec(m, v):
    return tuple(dot(row, v) for row in m)


def is_zero(v):
    return all(c == 0 for c in v)


def _axis_rotation(C):
    """(k, angle) if C is a simple rotation about basis axis k (SymPy's orient_axis form), else None."""
    for k in range(3):
        i, j = (k + 1) % 3, (k + 2) % 3
        if C[k, k] != 1 or any(C[k, x] != 0 or C[x, k] != 0 for x in (i, j)):
            continue
        c, s_ = C[i, i], C[j, i]
        if c != C[j, j] or C[i, j] != -s_ or not isinstance(c, sm.cos):
            return None
        angle = c.args[0]
        if s_ == sm.sin(angle):
            return k, angle
        if s_ == -sm.sin(angle):       # cos is even: the same rotation by -angle
            return k, -angle
        return None
    return None


def _rotation(k, angle):
    i, j = (k + 1) % 3, (k + 2) % 3
    C = sm.eye(3)
    C[i, i] = C[j, j] = sm.cos(angle)
    C[j, i], C[i, j] = sm.sin(angle), -sm.sin(angle)
    return C


def chained_dcm(to, frm):
    """``to.dcm(frm)`` with successive rotations about a shared axis merged into one.

    Why: SymPy multiplies the direction cosine matrices along the path of
    frames as they come, so a planar chain of n PinJoints (every joint about
    z) gives link n's orientation as nested products of n rotations, whose
    trees double in size with every link.  Rotations about the same basis axis
    compose to one rotation by the sum of the angles: Rz(q1) Rz(q2) =
    Rz(q1 + q2), the form a person would write.  Same value as ``to.dcm(frm)``.
    """
    if to == frm:
        return sm.eye(3)
    path = to._dict_list(frm, 0)
    factors = []                       # [(axis or None, angle or matrix)]
    for a, b in zip(path, path[1:]):
        C = a.dcm(b)
        rot = _axis_rotation(C)
        if rot is not None and factors and factors[-1][0] == rot[0]:
            factors[-1] = (rot[0], factors[-1][1] + rot[1])
        elif rot is not None:
            factors.append(rot)
        else:
            factors.append((None, C))
    out = None
    for axis, val in factors:
        C = val if axis is None else _rotation(axis, val)
        out = C if out is None else out * C
    return out


def run_angles(root):
    """Every sum of the angles of consecutive rotations about one basis axis in the frame
    graph around ``root`` (q2 + q3 for B3 oriented from B2 about z by q3, B2 from B1 about
    z by q2), with both signs.

    These are the angles :func:`chained_dcm` writes direction cosines in, so they are the
    ones worth contracting expanded sines and cosines into (:mod:`.measure_numbers`);
    contracting other pairs would only add sin/cos calls (the Whipple bicycle's rhs grew 2%).
    """
    frames, stack = {root}, [root]
    while stack:
        for g in stack.pop()._dcm_dict:
            if g not in frames:
                frames.add(g)
                stack.append(g)
    steps = {}                          # frame -> [(neighbour, axis, angle of frame rel. neighbour)]
    for f in frames:
        for g in f._dcm_dict:
            rot = _axis_rotation(f.dcm(g))
            if rot is not None:
                steps.setdefault(f, []).append((g, rot[0], rot[1]))
    out = set()

    def walk(f, axis, total, seen):
        for g, k, angle in steps.get(f, []):
            if k != axis or g in seen:
                continue
            s = total + angle
            out.update((s, -s))
            walk(g, axis, s, seen | {g})

    for f in steps:
        for axis in {k for _, k, _ in steps[f]}:
            walk(f, axis, sm.S.Zero, {f})
    return out


class VectorReader:
    """Reads SymPy Vectors/Dyadics as plain-symbol components in a chosen frame.

    Direction cosine matrices are converted to plain symbols once per frame
    pair and cached.  Measure numbers are tidied (:mod:`.measure_numbers`):
    expanded sines and cosines of the angle sums in ``angles`` contracted,
    terms grouped by speed.
    """

    def __init__(self, space, angles=()):
        self.space = space
        self._dcm = {}
        self._contracted = {}
        self._angles = frozenset(space.to_plain(a) for a in angles)

    def plain(self, expr):
        """A measure number in plain symbols, sines and cosines of angle sums contracted
        and terms grouped by speed (SymPy's kinematics of chained frames expand them:
        see :mod:`.measure_numbers`)."""
        return self._tidy(self.space.to_plain(expr))

    def _tidy(self, expr):
        return tidy(expr, self.space.speed_set, self._angles, self._contracted)

    def dcm(self, to, frm):
        key = (to, frm)
        if key not in self._dcm:
            try:
                C = chained_dcm(to, frm)
            except ValueError:
                raise ModelError(f"frame {frm.name} is not oriented relative to frame {to.name} "
                                 "(orient it with orient_axis/orientnew)") from None
            self._dcm[key] = [[self.space.to_plain(C[i, j]) for j in range(3)] for i in range(3)]
        return self._dcm[key]

    def dcm_cost(self, to, frm):
        """Operation count of the direction cosines from ``frm`` to ``to`` (0 for the same frame)."""
        if to == frm:
            return 0
        key = ("cost", to, frm)
        if key not in self._dcm:
            try:
                C = self.dcm(to, frm)
            except ModelError:
                return float("inf")
            self._dcm[key] = sum(sm.count_ops(e) + (e != 0) for row in C for e in row)
        return self._dcm[key]

    def components(self, vec, frame):
        acc = ([], [], [])
        for mat, f in vec.args:
            m = [self.plain(e) for e in mat]
            if f == frame:
                for i in range(3):
                    acc[i].append(m[i])
                continue
            C = self.dcm(frame, f)
            for i in range(3):
                acc[i].extend(C[i][j] * m[j] for j in range(3) if m[j] != 0 and C[i][j] != 0)
        return tuple(self._tidy(sm.Add(*a)) for a in acc)

    def dyadic_matrix(self, dyadic, frame):
        M = dyadic.to_matrix(frame)
        if {f for _, v1, v2 in dyadic.args for v in (v1, v2) for _, f in v.args} - {frame}:
            M = M.applyfunc(fewer_trig_squares)     # re-expressed: fold I*sin**2 + I*cos**2
        return tuple(tuple(self.plain(M[i, j]) for j in range(3)) for i in range(3))


def fewer_trig_squares(e):
    """``e`` with even powers of sin(x) written as powers of 1 - cos(x)**2, expanded,
    if that is shorter.

    A partial velocity spanning two frames (l*A.y + l*B.y) dotted with itself in
    one frame's components gives l**2*sin(q)**2 + (l*cos(q) + l)**2; SymPy's
    frame-by-frame dot gives 2*l**2*cos(q) + 2*l**2 -- the same value, which this
    recovers.  Used on inertia dyadics re-expressed in another frame (I*sin**2 +
    I*cos**2 -> I) and on the mass matrix of small systems (expanding is cheap there).
    """
    if not e.has(sm.sin):
        return e
    alt = sm.expand(e)
    pows = {p: (1 - sm.cos(p.base.args[0]) ** 2) ** (p.exp // 2) for p in alt.atoms(sm.Pow)
            if isinstance(p.base, sm.sin) and p.exp.is_Integer and p.exp > 0 and p.exp % 2 == 0}
    if not pows:
        return e
    alt = sm.expand(alt.xreplace(pows))
    return alt if sm.count_ops(alt) < sm.count_ops(e) else e


def partials(comps, speeds):
    """List over speeds of 3-tuples: the partial (angular) velocities."""
    cols = [linear_coefficients(c, speeds) for c in comps]
    return [tuple(cols[i][r] for i in range(3)) for r in range(len(speeds))]


@dataclass
class BodyTerms:
    """One body's pieces, in plain symbols (translation in frame F, rotation in B)."""
    name: str
    mass: sm.Expr
    frame: object            # F: the frame the translational components are taken in
    vr: list                 # partial velocities over u + u_aux, F components
    R0: tuple                # m a0 + m' v: the inertia force without the u' terms
    nR0: tuple = _ZERO3      # −R0 (negated once per body, not per equation)
    wr: list = field(default_factory=list)    # partial angular velocities, B components
    Iw: list = field(default_factory=list)    # I·ω_s for the main speeds
    T0: tuple = _ZERO3
    nT0: tuple = _ZERO3
    rframe: object = None    # B: the body frame the rotational components are taken in


@dataclass
class LoadTerms:
    name: str
    kind: str                # "force" or "torque"
    frame: object            # the frame the components are taken in
    pr: list                 # partial (angular) velocities over u + u_aux
    vec: tuple               # components of the force/torque


def _named(what, func, *args):
    """Call func; a ModelError from inside gets ``what`` (the body or load) in front."""
    try:
        return func(*args)
    except ModelError as exc:
        raise ModelError(f"{what}: {exc}") from None


def _zero_aux(space, comps):
    if not space.uaux:
        return comps
    z = dict.fromkeys(space.uaux, sm.S.Zero)
    return tuple(c.xreplace(z) for c in comps)


def component_frame(vec, inertial, reader, preferred=None):
    """The frame to take a velocity's components in: the cheapest of a few candidates.

    Candidates are a rigid body's own frame, the inertial frame and the frame
    most of the vector's terms are in; the cost of a candidate is the size of
    the direction cosines needed to bring every term into it (ties go to the
    earlier candidate).  A disc centre's velocity given in the disc frame
    stays in the disc frame; a double pendulum's bob velocity, with terms in
    two frames oriented from N, goes to N.
    """
    frames = [f for _, f in vec.args]
    candidates = [preferred] if preferred is not None else []
    candidates.append(inertial)
    if frames:
        candidates.append(max(frames, key=frames.count))
    candidates = list(dict.fromkeys(candidates))
    if len(candidates) == 1:
        return candidates[0]
    best, best_cost = None, None
    for F in candidates:
        cost = sum(reader.dcm_cost(F, f) for f in frames)
        if best_cost is None or cost < best_cost:
            best, best_cost = F, cost
    return best


def _rate_of_change(space, reader, inertial, frame, comps0, what):
    """ᴺd/dt of a vector given by its ``frame`` components, without the u' terms."""
    out = space.dt_vector(comps0, udot=False)
    if frame == inertial:
        return out
    w = _zero_aux(space, reader.components(frame_ang_vel(frame, inertial, what), frame))
    return tuple(a + b for a, b in zip(out, cross(w, comps0)))


def read_bodies(space, reader, inertial, bodies):
    speeds = space.u + space.uaux
    out = []
    for i, body in enumerate(bodies):
        what = f"body #{i + 1} ({body.name})"
        rigid = isinstance(body, sm.physics.mechanics.RigidBody)
        point = body.masscenter if rigid else body.point
        vel = point_velocity(point, inertial, what)
        F = component_frame(vel, inertial, reader, body.frame if rigid else None)
        v = _named(what, reader.components, vel, F)
        v0 = _zero_aux(space, v)
        m = space.to_plain(body.mass)
        if space.uaux:
            m = m.xreplace(dict.fromkeys(space.uaux, sm.S.Zero))
        R0 = tuple(m * a for a in _rate_of_change(space, reader, inertial, F, v0, what))
        dm = space.dt(m)
        if dm != 0:
            R0 = tuple(a + dm * b for a, b in zip(R0, v0))
        terms = BodyTerms(body.name, m, F, partials(v, speeds), R0, tuple(-c for c in R0))
        if rigid:
            _read_rotation(space, reader, inertial, body, terms, what)
        out.append(terms)
    return out


def _rotation_frame(reader, inertial, body):
    """The body frame, or -- when it is not oriented relative to N (a wheel given
    only an angular velocity) -- the frame its inertia dyadic is written in."""
    B = body.frame
    if reader.dcm_cost(B, inertial) != float("inf"):
        return B
    frames = [v.args[0][1] for arg in body.central_inertia.args for v in arg[1:] if v.args]
    for F in frames:
        if reader.dcm_cost(F, inertial) != float("inf"):
            return F
    return B


def _read_rotation(space, reader, inertial, body, terms, what):
    """ω_r, I·ω_s and T0 = I α0 + ω×I ω + (ᴮdI/dt) ω in the components of frame R.

    R is the body frame B whenever possible; then α = d/dt of ω's components.
    In another frame R, α = d/dt ω^R + ω_R × ω and ᴮdI/dt = dI^R/dt + Ω I − I Ω
    with Ω = [ω_{R/B} ×], which is SymPy's inertia torque term by term.
    """
    B = body.frame
    R = _rotation_frame(reader, inertial, body)
    speeds = space.u + space.uaux
    w = _named(what, reader.components, frame_ang_vel(B, inertial, what), R)
    w0 = _zero_aux(space, w)
    I = _named(what, reader.dyadic_matrix, body.central_inertia, R)
    if space.uaux:
        z = dict.fromkeys(space.uaux, sm.S.Zero)
        I = tuple(tuple(e.xreplace(z) for e in row) for row in I)
    terms.wr = partials(w, speeds)
    terms.Iw = [matvec(I, wr) for wr in terms.wr[:len(space.u)]]
    alpha0 = space.dt_vector(w0, udot=False)
    dI = [[space.dt(e) for e in row] for row in I]
    if R != B:
        wR = _zero_aux(space, reader.components(frame_ang_vel(R, inertial, what), R))
        alpha0 = tuple(a + b for a, b in zip(alpha0, cross(wR, w0)))
        Om = tuple(a - b for a, b in zip(wR, w0))          # ω of R relative to B
        cols = list(zip(*I))                                # (Ω I − I Ω), I symmetric
        for i in range(3):
            for j in range(3):
                dI[i][j] += cross(Om, cols[j])[i] + cross(Om, cols[i])[j]
    Iw0 = matvec(I, w0)
    T0 = tuple(a + b for a, b in zip(matvec(I, alpha0), cross(w0, Iw0)))
    if any(e != 0 for row in dI for e in row):
        T0 = tuple(a + b for a, b in zip(T0, matvec(dI, w0)))
    terms.T0 = T0
    terms.rframe = R
    terms.nT0 = tuple(-c for c in T0)


def to_dynamic(space, body_terms, load_terms):
    """Map every stored piece back to dynamic symbols, in place.

    Only the (small) partial velocities and u'-free accelerations are mapped;
    the large sums assembled from them are then born in dynamic symbols.
    """
    vec = lambda v: tuple(space.to_dynamic(c) for c in v)  # noqa: E731
    for b in body_terms:
        b.mass = space.to_dynamic(b.mass)
        b.vr = [vec(v) for v in b.vr]
        b.nR0 = vec(b.nR0)          # R0, T0 stay plain: only per-body reports use them
        b.wr = [vec(v) for v in b.wr]
        b.Iw = [vec(v) for v in b.Iw]
        b.nT0 = vec(b.nT0)
    for ld in load_terms:
        ld.pr = [vec(v) for v in ld.pr]
        ld.vec = vec(ld.vec)


def read_loads(space, reader, inertial, parsed_loads):
    speeds = space.u + space.uaux
    out = []
    for name, kind, vel, vec, where in parsed_loads:
        F = component_frame(vel, inertial, reader, where if kind == "torque" else None)
        what = f"load on {kind == 'torque' and 'frame' or 'point'} {name}"
        v = _named(what, reader.components, vel, F)
        f = _named(what, reader.components, vec, F)
        out.append(LoadTerms(name, kind, F, partials(v, speeds), f))
    return out


def _grouped(pairs):
    """Σ key·vec over (frame, key, vec) triples, summing the vecs that share a key first."""
    groups = {}
    for frame, key, vec in pairs:
        if is_zero(key) or is_zero(vec):
            continue
        groups.setdefault((frame, key), []).append(vec)
    out = []
    for (_, key), vecs in groups.items():
        total = tuple(sm.Add(*[v[i] for v in vecs]) for i in range(3))
        out.append(dot(key, total))
    return sm.Add(*out)


def assemble(body_terms, load_terms, n_rows, n_main):
    """Plain-symbol MM (n_rows x n_main), −nonMM and Fr (n_rows each).

    Rows 0..n_main-1 belong to the main speeds, the rest to auxiliary speeds.
    −nonMM (the inertia forces with u' = 0) is returned rather than nonMM so
    that no large sum ever has to be negated.
    """
    fr = [_grouped((ld.frame, ld.pr[r], ld.vec) for ld in load_terms) for r in range(n_rows)]
    neg_nonmm = []
    for r in range(n_rows):
        pairs = [(b.frame, b.vr[r], b.nR0) for b in body_terms]
        pairs += [(b.rframe, b.wr[r], b.nT0) for b in body_terms if b.wr]
        neg_nonmm.append(_grouped(pairs))
    return _mass_matrix(body_terms, n_rows, n_main), neg_nonmm, fr


def _mass_matrix(body_terms, n_rows, n_main):
    trans = {}
    rot = {}
    for b in body_terms:
        nz = [r for r in range(n_rows) if not is_zero(b.vr[r])]
        cols = [s for s in nz if s < n_main]
        for r in nz:
            for s in cols:
                if r < n_main and s < r:
                    continue
                trans.setdefault((r, s), {}).setdefault((b.vr[r], b.vr[s]), []).append(b.mass)
        if b.wr:
            nzw = [r for r in range(n_rows) if not is_zero(b.wr[r])]
            for r in nzw:
                for s in (s for s in nzw if s < n_main):
                    if r < n_main and s < r:
                        continue
                    rot.setdefault((r, s), []).append(dot(b.wr[r], b.Iw[s]))
    MM = [[sm.S.Zero] * n_main for _ in range(n_rows)]
    for (r, s) in set(trans) | set(rot):
        terms = [sm.Add(*ms) * dot(vr, vs) for (vr, vs), ms in trans.get((r, s), {}).items()]
        terms += rot.get((r, s), [])
        MM[r][s] = sm.Add(*terms)
        if r < n_main and s != r:
            MM[s][r] = MM[r][s]
    return MM
