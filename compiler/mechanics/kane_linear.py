"""Linearization and hand-off of a formed eomc KanesMethod.

``linearize()`` keeps the seed's meaning when called bare (Jacobians of
``forcing_full``) and SymPy 1.14's when given any of its keywords: then
eomc's :class:`~.linearizer.FastLinearizer` is fed with our Fr and Fr* exactly
as SymPy feeds its Linearizer, so the results (incl. dependent
coordinates/speeds and ``A_and_B``) are SymPy's.
"""
import sympy as sm
from sympy.core.function import AppliedUndef
from sympy.physics.mechanics import find_dynamicsymbols, msubs
from sympy.physics.mechanics.linearize import Linearizer
from sympy.physics.vector import dynamicsymbols
from sympy import default_sort_key

from eomc.runtime.errors import ModelError

from .formed import FormedSystem
from .linearizer import FastLinearizer, dag_subs, dynamic_atoms
from .kane_kinematics import linear_solver as _ls

__all__ = ["linearize", "to_linearizer", "formed_system", "input_symbols"]


def _walk(exprs):
    """(dynamic atoms, free plain Symbols) of the matrices ``exprs``, each shared
    sub-expression visited once.

    Why not ``e.atoms()`` / ``e.free_symbols`` per entry: those walk every entry as a
    tree, and the entries of a chain's mass matrix and forcing share most of their
    subtrees (at n = 20 the per-entry walks took ~1 s of a 4 s derivation).
    """
    seen, dyn, syms = set(), set(), set()
    stack = [e for m in exprs for e in m]
    while stack:
        e = stack.pop()
        if e in seen:
            continue
        seen.add(e)
        if isinstance(e, (AppliedUndef, sm.Derivative)):
            dyn.add(e)
        if isinstance(e, sm.Symbol):
            syms.add(e)
        elif getattr(e, "bound_symbols", None):       # Integral, Subs, Lambda: only free ones
            syms |= {s for s in e.free_symbols if isinstance(s, sm.Symbol)}
            dyn |= e.atoms(AppliedUndef, sm.Derivative)
        else:
            stack.extend(e.args)    # inside a Derivative too, as Basic.atoms does
    return dyn, syms


def _inputs(atoms, states):
    t = dynamicsymbols._t
    found = set()
    for a in atoms:
        if a in states:
            continue
        if isinstance(a, AppliedUndef) and a.args == (t,):
            found.add(a)
        elif isinstance(a, sm.Derivative) and isinstance(a.expr, AppliedUndef) \
                and a.expr not in states:
            found.add(a)
    return sorted(found, key=default_sort_key)


def input_symbols(exprs, states):
    """Dynamic symbols in ``exprs`` (matrices) that are not in ``states``, sorted canonically."""
    return _inputs(_walk(exprs)[0], states)


def _plain_names(items):
    return ", ".join(str(x).replace("(t)", "") for x in items)


def _states(km):
    t = dynamicsymbols._t
    s = set(km._q) | set(km._u) | set(km._qdot) | set(km._udot) | set(km._uaux)
    s |= {x.diff(t) for x in km._uaux}
    return s


def to_linearizer(self, linear_solver='LU', _cls=Linearizer):
    """A SymPy Linearizer built from this system's Fr and Fr* (as SymPy 1.14 does).

    (``linearize`` passes eomc's :class:`~.linearizer.FastLinearizer` as ``_cls``:
    same inputs, same results, without SymPy's slow Jacobians.)
    """
    self._need_equations()
    t = dynamicsymbols._t
    u = sm.Matrix(self._u)
    f_v = self._f_nh + self._k_nh * u if self._k_nh.rows else sm.Matrix()
    f_a = self._f_dnh + self._k_dnh * sm.Matrix(self._udot) if self._k_dnh.rows else sm.Matrix()
    u_zero = dict.fromkeys(self._u, 0)
    ud_zero = dict.fromkeys(self._udot, 0)
    qd_zero = dict.fromkeys(self._qdot, 0)
    qd_u_zero = dict.fromkeys(list(self._qdot) + list(self._u), 0)
    f_0 = msubs(self._f_k, u_zero) + self._k_kqdot * sm.Matrix(self._qdot)
    f_1 = msubs(self._f_k, qd_zero) + self._k_ku * u
    f_2 = dag_subs(self._frstar, qd_u_zero)
    f_3 = dag_subs(self._frstar, ud_zero) + self._fr
    f_4 = sm.zeros(len(f_2), 1)
    nqd, nud = len(self._qdep), len(self._udep)
    q_i = list(self._q)[:len(self._q) - nqd]
    u_i = list(self._u)[:len(self._u) - nud]
    uaux_zero = dict.fromkeys(list(self._uaux) + [x.diff(t) for x in self._uaux], 0)
    sym_list = _states(self)
    for name, mat in (("kinematic", self._k_kqdot), ("kinematic", self._k_ku),
                      ("kinematic", self._f_k), ("constraint", self._k_dnh),
                      ("constraint", self._f_dnh), ("mass matrix", self._k_d)):
        extra = find_dynamicsymbols(mat, sym_list) if mat.rows else set()
        if extra:
            raise ModelError(f"cannot linearize: input(s) {sorted(map(str, extra))} appear in the "
                             f"{name} terms; inputs may only appear in the forcing vector")
    r = list(dynamic_atoms([dag_subs(self._f_d, uaux_zero)]) - sym_list)
    r.sort(key=default_sort_key)
    for i in r:
        if i.diff(t) in r:
            raise ModelError(f"cannot linearize: both {i} and its derivative appear in the forcing")
    return _cls(f_0, f_1, f_2, f_3, f_4, self._f_h, f_v, f_a, self._q, self._u,
                q_i, self._qdep, u_i, self._udep, r, linear_solver=_ls(linear_solver))


