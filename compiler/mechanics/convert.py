"""Turn SymPy's formed mechanics objects into eomc's, re-forming the equations.

``from_sympy(obj)`` accepts a ``sympy.physics.mechanics`` KanesMethod,
LagrangesMethod, System or JointsMethod (1.14), formed or not, and returns the eomc KanesMethod or
LagrangesMethod built from the same description -- frame, coordinates,
speeds, kinematic equations, constraints, bodies and loads -- with the
equations formed again by eomc's own methods.  Bodies, particles, frames and
points are SymPy's objects and are used as they are.

Why read SymPy's private attributes: SymPy keeps the user's description only
there (``_q``, ``_qdep``, ``_f_h``, ``_k_nh``/``_f_nh``, ...); its public
results are already-derived equations, which we want to re-derive.
"""
import sympy as sm
from sympy.physics import mechanics as sme

from eomc.runtime.errors import ModelError

__all__ = ["from_sympy", "register_system_converter"]

# How a System/JointsMethod becomes an eomc method: registered by .system, which
# imports this module (so this one must not import it back).
_SYSTEMS = []


def register_system_converter(func):
    """``func(system_or_joints_method)`` -> its formed eomc KanesMethod/LagrangesMethod."""
    _SYSTEMS[:] = [func]


def from_sympy(obj):
    """An eomc KanesMethod/LagrangesMethod equivalent to SymPy's ``obj``, formed.

    eomc methods are returned unchanged.  A ``System`` or ``JointsMethod``
    (SymPy's or eomc's) gives its method, converted; one whose equations are
    not formed yet is formed with eomc's ``KanesMethod`` (as SymPy's default).
    """
    from .kane import KanesMethod
    from .lagrange import LagrangesMethod
    if isinstance(obj, (KanesMethod, LagrangesMethod)):
        return obj
    if isinstance(obj, (sme.System, sme.JointsMethod)) and _SYSTEMS:
        return _SYSTEMS[0](obj)
    if isinstance(obj, sme.LagrangesMethod):
        return _from_lagrange(obj, LagrangesMethod)
    if isinstance(obj, sme.KanesMethod):
        return _from_kane(obj, KanesMethod)
    raise ModelError(
        f"cannot convert {type(obj).__name__}: expected a sympy.physics.mechanics "
        "KanesMethod, LagrangesMethod, System or JointsMethod")


def _rows(mat):
    return list(mat) if mat is not None and len(mat) else None


def _from_lagrange(lm, cls):
    """SymPy stores ``coneqs = [d/dt hol_coneqs; nonhol_coneqs]``: split them back."""
    hol = lm._hol_coneqs
    nonhol = lm.coneqs[len(hol):, :] if len(lm.coneqs) else sm.Matrix()
    ours = cls(lm._L[0], list(lm.q), forcelist=lm.forcelist or None,
               bodies=lm._bodies, frame=lm.inertial,
               hol_coneqs=_rows(hol), nonhol_coneqs=_rows(nonhol))
    ours.form_lagranges_equations()
    return ours


def _kinematic_equations(km):
    """``k_kqdot q' + k_ku u + f_k = 0`` as the user gave them (implicit form)."""
    if km._qdot_u_map is None:
        return None
    kd = (km._k_kqdot_implicit * km._qdot + km._k_ku_implicit * km._u
          + km._f_k_implicit)
    return list(kd)


def _motion_constraints(km):
    """Velocity constraints, and acceleration constraints only if the user gave their own."""
    if not len(km._k_nh):
        return None, None
    vel = list(km._k_nh * km._u + km._f_nh)
    acc = None
    if km._k_dnh != km._k_nh:
        acc = list(km._k_dnh * km._u.diff(sme.dynamicsymbols._t) + km._f_dnh)
    return vel, acc


def _from_kane(km, cls):
    n_dep_q, n_dep_u = len(km._qdep), len(km._udep)
    q_ind = list(km._q[:len(km._q) - n_dep_q])
    u_ind = list(km._u[:len(km._u) - n_dep_u])
    vel, acc = _motion_constraints(km)
    ours = cls(km._inertial, q_ind, u_ind,
               kd_eqs=_kinematic_equations(km),
               q_dependent=list(km._qdep) or None,
               configuration_constraints=_rows(km._f_h),
               u_dependent=list(km._udep) or None,
               velocity_constraints=vel,
               acceleration_constraints=acc,
               u_auxiliary=list(km._uaux) or None,
               explicit_kinematics=getattr(km, "explicit_kinematics", True))
    if km._bodylist is not None or km._forcelist is not None:
        ours.kanes_equations(bodies=list(km._bodylist or []),
                             loads=list(km._forcelist or []) or None)
    return ours
