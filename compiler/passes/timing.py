"""A decorator that times passes and, on request, dumps the program after each one.

Set ``EOMC_DUMP_IR=1`` to print every pass's output to stderr; timings are
collected in :data:`PASS_TIMES` (name -> seconds, summed) for ``--print-ir``
style reports and benchmarks.
"""
import functools
import os
import sys
import time

__all__ = ["compiler_pass", "PASS_TIMES"]

PASS_TIMES = {}


def compiler_pass(func):
    """Wrap a pure ``program -> program`` pass with timing and optional dumping."""
    name = func.__name__

    @functools.wraps(func)
    def wrapper(program, *args, **kwargs):
        start = time.perf_counter()
        out = func(program, *args, **kwargs)
        PASS_TIMES[name] = PASS_TIMES.get(name, 0.0) + time.perf_counter() - start
        if os.environ.get("EOMC_DUMP_IR"):
            from ..ir import format_program
            sys.stderr.write(format_program(out, title=f"after {name}"))
        return out

    return wrapper
