"""A loaded Model pickles by content and unpickles in a fresh process with an empty cache.

Each way in is exercised in a child Python that cannot import SymPy: (a) the key
is in the worker's cache, (b) the shipped library is published under the same
key, (c) on a platform mismatch (faked) the shipped C is compiled there.
Altered pickles are refused; entries published from the runtime are hits for
the compiler's cache and the other way round.
"""
import copy
import json
import os
import pickle
import platform
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from helpers import osc_model
from helpers.sweep_support import BLOCKER
from eomc.compiler.build import build
from eomc.compiler.build import cache as compiler_cache
from eomc.runtime import store, travel
from eomc.runtime.loader import load, restore

X = [0.3, -0.2]


@pytest.fixture(autouse=True)
def private_cache(tmp_path, monkeypatch):
    """Unpickling in this process publishes into a cache of the test's own."""
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "own-cache"))


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    return build(osc_model.oscillator(), cache_dir=tmp_path_factory.mktemp("cache"))


@pytest.fixture(scope="module")
def blob(built, tmp_path_factory):
    path = tmp_path_factory.mktemp("blob") / "osc.pickle"
    path.write_bytes(pickle.dumps(load(built.directory)))
    return path


CHILD = BLOCKER + textwrap.dedent("""
    import json, pickle
    import eomc.runtime.travel as travel
    if sys.argv[2] == "elsewhere":
        travel.platform_tag = lambda: "elsewhere-on-mars"
    if sys.argv[2] == "no-avx2":      # a CPU of the same platform without AVX2
        import eomc.runtime.cpu as cpu
        cpu.cpu_features = lambda: frozenset({"sse2"})
    model = pickle.loads(open(sys.argv[1], "rb").read())
    try:
        import sympy
        sympy_ok = True
    except ImportError:
        sympy_ok = False
    print(json.dumps({"arrival": model.arrival, "directory": str(model.directory),
                      "rhs": model.rhs(0.0, [0.3, -0.2]).tolist(), "sympy": sympy_ok,
                      "compiler": sorted(m for m in sys.modules if m.startswith("eomc.compiler"))}))
    """)


