"""The Kane part of the seed document runs verbatim with ``from eomc.mechanics import *``."""
import doctest
import pathlib

SEED = pathlib.Path(__file__).resolve().parent / "data" / "001_353f4581c47c99ff.txt"


def kane_section():
    text = SEED.read_text()
    end = text.index("Lagrange's Method in Physics/Mechanics")
    return text[:end].replace("from sympy.physics.mechanics import *", "from eomc.mechanics import *")


def test_seed_kane_examples_print_documented_output():
    text = kane_section()
    assert "from eomc.mechanics import *" in text
    test = doctest.DocTestParser().get_doctest(text, {}, "seed-kane", str(SEED), 0)
    assert len(test.examples) > 30
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    runner.run(test)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, f"{result.failed} of {result.attempted} seed examples failed"


def test_seed_kane_uses_eomc_classes():
    ns = {}
    exec("from eomc.mechanics import *", ns)
    from eomc.compiler.mechanics.kane import KanesMethod
    assert ns["KanesMethod"] is KanesMethod
