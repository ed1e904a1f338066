"""eomc.compiler.emit: FormedSystem -> C99 source, header, cffi cdef and metadata."""
from .generate import ALL_FUNCTIONS, Lowered, generate_c, ir_listing, lower
from .generated import GeneratedModel
from .signatures import SIGNATURES, cdef, prototype

__all__ = ["generate_c", "lower", "ir_listing", "Lowered", "GeneratedModel", "ALL_FUNCTIONS", "SIGNATURES", "cdef", "prototype"]
