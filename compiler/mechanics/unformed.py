"""A SymPy or eomc ``System`` whose equations were never formed.

Why here: ``from_urdf`` and scripts that build a ``System`` of joints without
calling ``form_eoms()`` hand eomc an unformed System.  The recursive
formulation reads its joint tree directly (eomc.compiler.tree); everything else
(the Kane formulation, a tree the recursion cannot take) forms it with eomc's
own KanesMethod -- never SymPy's, which a SymPy System's ``form_eoms()`` would
use -- through :func:`eomc.compiler.mechanics.system.eomc_method_of`, which
copies a SymPy System first so the user's object stays as it was.
"""
from sympy.physics import mechanics as sme

__all__ = ["is_unformed_system", "form_system"]


def is_unformed_system(system):
    return isinstance(system, sme.System) and system.eom_method is None


def form_system(system):
    """The formed eomc method (``.formed()`` gives the FormedSystem) of an unformed System."""
    from .system import eomc_method_of
    return eomc_method_of(system)
