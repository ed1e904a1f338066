"""Constant folding, parameter folding and copy propagation."""
import sympy as sm

from .replace import Replacer
from .timing import compiler_pass

__all__ = ["fold_constants", "fold_parameters"]


@compiler_pass
def fold_parameters(program, values):
    """Replace parameter symbols by literal values ({symbol: float}) and fold what becomes constant.

    The folded symbols stop being inputs of the program.
    """
    env = {s: sm.Float(float(v)) for s, v in values.items()}
    inputs = tuple(s for s in program.inputs if s not in env)
    return _propagate(program.with_(inputs=inputs), env)


@compiler_pass
def fold_constants(program):
    """Drop assignments whose value is a number or a copy of another symbol, substituting them."""
    return _propagate(program, {})


def _propagate(program, env):
    # env grows as targets fold, but only before any expression reads them (single
    # assignment), so one memoized Replacer serves the whole program
    replace = Replacer(env)
    assignments = []
    for target, expr in program.assignments:
        if env and not expr.is_Atom:
            expr = replace(expr)
        elif expr in env:
            expr = env[expr]
        if expr.is_Number or expr.is_Symbol:
            env[target] = expr
        else:
            assignments.append((target, expr))
    results = tuple((k, replace(e) if env else e) for k, e in program.results)
    return program.with_(assignments=tuple(assignments), results=results)
