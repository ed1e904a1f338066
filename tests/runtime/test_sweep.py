"""eomc.sweep: the same answers as simulate_many, bit for bit, on every kind of executor.

Executors: none (here, threads), builtins.map, concurrent.futures (threads and
processes), a multiprocessing Pool started with ``spawn`` whose workers cannot
import SymPy, and a dask.distributed LocalCluster of two worker processes.
"""
import multiprocessing
import os
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor

import numpy as np
import pytest

from helpers import osc_model
from helpers.sweep_support import block_sympy, final_q, worker_facts
import eomc
from eomc.compiler.build import build
from eomc.errors import SimulationError
from eomc.runtime.batch import simulate_many
from eomc.runtime.loader import load
from eomc.runtime.sweep import SweepValues, case_arrays

N = 120
KW = dict(n_points=21, rtol=1e-9, atol=1e-12)


@pytest.fixture(autouse=True)
def private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "worker-cache"))


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    return load(build(osc_model.oscillator(), cache_dir=tmp_path_factory.mktemp("cache")).directory)


@pytest.fixture(scope="module")
def cases():
    rng = np.random.default_rng(12)
    return {"x0": rng.normal(size=(N, 2)),
            "p": np.column_stack([rng.uniform(1, 3, N), rng.uniform(0, 1, N), rng.uniform(4, 9, N)]),
            "r": rng.normal(size=(N, 1))}


@pytest.fixture(scope="module")
def reference(model, cases):
    return simulate_many(model, cases["x0"], (0, 3), p=cases["p"], r=cases["r"], progress=False, **KW)


def _same(got, ref):
    np.testing.assert_array_equal(got.t, ref.t)
    np.testing.assert_array_equal(got.x, ref.x)
    np.testing.assert_array_equal(got["energy"], ref["energy"])
    np.testing.assert_array_equal(got.status, ref.status)
    assert got.stats == ref.stats and got.state_names == ref.state_names


class MapMethod:
    """Something with a .map method only (like many cluster clients)."""
    def __init__(self):
        self.calls = 0

    def map(self, fn, items):
        self.calls += 1
        return map(fn, items)


@pytest.mark.parametrize("executor", ["here", "builtins", "threads", "processes", "map-method"])
def test_every_executor_gives_simulate_many_bit_for_bit(model, cases, reference, executor):
    pool = {"here": None, "builtins": map, "threads": ThreadPoolExecutor(2),
            "processes": ProcessPoolExecutor(2), "map-method": MapMethod()}[executor]
    try:
        got = eomc.sweep(model, cases, (0, 3), map=pool, chunk_size=25, progress=False, **KW)
    finally:
        if hasattr(pool, "shutdown"):
            pool.shutdown()
    _same(got, reference)
    if executor == "map-method":
        assert pool.calls == 1


def test_reductions_on_the_worker(model, cases, reference):
    final = eomc.sweep(model, cases, (0, 3), reduce="final", chunk_size=50, progress=False, **KW)
    assert final.x.shape == (N, 1, 2) and final.t.tolist() == [3.0]
    np.testing.assert_array_equal(final.x[:, 0], reference.x[:, -1])
    np.testing.assert_array_equal(final["energy"][:, 0], reference["energy"][:, -1])
    values = eomc.sweep(model, cases, (0, 3), reduce=final_q, chunk_size=50, progress=False, **KW)
    assert isinstance(values, SweepValues) and values.success and values.values.shape == (N,)
    np.testing.assert_array_equal(values.values, reference.x[:, -1, 0])


def test_spawned_pool_workers_without_sympy(model, cases, reference, tmp_path, monkeypatch):
    """Spawned workers start from nothing: the model arrives by pickle into their own cache."""
    blocker = block_sympy(tmp_path / "site")
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(blocker), os.environ.get("PYTHONPATH", "")]))
    with multiprocessing.get_context("spawn").Pool(2) as pool:
        got = eomc.sweep(model, cases, (0, 3), map=pool, chunk_size=30, progress=False, **KW)
        facts = eomc.sweep(model, cases, (0, 3), map=pool, chunk_size=30, reduce=worker_facts,
                           progress=False, **KW)
    _same(got, reference)
    assert [f[0] for f in facts.values] == reference.x[:, -1, 0].tolist()
    assert {(f[1], tuple(f[2])) for f in facts.values} == {(False, ())}   # no SymPy, no compiler
    published = list((tmp_path / "worker-cache" / "v1" / "models").glob("*/*/libosc.so"))
    assert len(published) == 1


