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


# ---- issue 24: what a sweep hands back, and how it reads its cases ------------------------------
import textwrap  # noqa: E402
from pathlib import Path  # noqa: E402

from helpers import model_files  # noqa: E402

from eomc.runtime.batch import CaseError  # noqa: E402
from eomc.runtime.simulate import simulate  # noqa: E402

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
# a model whose parameter is named p, its input r and its coordinate x0: the sweep's whole-row keys
ROW_KEY_NAMES = textwrap.dedent('''\
    import sympy as sm
    from eomc.mechanics import KanesMethod, Particle, Point, ReferenceFrame, dynamicsymbols
    x0, u = dynamicsymbols("x0 u")
    r = dynamicsymbols("r")
    p, q = sm.symbols("p q")
    N = ReferenceFrame("N")
    O = Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x0 * N.x)
    P.set_vel(N, u * N.x)
    system = KanesMethod(N, q_ind=[x0], u_ind=[u], kd_eqs=[x0.diff() - u])
    system.kanes_equations([Particle("b", P, q)], [(P, (-p * x0 + r) * N.x)])
    parameters = {p: 2.0, q: 1.0}
    inputs = [r]
    initial_state = {x0: 1.0, u: 0.0}
    ''')


@pytest.fixture(scope="module")
def cartpole():
    return eomc.compile(str(EXAMPLES / "cartpole_lqr.py"), progress=False)


@pytest.fixture(scope="module")
def named(tmp_path_factory):
    path = model_files.write(tmp_path_factory.mktemp("named"), ROW_KEY_NAMES, "rowkeys")
    return eomc.compile(str(path), progress=False)


def _cartpole_cases(model):
    return {"th": [3.0, 2.9, 2.5, 3.1]}


def _single(model, th, **kw):
    x0 = dict(zip(model.state_names, model.initial_state), th=th)
    return simulate(model, x0, (0, 10), **kw)


@pytest.mark.parametrize("pool", [None, "threads"])
def test_final_is_where_each_case_really_ended(cartpole, pool):
    """N2: the terminal event `fallen` ends every case; final = simulate()'s x_final, not NaN."""
    executor = ThreadPoolExecutor(2) if pool else None
    try:
        res = eomc.sweep(cartpole, _cartpole_cases(cartpole), (0, 10), reduce="final", map=executor,
                         chunk_size=2, progress=False)
    finally:
        if executor:
            executor.shutdown()
    assert res.x.shape == (4, 1, 4) and res.event_stop == ["fallen"] * 4
    for i, th in enumerate(_cartpole_cases(cartpole)["th"]):
        single = _single(cartpole, th)
        np.testing.assert_array_equal(res.x[i, 0], single.x_final)
        np.testing.assert_array_equal(res.x_final[i], single.x_final)
        assert res.t_final[i] == single.t_final < 10
        np.testing.assert_array_equal(res.t_events[i]["fallen"], single.t_events["fallen"])
        assert res["bob_height"][i, 0] == pytest.approx(cartpole.outputs(single.t_final, single.x_final)
                                                        ["bob_height"], abs=1e-15)


def test_reduce_sees_exactly_what_simulate_returns(cartpole):
    def facts(r):
        return (r.t_final, r.x_final.copy(), r.t_events["fallen"].copy(), r.event_stop, r.status, r.message,
                len(r.t), r.x[-1].copy())
    got = eomc.sweep(cartpole, _cartpole_cases(cartpole), (0, 10), reduce=facts, progress=False, n_points=51)
    for i, th in enumerate(_cartpole_cases(cartpole)["th"]):
        want = facts(_single(cartpole, th, n_points=51))
        have = got.values[i]
        assert have[0] == want[0] and have[3:7] == want[3:7]
        for a, b in ((have[1], want[1]), (have[2], want[2]), (have[7], want[7])):
            np.testing.assert_array_equal(a, b)
    assert got.event_stop == ["fallen"] * 4 and np.all(np.isfinite(got.x_final))
    mixed = eomc.sweep(cartpole, _cartpole_cases(cartpole), (0, 10), reduce=lambda r: (r.t_final, r.event_stop),
                       progress=False)
    assert mixed.values == [(t, "fallen") for t in got.t_final]     # not stacked into strings


def test_whole_trajectories_keep_the_event_records(cartpole):
    res = eomc.sweep(cartpole, _cartpole_cases(cartpole), (0, 10), progress=False, n_points=51)
    assert res.event_stop == ["fallen"] * 4
    single = _single(cartpole, 2.5, n_points=51)
    np.testing.assert_array_equal(res.x_final[2], single.x_final)
    np.testing.assert_array_equal(res.x[2, :len(single.t)], single.x)


def test_final_does_not_hold_trajectories(cartpole):
    """N12: reduce='final' asks the C loop for one row per case; whole trajectories would be
    n x 1001 x 5 doubles (40 MB for 1000 cases in one chunk): the peak stays far below that."""
    import tracemalloc
    n = 1000
    cases = {"th": np.linspace(3.0, 3.2, n)}
    eomc.sweep(cartpole, {"th": cases["th"][:4]}, (0, 0.5), reduce="final", progress=False)   # warm
    tracemalloc.start()
    try:
        res = eomc.sweep(cartpole, cases, (0, 0.5), reduce="final", progress=False, threads=2,
                         chunk_size=n)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    trajectories = n * 1001 * 5 * 8
    assert res.success and res.x.shape == (n, 1, 4)
    assert peak < trajectories / 4, f"peak {peak / 2**20:.1f} MiB"   # event buffers, prepared cases
    print(f"peak {peak / 2**20:.2f} MiB for {n} cases; trajectories {trajectories / 2**20:.1f} MiB")


