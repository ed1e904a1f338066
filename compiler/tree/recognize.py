"""Find the tree of bodies and joints in a mechanics description.

Two sources give the same :class:`~.model.Tree`:

* a SymPy ``System`` with joints (PinJoint, PrismaticJoint, WeldJoint,
  SphericalJoint as three pins through massless frames, PlanarJoint as two
  sliders and a pin through massless frames, and joints of k speeds whose
  axes are constant in the child's frame -- CylindricalJoint, and the URDF
  reader's FloatingJoint and PlanarJoint with body-frame speeds -- as one
  k-speed joint, :func:`_multi_joint`): the joints name each body's parent;
* a KanesMethod built from hand-made frames and points (each frame oriented
  from another, each point located from another): the parent of a body is the
  body whose speeds are the largest subset of its own.

A System whose loops holonomic constraints close (one joint of each loop left out) is
read as its spanning tree, and the constraints ride along on it (``Tree.loops``,
:mod:`.constrained`), as are a KanesMethod's dependent speeds and its constraint
matrices; nonholonomic constraints are refused.

Either way each joint is then read in joint-local terms (:func:`_joint`): the
rotation and offset of the body relative to its parent as functions of the
joint's own coordinate, and the constant motion axis S of its speed.  These
are found by setting the other coordinates to zero and then *checked* against
SymPy's own kinematics at random states, so an unusual construction is
refused (NotATree, naming the body and joint) rather than mis-read.
"""
import random
from dataclasses import replace

import numpy as np
import sympy as sm
from sympy.core.function import AppliedUndef
from sympy.physics import mechanics as me

from .model import Load, NotATree, Tree, TreeBody

__all__ = ["tree_from_system", "tree_from_kane", "tree_of", "system_kinematics"]

_T = me.dynamicsymbols._t
_CHECKS = 2           # random states each joint-local form is checked at
_TOL = 1e-9


class _Numbers:
    """Random values for every symbol and dynamic symbol met, fixed per instance."""

    def __init__(self, seed=20261124):
        self.rng = random.Random(seed)
        self.sets = [{} for _ in range(_CHECKS)]

    def evaluate(self, expr, k):
        vals = self.sets[k]
        expr = sm.sympify(expr)
        for a in expr.atoms(AppliedUndef) | expr.free_symbols:
            if a not in vals:
                vals[a] = sm.Float(self.rng.uniform(0.3, 1.3))
        return sm.N(expr.xreplace(vals), 20)

    def same(self, a, b):
        """Equal at every random state; a non-finite value (0/0 from a coordinate set to
        zero, say) is never equal to anything."""
        for k in range(_CHECKS):
            for x, y in zip(sm.Matrix(a), sm.Matrix(b)):
                try:
                    vx, vy = complex(self.evaluate(x, k)), complex(self.evaluate(y, k))
                except (TypeError, ValueError):
                    return False
                if not (np.isfinite(vx) and np.isfinite(vy)):
                    return False
                if abs(vx - vy) > _TOL * max(1.0, abs(vx), abs(vy)):
                    return False
        return True


def _nm(x):
    """q1 for q1(t), in messages."""
    return str(x).replace("(t)", "")


def _dynamic(expr):
    return {a for a in sm.sympify(expr).atoms(AppliedUndef)}


def _dynamic_matrix(M):
    out = set()
    for c in M:
        out |= _dynamic(c)
    return out


def _vector_atoms(vec):
    out = set()
    for comps, _frame in vec.args:
        for c in comps:
            out |= _dynamic(c)
    return out


class _Reader:
    """Shared state of one recognition: coordinates, speeds, kinematics, numbers."""

    def __init__(self, frame, origin, coordinates, speeds, kinematics):
        self.N, self.O = frame, origin
        self.q, self.u = tuple(coordinates), tuple(speeds)
        self.kin = tuple(kinematics)
        self.qd = {qi.diff(_T): k for qi, k in zip(self.q, self.kin)}
        self.qd_of = dict(zip(self.q, self.kin))
        self.q_set, self.u_set = set(self.q), set(self.u)
        self.numbers = _Numbers()
        self.notes = []             # joints read through SymPy's kinematics, and why
        self.coordinate_of = {}     # speed index -> coordinate index with q' = c·u, c constant
        first = {}                  # speed -> its first index (a dict: `in`/.index on the tuple were O(n²))
        for j, s in enumerate(self.u):
            first.setdefault(s, j)
        for i, k in enumerate(self.kin):
            atoms = [a for a in _dynamic(k)]
            if len(atoms) == 1 and atoms[0] in first:
                c = sm.simplify(k / atoms[0])
                if not _dynamic(c) and c != 0:
                    self.coordinate_of.setdefault(first[atoms[0]], i)

    def vec(self, v, frame):
        return sm.Matrix(v.to_matrix(frame)).xreplace(self.qd) if v != 0 else sm.zeros(3, 1)

    def only(self, expr, keep):
        """``expr`` with every coordinate but ``keep`` set to zero."""
        expr = sm.Matrix(expr)
        return expr.xreplace({qi: 0 for qi in _dynamic_matrix(expr) & self.q_set if qi != keep})

    def speeds_in(self, *vectors):
        """Indices of the speeds in ``vectors`` (coordinate rates counted by their
        kinematics), read off the components without building new Vectors."""
        if not hasattr(self, "_u_index"):
            self._u_index = {s: i for i, s in enumerate(self.u)}
        atoms = set()
        for v in vectors:
            for comps, _frame in (v.args if v != 0 else ()):
                for c in comps:
                    c = sm.sympify(c)
                    atoms |= c.atoms(AppliedUndef)
                    for d in c.atoms(sm.Derivative):
                        if d in self.qd:
                            atoms |= _dynamic(self.qd[d])
        return frozenset(self._u_index[a] for a in atoms if a in self._u_index)