def test_dask_local_cluster_two_workers(model, cases, reference, tmp_path):
    import distributed   # the test extra installs dask[distributed]: CI runs this
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        got = eomc.sweep(model, cases, (0, 3), map=client, chunk_size=20, progress=False, **KW)
        ran_on = client.run(lambda: "sympy" in __import__("sys").modules)
        facts = eomc.sweep(model, cases, (0, 3), map=client, reduce=worker_facts, progress=False, **KW)
    _same(got, reference)
    assert len(ran_on) == 2 and not any(ran_on.values())
    assert {(f[1], tuple(f[2])) for f in facts.values} == {(True, ())}  # installed, never imported
    assert len(list((tmp_path / "worker-cache" / "v1" / "models").glob("*/*/libosc.so"))) == 1


def test_cases_by_name_list_of_dicts_and_rows(model):
    by_name = {"q": [0.5, 1.0, 1.5], "k": [4.0, 9.0, 16.0], "F": [0.0, 0.0, 1.0]}
    n, X0, P, R = case_arrays(model, by_name)
    assert n == 3 and X0[:, 0].tolist() == [0.5, 1.0, 1.5] and X0[:, 1].tolist() == [0, 0, 0]
    assert P[:, 2].tolist() == [4.0, 9.0, 16.0] and P[:, 0].tolist() == [2.0] * 3 and R[:, 0].tolist() == [0, 0, 1]
    rows = [dict(zip(by_name, v)) for v in zip(*by_name.values())]
    m2 = case_arrays(model, rows)
    assert all(np.array_equal(a, b) for a, b in zip(m2[1:], (X0, P, R)))
    assert case_arrays(model, np.ones((4, 2)))[0] == 4 and case_arrays(model, np.ones((4, 2)))[2] is None
    res = eomc.sweep(model, by_name, (0, 1), progress=False, n_points=11)
    single = simulate_many(model, X0, (0, 1), p=P, r=R, progress=False, n_points=11)
    np.testing.assert_array_equal(res.x, single.x)


def test_bad_cases_are_named(model):
    with pytest.raises(ValueError, match="'stiffness' is not a state, parameter or input of osc.*states: q, u"):
        case_arrays(model, {"stiffness": [1.0, 2.0]})
    with pytest.raises(ValueError, match="columns differ in length: column 'q' has 2, column 'k' has 3"):
        case_arrays(model, {"q": [1.0, 2.0], "k": [1.0, 2.0, 3.0]})
    with pytest.raises(ValueError, match="nothing varies"):
        case_arrays(model, {"x0": [1.0, 0.0]})
    with pytest.raises(ValueError, match=r"'p' \(the whole parameter row\) must have shape \(3,\)"):
        case_arrays(model, {"p": np.ones((2, 2))})
    with pytest.raises(ValueError, match="case 1 has no 'k'"):
        case_arrays(model, [{"q": 1.0, "k": 2.0}, {"q": 1.0}])
    with pytest.raises(ValueError, match="reduce must be None, 'final' or a callable"):
        eomc.sweep(model, {"q": [1.0]}, (0, 1), reduce="last")
    with pytest.raises(TypeError, match="map= must be map-like"):
        eomc.sweep(model, {"q": [1.0]}, (0, 1), map=42)
    with ProcessPoolExecutor(1) as pool, pytest.raises(ValueError, match=r"t_span .* is reversed"):
        eomc.sweep(model, {"q": [1.0]}, (1, 0), map=pool)   # checked here, before any worker starts


def test_a_failed_case_is_named_by_its_place_in_the_sweep(model, capsys):
    masses = np.full(200, 2.0)
    masses[150] = 0.0                                   # m = 0: singular mass matrix
    with pytest.raises(SimulationError, match="case 150 of 200: .*singular"):
        eomc.sweep(model, {"m": masses}, (0, 1), chunk_size=64, progress=True, n_points=5)
    assert "200 cases in 4 chunks of up to 64" in capsys.readouterr().err
    res = eomc.sweep(model, {"m": masses}, (0, 1), chunk_size=64, progress=False, n_points=5,
                     raise_on_failure=False)
    assert np.flatnonzero(res.status).tolist() == [150] and np.isnan(res.x[150, -1]).all()
