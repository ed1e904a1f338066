"""eomc.compiler.emit: FormedSystem -> C99 source, header, cffi cdef and metadata."""
from .generate import ALL_FUNCTIONS, generate_c
from .generated import GeneratedModel
from .signatures import SIGNATURES, cdef, prototype

__all__ = ["generate_c", "GeneratedModel", "ALL_FUNCTIONS", "SIGNATURES", "cdef", "prototype"]
