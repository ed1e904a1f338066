"""The integrator library built with eomc (setup.py): find it and open it once per process.

The library is handed out wrapped (:class:`_Interruptible`): its two run functions
arm Ctrl-C before the C call (``eomc_interrupt_arm`` in eomc_integrators.h), so a
long run without Python callbacks stops within one model evaluation of SIGINT,
and Python raises KeyboardInterrupt as the call returns.  Without it the signal
waited for the whole run (report r3, N5).
"""
import importlib.machinery
import threading
from pathlib import Path

import cffi

from eomc.runtime.errors import EomcError

__all__ = ["integrator_library", "extension_library"]

_OPENED = {}
_EXTENSIONS = {}
_LOCK = threading.Lock()
_ARM_LOCK = threading.Lock()


def _library_path():
    here = Path(__file__).resolve().parent
    for suffix in importlib.machinery.EXTENSION_SUFFIXES:
        candidate = here / f"_eomc_integrators{suffix}"
        if candidate.is_file():
            return candidate
    raise EomcError(f"eomc's integrator library (_eomc_integrators) is missing from {here}; "
                    "eomc was not installed with its build step -- reinstall with `pip install .` "
                    "(or `pip install -e .` in a checkout)")


class _Interruptible:
    """The integrator library, with eomc_integrate/eomc_integrate_ex run under an armed Ctrl-C.

    The handler stays installed after the first run (it counts the signal and calls
    Python's, so it changes nothing else); each run re-arms it, a single sigaction query
    when it is still in place, in case Python code replaced it meanwhile.  Removing it
    after each run cost two more system calls per run (~5 us on a loaded machine), and
    simulate_many makes one run per case.
    """

    def __init__(self, lib):
        self._lib = lib
        for name in dir(lib):            # plain attributes: no __getattr__ detour per call
            if name not in ("eomc_integrate", "eomc_integrate_ex"):
                try:
                    setattr(self, name, getattr(lib, name))
                except AttributeError:
                    pass

    def __getattr__(self, name):
        return getattr(self._lib, name)

    def _arm(self):
        with _ARM_LOCK:
            self._lib.eomc_interrupt_arm()

    def eomc_integrate(self, *args):
        self._arm()
        return self._lib.eomc_integrate(*args)

    def eomc_integrate_ex(self, *args):
        self._arm()
        return self._lib.eomc_integrate_ex(*args)


def integrator_library(ffi):
    """``ffi.dlopen`` of the integrator library (wrapped, see above); ``ffi`` must declare
    INTEGRATOR_CDEF."""
    with _LOCK:
        key = id(ffi)
        if key not in _OPENED:
            _OPENED[key] = (ffi, _Interruptible(ffi.dlopen(str(_library_path()))))
        return _OPENED[key][1]


def extension_library(base, cdef):
    """(ffi, lib): a further API of the integrator library (sensitivities, rollouts) declared
    by ``cdef`` in an FFI that includes the model's ``base`` FFI, so the two share the model
    struct's type.  One per (base, cdef), kept while ``base`` lives (``id`` is checked against
    the kept object, so a reused id of a collected FFI is not mistaken for it)."""
    with _LOCK:
        key = (id(base), cdef)
        hit = _EXTENSIONS.get(key)
        if hit is None or hit[0] is not base:
            ffi = cffi.FFI()
            ffi.include(base)
            ffi.cdef(cdef)
            hit = _EXTENSIONS[key] = (base, ffi, ffi.dlopen(str(_library_path())))
        return hit[1], hit[2]
