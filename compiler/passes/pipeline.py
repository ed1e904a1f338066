"""The standard pass order."""
from .cse import cse
from .dce import dce
from .adjoint import adjoint
from .diff import differentiate, tangent
from .fold import fold_constants
from .powers import expand_powers
from .sincos import share_sincos

__all__ = ["optimize_shared", "finish_function"]


def optimize_shared(program, derivatives=()):
    """Passes run once over every function's results together.

    CSE, then the requested derivatives ``(source_group, wrt, target_group)`` by forward
    differentiation of the CSE'd program (``wrt``: a sequence of symbols for all partial
    derivatives, or a {symbol: seed} dict for one directional derivative), then sin/cos
    sharing and folding.  A request whose source is a {result key: weight symbol} dict is
    one reverse sweep (:func:`.adjoint.adjoint`): the gradient of the weighted sum.
    """
    program = cse(program)
    for source, wrt, target in derivatives:
        if isinstance(source, dict):  # {result key: weight}: reverse mode
            program = adjoint(program, source, wrt, target)
        elif isinstance(wrt, dict):     # {symbol: seed symbol}: one directional derivative
            program = tangent(program, source, wrt, target)
        else:
            program = differentiate(program, source, wrt, target)
    return fold_constants(share_sincos(program))


def finish_function(program, groups):
    """Per function: keep what ``groups`` need, then write powers as multiplies."""
    return expand_powers(dce(program, groups))
