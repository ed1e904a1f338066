"""The inverse-dynamics regressor of a tree: tau = Y(q, u, u') · pi, pi 10 numbers per body.

Why: inverse dynamics is linear in each body's inertial parameters
    pi_j = (m, m·cx, m·cy, m·cz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz)
(mass, first moments, inertia about the body's reference point; Pinocchio's
order, ``Inertia.toDynamicParameters``), so measured joint forces identify pi by
linear least squares.  The reference point and axes of a body are its link frame
when the model names its centre of mass by parameters ``cx_<body>``,
``cy_<body>``, ``cz_<body>`` (the URDF reader: the joint frame, as Pinocchio's),
else its mass centre (the tree's body origin).

How: the RNEA forward pass gives each body's spatial velocity v and acceleration
a (gravity as the base's acceleration), about the body origin O.  Moved to the
reference point P = O + d, the body's wrench about P is A(a_P, v_P)·pi with A
6x10 (the spatial inertia is linear in pi); moved back to O and up the tree by
the usual force transforms, its projection on each ancestor joint's axes is that
joint's row of the block.  Entries for bodies that do not hang below a joint are
structural zeros, never computed.  Applied loads (springs, dampers, inputs)
are not part of Y: Y·pi is inverse dynamics with the inputs at zero and no
other loads.
"""
import sympy as sm

from .spatial import _cross, _dot, _root_acceleration, cross_force, x_motion, xt_force

__all__ = ["PI_NAMES", "regressor_results", "reference_offsets"]

PI_NAMES = ("m", "mcx", "mcy", "mcz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")


def _generic():
    """(a symbols, v symbols, 6x10 coefficients of the wrench I a + v x* I v about P)."""
    a = sm.symbols("ra0:6", real=True)
    v = sm.symbols("rv0:6", real=True)
    m, hx, hy, hz, ixx, ixy, iyy, ixz, iyz, izz = pi = sm.symbols("rpi0:10", real=True)
    Ir = [[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]]
    H = [[0, -hz, hy], [hz, 0, -hx], [-hy, hx, 0]]             # h x
    I6 = [[Ir[i][j] for j in range(3)] + [H[i][j] for j in range(3)] for i in range(3)]
    I6 += [[H[j][i] for j in range(3)] + [m if i == j else 0 for j in range(3)] for i in range(3)]

    def times(x):
        return [sum((I6[i][k] * x[k] for k in range(6)), sm.S.Zero) for i in range(6)]
    f = [x + y for x, y in zip(times(a), cross_force(list(v), times(list(v))))]
    A = [[sm.expand(sm.diff(f[i], p)) for p in pi] for i in range(6)]
    return a, v, A


_GENERIC = None


def _coefficients():
    global _GENERIC
    if _GENERIC is None:
        _GENERIC = _generic()
    return _GENERIC


def _shift(m, d, rec):
    """Motion vector about O -> about O + d (same axes)."""
    w, lin = m[:3], m[3:]
    wd = _cross(w, d)
    return rec.vec(list(w) + [lin[i] + wd[i] for i in range(3)])


def reference_offsets(tree, layout):
    """Per body: d = reference point - mass centre in body axes (slot symbols or numbers), and
    what the reference point is ("link frame" or "mass centre")."""
    out = []
    names = list(layout.param_names)
    for b in tree.bodies:
        comps = []
        for axis in ("cx", "cy", "cz"):
            key = f"{axis}_{b.name}"
            if key in names:
                comps.append(-layout.p[names.index(key)])
            elif key in layout.folded:
                comps.append(-sm.Float(layout.folded[key]))
            else:
                comps.append(None)
        link_frame = any(c is not None for c in comps) or _link_frame_body(layout, b.name)
        out.append(([c if c is not None else sm.S.Zero for c in comps] if link_frame else [0, 0, 0],
                     "link frame" if link_frame else "mass centre"))
    return out


def _link_frame_body(layout, name):
    """A robot reader's body whose centre of mass is at its link origin (cx_ ... all structural zeros)."""
    return f"m_{name}" in layout.param_names or f"m_{name}" in layout.folded


def regressor_results(tree, bodies, rec, layout, speed_accels, gravity, v, c):
    """[(("Y", row, column), expression)] of the nonzero entries, and the body names of the
    column blocks (10 columns each, in tree order)."""
    geared = [b for b in tree.bodies if any(x != 0 for x in b.armature)]
    if geared:   # tau = Y pi would miss the armature's a u' (not a body's inertial parameter)
        from eomc.runtime.errors import ModelError
        raise ModelError(f"the inverse-dynamics regressor is not generated for a tree with armature "
                         f"(body {geared[0].name}, joint {geared[0].joint}): Y·pi would leave out "
                         f"its a·u' term")
    asym, vsym, A = _coefficients()
    n = len(bodies)
    offsets = reference_offsets(tree, layout)
    acc = [None] * n
    for i, b in enumerate(bodies):
        ap = acc[b.parent] if b.parent >= 0 else _root_acceleration(gravity)
        ai = [x + y for x, y in zip(x_motion(b, ap), c[i])]
        if b.S is not None:
            ai = [ai[k] + b.S[k] * speed_accels[b.speed] for k in range(6)]
        elif b.multi:
            for s, S in b.multi:
                ai = [ai[k] + S[k] * speed_accels[s] for k in range(6)]
        acc[i] = rec.vec(ai)
    out = []
    for j, b in enumerate(bodies):
        d = [sm.sympify(x) for x in offsets[j][0]]
        vP, aP = _shift(v[j], d, rec), _shift(acc[j], d, rec)
        subs = dict(zip(asym, aP))
        subs.update(zip(vsym, vP))
        cols = []
        for k in range(10):
            fP = [A[r][k].xreplace(subs) for r in range(6)]
            if all(x == 0 for x in fP):
                cols.append(None)
                continue
            fP = rec.vec(fP)
            dn = _cross(d, fP[3:])
            cols.append(rec.vec([fP[r] + dn[r] for r in range(3)] + fP[3:]))
        i = j
        while i >= 0:
            bi = bodies[i]
            dofs = [(bi.speed, bi.S)] if bi.S is not None else list(bi.multi or ())
            for s, S in dofs:
                for k, f in enumerate(cols):
                    if f is not None:
                        e = rec.let(_dot(S, f))
                        if e != 0:
                            out.append((("Y", s, 10 * j + k), e))
            if bi.parent < 0:
                break
            cols = [None if f is None else rec.vec(xt_force(bi, f)) for f in cols]
            i = bi.parent
    return out, tuple(b.name for b in tree.bodies), tuple(o[1] for o in offsets)