def _relative_motion(rd, where, frame, pframe, origin, porigin):
    """A joint as SymPy's kinematics have it: E (parent -> child components), r (the child
    origin from the parent's, parent components) and the child's angular and linear
    velocity relative to the parent (one 6-vector, child components)."""
    try:
        E_full = sm.Matrix(frame.dcm(pframe))
        r_vec = origin.pos_from(porigin)
        w_rel = frame.ang_vel_in(pframe)
        v_rel = r_vec.dt(pframe)
    except ValueError as exc:
        raise NotATree(f"{where}: its frame or point is not connected to its parent's ({exc})") from None
    return E_full, rd.vec(r_vec, pframe), rd.vec(w_rel, frame).col_join(rd.vec(v_rel, frame))


def _near_dcm(A, B):
    """A.dcm(B) (B components -> A components) when A is B or was oriented directly from B
    (or B from A): one dictionary look-up, never SymPy's search of the frame graph."""
    if A is B:
        return sm.eye(3)
    direct = A._dcm_dict.get(B)
    return None if direct is None else sm.Matrix(direct)


def _near_pos(P, Q):
    """P.pos_from(Q) when P is Q or one was located directly from the other, else None."""
    if P is Q:
        return me.Vector(0)
    direct = P._pos_dict.get(Q)
    return direct


def _mul(A, B):
    """A·B of small SymPy matrices, skipping identity factors and zero terms (SymPy's own
    product goes through its domain machinery: most of a joint's reading time)."""
    if _is_eye(A):
        return B
    if _is_eye(B):
        return A
    rows, inner, cols = A.shape[0], A.shape[1], B.shape[1]
    return sm.Matrix(rows, cols, lambda i, j: sm.Add(*[A[i, k] * B[k, j] for k in range(inner)
                                                       if A[i, k] != 0 and B[k, j] != 0]))


def _is_eye(A):
    return A.shape[0] == A.shape[1] and all(
        A[i, j] == (1 if i == j else 0) for i in range(A.shape[0]) for j in range(A.shape[1]))


def _components(vec, known):
    """``vec``'s components in the frame ``known`` maps to ({frame: DCM to it}), or None
    when it names a frame not in ``known``."""
    out = sm.zeros(3, 1)
    if vec == 0:
        return out
    for comps, f in vec.args:
        D = known.get(f)
        if D is None:
            return None
        out += _mul(D, sm.Matrix(comps))
    return out


def _rate(expr, rd):
    """d/dt of ``expr`` (a function of coordinates) with q' from the kinematics: the
    coordinates become plain symbols for the differentiation (SymPy differentiates with
    respect to a symbol much faster than through q(t)'s chain rule)."""
    qs = [qi for qi in _dynamic(expr) if qi in rd.qd_of]
    if not qs:
        return sm.zeros(*expr.shape)
    plain = {qi: sm.Dummy() for qi in qs}
    back = {v: k for k, v in plain.items()}
    e = expr.xreplace(plain)
    out = sm.zeros(*expr.shape)
    for qi in qs:    # element by element: Matrix.diff goes through array derivatives, slowly
        d = sm.Matrix(expr.shape[0], expr.shape[1], [c.diff(plain[qi]) for c in e])
        out += d.xreplace(back) * rd.qd_of[qi]
    return out


