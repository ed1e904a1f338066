"""Everything a mechanics script needs, in one import: ``from eomc.mechanics import *``.

This is the user-facing name of :mod:`eomc.compiler.mechanics`; see there.
"""
from eomc.compiler.mechanics import *  # noqa: F401,F403
from eomc.compiler.mechanics import __all__  # noqa: F401
from eomc.compiler.urdf import from_urdf  # noqa: E402,F401  (robots from URDF files)

__all__ = [*__all__, "from_urdf"]
