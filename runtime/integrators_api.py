"""cffi declarations of the integrator C API (templates/c/eomc_integrators.h).

Filled in together with eomc_integrators.c; the loader appends this to the
model ABI declarations so one FFI object sees both.
"""
INTEGRATOR_CDEF = ""