def _joint_motion(rd, joint, pframe, porigin, frame, origin):
    """A joint's relative motion (as :func:`_relative_motion` returns it) read from the
    joint object alone: the DCMs and position vectors its constructor set between the
    parent body, the parent interframe and point, the child interframe and point and the
    child body (each one hop), the relative angular velocity it set on the interframes and
    the derivative of the offset in the parent's frame.  No frame-graph search: O(1) per
    joint.  None (and a note on ``rd``) when a piece is not one hop away -- a frame or
    point the user related through others --; the caller then asks SymPy's kinematics.

    The velocity SymPy stored for the child's mass centre relative to the parent (SymPy's
    joints set it) is compared with the one read here at random numbers, so a joint class
    whose velocities contradict its positions is refused, not mis-read."""
    t = _T
    pi, ci = joint.parent_interframe, joint.child_interframe
    pp, cp = joint.parent_point, joint.child_point
    D_pb_pi, D_ci_pi, D_cb_ci = _near_dcm(pframe, pi), _near_dcm(ci, pi), _near_dcm(frame, ci)
    pieces = [_near_pos(pp, porigin), _near_pos(cp, pp), _near_pos(origin, cp)]
    w = ci._ang_vel_dict.get(pi)
    if any(D is None for D in (D_pb_pi, D_ci_pi, D_cb_ci)) or any(v is None for v in pieces) \
            or w is None or _dynamic(D_pb_pi) or _dynamic(D_cb_ci):
        rd.notes.append(f"joint {joint.name}: its frames or points are not one step from its "
                        f"bodies' (read through SymPy's kinematics)")
        return None
    D_pb_ci = _mul(D_pb_pi, D_ci_pi.T)
    D_pb_cb = _mul(D_pb_ci, D_cb_ci.T)
    to_parent = {pframe: sm.eye(3), pi: D_pb_pi, ci: D_pb_ci, frame: D_pb_cb}
    E = D_pb_cb.T                      # parent components -> child components
    D_cb_pi = _mul(D_cb_ci, D_ci_pi)
    to_child = {frame: sm.eye(3), ci: D_cb_ci, pi: D_cb_pi, pframe: E}
    parts = [_components(v, to_parent) for v in pieces]
    if any(c is None for c in parts):
        rd.notes.append(f"joint {joint.name}: an offset names a frame other than its bodies' "
                        f"and interframes (read through SymPy's kinematics)")
        return None
    r = parts[0] + parts[1] + parts[2]
    w_child = _components(w, to_child)
    if w_child is None:
        rd.notes.append(f"joint {joint.name}: its angular velocity names a frame other than its "
                        f"interframes (read through SymPy's kinematics)")
        return None
    qd = rd.qd
    w_child = w_child.xreplace(qd)
    fixed_in_child = _components(pieces[2], to_child)
    if not _dynamic_matrix(parts[0]) and not _dynamic_matrix(fixed_in_child):
        # the parent point is fixed in the parent and the child's origin in the child: only
        # the joint's own offset moves, the rest turns with the child (v = ṙ_J + ω × ρ)
        v_child = _mul(E, _rate(parts[1], rd)) + w_child.cross(fixed_in_child)
    else:
        v_child = _mul(E, _rate(r, rd))
    stored = origin._vel_dict.get(pframe)
    if stored is not None:
        c = _components(stored, to_child)
        if c is not None and not rd.numbers.same(c.xreplace(qd), v_child):
            raise NotATree(f"joint {joint.name}: the velocity SymPy stored for {origin} relative "
                           f"to {pframe} is not the rate of change of its position")
    return E, r, w_child.col_join(v_child)


def _joint(rd, name, joint, parent, pframe, porigin, frame, origin, speed, local=None):
    """TreeBody geometry of ``frame``/``origin`` hanging from ``pframe``/``porigin``.

    ``local``: the joint's relative motion read from its own objects
    (:func:`_joint_motion`), else SymPy's kinematics are asked (:func:`_relative_motion`)."""
    where = f"body {name} (joint {joint})"
    if speed is None:
        keep = None
    else:
        if speed not in rd.coordinate_of:
            raise NotATree(f"{where}: its speed {_nm(rd.u[speed])} is not a constant times the time "
                           f"derivative of one coordinate (q' = c·u), which the recursion needs")
        keep = rd.q[rd.coordinate_of[speed]]
    E_full, r_full, wv = local or _relative_motion(rd, where, frame, pframe, origin, porigin)
    if _dynamic(E_full) | _dynamic(r_full) <= {keep}:
        E, r = E_full, r_full           # nothing else to set to zero: no check needed
    else:
        E, r = rd.only(E_full, keep), rd.only(r_full, keep)
        if not (rd.numbers.same(E, E_full) and rd.numbers.same(r, r_full)):
            raise NotATree(f"{where}: its placement relative to body {parent} depends on more than "
                           f"its own coordinate {keep}")
    if speed is None:
        if any(sm.expand(c) != 0 for c in wv) and not rd.numbers.same(wv, sm.zeros(6, 1)):
            raise NotATree(f"{where}: moves relative to its parent without a speed of its own")
        return "fixed", E, r, None
    us = rd.u[speed]
    present = _dynamic_matrix(wv) & rd.u_set
    if local and all(c == 0 for c in wv.xreplace({v: 0 for v in present})):
        # linear in the speeds by construction: read the axis off, checked numerically below
        S = wv.xreplace({v: (1 if v == us else 0) for v in present})
    else:
        S = sm.Matrix([sm.expand(c).diff(us) for c in wv])
    S = sm.Matrix([sm.nsimplify(c) if c.is_Float else c for c in
                   (rd.only(S, None).xreplace({v: 0 for v in _dynamic_matrix(S) & rd.u_set}))])
    if _dynamic(S) or not (all(sm.expand(a - b) == 0 for a, b in zip(S * us, wv))
                           or rd.numbers.same(S * us, wv)):
        raise NotATree(f"{where}: its velocity relative to its parent is not a constant axis "
                       f"times {_nm(us)} (only revolute, prismatic and fixed joints are recursive)")
    if all(c == 0 for c in S):
        raise NotATree(f"{where}: its speed {_nm(us)} does not move it relative to its parent")
    kind = "revolute" if any(c != 0 for c in S[:3]) else "prismatic"
    return kind, E, r, tuple(S)