def linearize(self, *, new_method=None, linear_solver=None, **kwargs):
    """Linearize the equations of motion.

    Bare ``linearize()`` (the seed's meaning) returns ``(A, B)``: the
    Jacobians of ``forcing_full`` with respect to the independent states
    [q_ind, u_ind] and with respect to the inputs (the other dynamic symbols,
    sorted canonically; B has no columns when there are none), so that
    ``M_full ẋ ≈ A x + B r`` near the point of expansion.

    With any SymPy keyword (``op_point=``, ``A_and_B=``, ``simplify=``,
    ``linear_solver=``, ``new_method=``) this is SymPy 1.14's
    ``KanesMethod.linearize``: it returns ``(M, A, B, r)``, or ``(A, B, r)``
    with ``A_and_B=True``, handling dependent coordinates and speeds.
    """
    if new_method is None and linear_solver is None and not kwargs:
        self._need_equations()
        ff = self.forcing_full
        xs = list(self._q)[:len(self._q) - len(self._qdep)] + \
            list(self._u)[:len(self._u) - len(self._udep)]
        r = input_symbols([ff], _states(self))
        outside = input_symbols([self.mass_matrix_full, self.forcing_kin], _states(self))
        if outside:
            raise ModelError(f"cannot linearize: input(s) {_plain_names(outside)} appear in the mass "
                             "matrix or the kinematic equations; inputs may only enter the forcing")
        derivs = [x for x in r if isinstance(x, sm.Derivative)]
        if derivs:
            raise ModelError(f"cannot linearize: derivatives of inputs ({_plain_names(derivs)}) "
                             "appear in the forcing vector")
        A = ff.jacobian(xs)
        B = ff.jacobian(r) if r else sm.zeros(ff.rows, 0)
        return A, B
    lin = to_linearizer(self, linear_solver=linear_solver or 'LU', _cls=FastLinearizer)
    return lin.linearize(**kwargs) + (lin.r,)


def check_inertia(km, M):
    """A speed whose column of the mass matrix is identically zero has no inertia: its
    acceleration is in no equation, so no formulation can solve for it.  Say so before
    compiling, naming the joint (for a System of joints) and the bodies that move with it.

    Typical causes: a massless link with nothing beyond it, a point mass on its own pin
    axis, a slider of zero mass carrying nothing.
    """
    for j, speed in enumerate(km._u):
        if any(M[i, j] != 0 for i in range(M.rows)):
            continue
        name = _plain_names([speed])
        joint = getattr(km, "_joint_of_speed", {}).get(speed)
        where = f"joint {joint} (speed {name})" if joint else f"speed {name}"
        movers = [b.name for b in getattr(km, "_body_terms", ())
                  if any(c != 0 for v in (b.vr[j], *(b.wr[j:j + 1] if b.wr else ())) for c in v)]
        if movers:
            who = (f"bod{'y' if len(movers) == 1 else 'ies'} {', '.join(movers)} "
                   f"move{'s' if len(movers) == 1 else ''} with it but "
                   f"ha{'s' if len(movers) == 1 else 've'} no mass or inertia along it")
        else:
            who = "no body moves with it"
        raise ModelError(
            f"{where} has no inertia: {who}, so its acceleration appears in no equation (the mass "
            f"matrix's column is identically zero) and the equations of motion cannot be solved; "
            f"give a body beyond the joint a mass or an inertia about its axis (a link massless "
            f"with nothing at its end, or a point mass on its own pin axis, has none)")


def formed_system(km):
    """Build the FormedSystem of a KanesMethod whose equations are formed."""
    km._need_equations()
    t = dynamicsymbols._t
    zero_aux = dict.fromkeys(list(km._uaux) + [x.diff(t) for x in km._uaux], 0)
    kin = sm.Matrix(len(km._qdot), 1, [km._qdot_u_map[qd] for qd in km._qdot])
    M = km.mass_matrix
    f = km.forcing
    check_inertia(km, M)
    if zero_aux:
        M, f, kin = (x.xreplace(zero_aux) for x in (M, f, kin))
    hol = km._f_h if km._f_h.rows else sm.zeros(0, 1)
    vel = km.nonholonomic_constraints if km._k_nh.rows else sm.zeros(0, 1)
    mats = [kin, M, f, hol, vel]
    dyn, syms = _walk(mats)
    inputs = tuple(_inputs(dyn, _states(km)))
    params = {s for s in syms if s != t}
    return FormedSystem(
        method="kane", coordinates=tuple(km._q), speeds=tuple(km._u),
        n_dependent_coordinates=len(km._qdep), n_dependent_speeds=len(km._udep),
        kinematics=kin, dynamics_matrix=M, dynamics_rhs=f, multipliers=(),
        holonomic_constraints=hol, velocity_constraints=vel, inputs=inputs,
        parameters=tuple(sorted(params, key=lambda s: s.name)))
