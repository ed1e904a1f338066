"""Common-subexpression elimination over all results at once, with deterministic names."""
import sympy as sm

from ..ir import Names
from .timing import compiler_pass

__all__ = ["cse"]


@compiler_pass
def cse(program):
    """Run ``sympy.cse`` once over every assignment and result of the program.

    Existing assignments are kept as they are (they are usually none: the
    program starts as bare results); new temporaries come from the program's
    names registry, in the order ``sympy.cse`` defines them.
    """
    keys = [k for k, _ in program.results]
    exprs = [e for _, e in program.results]
    if not exprs:
        return program
    names = Names(program)
    replacements, reduced = sm.cse(exprs, symbols=names.stream(), order="none", list=True)
    assignments = program.assignments + tuple((s, e) for s, e in replacements)
    return program.with_(assignments=assignments,
                         results=tuple(zip(keys, reduced)),
                         ntemp=names.count)   # cse may draw names it does not use