def _effective_inertias(rd, bodies):
    """Each body's inertia reduced to the part its motion can excite, so that only symbols
    the equations use become parameters (Kane's equations drop the rest too).

    A body that never turns (every joint from the ground to it translates or is fixed)
    feels none of its rotational inertia; one that turns about a single axis a fixed in
    it (all those joints' axes parallel: a planar chain) feels only aᵀIa.  Zeroing the
    rest is exact: the inertia moments it removes are perpendicular to every joint axis
    on the way, so they do no work in any speed (in ABA they only reach the ground's
    articulated inertia, which nothing reads).  A turning axis is checked constant in
    the body at random states; anything else keeps the whole inertia."""
    out, axis = [], {}
    for i, b in enumerate(bodies):
        own = [m[:3] for _, m in b.dofs if any(c != 0 for c in m[:3])]
        inherited = axis.get(b.parent) if b.parent >= 0 else None
        mine = "general"
        if len(own) > 1 or isinstance(inherited, str):
            pass
        elif inherited is None:
            mine = sm.Matrix(own[0]) if own else None
        else:
            a = _mul(b.rotation, inherited)              # the parent's axis in this body
            if _dynamic_matrix(a):
                a0 = rd.only(a, None)
                a = a0 if rd.numbers.same(a0, a) else None
            if a is not None and not own:
                mine = a
            elif a is not None and _parallel(rd, a, sm.Matrix(own[0])):
                mine = sm.Matrix(own[0])
        axis[i] = mine
        if isinstance(mine, str) or b.inertia == sm.zeros(3, 3):
            out.append(b)
            continue
        if mine is None:
            I = sm.zeros(3, 3)
        else:
            aa = (mine.T * mine)[0]
            I = (mine.T * b.inertia * mine)[0] / aa**2 * (mine * mine.T)
            I = I.applyfunc(sm.expand)
        out.append(replace(b, inertia=I))
    return out


def effective_inertias(bodies, coordinates, speeds, kinematics):
    """:func:`_effective_inertias` for a tree built elsewhere (the URDF reader's), so that
    both routes to a tree name the same parameters."""
    return _effective_inertias(_Reader(None, None, coordinates, speeds, kinematics), list(bodies))


def _parallel(rd, a, w):
    """a ∥ w (constant vectors, or checked at random numbers)."""
    c = a.cross(w)
    return all(sm.expand(x) == 0 for x in c) or rd.numbers.same(c, sm.zeros(3, 1))


def _inertia(body, frame):
    if body is None:              # a massless intermediate frame of a ball joint
        return sm.S.Zero, sm.zeros(3, 3)
    if isinstance(body, me.RigidBody):
        central = body.central_inertia
        I = sm.Matrix(central.to_matrix(frame)) if central != 0 else sm.zeros(3, 3)
        return body.mass, I
    return body.mass, sm.zeros(3, 3)


def _loads(rd, loads, bodies, frames, origins, names):
    """Loads as Load records; forces m·G at every massive body's centre become gravity."""
    out, candidates = [], []
    for load in loads or ():
        where, vec = load[0], load[1]
        if vec == 0:
            continue
        if isinstance(where, me.Point):
            hit = [i for i, o in enumerate(origins) if o == where]
            if hit:
                i, offset = hit[0], sm.zeros(3, 1)
            else:
                i, offset = _point_on_body(rd, where, frames, origins, names)
            moment, force = None, vec
        else:
            hit = [i for i, f in enumerate(frames) if f == where]
            if not hit:
                if where == rd.N:
                    continue      # a reaction on the ground does no work
                raise NotATree(f"a torque acts on frame {where}, which is no body's frame")
            i, offset, moment, force = hit[0], sm.zeros(3, 1), vec, None
        if i is None:
            continue
        if force is not None and offset == sm.zeros(3, 1):
            candidates.append((len(out), i, vec))
        out.append((i, offset, moment, force))
    gravity, skip = _gravity(rd, candidates, bodies)
    records = []
    for k, (i, offset, moment, force) in enumerate(out):
        if k in skip:
            continue
        v = moment if moment is not None else force
        comps = _body_components(rd, v, frames[i])
        local = comps is not None
        comps = comps if local else rd.vec(v, rd.N)
        zero = sm.zeros(3, 1)
        records.append(Load(body=i, frame="body" if local else "world",
                            moment=comps if moment is not None else zero,
                            force=comps if force is not None else zero, offset=offset))
    return gravity, tuple(records)


def _body_components(rd, vec, frame):
    """``vec`` in ``frame`` components if they do not change with the motion, else None.

    A joint's torque is often written along its axis in a joint frame (the URDF
    reader's, SymPy's interframes) one orientation away from the body frame: its
    body components are then constant (the axis turns with the body), and the
    recursion applies it in the body without building world rotations.  Only frames
    oriented directly from ``frame`` are tried (one DCM: cheap); the constancy is
    checked at random states like the joints."""
    used = {f for _, f in vec.args}
    if used <= {frame}:
        return rd.vec(vec, frame)
    if not all(f in frame._dcm_dict for f in used):
        return None
    comps = rd.vec(vec, frame)
    fixed = comps.xreplace({qi: 0 for qi in rd.q})
    return fixed if rd.numbers.same(fixed, comps) else None


def _gravity(rd, candidates, bodies):
    """G if every massive body carries exactly m·G at its centre (then those loads are skipped)."""
    massive = [i for i, b in enumerate(bodies) if b[3] != 0]
    by_body = {}
    for k, i, vec in candidates:
        G = sm.expand(rd.vec(vec, rd.N) / bodies[i][3]) if bodies[i][3] != 0 else None
        if G is not None and not _dynamic(G):
            by_body.setdefault(i, []).append((k, G))
    if not massive or any(len(by_body.get(i, ())) < 1 for i in massive):
        return sm.zeros(3, 1), set()
    G = by_body[massive[0]][0][1]
    chosen = set()
    for i in massive:
        match = [k for k, g in by_body[i] if sm.expand(g - G) == sm.zeros(3, 1)]
        if not match:
            return sm.zeros(3, 1), set()
        chosen.add(match[0])
    return G, chosen


