"""A SymPy ``System`` whose equations were never formed, formed by eomc's own Kane.

Why here: ``from_urdf`` and scripts that build a ``System`` of joints without
calling ``form_eoms()`` hand eomc an unformed System; the recursive formulation
reads its tree directly, and everything else (the Kane formulation, a tree the
recursion cannot take) forms it with eomc's KanesMethod -- never SymPy's, which
is what ``System.form_eoms()`` of a SymPy System would use.
"""
from sympy.physics import mechanics as sme

__all__ = ["is_unformed_system", "form_system"]


def is_unformed_system(system):
    return isinstance(system, sme.System) and system.eom_method is None


def form_system(system):
    """An eomc KanesMethod with the equations of the (SymPy) ``System``, formed.

    Mirrors ``System.form_eoms()``: the same coordinates, speeds, kinematic
    equations, constraints, bodies, loads and actuators' loads.
    """
    from eomc.compiler.mechanics import KanesMethod
    loads = list(system.loads) + [load for actuator in system.actuators for load in actuator.to_loads()]
    bodies = list(system.bodies)
    method = KanesMethod(system.frame, list(system.q_ind), list(system.u_ind), kd_eqs=list(system.kdes),
                         q_dependent=list(system.q_dep) or None,
                         configuration_constraints=list(system.holonomic_constraints) or None,
                         u_dependent=list(system.u_dep) or None,
                         velocity_constraints=list(system.velocity_constraints) or None,
                         u_auxiliary=list(system.u_aux) or None)
    method.kanes_equations(bodies, loads or None)
    return method
