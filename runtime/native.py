"""The integrator library built with eomc (setup.py): find it and open it once per process.

The library is handed out wrapped (:class:`_Interruptible`): its two run functions
arm Ctrl-C for the length of the C call (``eomc_interrupt_arm`` in
eomc_integrators.h), so a long run without Python callbacks stops within one
model evaluation of SIGINT, and Python raises KeyboardInterrupt as the call
returns.  Without it the signal waited for the whole run (report r3, N5).
"""
import importlib.machinery
import threading
from pathlib import Path

from eomc.runtime.errors import EomcError

__all__ = ["integrator_library"]

_OPENED = {}
_LOCK = threading.Lock()
_ARMED = {"count": 0}
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

    Arming is counted: concurrent runs (simulate_many's threads) share one handler, installed
    by the first and removed by the last.
    """

    def __init__(self, lib):
        self._lib = lib

    def __getattr__(self, name):
        return getattr(self._lib, name)

    def _run(self, fn, args):
        lib = self._lib
        with _ARM_LOCK:
            # armed on every run (cheap when it already is), so a count left high by an
            # exception in the bookkeeping below never leaves a run unarmed; a handler left
            # installed is harmless: it counts and chains to Python's
            lib.eomc_interrupt_arm()
            _ARMED["count"] += 1
        try:
            return fn(*args)
        finally:
            with _ARM_LOCK:
                _ARMED["count"] -= 1
                if _ARMED["count"] == 0:
                    lib.eomc_interrupt_disarm()

    def eomc_integrate(self, *args):
        return self._run(self._lib.eomc_integrate, args)

    def eomc_integrate_ex(self, *args):
        return self._run(self._lib.eomc_integrate_ex, args)


def integrator_library(ffi):
    """``ffi.dlopen`` of the integrator library (wrapped, see above); ``ffi`` must declare
    INTEGRATOR_CDEF."""
    with _LOCK:
        key = id(ffi)
        if key not in _OPENED:
            _OPENED[key] = (ffi, _Interruptible(ffi.dlopen(str(_library_path()))))
        return _OPENED[key][1]