def test_names_that_are_also_row_keys_are_names(named):
    """N13: a parameter named p, an input named r and a coordinate named x0 are swept by name;
    (2 rows = nparam used to be read as one shared parameter row, silently)."""
    res = eomc.sweep(named, {"p": [1.0, 5.0], "q": [1.0, 1.1], "r": [0.0, 0.5], "x0": [0.3, 0.7]},
                     (0, 2), reduce="final", progress=False)
    for i, (p, q, r, x0) in enumerate([(1.0, 1.0, 0.0, 0.3), (5.0, 1.1, 0.5, 0.7)]):
        single = simulate(named, {"x0": x0}, (0, 2), p={"p": p, "q": q}, r=[r])
        np.testing.assert_array_equal(res.x_final[i], single.x_final)
    with pytest.raises(ValueError, match="'p' is a parameter of rowkeys, so cases\\['p'\\] is its column"):
        eomc.sweep(named, {"p": np.ones((2, 2))}, (0, 1), progress=False)
    # the model's own names win; a whole row is still a row where no name is taken
    n, X0, P, R = case_arrays(named, {"x0": [0.1, 0.2]})
    assert X0[:, 0].tolist() == [0.1, 0.2] and X0[:, 1].tolist() == [0.0, 0.0]


def test_bad_cases_name_their_case_across_chunks(model):
    """N13: case 350 with chunks of 100 is case 350 (not 'case 50 of 100'); empty columns, a
    chunk size of 0 are clear errors."""
    m = np.full(400, 2.0)
    m[350] = np.inf
    with pytest.raises(CaseError, match=r"case 350 of 400: osc: p \(parameters\) is not finite for m") as err:
        eomc.sweep(model, {"m": m}, (0, 1), chunk_size=100, progress=False)
    assert err.value.case == 350
    with pytest.raises(ValueError, match="no cases"):
        eomc.sweep(model, {"q": []}, (0, 1), progress=False)
    with pytest.raises(ValueError, match="chunk_size must be a positive integer"):
        eomc.sweep(model, {"q": [1.0]}, (0, 1), chunk_size=0, progress=False)


def test_consistent_starts_in_a_sweep():
    """N13/N14: consistent=True completes each case's start as simulate(consistent=True) does."""
    fourbar = eomc.compile(str(EXAMPLES / "four_bar_system.py"), progress=False)
    q1 = [-1.0, -0.9]
    res = eomc.sweep(fourbar, {"q1": q1}, (0, 0.5), consistent=True, reduce="final", progress=False)
    for i, v in enumerate(q1):
        single = simulate(fourbar, {"q1": v}, (0, 0.5), consistent=True)
        np.testing.assert_array_equal(res.x_final[i], single.x_final)



class _StopAt:
    """reduce= that raises KeyboardInterrupt (Ctrl-C) at the case whose q starts at ``q``."""

    def __init__(self, q):
        self.q = q

    def __call__(self, res):
        if res.x[0, 0] == self.q:
            raise KeyboardInterrupt
        return res.x[-1, 0]


@pytest.mark.parametrize("reduce", ["final", None, "callable"])
def test_a_stopped_sweep_keeps_the_chunks_that_came_back(model, reduce, monkeypatch):
    """s29: Ctrl-C or SIGTERM during a sweep lost every finished chunk (the command line wrote
    nothing).  Now the exception carries the sweep's result in ``partial_result``: the chunks
    that came back as they ended, the others status 9, NaN and a "not run" message."""
    import eomc.runtime.sweep as sw
    x0 = np.column_stack([np.arange(1.0, 7.0), np.zeros(6)])
    if reduce == "callable":
        reduce = _StopAt(5.0)       # case 4: the third chunk of two
    else:                           # stop in the third chunk, through the chunk runner
        real = sw.run_chunk
        monkeypatch.setattr(sw, "run_chunk", lambda m, task: (_ for _ in ()).throw(KeyboardInterrupt)
                            if task["start"] == 4 else real(m, task))
    with pytest.raises(KeyboardInterrupt) as info:
        eomc.sweep(model, {"x0": x0}, (0, 1), chunk_size=2, reduce=reduce, progress=False, threads=1, **KW)
    res = info.value.partial_result
    assert res.status.tolist() == [0, 0, 0, 0, 9, 9]
    assert res.messages[4].startswith("not run: the sweep was stopped") and res.messages[3] == "ok"
    assert np.all(np.isnan(res.x_final[4:])) and np.all(np.isnan(res.t_final[4:]))
    whole = eomc.sweep(model, {"x0": x0[:4]}, (0, 1), chunk_size=2, reduce="final", progress=False, threads=1,
                       **KW)
    np.testing.assert_array_equal(res.x_final[:4], whole.x_final)
    if callable(reduce):
        assert res.values[4:] == [None, None] and all(np.isfinite(v) for v in res.values[:4])
    else:
        assert res.x.shape[0] == 6 and np.all(np.isnan(res.x[4:])) and np.all(np.isfinite(res.x[:4]))
        assert res.t.size == res.x.shape[1] and all(np.all(np.isnan(v[4:])) for v in res.outputs.values())
