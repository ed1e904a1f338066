"""eomc.compiler sizes SymPy's expression cache where the user has not (compiler/__init__.py)."""
import os
import subprocess
import sys

PROBE = ("import os, {first}sympy.core.cache as c; print(c.SYMPY_CACHE_SIZE, os.environ.get('SYMPY_CACHE_SIZE'))")


def _run(first, **env):
    clean = {k: v for k, v in os.environ.items() if k != "SYMPY_CACHE_SIZE"}
    out = subprocess.run([sys.executable, "-c", PROBE.format(first=first)], env={**clean, **env},
                         capture_output=True, text=True, check=True)
    return out.stdout.split()


def test_compiler_import_sizes_the_cache_and_leaves_the_environment():
    from eomc.compiler import SYMPY_CACHE_SIZE
    assert _run("eomc.compiler, ") == [str(SYMPY_CACHE_SIZE), "None"]


def test_a_users_choice_or_an_earlier_sympy_import_is_kept():
    assert _run("eomc.compiler, ", SYMPY_CACHE_SIZE="500") == ["500", "500"]
    assert _run("sympy, eomc.compiler, ") == ["1000", "None"]


def test_the_cache_is_sized_when_sympy_is_imported_not_when_eomc_compiler_is():
    """eomc.compiler no longer imports SymPy (the look-up of a model built before needs none:
    ~0.7 s a command, s27); SymPy imported later, after a find_spec alone, still gets the size."""
    from eomc.compiler import SYMPY_CACHE_SIZE
    probe = ("import sys, importlib.util, eomc.compiler; print('sympy' in sys.modules); "
             "importlib.util.find_spec('sympy'); import sympy.core.cache as c, os; "
             "print(c.SYMPY_CACHE_SIZE, os.environ.get('SYMPY_CACHE_SIZE'))")
    clean = {k: v for k, v in os.environ.items() if k != "SYMPY_CACHE_SIZE"}
    out = subprocess.run([sys.executable, "-c", probe], env=clean, capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", str(SYMPY_CACHE_SIZE), "None"], out.stdout + out.stderr
