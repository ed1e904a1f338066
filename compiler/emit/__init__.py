"""eomc.compiler.emit: lowering -- FormedSystem -> C99 source, header, cffi cdef and metadata.

The stage, in the order ``generate.generate_c`` uses it:

- ``symbolic.py``    the symbolic result of every generated function (rhs, jac_x, M, ...), unoptimized
- ``layout.py``      where each symbol lives in the C arrays (x, p, r, outputs)
- ``generate.py``    lowers each function to an IR program, runs the passes, renders the templates
- ``bodies.py``      the C body of each function from its optimized program
- ``printer.py``     C99 expression printer for IR expressions
- ``linsolve.py``    numeric solve of M·u̇ = f in C (unrolled LDLᵀ), ``sparse_lu.py`` for non-symmetric A
- ``signatures.py``  the one table of C signatures (header, definitions and cdef all come from it)
- ``generated.py``   ``GeneratedModel``: the bundle handed to the build step
"""
from .generate import ALL_FUNCTIONS, Lowered, generate_c, ir_listing, lower
from .generated import GeneratedModel
from .signatures import SIGNATURES, cdef, prototype

__all__ = ["generate_c", "lower", "ir_listing", "Lowered", "GeneratedModel", "ALL_FUNCTIONS", "SIGNATURES", "cdef", "prototype"]
