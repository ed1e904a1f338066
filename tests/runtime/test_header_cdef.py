"""The cffi declarations come from the shipped headers, and what Python keeps beside them agrees."""
import cffi

from eomc.runtime.cdef import ABI_VERSION, BATCH_CDEF, MODEL_CDEF
from eomc.runtime.header_cdef import _strip
from eomc.runtime.integrators_api import INTEGRATOR_CDEF, METHOD_IDS


def _ffi():
    ffi = cffi.FFI()
    ffi.cdef(MODEL_CDEF + BATCH_CDEF + INTEGRATOR_CDEF)
    return ffi


def test_headers_parse_and_declare_the_abi():
    ffi = _ffi()
    fields = [name for name, _ in ffi.typeof("eomc_model").fields]
    assert fields[:3] == ["abi_version", "name", "nq"] and fields[-1] == "constraints_jac"
    assert {"method", "rtol", "atol", "baumgarte"} <= {n for n, _ in ffi.typeof("eomc_options").fields}
    assert "int eomc_integrate(" in INTEGRATOR_CDEF and "int eomc_rhs_many(" in BATCH_CDEF


def test_python_constants_match_the_headers_defines():
    ffi = _ffi()
    lib = ffi.dlopen(None)  # integer #defines need no library symbols
    assert lib.EOMC_ABI_VERSION == ABI_VERSION
    assert METHOD_IDS == {"rk4": lib.EOMC_RK4, "dopri5": lib.EOMC_DOPRI5,
                          "dop853": lib.EOMC_DOP853, "radau": lib.EOMC_RADAU5,
                          "implicitfast": lib.EOMC_IMPLICITFAST, "bdf": lib.EOMC_BDF}
    assert lib.EOMC_SINGULAR_MASS_MATRIX == 1 and lib.EOMC_STIFF == 7


def test_strip_keeps_declarations_and_integer_defines_only():
    text = ('#ifndef G\n#define G\n#include <stddef.h>\n#ifdef __cplusplus\nextern "C" {\n#endif\n'
            '#define N 3\n#define NAME(x) x\nint f(int);\n#ifdef __cplusplus\n}\n#endif\n#endif\n')
    assert _strip(text) == "#define N 3\nint f(int);\n"
