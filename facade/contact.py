"""Ground contact for models: ``eomc.contact.ground(point, body, world=system, ...)``.

The user-facing name of :mod:`eomc.compiler.contact` (see there for the law and its
defaults).  For URDF robots pass ``contacts=[...]`` to :func:`eomc.compile` instead.
"""
from eomc.compiler.contact import *  # noqa: F401,F403
from eomc.compiler.contact import __all__  # noqa: F401
from eomc.compiler.contact.tree import COLLISION_SPHERES, ContactSpec  # noqa: F401,E402

__all__ = [*__all__, "ContactSpec", "COLLISION_SPHERES"]
