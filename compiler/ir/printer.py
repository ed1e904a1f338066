"""Human-readable listing of a program (``--print-ir``)."""
from .program import c_names

__all__ = ["format_program"]


def format_program(program, title=None):
    """One line per assignment and result, temporaries named t0, t1, ... as in the C code."""
    names = {s: s.name for s in program.inputs}
    names.update(c_names(program))

    def show(expr):
        return str(expr.xreplace({s: _Named(n) for s, n in names.items() if s in expr.free_symbols}))

    lines = [f"# {title}"] if title else []
    lines.append(f"# inputs: {', '.join(sorted(s.name for s in program.inputs))}")
    for target, expr in program.assignments:
        lines.append(f"{names[target]} = {show(expr)}")
    for key, expr in program.results:
        lines.append(f"{_key(key)} <- {show(expr)}")
    return "\n".join(lines) + "\n"


def _key(key):
    return key[0] + "".join(f"[{i}]" for i in key[1:])


def _Named(name):
    import sympy as sm
    return sm.Symbol(name)
