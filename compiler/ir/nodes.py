"""IR-only expression nodes.

``IMul(a, b, ...)`` is a product SymPy must not fold back into a power: the
power pass writes ``x**3`` as ``IMul(x, x, x)`` and the C printer prints
``x*x*x``.  With numeric arguments it evaluates to the ordinary product, so
numeric checks of a program need nothing special.
"""
import sympy as sm
from sympy.printing.precedence import PRECEDENCE

__all__ = ["IMul"]


class IMul(sm.Function):
    is_real = True
    # C printing wraps the product in its own parentheses (1/(x*x), -(x*x)), so for
    # SymPy's printers it is an atom: they never add a second pair
    precedence = PRECEDENCE["Atom"]

    @classmethod
    def eval(cls, *args):
        if all(a.is_Number for a in args):
            return sm.Mul(*args)
        return None

    def _eval_evalf(self, prec):
        return sm.Mul(*[a.evalf(prec) for a in self.args])