def _start(blob, cache_dir, where="here"):
    env = dict(os.environ, EOMC_CACHE_DIR=str(cache_dir))
    return subprocess.Popen([sys.executable, "-c", CHILD, str(blob), where], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _finish(proc):
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    facts = json.loads(out.splitlines()[-1])
    assert facts["sympy"] is False and facts["compiler"] == []   # a worker without SymPy
    np.testing.assert_array_equal(facts["rhs"], osc_model.oscillator_rhs(0.0, X))
    return facts


def _entries(cache_dir):
    return sorted(p.name for p in (cache_dir / "v1" / "models").glob("*/*"))


def test_a_key_in_the_workers_cache_is_loaded_from_there(built, blob):
    facts = _finish(_start(blob, built.directory.parents[3]))
    assert facts["arrival"] == "cache" and facts["directory"] == str(built.directory)


def test_b_same_platform_publishes_the_shipped_library_once(built, blob, tmp_path):
    procs = [_start(blob, tmp_path) for _ in range(3)]    # three workers, one empty cache, at once
    arrivals = sorted(_finish(p)["arrival"] for p in procs)
    assert set(arrivals) <= {"library", "cache"} and "library" in arrivals
    assert _entries(tmp_path) == [built.key]               # published once, under the same key
    entry = tmp_path / "v1" / "models" / built.key[:2] / built.key
    assert (entry / "libosc.so").read_bytes() == built.library.read_bytes()
    # the compiler's cache sees the runtime's entry as a hit
    assert compiler_cache.lookup(compiler_cache.cache_root(tmp_path), "models", built.key) == entry


def test_c_another_platform_compiles_the_shipped_c(built, blob, tmp_path):
    facts = _finish(_start(blob, tmp_path, "elsewhere"))
    assert facts["arrival"] == "compiled"
    (key,) = _entries(tmp_path)
    assert key != built.key and facts["directory"].endswith(key)
    manifest = json.loads((tmp_path / "v1" / "models" / key[:2] / key / "manifest.json").read_text())
    assert manifest["inputs"]["compiled_from"] == built.key
    again = _finish(_start(blob, tmp_path, "elsewhere"))      # the compiled entry is reused
    assert again["directory"] == facts["directory"] and _entries(tmp_path) == [key]


def test_an_altered_pickle_is_refused(built, blob):
    data = bytearray(blob.read_bytes())
    library = built.library.read_bytes()
    at = data.find(library[4096:4160])
    assert at > 0
    data[at + 10] ^= 0xFF
    with pytest.raises(travel.TravelError, match="'osc'.*corrupt or was altered.*refusing"):
        pickle.loads(bytes(data))
    payload = dict(travel.pack(load(built.directory)))
    payload["files"] = {**payload["files"], "osc.c": payload["files"]["osc.c"].replace("x[1]", "x[0]")}
    with pytest.raises(travel.TravelError, match="corrupt or was altered"):
        restore(payload)
    with pytest.raises(travel.TravelError, match="does not hold an eomc model"):
        restore({"something": "else"})


def test_a_payload_reaching_outside_the_cache_is_refused(built):
    payload = dict(travel.pack(load(built.directory)))
    payload["files"] = {**payload["files"], "../evil.h": "int x;"}
    payload["digest"] = travel._digest(payload)
    with pytest.raises(travel.TravelError, match="outside its directory"):
        restore(payload)
    payload = dict(travel.pack(load(built.directory)), key="../../../elsewhere")
    payload["digest"] = travel._digest(payload)
    with pytest.raises(travel.TravelError, match="malformed cache key"):
        restore(payload)


def test_one_process_restores_a_model_once(built):
    model = load(built.directory)
    first = pickle.loads(pickle.dumps(model))
    assert pickle.loads(pickle.dumps(model)) is first and copy.deepcopy(first) is first
    np.testing.assert_array_equal(first.rhs(0.0, X), model.rhs(0.0, X))


def test_runtime_store_and_compiler_cache_agree(built, tmp_path):
    assert store.CACHE_SCHEMA == compiler_cache.CACHE_SCHEMA
    assert store.hash_key({"a": [1, 2]}) == compiler_cache.hash_key({"a": [1, 2]})
    root = compiler_cache.cache_root(built.directory.parents[3])
    assert store.find(root, "models", built.key, verify=("libosc.so",)) == built.directory
    entry, published = store.publish(store.cache_root(tmp_path), "things", "ab" * 32,
                                     lambda tmp: (tmp / "x.bin").write_bytes(b"123"), {"why": "test"})
    assert published and compiler_cache.lookup(compiler_cache.cache_root(tmp_path), "things", "ab" * 32) == entry
    (entry / "x.bin").write_bytes(b"12X")                  # same size, other content
    assert store.find(store.cache_root(tmp_path), "things", "ab" * 32, verify=("x.bin",)) is None


def test_a_cython_built_model_travels_as_its_cffi_library(built, tmp_path):
    """The Cython extension is tied to one Python; the library under it travels, under its own key."""
    directory = tmp_path / "built"
    directory.mkdir()
    for path in built.directory.iterdir():
        (directory / path.name).write_bytes(path.read_bytes())
    data = json.loads((directory / "osc.json").read_text())
    data["build"].update(backend="cython", extension="osc_cy.so")
    (directory / "osc.json").write_text(json.dumps(data))
    payload = travel.pack(load(directory, backend="cffi"))
    assert payload["key"] != built.key
    shipped = json.loads(payload["files"]["osc.json"])["build"]
    assert shipped["backend"] == "cffi" and shipped["extension"] is None
    model = restore(payload)
    assert model.arrival == "library" and model.backend == "cffi" and model.directory.name == payload["key"]
    np.testing.assert_array_equal(model.rhs(0.0, X), osc_model.oscillator_rhs(0.0, X))


@pytest.mark.skipif(platform.machine().lower() not in ("x86_64", "amd64"), reason="-mavx2 is an x86 flag")
def test_a_library_for_a_cpu_the_worker_lacks_is_compiled_there(tmp_path):
    """Built with -mavx2 (the default on an AVX2 machine): a worker without AVX2 neither loads the
    key from its (shared) cache nor unpacks the shipped library (SIGILL at the first call); it
    compiles the C without the flag."""
    mine = build(osc_model.oscillator(), cache_dir=tmp_path / "cache", cflags="-O2 -fPIC -std=c99 -mavx2")
    blob = tmp_path / "osc.pickle"
    blob.write_bytes(pickle.dumps(load(mine.directory)))
    facts = _finish(_start(blob, tmp_path / "cache", "no-avx2"))      # the key is in this cache
    assert facts["arrival"] == "compiled" and not facts["directory"].endswith(mine.key)
    manifest = json.loads((Path(facts["directory"]) / "manifest.json").read_text())
    assert "-mavx2" not in manifest["inputs"]["argv"] and "-O2" in manifest["inputs"]["argv"]
