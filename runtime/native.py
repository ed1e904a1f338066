"""The integrator library built with eomc (setup.py): find it and open it once per process.

The library is handed out wrapped (:class:`_Interruptible`): its two run functions
arm Ctrl-C before the C call (``eomc_interrupt_arm`` in eomc_integrators.h), so a
long run without Python callbacks stops within one model evaluation of SIGINT,
and Python raises KeyboardInterrupt as the call returns.  Without it the signal
waited for the whole run (report r3, N5).
"""
import importlib.machinery
import threading
import warnings
from pathlib import Path

import cffi

from eomc.runtime.errors import EomcError, EomcWarning

__all__ = ["integrator_library", "extension_library", "stale_sources"]

_OPENED = {}
_EXTENSIONS = {}
_LOCK = threading.Lock()
_ARM_LOCK = threading.Lock()
_CHECKED = []       # the stale-library check runs once per process


def stale_sources(library, runtime_dir):
    """The names of the C sources in ``runtime_dir``/c newer than the built integrator library
    ``library``, when ``runtime_dir`` sits in a source checkout (an editable install: pyproject.toml
    beside it); else [].

    Why: the integrators are compiled once, when eomc is installed (setup.py).  In a checkout
    installed with ``pip install -e .``, a pull or merge that changes runtime/c leaves the old
    library in place, and every run then uses the old integrators without a word -- a test of the
    new behaviour fails as if the change were wrong (session 17).  An installed package
    (site-packages, no pyproject.toml beside it) is never checked: its files' times say nothing."""
    sources = Path(runtime_dir) / "c"
    if not (Path(runtime_dir).parent / "pyproject.toml").is_file() or not sources.is_dir():
        return []
    built = Path(library).stat().st_mtime
    return sorted(p.name for p in sources.iterdir()
                  if p.suffix in (".c", ".h") and p.stat().st_mtime > built)


def _warn_if_stale(library, here):
    if _CHECKED:
        return
    _CHECKED.append(True)
    newer = stale_sources(library, here)
    if newer:
        warnings.warn(f"eomc's integrator library {library.name} is older than its C sources in "
                      f"{here / 'c'} ({', '.join(newer[:4])}{', ...' if len(newer) > 4 else ''}): the "
                      "runs use the integrators as they were when it was built; rebuild it with "
                      "`pip install -e .` in the checkout", EomcWarning, stacklevel=3)


def _library_path():
    here = Path(__file__).resolve().parent
    for suffix in importlib.machinery.EXTENSION_SUFFIXES:
        candidate = here / f"_eomc_integrators{suffix}"
        if candidate.is_file():
            _warn_if_stale(candidate, here)
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
        """Arm Ctrl-C and SIGTERM; return the eomc_options.interrupt_base of the run that follows:
        a signal from now on stops it, also one that comes before the C run reads the count
        (Python raises KeyboardInterrupt only as the C call returns, so that one was lost)."""
        with _ARM_LOCK:
            return self._lib.eomc_interrupt_arm_base()

    def eomc_integrate(self, *args):
        if args[1]:                      # the options (a NULL is the C call's own error)
            args[1].interrupt_base = self._arm()
        return self._lib.eomc_integrate(*args)

    def eomc_integrate_ex(self, *args):
        if args[1]:
            args[1].interrupt_base = self._arm()
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