def _point_on_body(rd, point, frames, origins, names):
    """(body, offset) of a point fixed in a body; (None, None) for a point fixed in the ground.

    Bodies whose origin the point was located from (or located) are tried first: the
    others' offsets would be expressed through long chains of frames."""
    if point == rd.O or (rd.N in point._vel_dict and point._vel_dict[rd.N] == 0):
        return None, None
    near = [i for i, o in enumerate(origins) if o in point._pos_dict]
    order = near + [i for i in range(len(origins)) if i not in near]
    for i in order:
        f, o = frames[i], origins[i]
        try:
            rho = rd.vec(point.pos_from(o), f)
        except ValueError:
            continue
        rho0 = rd.only(rho, None)
        if not _dynamic(rho0) and rd.numbers.same(rho0, rho):
            return i, rho0
    try:
        if point.vel(rd.N) == 0:
            return None, None
    except ValueError:
        pass
    raise NotATree(f"a force acts at point {point}, which is fixed in no body")


def _assemble(rd, entries, loads):
    """entries: (name, joint, parent index, body, frame, origin, speed index) in tree order."""
    bodies, frames, origins = [], [], []
    for name, joint, parent, body, frame, origin, speed, *obj in entries:
        pframe, porigin = (rd.N, rd.O) if parent < 0 else (frames[parent], origins[parent])
        pname = "ground" if parent < 0 else bodies[parent].name
        mass, I = _inertia(body, frame)
        local = _joint_motion(rd, obj[0], pframe, porigin, frame, origin) if obj and obj[0] else None
        if isinstance(speed, tuple):          # one joint of several speeds
            kind, E, r, motions = _multi_joint(rd, name, joint, pname, pframe, porigin, frame,
                                               origin, speed, local)
            bodies.append(TreeBody(name=name, joint=joint, kind=kind, parent=parent, speed=None,
                                   rotation=E, position=r, motion=None, mass=mass, inertia=I,
                                   speeds=speed, motions=motions))
        else:
            kind, E, r, S = _joint(rd, name, joint, pname, pframe, porigin, frame, origin, speed,
                                   local)
            bodies.append(TreeBody(name=name, joint=joint, kind=kind, parent=parent, speed=speed,
                                   rotation=E, position=r, motion=S, mass=mass, inertia=I))
        frames.append(frame)
        origins.append(origin)
    used = [k for b in bodies for k, _ in b.dofs]
    missing = [_nm(rd.u[k]) for k in range(len(rd.u)) if k not in used]
    if missing:
        raise NotATree(f"speed(s) {', '.join(missing)} move no body: no inertia resists them, "
                       f"so their accelerations are undefined (a mass on the axis it turns about?)")
    if len(set(used)) != len(used):
        raise NotATree("a speed moves two bodies relative to their parents: not a tree of one-speed joints")
    bodies = _effective_inertias(rd, bodies)
    basic = [(b.name, frames[i], origins[i], b.mass) for i, b in enumerate(bodies)]
    gravity, records = _loads(rd, loads, basic, frames, origins, [b.name for b in bodies])
    return Tree(bodies=tuple(bodies), coordinates=rd.q, speeds=rd.u, kinematics=rd.kin,
                gravity=gravity, loads=records, notes=tuple(rd.notes))


def system_kinematics(system):
    """Explicit q' of a SymPy System's kinematic differential equations.

    Each equation is read for the coordinate rates it contains (a joint's own: one
    look at its atoms, not the n x n Jacobian, which costs O(n²) derivatives); when every
    equation holds one rate linearly (q' = f(q, u) solved up to a factor, what every
    joint writes) it is solved alone, else the rates are solved together."""
    if _is_kane(system):        # a KanesMethod: its kd_eqs were solved by its constructor
        qdot = system.kindiffdict()
        return tuple(qdot[qi.diff(_T)] for qi in system.q)
    q = list(system.q)
    qd = [qi.diff(_T) for qi in q]
    kdes = list(system.kdes)
    if len(kdes) != len(q):
        raise NotATree(f"the system has {len(q)} coordinates but {len(kdes)} kinematic equations")
    where = {d: i for i, d in enumerate(qd)}
    solved = [None] * len(q)
    for e in kdes:
        e = sm.sympify(e)
        rates = [d for d in e.atoms(sm.Derivative) if d in where]
        if len(rates) != 1 or solved[where[rates[0]]] is not None:
            break
        d = rates[0]
        K = e.diff(d)
        if _dynamic(K) or K.has(sm.Derivative) or K == 0:
            break
        rest = e.xreplace({d: 0})
        solved[where[d]] = -rest * K if K in (1, -1) else sm.simplify(-rest / K)
    else:
        return tuple(solved)
    K = sm.Matrix(kdes).jacobian(qd)
    rest = sm.Matrix(kdes).xreplace({d: 0 for d in qd})
    return tuple(-K.LUsolve(rest))


