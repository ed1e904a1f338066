"""cffi declarations of the integrator C API (runtime/c/eomc_integrators.h).

Read from the header itself (:mod:`.header_cdef`); the loader appends
INTEGRATOR_CDEF to the model ABI declarations (which declare ``eomc_model``)
so one FFI object sees both.  The method numbers are also Python constants
here (a test checks them against the header's EOMC_* defines).
"""
from .header_cdef import header_cdef


__all__ = ["INTEGRATOR_CDEF", "METHOD_IDS", "METHOD_ALIASES", "FIXED_STEP", "STATUS_NAMES", "STATUS_OK"]

INTEGRATOR_CDEF = header_cdef("eomc_integrators.h")

# Canonical method name -> EOMC_* number in eomc_integrators.h.
METHOD_IDS = {"rk4": 0, "dopri5": 1, "dop853": 2, "radau": 3, "implicitfast": 4, "bdf": 5}
# Other accepted spellings.
METHOD_ALIASES = {"rk45": "dopri5", "radau5": "radau", "radauiia": "radau",
                  "implicit": "implicitfast", "implicitfixed": "implicitfast",
                  "ndf": "bdf", "ode15s": "bdf"}
# Fixed-step methods: they take dt= and write every step unless given t_eval.
FIXED_STEP = ("rk4", "implicitfast")

STATUS_OK = 0
# eomc_status -> what went wrong, in words: one table for the whole runtime (cdef.py).
from .cdef import STATUS_NAMES  # noqa: E402
