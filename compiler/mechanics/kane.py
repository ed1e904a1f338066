"""eomc's KanesMethod: Kane's equations Fr + Fr* = 0 from partial velocities.

The API follows the seed document and SymPy 1.14's ``KanesMethod`` (same
constructor keywords, attributes and results), but the formulation is our
own (see :mod:`.kane_forms`): generalized active and inertia forces are built
directly from partial velocities and partial angular velocities,

    F_r  = v_r·R + ω_r·T,      F_r* = v_r·R* + ω_r·T*,
    R* = −m a,                 T* = −(α·I + ω×I·ω),

with the mass matrix read off as M_rs = Σ m v_r·v_s + ω_r·I·ω_s.  The heavy
algebra runs on plain symbols (:mod:`.plain`), which is what makes it fast.

Differences from SymPy 1.14, on purpose:

* ``kanes_equations`` accepts both the seed's order ``(loads, bodies)`` and
  SymPy's ``(bodies, loads)``; the lists are told apart by their content.
* ``linearize()`` with no arguments has the seed's meaning: it returns
  ``(A, B)``, the Jacobians of ``forcing_full`` with respect to the
  independent coordinates and speeds and with respect to the other dynamic
  symbols (inputs).  With any SymPy keyword (``op_point``, ``A_and_B``,
  ``linear_solver``, ``simplify``, ``new_method``) it behaves exactly like
  SymPy 1.14 and returns ``(M, A, B, r)`` or ``(A, B, r)``.
* ``constraint_solver`` defaults to ``'auto'``: Cramer's rule for up to 3
  dependent speeds, LU beyond (SymPy: always LU, whose symbolic pivots can
  vanish where the constraints are regular, e.g. the Whipple bicycle upright,
  and turn into divisions by zero).  ``'LU'`` and SymPy's other names still work.
* Bad input raises :class:`eomc.runtime.errors.ModelError` naming the culprit.
* Accelerations set explicitly on points/frames (``set_acc``) are not used:
  accelerations are always the time derivatives of the velocities.
* ``kanes_equations`` records the bodies and loads and forms the equations on
  first use of any result (``fr``, ``frstar``, ``mass_matrix``, ``forcing``,
  ``formed()``, unpacking its return value, ...), which then is exactly what
  forming at once gives.  A model file that calls it only to hand the method to
  the compiler pays nothing when the recursive formulation reads the tree from
  the recorded bodies and loads instead (minutes at 80 bodies).  Errors that
  forming finds (a load on a point without a velocity) surface at that first use.
"""
import sympy as sm
from sympy.physics.mechanics import ReferenceFrame
from sympy.physics.vector import dynamicsymbols

from eomc.runtime.errors import ModelError

from .kane_forms import (FOLD_OPS, VectorReader, assemble, dot, fewer_trig_squares, read_bodies,
                         read_loads, run_angles, to_dynamic)
from .kane_inputs import (as_symbol_list, names, check_bodies, check_time_functions,
                          frame_ang_vel, parse_loads, point_velocity, split_bodies_and_loads)
from .kane_kinematics import constraint_matrices, kinematic_matrices, linear_solver
from .plain import PlainSpace

__all__ = ["KanesMethod"]


def _rows(mat, n):
    return mat if mat.rows else sm.zeros(0, n)


_SMALL = 8   # systems with at most this many bodies + loads try an expanded forcing


def _cse_ops(exprs):
    repl, red = sm.cse(exprs)
    return sm.count_ops([r[1] for r in repl]) + sm.count_ops(red)


def _compact(mm, forcing):
    """The forcing with each entry expanded where that is shorter, if CSE then agrees.

    In small systems a link's centripetal terms cancel in v_r·a only after
    expansion; in large ones expanding destroys the shared sums CSE finds, so
    the variant is kept only when the operation count after CSE drops.
    """
    alt = forcing.applyfunc(lambda e: min(e, sm.expand(e), key=sm.count_ops))
    if alt == forcing:
        return forcing
    base = list(mm)
    return alt if _cse_ops(base + list(alt)) < _cse_ops(base + list(forcing)) else forcing


def _at_most(expr, limit):
    """True if ``expr`` has at most ``limit`` nodes; stops walking as soon as it has more."""
    count = 0
    for _ in sm.preorder_traversal(expr):
        count += 1
        if count > limit:
            return False
    return True


