"""Builds that several test files need as they are, made once per test process.

Why: a module-scoped fixture builds its model once per file; two files that build the same
model with the same options paid for it twice (Solo12 on its four feet, rhs + jac_x + jac_r +
outputs + events: ~20 s CPU on a quiet machine, the suite's most expensive setup).  A build
here is the same object every file gets, so every assertion still runs against a model built
exactly as before; only the repeated build is gone.  The library goes to the test session's
cache ($EOMC_CACHE_DIR, a temporary directory set by tests/conftest.py), never the user's.

Import this module as ``helpers.shared_builds`` (not ``tests.helpers...``): the two names are
two module objects, each with its own memo.
"""
import functools
import sys
from pathlib import Path

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def quadruped_stand():
    """examples/quadruped_stand.py as a module (its build, stance and stand helpers)."""
    if str(EXAMPLES) not in sys.path:
        sys.path.insert(0, str(EXAMPLES))
    import quadruped_stand
    return quadruped_stand


@functools.lru_cache(maxsize=None)
def solo12_stand():
    """quadruped_stand.build() with its default functions (what Radau with feedback needs)."""
    return quadruped_stand().build()