def tree_from_system(system, kinematics=None):
    """Tree of a SymPy ``System`` built with joints (see the module docstring).

    Each joint object names its parent and child and carries its interframes, points,
    coordinates and speeds: the tree is put in order from them (parents before
    children, one pass) and each joint is read from its own objects
    (:func:`_joint_motion`), so the cost grows linearly with the number of joints."""
    if _is_kane(system):        # a KanesMethod with pending equations (tree_formed's way in)
        return tree_from_kane(system, kinematics if kinematics is not None
                              else system_kinematics(system))
    if len(getattr(system, "nonholonomic_constraints", ())):
        raise NotATree(_constrained(system))
    kin = kinematics if kinematics is not None else system_kinematics(system)
    # loop-closing (holonomic) constraints: the spanning tree plus a constraint solve
    # (compiler/tree/constrained.py); read before the tree, so a refusal costs nothing
    from .constrained import attach, loops_of_system
    loops = loops_of_system(system, system.q, system.u, kin)
    rd = _Reader(system.frame, system.fixed_point, system.q, system.u, kin)
    ground = [b for b in system.bodies if getattr(b, "frame", None) == system.frame
              and b.masscenter == system.fixed_point]
    speed_index = {s: i for i, s in enumerate(rd.u)}
    parent_of, body_frame, children = {}, {}, {}
    for j in system.joints:
        if j.child in parent_of:
            raise NotATree(f"body {j.child.name} is the child of joints {parent_of[j.child][0]} and "
                           f"{j.name}: a closed loop, not a tree (leave one joint of the loop out "
                           f"and close the loop with holonomic constraints instead)")
        speed = speed_index[j.speeds[0]] if len(j.speeds) else None
        if len(j.speeds) > 1 and not isinstance(j, _STAGED):
            speed = tuple(speed_index[s] for s in j.speeds)
        parent_of[j.child] = (j.name, j.parent, speed, j)
        children.setdefault(j.parent, []).append(j.child)
        body_frame[j.child] = j.child.frame if hasattr(j.child, "frame") else j.child_interframe
    order, index, added = [], {}, []
    remaining = [b for b in system.bodies if b not in ground]
    for b in remaining:
        if b not in parent_of:
            raise NotATree(f"body {b.name} is attached by no joint")
    members = set(remaining)
    queue = [b for b in remaining if parent_of[b][1] in ground]
    while queue:
        b = queue.pop(0)
        jname, p, speed, joint = parent_of[b]
        pi = -1 if p in ground else index[p]
        obj = joint
        if isinstance(joint, me.SphericalJoint):
            pi, speed = _ball_stages(system, joint, pi, order, added)
            obj = None
        elif isinstance(joint, me.PlanarJoint):
            pi, speed = _planar_stages(system, joint, pi, order, added)
            obj = None
        index[b] = len(order)
        order.append((b.name, jname, pi, b, body_frame[b], b.masscenter, speed, obj))
        queue += [c for c in children.get(b, ()) if c in members]
    if len(index) < len(remaining):
        raise NotATree("joints " + ", ".join(parent_of[b][0] for b in remaining if b not in index)
                       + " form a loop or hang from a body outside the system")
    # actuators (springs, dampers, forces, torques along pathways) act through their loads
    loads = list(system.loads) + [load for actuator in system.actuators for load in actuator.to_loads()]
    try:
        return attach(_assemble(rd, order, loads), loops)
    finally:
        _forget(added)


_STAGED = (me.SphericalJoint, me.PlanarJoint)   # read as single-axis stages, not as one joint


def _constrained(system):
    """Why a System with nonholonomic constraints is not taken, naming the joints the
    constraints tie and the dependent variables (holonomic ones close loops on the tree:
    compiler/tree/constrained.py)."""
    hol = list(getattr(system, "holonomic_constraints", ()))
    nonhol = list(getattr(system, "nonholonomic_constraints", ()))
    atoms = set()
    for c in hol + nonhol:
        atoms |= {a for a in sm.sympify(c).atoms(AppliedUndef)}
        atoms |= {d.expr for d in sm.sympify(c).atoms(sm.Derivative)}
    tied = [j.name for j in system.joints
            if atoms & (set(getattr(j, "coordinates", ())) | set(getattr(j, "speeds", ())))]
    dep = [_nm(x) for x in list(getattr(system, "q_dep", ())) + list(getattr(system, "u_dep", ()))]
    kinds = ", ".join(f"{len(c)} {k} constraint{'s' if len(c) != 1 else ''}"
                      for c, k in ((hol, "holonomic"), (nonhol, "nonholonomic")) if len(c))
    why = f"{kinds or 'constraints'}" + (f" (dependent {', '.join(dep)})" if dep else "")
    only = "the recursion takes loop-closing (holonomic) constraints only"
    if len(tied) > 1:
        return f"joints {', '.join(tied)} are tied by {why}; {only}"
    if tied:
        return f"joint {tied[0]} is constrained: {why}; {only}"
    return f"the system has {why}: {only}"


def _ball_stages(system, joint, parent, order, added):
    """A ball joint as three pins: append two massless intermediate stages to ``order``.

    SphericalJoint orients the child's joint frame from the parent's by three
    successive rotations (body- or space-fixed, in its rotation order) through the
    coordinates, with speeds that are their rates; so the same motion is three
    single-axis rotations about the joint point.  Two frames A1, A2 are made for the
    stages in between (massless bodies: the recursion needs only the articulated
    inertia beyond them to be non-zero); the third stage is the child itself.  Every
    stage is then read and checked like any joint (:func:`_joint`), so a rotation that
    does not decompose this way (custom amounts, say) is refused, not mis-read.
    Returns the index of the last intermediate stage (the child's parent) and the
    index of the speed the child's own stage turns with."""
    kind = joint._rot_type.upper()
    axes = [int(c) - 1 for c in str(joint._rot_order)]
    amounts = list(joint._amounts if joint._amounts is not None else joint.coordinates)
    speeds = list(joint.speeds)
    steps = list(zip(axes, amounts, speeds))
    if kind == "SPACE":       # space-fixed 1,2,3 = body-fixed 3,2,1
        steps.reverse()
    if len(steps) != 3 or kind not in ("BODY", "SPACE"):
        raise NotATree(f"joint {joint.name}: a {kind} rotation of order {joint._rot_order} is not "
                       f"three single-axis rotations")
    frame, index = joint.parent_interframe, parent
    for k, (axis, amount, speed) in enumerate(steps[:2]):
        A = me.ReferenceFrame(f"{joint.name}_stage{k + 1}")
        A.orient_axis(frame, frame.x if axis == 0 else frame.y if axis == 1 else frame.z, amount)
        A.set_ang_vel(frame, speed * [frame.x, frame.y, frame.z][axis])
        added.append((A, frame))
        order.append((f"{joint.name}_stage{k + 1}", joint.name, index, None, A, joint.parent_point,
                      list(system.u).index(speed)))
        frame, index = A, len(order) - 1
    return index, list(system.u).index(steps[2][2])


