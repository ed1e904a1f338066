"""The split sub-functions' optimization level (compiler/emit/split.py, NOINLINE_MACRO), and
the long bodies' (LEAN_MACRO: EOMC_LEAN, EOMC_LEAN_PRE), which follow the same guard.

gcc compiles them at -O1 when the library is built at -O2/-O3 (a third of gcc's time on
large models, no slower code); not at -O0 or -Os, not under clang, and not when CFLAGS
define EOMC_PARTS_FULL_OPT.  Checked on the preprocessor's expansion of the macro, and the
macro compiles clean under -Wall -Wextra -Werror.
"""
import shutil
import subprocess

import pytest

from eomc.compiler.emit.split import LEAN_MACRO, NOINLINE_MACRO

CC = shutil.which("gcc")
pytestmark = pytest.mark.skipif(CC is None, reason="needs gcc")


def _expand(tmp_path, *flags, text=NOINLINE_MACRO + "\nEOMC_NOINLINE\n"):
    src = tmp_path / "m.c"
    src.write_text(text)
    out = subprocess.run([CC, "-E", "-P", *flags, str(src)], capture_output=True, text=True, check=True)
    return out.stdout.strip()


def test_parts_at_O1_only_when_optimizing_for_speed(tmp_path):
    assert 'optimize("O1")' in _expand(tmp_path, "-O2")
    assert 'optimize("O1")' in _expand(tmp_path, "-O3")
    for flags in (("-O0",), ("-Os",), ("-O2", "-DEOMC_PARTS_FULL_OPT")):
        text = _expand(tmp_path, *flags)
        assert "noinline" in text and "optimize" not in text, flags


def _compiles_clean(tmp_path, text):
    """``text`` compiles with no warning at -O0, -O2 and -Os (-std=c99 -Wall -Wextra -Werror)."""
    src = tmp_path / "clean.c"
    src.write_text(text)
    for level in ("-O0", "-O2", "-Os"):
        subprocess.run([CC, level, "-std=c99", "-Wall", "-Wextra", "-Werror", "-c", str(src),
                        "-o", str(tmp_path / "clean.o")], check=True)


def test_macro_compiles_clean(tmp_path):
    _compiles_clean(tmp_path, NOINLINE_MACRO + "\nstatic EOMC_NOINLINE void part(const double *x, double *y)\n"
                    "{\n    y[0] = x[0] * x[1] + x[2];\n}\n"
                    "void f(const double *x, double *y) { part(x, y); }\n")


def test_lean_bodies_follow_the_parts_guard(tmp_path):
    """EOMC_LEAN (-O1 plus chosen -O2 passes) and EOMC_LEAN_PRE (also PRE and GCSE) expand
    where the parts' -O1 does, and to nothing elsewhere; clean under -Wall -Wextra -Werror."""
    text = LEAN_MACRO + "\nA EOMC_LEAN\nB EOMC_LEAN_PRE\n"
    for flags in (("-O2",), ("-O3",)):
        a, b = _expand(tmp_path, *flags, text=text).splitlines()[-2:]
        assert a.startswith('A __attribute__((optimize("O1", "tree-slp-vectorize"') and "tree-pre" not in a
        assert b.startswith('B __attribute__((optimize("O1", "tree-slp-vectorize"') and '"tree-pre", "gcse"' in b
    for flags in (("-O0",), ("-Os",), ("-O2", "-DEOMC_PARTS_FULL_OPT")):
        assert _expand(tmp_path, *flags, text=text).splitlines()[-2:] == ["A", "B"], flags
    _compiles_clean(tmp_path, LEAN_MACRO + "\nEOMC_LEAN int g(const double *x, double *y);\n"
                    "EOMC_LEAN int g(const double *x, double *y)\n{\n    y[0] = x[0] * x[1];\n    return 0;\n}\n"
                    "EOMC_LEAN_PRE int h(const double *x, double *y)\n{\n    y[0] = x[0] + x[1];\n    return 0;\n}\n")
