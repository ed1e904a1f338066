"""Numeric interpretation of a program, the oracle the pass tests compare against."""
import sympy as sm

__all__ = ["evaluate"]


def evaluate(program, values):
    """{result key: float} for input values {symbol: number}."""
    env = {s: sm.Float(v, 30) for s, v in values.items()}
    for target, expr in program.assignments:
        env[target] = sm.sympify(expr.xreplace(env)).evalf(30)
    out = {}
    for key, expr in program.results:
        out[key] = complex(sm.sympify(expr.xreplace(env)).evalf(30))
    return out
