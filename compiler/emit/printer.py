"""C99 expression printer for IR expressions.

SymPy's C99CodePrinter does the precedence work; this subclass only

* maps symbols to C names (array slots ``x[3]``, temporaries ``t12``),
* prints floats so they round-trip exactly (``repr``), exact rationals as
  ``1.0/3.0`` (SymPy's rule), and named constants (pi, E) as literals rather than the
  non-C99 ``M_PI`` macros,
* prints :class:`~eomc.compiler.ir.IMul` products as ``(a*b*c)``.
"""
import sympy as sm
from sympy.printing.c import C99CodePrinter
from sympy.printing.precedence import PRECEDENCE

__all__ = ["CPrinter", "NonFiniteLiteral"]


class NonFiniteLiteral(ValueError):
    """A NaN or infinite constant reached the printer; generate_c turns it into a ModelError
    naming the function (C99 has no portable literal for them, and a model that computes a
    constant NaN is wrong: eomc refuses it rather than compile it)."""


class CPrinter(C99CodePrinter):
    def __init__(self, names):
        # order="none": print terms in the IR's own (deterministic) order instead of
        # sorting every sum again, the most expensive part of printing
        super().__init__({"math_macros": {}, "order": "none"})
        self._names = names

    def _print_Symbol(self, expr):
        name = self._names.get(expr)
        if name is None:
            raise KeyError(f"symbol {expr} has no C name (compiler bug)")
        return name

    def _print_Float(self, expr):
        text = repr(float(expr))
        if "inf" in text or "nan" in text:
            raise NonFiniteLiteral(text)
        return text if ("." in text or "e" in text) else text + ".0"

    def _refuse(self, expr):
        raise NonFiniteLiteral(str(expr))

    _print_NaN = _refuse
    _print_Infinity = _refuse
    _print_NegativeInfinity = _refuse
    _print_ComplexInfinity = _refuse

    def _print_Integer(self, expr):
        return f"{int(expr)}.0"

    def _print_NumberSymbol(self, expr):
        return self._print_Float(sm.Float(expr.evalf(17)))

    _print_Pi = _print_NumberSymbol
    _print_Exp1 = _print_NumberSymbol

    def _print_IMul(self, expr):
        # always parenthesized: SymPy's Mul printer may put it after "/" at Add precedence
        prec = PRECEDENCE["Mul"]
        return "(" + "*".join(self.parenthesize(a, prec) for a in expr.args) + ")"