def _frstar(mm, neg_nonmm, udot):
    """−(mm u' + nonMM), row by row, without negating large sums."""
    rows = []
    for r in range(mm.rows):
        terms = [sm.Mul(sm.S.NegativeOne, mm[r, c], udot[c]) for c in range(mm.cols) if mm[r, c] != 0]
        rows.append(sm.Add(*terms, neg_nonmm[r]))
    return sm.Matrix(len(rows), 1, rows)


def _check_kinematics(N, bodies, parsed):
    """What forming would refuse about the bodies' and loads' kinematics, refused when
    ``kanes_equations`` is called (forming is deferred, its errors should not be): a body
    point without a velocity in N, a rigid body's frame without an angular velocity, a
    load written in a frame not oriented relative to N.  Look-ups only (what forming
    reads first anyway, and SymPy caches)."""
    for i, body in enumerate(bodies):
        what = f"body #{i + 1} ({body.name})"
        rigid = isinstance(body, sm.physics.mechanics.RigidBody)
        point_velocity(body.masscenter if rigid else body.point, N, what)
        if rigid:
            frame_ang_vel(body.frame, N, what)
    for name, kind, _vel, vec, _where in parsed:
        for _comps, frame in vec.args:
            try:
                if frame != N:
                    N._dict_list(frame, 0)      # a path of orientations to N exists
            except ValueError:
                raise ModelError(f"load on {'frame' if kind == 'torque' else 'point'} {name}: "
                                 f"frame {frame.name} is not oriented relative to frame {N.name} "
                                 f"(orient it with orient_axis/orientnew)") from None


def _formed_on_use(name):
    """An attribute holding a result of forming: reading it forms pending equations."""
    key = "_v" + name

    def get(self):
        if self.__dict__.get("_pending") is not None:
            self._form_pending()
        return self.__dict__.get(key)

    def set(self, value):
        self.__dict__[key] = value
    return property(get, set)


class FormedOnUse(tuple):
    """What ``kanes_equations`` returns: ``(fr, frstar)``, formed when first unpacked,
    indexed, compared or printed (``fr, frstar = km.kanes_equations(...)`` forms them at
    once; a model file that ignores the result and hands the method to the compiler
    never does).  A tuple, so ``isinstance(result, tuple)`` holds as with SymPy."""

    def __new__(cls, method):
        self = super().__new__(cls, ())
        self._method = method
        return self

    def _pair(self):
        return (self._method.fr, self._method.frstar)

    def __iter__(self):
        return iter(self._pair())

    def __getitem__(self, k):
        return self._pair()[k]

    def __len__(self):
        return 2

    def __eq__(self, other):
        return self._pair() == (tuple(other) if isinstance(other, tuple) else other)

    def __ne__(self, other):
        return not self == other

    __hash__ = None

    def __repr__(self):
        return repr(self._pair())

    __str__ = __repr__

    def __reduce__(self):
        return (tuple, (self._pair(),))


