"""Checks a program obeys the single-assignment rules; passes call it in tests and in debug runs."""
from .program import IRError, symbols_of

__all__ = ["verify"]


def verify(program):
    """Raise IRError unless every symbol is defined once, before it is read.

    Returns the program so calls can be chained.
    """
    defined = set(program.inputs)
    for target, expr in program.assignments:
        if not getattr(target, "is_Symbol", False):
            raise IRError(f"assignment target {target!r} is not a symbol")
        if target in defined:
            raise IRError(f"{target} is assigned twice or shadows an input")
        missing = symbols_of(expr) - defined
        if missing:
            raise IRError(f"{target} reads undefined {sorted(map(str, missing))}")
        defined.add(target)
    keys = set()
    for key, expr in program.results:
        if key in keys:
            raise IRError(f"result {key} is computed twice")
        keys.add(key)
        missing = symbols_of(expr) - defined
        if missing:
            raise IRError(f"result {key} reads undefined {sorted(map(str, missing))}")
    return program
