"""Issue 12: throughput of eomc.sweep on threads, local processes and a 2-worker Dask LocalCluster.

The workload is 2,000 cases of the n = 4 cart (examples/n_link_cart.py with
EOMC_N_LINKS=4): link angles varied around the model's initial state, 10 s
each, DOP853 at rtol = atol = 1e-8, 101 output times, whole trajectories
shipped home.  Every contestant uses both cores of this machine:

- ``simulate_many``, 2 threads in this process (the baseline every ratio divides by);
- ``sweep(map=None)``: the same through sweep's chunking, in this process;
- ``sweep`` on a ``ProcessPoolExecutor(2)`` and on a Dask ``LocalCluster`` of 2
  worker processes with 1 thread each, for several chunk sizes.

Pools and clusters are started, and the model shipped to them, before timing
(a warm-up sweep); the cold first sweep is reported on its own.  Then: the
cost of one chunk on its own (1-case chunks of a 1 us simulation), the bytes a
case ships home, and how a worker receives the model (pickle size; unpickle
by (a) cache hit, (b) publishing the shipped library, (c) compiling the C).

Why wall time and no core pinning, against the house rule: this measures
parallel throughput across processes, which a one-core, thread-CPU-time
measurement cannot see.  Contestants are interleaved and medians reported.
"""
import os
import pickle
import subprocess
import sys
import tempfile
import textwrap
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from common import environment_header, fmt, format_table, median_iqr, parse_args, write_results

ROOT = Path(__file__).resolve().parent.parent
CASES = 2000
KW = dict(method="dop853", rtol=1e-8, atol=1e-8, n_points=101)
T_SPAN = (0.0, 10.0)

UNPICKLE = textwrap.dedent("""
    import pickle, sys, time
    import eomc.runtime.loader, eomc.runtime.travel as travel
    if sys.argv[2] == "elsewhere":
        travel.platform_tag = lambda: "elsewhere"
    blob = open(sys.argv[1], "rb").read()
    t = time.perf_counter()
    model = pickle.loads(blob)
    print(time.perf_counter() - t, model.arrival)
    """)


def _cases(model, count, seed=0):
    rng = np.random.default_rng(seed)
    X = np.tile(model.initial_state, (count, 1))
    X[:, 1:5] += rng.uniform(-0.2, 0.2, size=(count, 4))
    return X


def _unpickle_times(blob_path, repeat):
    """Seconds for pickle.loads in a fresh process: (a) cache hit, (b) shipped library, (c) compile."""
    out = {"cache": [], "library": [], "compiled": []}
    for _ in range(repeat):
        for steps in ((("here", "library"), ("here", "cache")), (("elsewhere", "compiled"),)):
            with tempfile.TemporaryDirectory() as cache:        # each sequence starts from an empty cache
                env = dict(os.environ, EOMC_CACHE_DIR=cache)
                for where, expect in steps:
                    text = subprocess.run([sys.executable, "-c", UNPICKLE, str(blob_path), where], env=env,
                                          capture_output=True, text=True, check=True).stdout.split()
                    assert text[1] == expect, text
                    out[expect].append(float(text[0]))
    return {k: median_iqr(v)[0] for k, v in out.items()}