class KanesMethod:
    """Kane's method: forms Fr, Fr*, the mass matrix and forcing vector.

    Parameters are those of ``sympy.physics.mechanics.KanesMethod`` (1.14).
    See the module docstring for the (few, deliberate) differences.
    """

    _pending = None
    _fr = _formed_on_use("_fr")
    _frstar = _formed_on_use("_frstar")
    _k_d = _formed_on_use("_k_d")
    _forcing_d = _formed_on_use("_forcing_d")
    _aux_eq = _formed_on_use("_aux_eq")
    _body_terms = _formed_on_use("_body_terms")
    _load_terms = _formed_on_use("_load_terms")
    _space = _formed_on_use("_space")

    def __init__(self, frame, q_ind, u_ind, kd_eqs=None, q_dependent=None,
                 configuration_constraints=None, u_dependent=None,
                 velocity_constraints=None, acceleration_constraints=None,
                 u_auxiliary=None, bodies=None, forcelist=None,
                 explicit_kinematics=True, kd_eqs_solver='LU',
                 constraint_solver='auto'):
        if not isinstance(frame, ReferenceFrame):
            raise ModelError(f"the first argument of KanesMethod must be the inertial "
                             f"ReferenceFrame, got {frame!r}")
        self._inertial = frame
        t = dynamicsymbols._t
        q_ind = as_symbol_list(q_ind, "q_ind (independent coordinates)")
        u_ind = as_symbol_list(u_ind, "u_ind (independent speeds)")
        self._qdep = as_symbol_list(q_dependent, "q_dependent")
        self._udep = as_symbol_list(u_dependent, "u_dependent")
        self._uaux = as_symbol_list(u_auxiliary, "u_auxiliary")
        self._q = sm.Matrix(q_ind + self._qdep)
        self._u = sm.Matrix(u_ind + self._udep)
        check_time_functions(list(self._q), "coordinate")
        check_time_functions(list(self._u) + self._uaux, "speed")
        clash = set(self._q) & set(list(self._u) + self._uaux)
        if clash:
            raise ModelError(f"{sorted(map(str, clash))[0]} is listed both as a coordinate and a speed")
        self._qdot = sm.Matrix([x.diff(t) for x in self._q])
        self._udot = sm.Matrix([x.diff(t) for x in self._u])
        self.explicit_kinematics = explicit_kinematics
        self._kd_solver = linear_solver(kd_eqs_solver)
        self._constraint_solver = linear_solver(constraint_solver)
        self._bodylist = None if bodies is None else list(bodies)
        self._forcelist = None if forcelist is None else list(forcelist)
        self._fr = self._frstar = None
        self._aux_eq = None
        self._init_kinematics(kd_eqs)
        self._init_constraints(configuration_constraints, velocity_constraints,
                               acceleration_constraints)

    # -- set-up ---------------------------------------------------------------
    def _init_kinematics(self, kd_eqs):
        kd = as_symbol_list(kd_eqs, "kd_eqs (kinematic differential equations)")
        if kd:
            k = kinematic_matrices(kd, list(self._q), list(self._u), self._uaux, self._kd_solver)
            self._k_kqdot_implicit = k["k_kqdot_implicit"]
            self._k_ku_implicit, self._f_k_implicit = k["k_ku_implicit"], k["f_k_implicit"]
            self._k_ku, self._f_k = k["k_ku"], k["f_k"]
            self._k_kqdot = sm.eye(len(self._q))
            self._qdot_u_map = k["qdot_u_map"]
        else:
            # No coordinates at all (a system described by speeds only) needs no kd_eqs.
            self._qdot_u_map = None if len(self._q) else {}
            n, o = len(self._q), len(self._u)
            self._k_kqdot_implicit = self._k_kqdot = sm.zeros(n, n)
            self._k_ku_implicit = self._k_ku = sm.zeros(n, o)
            self._f_k_implicit = self._f_k = sm.zeros(n, 1)

    def _init_constraints(self, config, vel, acc):
        config = as_symbol_list(config, "configuration_constraints")
        vel = as_symbol_list(vel, "velocity_constraints")
        acc = as_symbol_list(acc, "acceleration_constraints")
        if len(config) != len(self._qdep):
            raise ModelError(
                f"{len(self._qdep)} dependent coordinate(s) ({names(self._qdep) or 'none'}) "
                f"but {len(config)} configuration constraint(s); the counts must match")
        if self._udep and not vel:
            raise ModelError(f"dependent speeds ({names(self._udep)}) were given "
                             "without velocity_constraints to determine them")
        if len(vel) != len(self._udep):
            raise ModelError(
                f"{len(self._udep)} dependent speed(s) ({names(self._udep) or 'none'}) "
                f"but {len(vel)} velocity constraint(s); the counts must match")
        if acc and len(acc) != len(self._udep):
            raise ModelError(f"{len(self._udep)} dependent speed(s) but {len(acc)} acceleration "
                             "constraint(s); the counts must match")
        c = constraint_matrices(config, vel, acc, list(self._u), self._udep,
                                self._qdot_u_map, self._constraint_solver)
        self._f_h, self._k_nh, self._f_nh = c["f_h"], c["k_nh"], c["f_nh"]
        self._k_dnh, self._f_dnh, self._Ars = c["k_dnh"], c["f_dnh"], c["Ars"]

    # -- forming the equations --------------------------------------------------
    def kanes_equations(self, bodies=None, loads=None):
        """Form Fr and Fr*; returns ``(fr, frstar)``.

        Takes the seed's ``(loads, bodies)`` or SymPy's ``(bodies, loads)``:
        bodies are Particle/RigidBody objects, loads are (Point, Vector) or
        (ReferenceFrame, Vector) pairs (``Force``/``Torque`` objects too).
        With auxiliary speeds the returned vectors have the auxiliary rows
        appended; ``auxiliary_eqs`` holds their sum (the constraint forces).
        """
        return self._record(bodies, loads)

    def _record(self, bodies, loads, kinematics_now=True):
        """kanes_equations' recording; ``kinematics_now=False`` (eomc's System.form_eoms)
        leaves the loads' and bodies' velocities -- SymPy's path search through the frame
        and point graph, O(n^2) for a chain of joints -- to forming, whose first step they
        are anyway: their errors come then, as the same ModelErrors."""
        bodies, loads = split_bodies_and_loads(bodies, loads)
        if bodies is None:
            bodies = self._bodylist
        if loads is None:
            loads = self._forcelist
        if self._qdot_u_map is None:
            raise ModelError("kanes_equations needs kinematic differential equations: "
                             "pass kd_eqs=[...] to KanesMethod")
        bodies = check_bodies(bodies)
        # bad loads are named here, as before (their velocities too, unless deferred)
        parsed = parse_loads(loads, self._inertial, velocities=kinematics_now)
        if kinematics_now:
            _check_kinematics(self._inertial, bodies, parsed)
        self._bodylist = bodies
        self._forcelist = None if loads is None else list(loads)
        self._formed_cache = None
        self._pending = (bodies, parsed, kinematics_now)
        return FormedOnUse(self)

    def _form_pending(self):
        """Form the equations recorded by the last ``kanes_equations`` call (see the
        module docstring: Kane's equations are formed on first use)."""
        pending = self._pending
        bodies, parsed, checked = pending
        self._pending = None
        try:
            if not checked:
                parsed = parse_loads(self._forcelist, self._inertial)
                _check_kinematics(self._inertial, bodies, parsed)
            self._form(bodies, parsed)
        except BaseException:
            self._pending = pending
            raise

    @property
    def is_formed(self):
        """False while ``kanes_equations`` was called but nothing has used its results."""
        return self.__dict__.get("_pending") is None

    def _form(self, bodies, parsed):
        space = PlainSpace(list(self._q), list(self._u), self._uaux, self._qdot_u_map)
        reader = VectorReader(space, run_angles(self._inertial))
        self._body_terms = read_bodies(space, reader, self._inertial, bodies)
        self._load_terms = read_loads(space, reader, self._inertial, parsed)
        self._space = space
        to_dynamic(space, self._body_terms, self._load_terms)
        o, s = len(self._u), len(self._uaux)
        MM, neg_nonmm, fr = assemble(self._body_terms, self._load_terms, o + s, o)
        MM = sm.Matrix(o + s, o, [e for row in MM for e in row])
        neg_nonmm = sm.Matrix(o + s, 1, neg_nonmm)
        fr = sm.Matrix(o + s, 1, fr)
        self._finish(MM, neg_nonmm, fr, o, s)

    def _finish(self, MM, neg_nonmm, fr, o, s):
        """Eliminate dependent speeds; store k_d, forcing, Fr, Fr* (and auxiliary rows).

        Fr* = −(M u' + nonMM) is built term by term so that no large sum is
        negated (SymPy distributes a −1 over every term of a sum).
        """
        udot = list(self._udot)
        mm, nn, f = MM[:o, :], neg_nonmm[:o, :], fr[:o, :]
        if self._udep:
            p = o - len(self._udep)
            A = self._Ars.T
            mm = mm[:p, :] + A * mm[p:, :]
            nn = nn[:p, :] + A * nn[p:, :]
            f = f[:p, :] + A * f[p:, :]
        # Products of a partial angular velocity and ω×Iω written in different
        # frames leave sin² + cos² of the angle between them in small rows
        # (SymPy's frame-by-frame dot products do not): fold those rows.
        # (size checked by a walk that stops early: count_ops costs seconds at n = 20)
        nn = nn.applyfunc(lambda e: fewer_trig_squares(e) if _at_most(e, FOLD_OPS) else e)
        self._k_d = mm
        self._forcing_d = sm.Matrix([sm.Add(f[r], nn[r]) for r in range(f.rows)])
        # Not after eliminating dependent speeds: A_rs brings the constraint
        # solve's quotients into every row, and expanding those blows up (the
        # Whipple bicycle's forcing did not finish expanding in 10 minutes).
        if not self._udep and len(self._body_terms) + len(self._load_terms) <= _SMALL:
            mm = self._k_d = mm.applyfunc(fewer_trig_squares)
            self._forcing_d = _compact(mm, self._forcing_d)
        frstar = _frstar(mm, nn, udot)
        self._fr, self._frstar = f, frstar
        if s:
            fraux, mma, nna = fr[o:, :], MM[o:, :], neg_nonmm[o:, :]
            if self._udep:
                # Auxiliary speeds that enter the velocity constraints move the
                # dependent speeds too: their partial velocities gain A_aux^T times
                # the dependent rows, A_aux = -B_dep^-1 ∂(constraints)/∂u_aux.
                p = o - len(self._udep)
                B_aux = self._f_nh.jacobian(self._uaux)
                A = (-self._constraint_solver(self._k_nh[:, p:o], B_aux)).T
                fraux = fraux + A * fr[p:o, :]
                mma = mma + A * MM[p:o, :]
                nna = nna + A * neg_nonmm[p:o, :]
            frstaraux = _frstar(mma, nna, udot)
            self._aux_eq = fraux + frstaraux
            self._fr = f.col_join(fraux)
            self._frstar = frstar.col_join(frstaraux)

    def _form_eoms(self):
        """``fr + frstar`` from the bodies and loads given to the constructor.

        ``System.form_eoms`` and ``JointsMethod.form_eoms`` (SymPy's and
        eomc's) call this private hook of SymPy's ``_Methods`` interface.
        """
        fr, frstar = self.kanes_equations(self._bodylist, self._forcelist)
        return fr + frstar

    def _form_fr(self, fl):
        """Fr alone (SymPy's private helper, kept because scripts and tests call it).

        ``fl`` is a non-empty list of loads or None, as in SymPy; the bodies
        are those given before (none: Fr does not need them).
        """
        if fl is not None and (isinstance(fl, (str, sm.Basic)) or not hasattr(fl, "__len__")
                               or len(fl) == 0):
            raise ModelError("Force pairs must be supplied in a non-empty iterable or None "
                             f"(got {fl!r})")
        bodies = self._bodylist
        self.kanes_equations(bodies if bodies is not None else [], fl)
        fr = self._fr
        if bodies is None:
            self._bodylist, self._frstar = None, None
        return fr

    @property
    def _f_d(self):
        """SymPy's f_d (k_d u' + f_d = 0): minus the forcing rows from Kane's equations."""
        return -self._forcing_d

    # -- per-body contributions ------------------------------------------------
    def _reduce(self, vec):
        """Apply the dependent-speed elimination to a column over all speeds."""
        vec = sm.Matrix(vec)
        if not self._udep:
            return vec
        p = len(self._u) - len(self._udep)
        return vec[:p, :] + self._Ars.T * vec[p:, :]

    def generalized_active_forces_by_body(self):
        """{load name: its contribution to Fr} (point or frame name; repeats get '#k')."""
        self._need_equations()
        o, out = len(self._u), {}
        for ld in self._load_terms:
            key = ld.name if ld.name not in out else f"{ld.name}#{sum(k.split('#')[0] == ld.name for k in out) + 1}"
            out[key] = self._reduce([dot(ld.pr[r], ld.vec) for r in range(o)])
        return out

    def generalized_inertia_forces_by_body(self):
        """{body name: its contribution to Fr*} = −Σ (v_r·m a + ω_r·(α·I + ω×I·ω))."""
        self._need_equations()
        o, out = len(self._u), {}
        udot = list(self._udot)
        back = self._space.to_dynamic
        for b in self._body_terms:
            R0, T0 = tuple(map(back, b.R0)), tuple(map(back, b.T0))
            col = []
            for r in range(o):
                acc = [sm.Add(*[b.mass * dot(b.vr[r], b.vr[k]) * udot[k] for k in range(o)]),
                       dot(b.vr[r], R0)]
                if b.wr:
                    acc += [sm.Add(*[dot(b.wr[r], b.Iw[k]) * udot[k] for k in range(o)]),
                            dot(b.wr[r], T0)]
                col.append(-sm.Add(*acc))
            out[b.name] = self._reduce(col)
        return out

    # -- results -----------------------------------------------------------------
    def _need_equations(self):
        if self._fr is None or self._frstar is None:
            raise ModelError("the equations are not formed yet: call kanes_equations(...) first")

    def kindiffdict(self):
        """A dictionary mapping each q' to its expression in u (and q, t)."""
        if self._qdot_u_map is None:
            raise ModelError("no kinematic differential equations were given (kd_eqs)")
        return dict(self._qdot_u_map)

    @property
    def auxiliary_eqs(self):
        """The auxiliary equations (Fr + Fr* for the auxiliary speeds): constraint forces = 0."""
        self._need_equations()
        if not self._uaux:
            raise ModelError("no auxiliary speeds have been declared (u_auxiliary)")
        return self._aux_eq

    @property
    def fr(self):
        return self._fr

    @property
    def frstar(self):
        return self._frstar

    @property
    def mass_matrix_kin(self):
        return self._k_kqdot if self.explicit_kinematics else self._k_kqdot_implicit

    @property
    def forcing_kin(self):
        u = sm.Matrix(self._u)
        if self.explicit_kinematics:
            return -(self._k_ku * u + self._f_k)
        return -(self._k_ku_implicit * u + self._f_k_implicit)

    @property
    def mass_matrix(self):
        self._need_equations()
        return self._k_d.col_join(_rows(self._k_dnh, len(self._u)))

    @property
    def forcing(self):
        self._need_equations()
        return self._forcing_d.col_join(-_rows(self._f_dnh, 1))

    @property
    def mass_matrix_full(self):
        self._need_equations()
        o, n = len(self._u), len(self._q)
        return (self.mass_matrix_kin.row_join(sm.zeros(n, o))).col_join(
            sm.zeros(o, n).row_join(self.mass_matrix))

    @property
    def forcing_full(self):
        self._need_equations()
        return self.forcing_kin.col_join(self.forcing)

    def rhs(self, inv_method=None):
        """x' = [q'; u'] solved symbolically (small systems only; the compiler solves numerically)."""
        kdes = self.kindiffdict()
        top = sm.Matrix([kdes[qi.diff(dynamicsymbols._t)] for qi in self._q])
        if inv_method is None:
            bottom = self.mass_matrix.LUsolve(self.forcing)
        else:
            bottom = self.mass_matrix.inv(inv_method, try_block_diag=True) * self.forcing
        return top.col_join(bottom)

    q = property(lambda self: self._q)
    u = property(lambda self: self._u)
    bodies = property(lambda self: self._bodylist)
    bodylist = property(lambda self: self._bodylist)
    loads = property(lambda self: self._forcelist)
    forcelist = property(lambda self: self._forcelist)
    holonomic_constraints = property(lambda self: self._f_h, doc="f_h(q, t) = 0")

    @property
    def nonholonomic_constraints(self):
        """k_nh u + f_nh = 0 (the velocity constraints, q' eliminated)."""
        if not self._k_nh.rows:
            return sm.Matrix()
        return self._k_nh * sm.Matrix(self._u) + self._f_nh

    @property
    def velocity_constraint_matrices(self):
        """(k_nh, f_nh, A_rs) with u_dep = A_rs u_ind when f_nh = 0."""
        return self._k_nh, self._f_nh, self._Ars

    # -- linearization and hand-off ---------------------------------------------
    from .kane_linear import linearize, to_linearizer  # noqa: E402  (methods)

    def formed(self):
        """The method-neutral :class:`FormedSystem` the compiler consumes.

        Memoized per formed set of equations (a new ``kanes_equations`` call
        forms new ones): finding the inputs and parameters walks every
        expression, which would otherwise dominate a warm ``eomc.compile``.
        """
        from .kane_linear import formed_system
        cached = getattr(self, "_formed_cache", None)
        if cached is None or cached[0] is not self._frstar:
            cached = self._formed_cache = (self._frstar, formed_system(self))
        return cached[1]
