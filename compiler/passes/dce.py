"""Dead-code elimination: keep only the assignments some result needs."""
from ..ir.program import symbols_of
from .timing import compiler_pass

__all__ = ["dce"]


@compiler_pass
def dce(program, groups=None):
    """Restrict to result ``groups`` (all when None) and drop assignments no kept result reads."""
    if groups is not None:
        program = program.select(groups)
    needed = set()
    for _, expr in program.results:
        needed |= symbols_of(expr)
    kept = []
    for target, expr in reversed(program.assignments):
        if target in needed:
            kept.append((target, expr))
            needed |= symbols_of(expr)
    return program.with_(assignments=tuple(reversed(kept)))