def main():
    args = parse_args(__doc__.splitlines()[0], default_n=[4], default_repeat=5)
    os.environ["EOMC_N_LINKS"] = "4"
    import eomc
    from distributed import Client, LocalCluster
    from eomc.runtime.batch import simulate_many
    from eomc.runtime.sweep import run_chunk

    cases = CASES // 4 if args.quick else CASES
    chunk_sizes = [25, 100, 250, 1000]
    with tempfile.TemporaryDirectory() as cache:
        os.environ["EOMC_CACHE_DIR"] = cache        # the workers inherit it: one private cache
        model = eomc.compile(str(ROOT / "examples" / "n_link_cart.py"), progress=False)
        X = _cases(model, cases)
        blob = pickle.dumps(model)
        blob_path = Path(cache) / "model.pickle"
        blob_path.write_bytes(blob)

        pool = ProcessPoolExecutor(2)
        cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
        client = Client(cluster)
        try:
            def baseline():
                return simulate_many(model, X, T_SPAN, threads=2, progress=False, **KW)

            def sweeper(where, size):
                return lambda: eomc.sweep(model, {"x0": X}, T_SPAN, map=where, chunk_size=size,
                                          threads=2 if where is None else None, progress=False, **KW)

            contestants = [("simulate_many, 2 threads", None, baseline),
                           ("sweep, here, 2 threads", 250, sweeper(None, 250))]
            contestants += [("sweep, 2 processes", s, sweeper(pool, s)) for s in chunk_sizes]
            contestants += [("sweep, Dask 2 workers", s, sweeper(client, s)) for s in chunk_sizes]

            t0 = time.perf_counter()
            cold = eomc.sweep(model, {"x0": X[:200]}, T_SPAN, map=client, chunk_size=100, progress=False, **KW)
            cold_dask = time.perf_counter() - t0
            t0 = time.perf_counter()
            eomc.sweep(model, {"x0": X[:200]}, T_SPAN, map=pool, chunk_size=100, progress=False, **KW)
            cold_pool = time.perf_counter() - t0
            reference = baseline()
            np.testing.assert_array_equal(cold.x, reference.x[:200])
            for name, _, run in contestants:                # warm up, and check bit-identity once
                np.testing.assert_array_equal(run().x, reference.x)

            samples = {name + str(size): [] for name, size, _ in contestants}
            for _ in range(args.repeat):                    # interleaved
                for name, size, run in contestants:
                    t0 = time.perf_counter()
                    run()
                    samples[name + str(size)].append(time.perf_counter() - t0)

            # one chunk on its own: 1-case chunks of a trivial simulation
            tiny = {"x0": X[:400]}
            tiny_kw = dict(method="dop853", n_points=2)
            chunk_cost = {}
            for label, where in (("2 processes", pool), ("Dask 2 workers", client), ("here", None)):
                eomc.sweep(model, tiny, (0, 1e-6), map=where, chunk_size=1, progress=False, **tiny_kw)
                runs = []
                for _ in range(max(2, args.repeat // 2)):
                    t0 = time.perf_counter()
                    eomc.sweep(model, tiny, (0, 1e-6), map=where, chunk_size=1, progress=False, **tiny_kw)
                    runs.append((time.perf_counter() - t0) / len(X[:400]))
                chunk_cost[label] = median_iqr(runs)[0]
        finally:
            client.close()
            cluster.close()
            pool.shutdown()

        task = {"start": 0, "x0": X[:100], "p": None, "r": None, "t_span": T_SPAN, "simulate": KW,
                "reduce": None, "threads": 1}
        full = len(pickle.dumps(run_chunk(model, task))) / 100
        final = len(pickle.dumps(run_chunk(model, {**task, "reduce": "final"}))) / 100
        unpickle = _unpickle_times(blob_path, max(1, args.repeat // 2))

    base = median_iqr(samples["simulate_many, 2 threads" + "None"])[0]
    rows = []
    for name, size, _ in contestants:
        med, q1, q3 = median_iqr(samples[name + str(size)])
        chunks = 1 if size is None else -(-cases // size)
        extra = med - base
        rows.append([name, "-" if size is None else size, "-" if size is None else chunks, fmt(med),
                     fmt(q3 - q1, 2), fmt(cases / med, 4), fmt(med / base),
                     "-" if size is None else fmt(extra / cases * 1e6, 2),
                     "-" if size is None else fmt(extra / chunks * 1e3, 2)])
    headers = ["how", "chunk", "chunks", "wall [s]", "IQR [s]", "cases/s", "vs simulate_many",
               "extra per case [us]", "extra per chunk [ms]"]
    table = format_table(headers, rows)
    side = format_table(["measure", "value"], [
        ["one 1-case chunk, 2 processes (wall per chunk, both busy)", f"{fmt(chunk_cost['2 processes'] * 1e3)} ms"],
        ["one 1-case chunk, Dask 2 workers (wall per chunk, both busy)", f"{fmt(chunk_cost['Dask 2 workers'] * 1e3)} ms"],
        ["one 1-case chunk, here (no executor)", f"{fmt(chunk_cost['here'] * 1e3)} ms"],
        ["bytes shipped home per case, whole trajectory (101 x 10 states + 2 outputs)", f"{full:.0f}"],
        ["bytes shipped home per case, reduce='final'", f"{final:.0f}"],
        ["pickled model (n = 4 cart)", f"{len(blob) / 1024:.0f} KiB"],
        ["unpickle in a fresh process: (a) key in the worker's cache", f"{fmt(unpickle['cache'] * 1e3)} ms"],
        ["unpickle in a fresh process: (b) publish the shipped library", f"{fmt(unpickle['library'] * 1e3)} ms"],
        ["unpickle in a fresh process: (c) compile the shipped C", f"{fmt(unpickle['compiled'] * 1e3)} ms"],
        ["first sweep on a fresh cluster, 200 cases (model shipped, published, loaded)",
         f"Dask {fmt(cold_dask)} s, processes {fmt(cold_pool)} s"],
    ])
    print(table)
    print()
    print(side)
    if not args.no_write:
        text = environment_header("Sweeps: threads, local processes and a Dask LocalCluster (issue 12)", args, notes=[
            f"{cases} cases of the n = 4 cart (examples/n_link_cart.py, EOMC_N_LINKS=4), 10 s each, "
            f"DOP853 rtol=atol=1e-8, 101 output times, whole trajectories returned",
            "2 cores; every contestant uses both (2 threads, 2 processes, 2 Dask workers x 1 thread); "
            "pools and the cluster are started and warmed up before timing",
            "wall-clock medians of interleaved repeats, not pinned (this measures parallel throughput); "
            "the machine was heavily loaded by other jobs (see the load average), so ratios are what to read",
            "extra per case / per chunk: (wall - simulate_many's wall) / cases or / chunks",
            "every contestant's trajectories were checked bit-identical to simulate_many's",
        ]) + "\n" + table + "\n\n" + side + "\n"
        print("wrote", ", ".join(map(str, write_results("sweep", text, rows, headers))))


if __name__ == "__main__":
    main()
