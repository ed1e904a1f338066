"""Support for the sweep and pickle tests: picklable per-case reductions and a SymPy blocker.

Functions given to a process pool must be importable by name in the worker,
so they live here (tests/ is on the workers' sys.path) rather than in a test
module.  ``block_sympy(directory)`` writes a sitecustomize.py that makes
``import sympy`` fail in every Python started with the directory on
PYTHONPATH: a worker that has numpy, cffi and eomc but no SymPy.
"""
import sys
from pathlib import Path

__all__ = ["final_q", "worker_facts", "block_sympy", "BLOCKER"]

BLOCKER = '''
import sys

class _NoSympy:
    """A meta-path finder that refuses SymPy, as if it were not installed."""
    def find_spec(self, name, path=None, target=None):
        if name == "sympy" or name.startswith("sympy."):
            raise ImportError(f"No module named {name!r} (blocked for the test)")
        return None

sys.meta_path.insert(0, _NoSympy())
'''


def final_q(result):
    """The first state at the last output time."""
    return float(result.x[-1, 0])


def worker_facts(result):
    """(final q, whether the worker could import SymPy, compiler modules it imported)."""
    try:
        import sympy  # noqa: F401
        has_sympy = True
    except ImportError:
        has_sympy = False
    compiler = sorted(m for m in sys.modules if m.startswith("eomc.compiler"))
    return float(result.x[-1, 0]), has_sympy, compiler


def block_sympy(directory):
    """Write sitecustomize.py into ``directory``; put it first on PYTHONPATH to block SymPy."""
    Path(directory).mkdir(parents=True, exist_ok=True)
    path = Path(directory) / "sitecustomize.py"
    path.write_text(BLOCKER)
    return Path(directory)
