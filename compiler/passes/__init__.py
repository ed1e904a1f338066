"""eomc.compiler.passes: pure ``Program -> Program`` optimizations, one per module."""
from .cse import cse
from .dce import dce
from .diff import differentiate, tangent
from .adjoint import adjoint
from .fold import fold_constants, fold_parameters
from .pipeline import finish_function, optimize_shared
from .powers import expand_powers
from .sincos import share_sincos
from .timing import PASS_TIMES, compiler_pass, compiler_step

__all__ = ["adjoint", "cse", "dce", "fold_constants", "fold_parameters", "expand_powers", "share_sincos", "differentiate", "tangent",
           "optimize_shared", "finish_function", "compiler_pass", "compiler_step", "PASS_TIMES"]
