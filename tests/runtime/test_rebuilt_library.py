"""A rebuilt model in the same process runs the new library; an exported set is never mixed;
a model whose cache entry was removed still pickles (reliability report 2026-11-r3, N1, N4, N6).

N1: ``dlopen`` of a path the process already opened returns the mapping made then, so
``eomc.compile(..., output_dir="out")`` twice in a notebook ran the first build.
N4: two ``eomc build -o DIR`` of different models under one name interleaved their files.
N6: ``pickle.dumps(model)`` read the library from the cache entry, which may be gone by then.
"""
import json
import multiprocessing
import os
import pickle
import shutil
import textwrap
import threading
import time

import numpy as np
import pytest

from helpers import osc_model
from eomc.compiler.build import build
from eomc.compiler.build.export import export
from eomc.runtime import store
from eomc.runtime.loader import LoadError, load

X = np.array([0.3, -0.25])
SPRING = textwrap.dedent('''\
    import sympy as sm
    from eomc.mechanics import KanesMethod, Particle, Point, ReferenceFrame, dynamicsymbols
    q, u = dynamicsymbols("q u")
    F = dynamicsymbols("F")
    m, k = sm.symbols("m k")
    N = ReferenceFrame("N")
    O = Point("O"); O.set_vel(N, 0)
    P = O.locatenew("P", q * N.x); P.set_vel(N, u * N.x)
    system = KanesMethod(N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u])
    LOAD = -k * q + F
    system.kanes_equations([Particle("p", P, m)], [(P, LOAD * N.x)])
    parameters = {m: 1.0, k: 2.0}
    inputs = [F]
    initial_state = {q: 1.0, u: 0.0}
    ''')


def _variant(factor, name="osc"):
    """The oscillator whose q' is ``factor * u``: same name, sizes, names and defaults."""
    text = osc_model.SOURCE.format(n=name, N=name.upper()).replace("xdot[0] = x[1];",
                                                                   f"xdot[0] = {factor} * x[1];")
    return osc_model.oscillator(name, c_source=text)


@pytest.fixture(scope="module")
def builds(tmp_path_factory):
    cache = tmp_path_factory.mktemp("cache")
    return {f: build(_variant(f), cache_dir=cache) for f in (1.0, 2.0, 3.0)}


@pytest.fixture(autouse=True)
def private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "own-cache"))


def test_the_notebook_case_compile_twice_into_one_directory(tmp_path, monkeypatch):
    """The report's case: edit the equations, compile again into the same output_dir."""
    import eomc
    monkeypatch.chdir(tmp_path)
    (tmp_path / "m.py").write_text(SPRING)
    x = np.array([2.0, 0.0])
    m1 = eomc.compile("m.py", output_dir="out", cache_dir=tmp_path / "cache")
    assert m1.rhs(0, x, r=[0])[1] == pytest.approx(-4.0)
    (tmp_path / "m.py").write_text(SPRING.replace("LOAD = -k * q + F", "LOAD = -k * q**3 + F"))
    m2 = eomc.compile("m.py", output_dir="out", cache_dir=tmp_path / "cache")
    assert m2.rhs(0, x, r=[0])[1] == pytest.approx(-16.0)
    assert eomc.load("out").rhs(0, x, r=[0])[1] == pytest.approx(-16.0)
    assert m1.rhs(0, x, r=[0])[1] == pytest.approx(-4.0)  # the first model keeps its own library
    leftovers = [p for p in (tmp_path / "cache").rglob("*") if "load-" in p.name]
    assert leftovers == []  # the private copies are gone once opened


def test_a_directory_rebuilt_by_another_build_loads_the_new_library(builds, tmp_path):
    out = tmp_path / "out"
    seen = []
    for factor in (1.0, 2.0, 3.0, 1.0):
        export(builds[factor], out)
        seen.append(load(out).rhs(0.0, X)[0])
    np.testing.assert_allclose(seen, [-0.25, -0.5, -0.75, -0.25])
    assert sorted(p.name for p in out.iterdir() if p.name.startswith(".eomc-tmp")) == []


def test_a_library_rewritten_in_place_is_not_served_stale(builds, tmp_path):
    """Same path, same inode, new bytes (``cp new.so out/libosc.so``)."""
    out = tmp_path / "out"
    shutil.copytree(builds[1.0].directory, out)
    assert load(out).rhs(0.0, X)[0] == pytest.approx(-0.25)
    for name in ("libosc.so", "osc.json"):
        with open(out / name, "r+b") as fh:  # overwrite in place: the inode stays
            fh.write((builds[2.0].directory / name).read_bytes())
            fh.truncate()
    assert load(out).rhs(0.0, X)[0] == pytest.approx(-0.5)


def test_a_mixed_directory_is_refused_naming_the_file(builds, tmp_path):
    out = tmp_path / "out"
    export(builds[1.0], out)
    shutil.copyfile(builds[2.0].directory / "libosc.so", out / "libosc.so")
    with pytest.raises(LoadError, match=r"libosc\.so is not the file eomc built with the rest of model 'osc'"):
        load(out)


def _export_many(args):
    directory, entries, rounds = args
    for i in range(rounds):
        export(entries[i % len(entries)], directory)


