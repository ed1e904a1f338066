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
import eomc.compiler.contact.ground_table
print(before == generator_switches(), list(before.items()) == list(generator_switches().items()))
"""


def test_switches_of_modules_not_imported_are_their_defaults():
    """A switch's module not imported yet is taken at its default without importing it (the
    modules import SymPy, ~0.7 s per command before); the defaults so assumed must be the
    modules' own, in the same order, or the key of a model built before would change."""
    out = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "True", "True"], out.stdout + out.stderr


def test_ground_table_switches_are_in_the_key(monkeypatch):
    """The ground points' loop threshold and its two switches change the C, so each must change
    the key when not its default (before session 29 none did: a lowered TABLE_FROM found the
    straight-line C of the default build in the cache)."""
    from eomc.compiler.build.reuse import generator_switches
    from eomc.compiler.contact import ground_table as gt
    default = generator_switches()
    assert not any(k.startswith(("ground_", "no_ground")) for k in default)
    for name, value in (("TABLE_FROM", 1), ("GROUND_TABLE", False), ("SLOPES_TABLE", False)):
        with monkeypatch.context() as mp:
            mp.setattr(gt, name, value)
            assert generator_switches() != default, name
    assert generator_switches() == default
