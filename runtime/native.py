"""The integrator library built with eomc (setup.py): find it and open it once per process."""
import importlib.machinery
import threading
from pathlib import Path

from eomc.runtime.errors import EomcError

__all__ = ["integrator_library"]

_OPENED = {}
_LOCK = threading.Lock()


def _library_path():
    here = Path(__file__).resolve().parent
    for suffix in importlib.machinery.EXTENSION_SUFFIXES:
        candidate = here / f"_eomc_integrators{suffix}"
        if candidate.is_file():
            return candidate
    raise EomcError(f"eomc's integrator library (_eomc_integrators) is missing from {here}; "
                    "eomc was not installed with its build step -- reinstall with `pip install .` "
                    "(or `pip install -e .` in a checkout)")


def integrator_library(ffi):
    """``ffi.dlopen`` of the integrator library; ``ffi`` must declare INTEGRATOR_CDEF."""
    with _LOCK:
        key = id(ffi)
        if key not in _OPENED:
            _OPENED[key] = (ffi, ffi.dlopen(str(_library_path())))
        return _OPENED[key][1]