def test_concurrent_exports_under_one_name_never_mix(builds, tmp_path):
    """Two processes export different builds into one DIR; every state a reader sees is one build."""
    out = tmp_path / "out"
    export(builds[1.0], out)
    a, b = [builds[1.0], builds[2.0]], [builds[3.0], builds[1.0]]
    ctx = multiprocessing.get_context("fork")
    procs = [ctx.Process(target=_export_many, args=((out, e, 15),)) for e in (a, b)]
    for p in procs:
        p.start()
    loads = 0
    while any(p.is_alive() for p in procs):
        model = load(out)  # raises LoadError if it ever saw a mixed set
        assert model.rhs(0.0, X)[0] in (-0.25, -0.5, -0.75)
        loads += 1
    for p in procs:
        p.join()
        assert p.exitcode == 0
    listing = json.loads((out / ".eomc-files-osc.json").read_text())["files"]
    for fname, digest in listing.items():
        assert store.sha256_file(out / fname) == digest, fname
    assert loads > 0


def test_an_export_waits_for_a_load_in_progress(builds, tmp_path):
    out = tmp_path / "out"
    export(builds[1.0], out)
    before = (out / "libosc.so").read_bytes()
    with store.directory_lock(out, exclusive=False):
        worker = threading.Thread(target=export, args=(builds[2.0], out))
        worker.start()
        time.sleep(0.3)
        assert (out / "libosc.so").read_bytes() == before  # not published under a reader
    worker.join()
    assert load(out).rhs(0.0, X)[0] == pytest.approx(-0.5)


def test_a_model_whose_cache_entry_was_removed_still_pickles(builds, tmp_path):
    """N6: `eomc cache clear` (or a prune) after the load; pickling reads what the load read."""
    entry = tmp_path / "entry"
    shutil.copytree(builds[2.0].directory, entry)
    model = load(entry)
    shutil.rmtree(entry)
    back = pickle.loads(pickle.dumps(model))
    assert back.rhs(0.0, X)[0] == pytest.approx(-0.5)


def test_a_model_whose_cache_entry_was_removed_sweeps_in_a_process_pool(builds, tmp_path):
    from concurrent.futures import ProcessPoolExecutor
    import eomc
    entry = tmp_path / "entry"
    shutil.copytree(builds[2.0].directory, entry)
    model = load(entry)
    shutil.rmtree(entry)
    cases = [{"q": 0.3, "k": 8.0}, {"q": 0.3, "k": 4.0}]
    with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("fork")) as pool:
        result = eomc.sweep(model, cases, (0.0, 0.5), map=pool, progress=False)
    here = eomc.sweep(model, cases, (0.0, 0.5), progress=False)
    np.testing.assert_array_equal(result.x, here.x)


def test_cython_backend_never_runs_a_stale_library(tmp_path):
    """The Cython extension binds libNAME.so by its bare name, once per process: a second,
    different build of the same name through Cython is refused with the way out, not run stale.
    (A name of its own: the binding is per process, and other tests load "osc" through Cython.)"""
    name = "osc_stale_cy"
    first = build(_variant(5.0, name), backend="cython", cache_dir=tmp_path / "cache")
    other = build(_variant(2.0, name), cache_dir=tmp_path / "cache")
    out, rebuilt = tmp_path / "out", tmp_path / "rebuilt"
    export(first, out)
    assert load(out, backend="cython").rhs(0.0, X)[0] == pytest.approx(5 * -0.25)
    # the glue depends only on the name and the functions: a rebuild of other equations is
    # the same extension beside another library (made here without a second Cython run)
    shutil.copytree(first.directory, rebuilt)
    shutil.copyfile(other.directory / f"lib{name}.so", rebuilt / f"lib{name}.so")
    with pytest.raises(LoadError, match=rf"another build of a model named '{name}' through Cython.*"
                                        r"backend='cffi'"):
        load(rebuilt, backend="cython")
    assert load(rebuilt, backend="cffi").rhs(0.0, X)[0] == pytest.approx(2 * -0.25)  # the new library
    assert load(out, backend="cython").rhs(0.0, X)[0] == pytest.approx(5 * -0.25)  # the bound one


def test_a_loaded_model_survives_its_library_rewritten_in_place(builds, tmp_path):
    """Round 4: `cp new.so out/libosc.so` while another process runs the old one killed that
    process with SIGBUS (the loader maps the file by its path).  Run in a child process: a
    crash must fail this test, not end the test session."""
    import subprocess
    import sys
    import textwrap
    out = tmp_path / "out"
    shutil.copytree(builds[1.0].directory, out)
    new = builds[2.0].directory / "libosc.so"
    script = textwrap.dedent(f"""
        import numpy as np
        from eomc.runtime.loader import load
        model = load({str(out)!r})
        x = np.array({X.tolist()!r})
        before = model.rhs(0.0, x)[0]
        with open({str(out / 'libosc.so')!r}, "r+b") as fh:   # in place: same inode, new bytes
            fh.write(b"\\0" * 4096)
            fh.flush()
            fh.seek(0)
            fh.write(open({str(new)!r}, "rb").read())
            fh.truncate()
        after = [model.rhs(0.0, x)[0] for _ in range(3)]
        print(before, *after)
    """)
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, (run.returncode, run.stderr[-2000:])
    np.testing.assert_allclose([float(v) for v in run.stdout.split()], [-0.25] * 4)