def _planar_stages(system, joint, parent, order, added):
    """SymPy's PlanarJoint as two sliders and a pin: two massless stages appended to ``order``.

    SymPy's planar speeds are the rates of the in-plane coordinates along the
    parent's plane vectors (parent-frame directions, so not constant axes of the
    child, which turns): the same motion is a slide along each plane vector, then
    the turn about the plane's normal.  Stage k is a frame aligned with the parent
    interframe whose origin slides from the previous one; the child is the third
    stage.  Each stage is read and checked like any joint (:func:`_joint`), so other
    speeds (say, body-frame ones) are refused naming the joint.  Returns the last
    stage's index and the rotation speed's index."""
    P = joint.parent_interframe
    point, index = joint.parent_point, parent
    for k, (vec, coord, speed) in enumerate(zip(joint.planar_vectors, joint.planar_coordinates,
                                                joint.planar_speeds)):
        A = me.ReferenceFrame(f"{joint.name}_stage{k + 1}")
        A.orient_explicit(P, sm.eye(3))
        A.set_ang_vel(P, 0)
        added.append((A, P))
        stage = me.Point(f"{joint.name}_stage{k + 1}")
        stage.set_pos(point, coord * vec)
        added.append((stage, point))
        order.append((f"{joint.name}_stage{k + 1}", joint.name, index, None, A, stage,
                      list(system.u).index(speed)))
        point, index = stage, len(order) - 1
    return index, list(system.u).index(joint.rotation_speed)


def _multi_joint(rd, name, joint, parent, pframe, porigin, frame, origin, speeds, local=None):
    """A joint of k speeds (indices ``speeds``) read as one: E(q_J), r(q_J) and constant axes.

    Its coordinates q_J are those whose rates the kinematics give in terms of its
    speeds (q' = f(q, u) in general: a free joint's Euler-angle rates are not its
    body-frame angular velocity).  Like :func:`_joint`, the joint-local forms are
    found by zeroing everything else and then checked against SymPy's kinematics
    at random states; the axes S_k = ∂(ω, v)/∂u_k in the child's frame must be
    constants, which holds for body-frame speeds (free, URDF planar) and for a
    cylindrical joint, and not for speeds along parent-frame directions."""
    where = f"body {name} (joint {joint})"
    mine = {rd.u[k] for k in speeds}
    keep = {qi for qi, kin in zip(rd.q, rd.kin) if _dynamic(kin) & mine}
    E_full, r_full, wv = local or _relative_motion(rd, where, frame, pframe, origin, porigin)
    others = {qi: 0 for qi in rd.q if qi not in keep}
    E, r = E_full.xreplace(others), r_full.xreplace(others)
    if not (_dynamic(E_full) | _dynamic(r_full) <= keep) and not (
            rd.numbers.same(E, E_full) and rd.numbers.same(r, r_full)):
        raise NotATree(f"{where}: its placement relative to body {parent} depends on more than its "
                       f"own coordinates {', '.join(_nm(q) for q in rd.q if q in keep)}")
    zero = {qi: 0 for qi in rd.q} | {v: 0 for v in rd.u}
    expanded = wv.applyfunc(sm.expand)
    motions = []
    for k in speeds:
        S = expanded.diff(rd.u[k]).xreplace(zero)
        motions.append(tuple(sm.nsimplify(c) if c.is_Float else c for c in S))
    if any(_dynamic(c) for S in motions for c in S) or not rd.numbers.same(
            sum((sm.Matrix(S) * rd.u[k] for S, k in zip(motions, speeds)), sm.zeros(6, 1)), wv):
        raise NotATree(f"{where}: its velocity relative to its parent is not constant axes in its "
                       f"own frame times its speeds {', '.join(_nm(rd.u[k]) for k in speeds)} "
                       f"(the recursion takes joints of several speeds whose axes are fixed in the "
                       f"child: free joints with body-frame speeds, planar, cylindrical)")
    numeric = [[complex(rd.numbers.evaluate(c, 0)).real for c in S] for S in motions]
    if np.linalg.matrix_rank(np.array(numeric), tol=1e-9) < len(speeds):
        raise NotATree(f"{where}: its speeds {', '.join(_nm(rd.u[k]) for k in speeds)} do not move "
                       f"it independently relative to its parent")
    kind = "free" if len(speeds) == 6 else f"{len(speeds)}-speed"
    return kind, E, r, tuple(motions)


