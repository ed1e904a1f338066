"""The errors eomc raises on purpose, under their public name ``eomc.errors``.

They live in the leaf module :mod:`eomc.runtime.errors`, which both halves
(``eomc.compiler`` and ``eomc.runtime``) import without touching this package.
"""
from eomc.runtime.errors import *  # noqa: F401,F403
from eomc.runtime.errors import __all__  # noqa: F401
