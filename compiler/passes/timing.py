"""A decorator that times passes and, on request, dumps the program after each one.

Set ``EOMC_DUMP_IR=1`` to print every pass's output to stderr; timings are
collected in :data:`PASS_TIMES` (name -> seconds, summed) for ``--print-ir``
style reports and benchmarks.  Inside ``with reporting(callback):`` every
finished pass also calls ``callback(name, seconds)``: the driver's progress
display uses it, so a long generation (a bicycle: ~20 s) shows what it is doing.
"""
import contextlib
import functools
import os
import sys
import time

__all__ = ["compiler_pass", "compiler_step", "PASS_TIMES", "reporting", "doing"]

PASS_TIMES = {}
_LISTENERS = []
_DOING = []


@contextlib.contextmanager
def reporting(callback, now=None):
    """Call ``callback(pass name, seconds)`` after every pass run inside the block, and
    ``now(text)`` (when given) with every :func:`doing` note."""
    _LISTENERS.append(callback)
    if now is not None:
        _DOING.append(now)
    try:
        yield
    finally:
        _LISTENERS.remove(callback)
        if now is not None:
            _DOING.remove(now)


def doing(text):
    """Say what a long step is at now, in the user's words: the build's progress log names it.

    Why: the log's lines said only which pass a stage was past ("26 passes done, the last
    dropping unused code") while dm_control's dog spent over ten minutes inside the next step,
    inlining its body-body contacts with rolling friction one by one (session 41)."""
    for listener in list(_DOING):
        listener(text)


def compiler_pass(func):
    """Wrap a pure ``program -> program`` pass with timing and optional dumping."""
    name = func.__name__

    @functools.wraps(func)
    def wrapper(program, *args, **kwargs):
        start = time.perf_counter()
        out = func(program, *args, **kwargs)
        _finished(name, time.perf_counter() - start)
        if os.environ.get("EOMC_DUMP_IR"):
            from ..ir import format_program
            sys.stderr.write(format_program(out, title=f"after {name}"))
        return out

    return wrapper


@contextlib.contextmanager
def compiler_step(name):
    """Time a named compiler step that is not a ``program -> program`` pass (the contact laws'
    lowering, a recursive Jacobian's plan): PASS_TIMES and the progress display see it as they
    see a pass, so the tens of seconds such steps take on a contact-rich model (dm_control's
    quadruped: ~17 s of contacts, ~17 s of Jacobian plans under a profiler) are not a silent
    part of "generate"."""
    start = time.perf_counter()
    yield
    _finished(name, time.perf_counter() - start)


def _finished(name, elapsed):
    PASS_TIMES[name] = PASS_TIMES.get(name, 0.0) + elapsed
    for listener in list(_LISTENERS):
        listener(name, elapsed)
