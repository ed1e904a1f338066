"""The generation cache: a warm compile skips generate_c; any change in its inputs is a miss."""
import json

import pytest
import sympy as sm

from helpers import model_files
import eomc.compiler.emit as emit
from eomc.compiler.build import cache_root
from eomc.compiler.build.cache import CacheWarning
from eomc.compiler.build.gencache import _Digester, generation_key
from eomc.compiler.driver import generate
from eomc.compiler.model import model_spec


@pytest.fixture
def counted(monkeypatch):
    calls = []
    real = emit.generate_c

    def counting(*args, **kw):
        calls.append(args[1])
        return real(*args, **kw)
    monkeypatch.setattr(emit, "generate_c", counting)
    return calls


def test_second_generation_is_served_from_the_cache(tmp_path, counted):
    # formulation="kane": one generate_c per generation (auto lowers two forms of a small tree)
    path = model_files.write(tmp_path, model_files.PENDULUM, "p")
    _, first = generate(path, cache_dir=tmp_path / "c", progress=False, formulation="kane")
    _, second = generate(path, cache_dir=tmp_path / "c", progress=False, formulation="kane")
    assert counted == ["pend"]
    assert second.c_source == first.c_source and second.cdef == first.cdef
    assert json.dumps(second.metadata, sort_keys=True) == json.dumps(first.metadata, sort_keys=True)


@pytest.mark.parametrize("change", [
    dict(parameters={"m": 3.0}), dict(functions=["rhs"]), dict(fold_parameters=True), dict(name="other"),
])
def test_changed_inputs_are_misses(tmp_path, counted, change):
    path = model_files.write(tmp_path, model_files.PENDULUM, "p")
    generate(path, cache_dir=tmp_path / "c", progress=False, formulation="kane")
    generate(path, cache_dir=tmp_path / "c", progress=False, formulation="kane", **change)
    assert len(counted) == 2


def test_key_follows_the_equations(tmp_path):
    path = model_files.write(tmp_path, model_files.PENDULUM, "p")
    other = model_files.write(tmp_path, model_files.PENDULUM.replace("-m * g * N.y", "-2 * m * g * N.y"), "q")
    keys = {generation_key(model_spec(p), None, False) for p in (path, path, other)}
    assert len(keys) == 2


def test_key_follows_the_generator_switches(tmp_path, monkeypatch):
    # pairs.INLINE_NARROW changes the C of a model with body-body pairs for the same sources:
    # the generation key and a model file's build key differ with it (they did not: a flip was
    # served the other setting's C from the cache)
    import eomc.compiler.contact.pairs as pairs
    from eomc.compiler.build.reuse import source_key
    path = model_files.write(tmp_path, model_files.PENDULUM, "p")
    keys = []
    for inline in (True, False, True):
        monkeypatch.setattr(pairs, "INLINE_NARROW", inline)
        keys.append((generation_key(model_spec(path), None, False), source_key(path, {})))
    assert keys[0] == keys[2]
    assert keys[0][0] != keys[1][0] and keys[0][1] != keys[1][1]
    # second_order.TANGENT (hess_id along the joints' tangent, for the Pinocchio comparison) likewise
    import eomc.compiler.tree.second_order as second_order
    tangent = []
    for flag in (False, True, False):
        monkeypatch.setattr(second_order, "TANGENT", flag)
        tangent.append((generation_key(model_spec(path), None, False), source_key(path, {})))
    assert tangent[0] == tangent[2] == keys[0]
    assert tangent[0][0] != tangent[1][0] and tangent[0][1] != tangent[1][1]
    # pairs.LAW_ROUTINES (each pair one call of its kinds' law routine) and pairs.PAIR_TABLE (every
    # pair in one table-driven loop, compiler/contact/table.py) likewise
    for switch in ("LAW_ROUTINES", "PAIR_TABLE"):
        law, default = [], getattr(pairs, switch)          # PAIR_TABLE: on by default
        for flag in (default, not default, default):
            monkeypatch.setattr(pairs, switch, flag)
            law.append((generation_key(model_spec(path), None, False), source_key(path, {})))
        assert law[0] == law[2] == keys[0], switch
        assert law[0][0] != law[1][0] and law[0][1] != law[1][1], switch
    # pairs.TABLE_FROM (the fewest pairs of a tree that take the table) likewise
    sizes = []
    for n in (pairs.TABLE_FROM_DEFAULT, 1, pairs.TABLE_FROM_DEFAULT):
        monkeypatch.setattr(pairs, "TABLE_FROM", n)
        sizes.append((generation_key(model_spec(path), None, False), source_key(path, {})))
    assert sizes[0] == sizes[2] == keys[0]
    assert sizes[0][0] != sizes[1][0] and sizes[0][1] != sizes[1][1]


def test_digest_distinguishes_structure_and_assumptions():
    x, y = sm.symbols("x y")
    xp = sm.Symbol("x", positive=True)
    d = _Digester()
    assert d(x + y) == _Digester()(sm.Add(y, x))
    assert len({d(x + y), d(x * y), d(x - y), d(xp + y), d(sm.Function("x")(y)), d(sm.Float(0.1) * x)}) == 6


def test_unreadable_entry_is_regenerated(tmp_path, counted):
    path = model_files.write(tmp_path, model_files.PENDULUM, "p")
    generate(path, cache_dir=tmp_path / "c", progress=False, formulation="kane")
    stored, = (cache_root(tmp_path / "c") / "generated").rglob("generated.json")
    stored.write_text("{" + " " * (stored.stat().st_size - 1))  # same size, not JSON
    with pytest.warns(CacheWarning, match=r"generated.json differs from the file that was built\); rebuilding"):
        _, again = generate(path, cache_dir=tmp_path / "c", progress=False, formulation="kane")
    assert len(counted) == 2 and "pend_rhs" in again.c_source
