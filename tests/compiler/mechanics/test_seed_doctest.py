"""The seed API document, run as a doctest: every ``>>>`` example, verbatim.

The only change is the import: ``from sympy.physics.mechanics import *``
becomes ``from eomc.mechanics import *``.  Whitespace is not normalized: the
output must print exactly as documented.  A copy of the seed lives in
``data/`` so the suite does not depend on files outside the repository.
"""
import contextlib
import doctest
import io
import pathlib
import sys

import pytest
from sympy.printing.printer import Printer

SEED = pathlib.Path(__file__).parent / "data" / "001_353f4581c47c99ff.txt"
SYMPY_IMPORT = "from sympy.physics.mechanics import *"
EOMC_IMPORT = "from eomc.mechanics import *"
LAGRANGE_TITLE = "Lagrange's Method in Physics/Mechanics"


def _sections():
    """The document's Kane half and Lagrange half (each starts with its own import)."""
    text = SEED.read_text()
    cut = text.index(LAGRANGE_TITLE)
    cut = text.rindex("\n", 0, text.rindex("=" * 10, 0, cut))
    return {"kane": text[:cut], "lagrange": text[cut:]}


def _run(text, name, import_line=EOMC_IMPORT):
    """Run the examples of ``text``; return (failed, attempted, report)."""
    text = text.replace(SYMPY_IMPORT, import_line)
    test = doctest.DocTestParser().get_doctest(text, {}, name, str(SEED), 0)
    lines = []
    runner = doctest.DocTestRunner(optionflags=0, verbose=False)
    saved_settings = dict(Printer._global_settings)
    saved_hook = sys.displayhook
    try:
        runner.run(test, out=lines.append)
    finally:
        Printer._global_settings.clear()
        Printer._global_settings.update(saved_settings)
        sys.displayhook = saved_hook
    with contextlib.redirect_stdout(io.StringIO()):
        result = runner.summarize(verbose=False)
    return result.failed, result.attempted, "".join(lines)


def test_the_seed_has_58_examples():
    parser = doctest.DocTestParser()
    counts = {k: len(parser.get_examples(v)) for k, v in _sections().items()}
    assert sum(counts.values()) == 58
    assert counts["lagrange"] == 19


@pytest.mark.parametrize("half", ["kane", "lagrange"])
def test_seed_examples_run_verbatim_with_eomc(half):
    failed, attempted, report = _run(_sections()[half], f"seed-{half}")
    assert attempted > 0
    assert failed == 0, report


def test_sympy_itself_fails_10_seed_examples():
    """Why eomc differs from SymPy 1.14: the seed's ``coneqs`` keyword and
    ``kanes_equations(loads, bodies)`` argument order are gone from SymPy."""
    runs = {h: _run(text, f"sympy-{h}", SYMPY_IMPORT) for h, text in _sections().items()}
    assert sum(r[1] for r in runs.values()) == 58
    assert sum(r[0] for r in runs.values()) == 10
    assert "coneqs" in runs["lagrange"][2]
    assert "kanes_equations" in runs["kane"][2]
