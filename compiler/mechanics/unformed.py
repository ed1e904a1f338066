"""A SymPy or eomc ``System`` whose equations were never formed (or an eomc
``KanesMethod`` whose recorded equations were never used).

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


# An eomc KanesMethod whose kanes_equations have not been used yet is read as a tree first
# from this many bodies on: below it Kane's equations are cheap to form and its rhs can be
# the cheaper one (auto compares both there; README "Joint trees": Kane wins below n ≈ 10).
PENDING_KANE_MIN_BODIES = 8


def is_unformed_system(system):
    """A System whose equations were never formed (or, eomc's System, whose form_eoms()
    recorded Kane's equations that nobody has read: System.kane_pending), or an eomc
    KanesMethod of at least
    PENDING_KANE_MIN_BODIES bodies and no constraints whose ``kanes_equations`` results
    nobody has used yet (so they were not formed: see :mod:`.kane`)."""
    if isinstance(system, sme.System):   # (eomc's form_eoms() only records Kane's equations)
        return system.eom_method is None or bool(getattr(system, "kane_pending", bool)())
    from .kane import KanesMethod
    return (isinstance(system, KanesMethod) and not system.is_formed
            and len(system._bodylist or ()) >= PENDING_KANE_MIN_BODIES
            and not (system._qdep or system._udep or system._uaux))


def form_system(system):
    """The formed eomc method (``.formed()`` gives the FormedSystem) of an unformed System
    (a pending KanesMethod forms itself on that first use)."""
    from .kane import KanesMethod
    if isinstance(system, KanesMethod):
        return system
    from .system import eomc_method_of
    return eomc_method_of(system)
