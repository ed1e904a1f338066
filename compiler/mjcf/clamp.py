"""clamp(x, lo, hi) as an expression node: MuJoCo's ctrlrange and forcerange clamping in generated C.

Why not SymPy's Min/Max: their derivative is a Piecewise of relationals, which the C
printer writes with ``false`` and which the optimizer cannot share; this node prints as
``fmin(hi, fmax(lo, x))`` and its derivative is :class:`ClampSlope`, printed as
``((x > lo && x < hi) ? 1.0 : 0.0)`` (zero where the clamp holds, as a one-sided limit
would have it at the bounds).  ``lo`` and ``hi`` are numbers.
"""
import sympy as sm
from sympy.core.function import ArgumentIndexError

__all__ = ["Clamp", "ClampSlope"]


def _bounds(lo, hi):
    if not (lo.is_Number and hi.is_Number):
        raise ValueError(f"clamp bounds must be numbers, not {lo}, {hi}")


def _clamped(x, lo, hi):
    return min(max(x, lo), hi) if x.is_Number else None


def _slope(x, lo, hi):
    return (sm.S.One if lo < x < hi else sm.S.Zero) if x.is_Number else None


class Clamp(sm.Function):
    """min(max(x, lo), hi)."""
    nargs = 3
    is_real = True

    @classmethod
    def eval(cls, x, lo, hi):
        _bounds(lo, hi)
        return _clamped(x, lo, hi)

    def fdiff(self, argindex=1):
        if argindex == 1:
            return ClampSlope(*self.args)
        raise ArgumentIndexError(self, argindex)

    def _eval_evalf(self, prec):
        return _clamped(*(a.evalf(prec) for a in self.args))

    def _ccode(self, printer):
        from ..emit.printer import c_minmax
        x, lo, hi = (printer._print(a) for a in self.args)
        return c_minmax(printer, "fmin", hi, c_minmax(printer, "fmax", lo, x))


class ClampSlope(sm.Function):
    """d clamp(x, lo, hi) / dx: 1 strictly inside (lo, hi), else 0."""
    nargs = 3
    is_real = True

    @classmethod
    def eval(cls, x, lo, hi):
        _bounds(lo, hi)
        return _slope(x, lo, hi)

    def fdiff(self, argindex=1):
        return sm.S.Zero

    def _eval_evalf(self, prec):
        return _slope(*(a.evalf(prec) for a in self.args))

    def _ccode(self, printer):
        x, lo, hi = (printer._print(a) for a in self.args)
        return f"(({x} > {lo} && {x} < {hi}) ? 1.0 : 0.0)"
