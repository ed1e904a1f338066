"""The reuse key's generator switches without importing the generator (compiler/build/reuse.py)."""
import subprocess
import sys

PROBE = """
import sys
from eomc.compiler.build.reuse import generator_switches
before = generator_switches()
print('sympy' in sys.modules)
import eomc.compiler.contact.pairs, eomc.compiler.tree.second_order, eomc.compiler.tree.chain_loop
import eomc.compiler.emit.seed_pairs, eomc.compiler.tree.limbs, eomc.compiler.tree.body_loops
print(before == generator_switches(), list(before.items()) == list(generator_switches().items()))
"""


def test_switches_of_modules_not_imported_are_their_defaults():
    """A switch's module not imported yet is taken at its default without importing it (the
    modules import SymPy, ~0.7 s per command before); the defaults so assumed must be the
    modules' own, in the same order, or the key of a model built before would change."""
    out = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "True", "True"], out.stdout + out.stderr
