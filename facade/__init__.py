"""eomc: an equations-of-motion compiler for multibody dynamics.

This folder (``facade/``) is the top package ``eomc``; the layers under it:

- ``eomc``, ``eomc.mechanics``, ``eomc.errors``: the public names (this folder)
- ``eomc.cli``: the ``eomc`` command, one module per subcommand (``facade/cli/``)
- ``eomc.compiler``: model -> equations -> C -> library (``compiler/``, uses SymPy)
- ``eomc.runtime``: load and run built models (``runtime/``, numpy + cffi, no SymPy)

``import eomc`` is cheap and never imports SymPy: a user who only loads and
simulates a built model (``eomc.load``) does not need SymPy installed.  The
symbolic entry points (``eomc.compile``, ``eomc.mechanics``) are resolved on
first use.
"""
from importlib import import_module

from eomc.runtime.version import __version__

__all__ = ["__version__", "compile", "load", "mechanics", "rollout", "Rollout", "sweep", "gradient"]

# name -> (module, attribute or None for the module itself)
_LAZY = {
    "compile": ("eomc.compiler.driver", "compile"),
    "load": ("eomc.runtime.loader", "load"),
    "mechanics": ("eomc.mechanics", None),
    "geometry": ("eomc.geometry", None),
    "contact": ("eomc.contact", None),
    "sweep": ("eomc.runtime.sweep", "sweep"),
    "rollout": ("eomc.runtime.rollout", "rollout"),
    "Rollout": ("eomc.runtime.rollout_session", "Rollout"),
    "gradient": ("eomc.runtime.adjoint", "gradient"),
}


def __getattr__(name):
    try:
        module_name, attribute = _LAZY[name]
    except KeyError:
        raise AttributeError(f"module 'eomc' has no attribute {name!r}") from None
    module = import_module(module_name)
    value = module if attribute is None else getattr(module, attribute)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_LAZY))