def _forget(added):
    """Undo the intermediate frames' and points' links in the user's graphs (orient and
    set_ang_vel record themselves in the parent frame too, dcm() caches at both ends,
    set_pos records the new point in the point it is located from)."""
    frames = [(A, parent) for A, parent in added if isinstance(A, me.ReferenceFrame)]
    stages = {A for A, _ in frames}
    for A, parent in frames:
        for f in _all_frames(parent):
            for d in (f._dcm_dict, f._dcm_cache, f._ang_vel_dict, f._ang_acc_dict):
                for s in stages:
                    d.pop(s, None)
    for P, parent in added:
        if isinstance(P, me.Point):
            parent._pos_dict.pop(P, None)


def tree_from_kane(kane, kinematics):
    """Tree of a KanesMethod formed from hand-built frames and points."""
    if len(kane._uaux):
        raise NotATree(f"the system has auxiliary speeds ({', '.join(_nm(x) for x in kane._uaux)}): "
                       f"they add speeds no joint has, so it is not a tree")
    from .constrained import attach, loops_of_kane   # dependent speeds: loops closed by constraints
    loops = loops_of_kane(kane)
    bodies = list(kane._bodylist or [])
    if not bodies:
        raise NotATree("the KanesMethod has no bodies")
    N = kane._inertial
    rd = _Reader(N, None, list(kane._q), list(kane._u), kinematics)
    rd.O = _fixed_point(rd, bodies[0].masscenter)
    speed_sets = []
    for b in bodies:
        vecs = [b.masscenter.vel(N)]
        if isinstance(b, me.RigidBody):
            vecs.append(b.frame.ang_vel_in(N))
        speed_sets.append(rd.speeds_in(*vecs))
    order = sorted(range(len(bodies)), key=lambda i: (len(speed_sets[i]), i))
    entries, index, frames = [], {}, {}
    for i in order:
        s = speed_sets[i]
        parents = [k for k in index if speed_sets[k] <= s]
        p = max(parents, key=lambda k: (len(speed_sets[k]), -k)) if parents else None
        new = s - (speed_sets[p] if p is not None else frozenset())
        b = bodies[i]
        if len(new) > 1:
            rel = f"body {bodies[p].name}" if p is not None else "the ground"
            raise NotATree(f"body {b.name} moves with speeds "
                           f"{', '.join(_nm(rd.u[k]) for k in sorted(new))} relative to {rel}: the "
                           f"recursion takes one speed per joint (pin, slider, weld), not a ball or "
                           f"free joint, nor a massless body in between")
        speed = next(iter(new)) if new else None
        pframe = frames[p] if p is not None else N
        frame = b.frame if isinstance(b, me.RigidBody) else _particle_frame(rd, b, pframe, speed, frames.values())
        index[i] = len(entries)
        frames[i] = frame
        entries.append((b.name, f"of {b.name}", -1 if p is None else index[p], b, frame,
                        b.masscenter, speed))
    return attach(_assemble(rd, entries, kane._forcelist), loops)


def _fixed_point(rd, start):
    """A point with zero velocity in N, reached from ``start`` through located points."""
    seen, stack = {start}, [start]
    while stack:
        p = stack.pop()
        if rd.N in p._vel_dict and p._vel_dict[rd.N] == 0:
            return p
        for nxt in p._pos_dict:
            if nxt not in seen:
                seen.add(nxt)
                stack.append(nxt)
    raise NotATree(f"no point fixed in {rd.N} is connected to point {start}")


def _all_frames(N):
    seen, stack = [N], [N]
    while stack:
        f = stack.pop()
        for g in list(f._dcm_dict) + list(f._ang_vel_dict):
            if g not in seen:
                seen.append(g)
                stack.append(g)
    return seen


def _particle_frame(rd, particle, pframe, speed, taken):
    """The frame a particle turns with: one whose angular velocity adds just its speed."""
    if speed is None:
        return pframe
    if not hasattr(rd, "_frames"):
        rd._frames = _all_frames(rd.N)
        # each frame's speeds once per recognition, not once per particle: SymPy's
        # ang_vel_in searches every path of the frame graph, and a chain whose frames are
        # oriented from the previous one but given angular velocities in N has many
        rd._frame_speeds = {f: rd.speeds_in(f.ang_vel_in(rd.N)) for f in rd._frames if f != rd.N}
    want = rd.speeds_in(pframe.ang_vel_in(rd.N)) | {speed}
    # frames the particle's own offsets are written in (one step: its whole position from
    # O would be a sum over every link before it, quadratic to build)
    named = {f for v in particle.masscenter._pos_dict.values() for _, f in v.args}
    found = [f for f, s in rd._frame_speeds.items() if s == want]
    if not found:
        return pframe
    found.sort(key=lambda f: (f not in named, f.name))
    return found[0]


def _is_kane(system):
    return hasattr(system, "_bodylist") and hasattr(system, "_inertial") and hasattr(system, "_uaux")


def tree_of(system, formed=None):
    """The Tree of ``system`` (a SymPy/eomc System or a KanesMethod); NotATree otherwise."""
    if isinstance(system, me.System):
        kin = tuple(formed.kinematics) if formed is not None else None
        return tree_from_system(system, kin)
    if _is_kane(system):
        if formed is None:      # the kinematics alone: no need to form Kane's equations
            return tree_from_kane(system, system_kinematics(system))
        return tree_from_kane(system, tuple(formed.kinematics))
    raise NotATree(f"a {type(system).__name__} is neither a System with joints nor a KanesMethod")
