"""The standard pass order."""
from .cse import cse
from .dce import dce
from .fold import fold_constants
from .powers import expand_powers
from .sincos import share_sincos

__all__ = ["optimize_shared", "finish_function"]


def optimize_shared(program):
    """Passes run once over every function's results together: CSE, folding, sin/cos sharing."""
    return fold_constants(share_sincos(cse(program)))


def finish_function(program, groups):
    """Per function: keep what ``groups`` need, then write powers as multiplies."""
    return expand_powers(dce(program, groups))
