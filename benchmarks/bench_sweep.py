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

Why no core pinning, against the house rule: this measures parallel
throughput across processes, which one pinned core cannot show.  Two clocks:
wall time (what a user waits; on a loaded machine it mostly measures the
other jobs) and the CPU time of every process that takes part -- this one
(client, Dask scheduler, threads) plus the pool's or the cluster's worker and
nanny processes, read from /proc -- which other jobs hardly disturb.  On a
quiet 2-core machine, wall ~ CPU / 2 for a contestant that keeps both cores
busy.  Contestants are interleaved and medians reported.
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


_TICK = os.sysconf("SC_CLK_TCK")


def _cpu_seconds(pids):
    """user + system CPU seconds of these processes so far (from /proc/PID/stat)."""
    total = 0
    for pid in pids:
        try:
            fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        total += int(fields[11]) + int(fields[12])        # utime, stime
    return total / _TICK


def _descendants(pid):
    """Every process started (directly or not) by ``pid``."""
    parents = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        parents.setdefault(int(fields[1]), []).append(int(stat.parent.name))
    out, todo = [], [pid]
    while todo:
        kids = parents.get(todo.pop(), [])
        out += kids
        todo += kids
    return out


def _measure(run, pids):
    """(wall seconds, CPU seconds of pids) of one run()."""
    c0, t0 = _cpu_seconds(pids), time.perf_counter()
    run()
    return time.perf_counter() - t0, _cpu_seconds(pids) - c0


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

            def sweeper(where, size, reduce=None):
                return lambda: eomc.sweep(model, {"x0": X}, T_SPAN, map=where, chunk_size=size, reduce=reduce,
                                          threads=2 if where is None else None, progress=False, **KW)

            me = os.getpid()
            pool.submit(int).result()                          # the pool's processes exist from here on
            pool_pids = [me, *pool._processes]
            dask_pids = [me, *(p for p in _descendants(me) if p not in pool._processes)]
            contestants = [("simulate_many, 2 threads", None, baseline, [me]),
                           ("sweep, here, 2 threads", 250, sweeper(None, 250), [me])]
            contestants += [("sweep, 2 processes", s, sweeper(pool, s), pool_pids) for s in chunk_sizes]
            contestants += [("sweep, Dask 2 workers", s, sweeper(client, s), dask_pids) for s in chunk_sizes]
            contestants += [("sweep, Dask 2 workers, reduce='final'", 250, sweeper(client, 250, "final"), dask_pids)]

            t0 = time.perf_counter()
            cold = eomc.sweep(model, {"x0": X[:200]}, T_SPAN, map=client, chunk_size=100, progress=False, **KW)
            cold_dask = time.perf_counter() - t0
            t0 = time.perf_counter()
            eomc.sweep(model, {"x0": X[:200]}, T_SPAN, map=pool, chunk_size=100, progress=False, **KW)
            cold_pool = time.perf_counter() - t0
            reference = baseline()
            np.testing.assert_array_equal(cold.x, reference.x[:200])
            for name, _, run, _ in contestants:             # warm up, and check bit-identity once
                got = run().x
                np.testing.assert_array_equal(got, reference.x[:, -1:] if got.shape[1] == 1 else reference.x)
            c0 = _cpu_seconds(dask_pids)
            time.sleep(3.0)
            dask_idle = (_cpu_seconds(dask_pids) - c0) / 3.0    # the cluster's own heartbeat, per second

            samples = {name + str(size): [] for name, size, _, _ in contestants}
            for _ in range(args.repeat):                    # interleaved
                for name, size, run, pids in contestants:
                    samples[name + str(size)].append(_measure(run, pids))

            # one chunk on its own: 1-case chunks of a trivial simulation
            tiny = {"x0": X[:400]}
            tiny_kw = dict(method="dop853", n_points=2)
            chunk_cost = {}
            for label, where, pids in (("2 processes", pool, pool_pids), ("Dask 2 workers", client, dask_pids),
                                       ("here", None, [me])):
                def tiny_sweep():
                    eomc.sweep(model, tiny, (0, 1e-6), map=where, chunk_size=1, progress=False, **tiny_kw)
                tiny_sweep()
                runs = [_measure(tiny_sweep, pids) for _ in range(max(2, args.repeat // 2))]
                chunk_cost[label] = [median_iqr([r[k] / len(tiny["x0"]) for r in runs])[0] for k in (0, 1)]
        finally:
            client.close()
            cluster.close()
            pool.shutdown()

        task = {"start": 0, "x0": X[:100], "p": None, "r": None, "t_span": T_SPAN, "simulate": KW,
                "reduce": None, "threads": 1}
        full = len(pickle.dumps(run_chunk(model, task))) / 100
        final = len(pickle.dumps(run_chunk(model, {**task, "reduce": "final"}))) / 100
        unpickle = _unpickle_times(blob_path, max(1, args.repeat // 2))

    base_wall = median_iqr([w for w, _ in samples["simulate_many, 2 threads" + "None"]])[0]
    base_cpu = median_iqr([c for _, c in samples["simulate_many, 2 threads" + "None"]])[0]
    rows = []
    for name, size, _, _ in contestants:
        wall, _, _ = median_iqr([w for w, _ in samples[name + str(size)]])
        cpu, q1, q3 = median_iqr([c for _, c in samples[name + str(size)]])
        chunks = 1 if size is None else -(-cases // size)
        extra = cpu - base_cpu
        rows.append([name, "-" if size is None else size, "-" if size is None else chunks, fmt(wall),
                     fmt(wall / base_wall), fmt(cpu), fmt(q3 - q1, 2), fmt(cpu / cases * 1e3),
                     fmt(cpu / base_cpu), "-" if size is None else fmt(extra / cases * 1e6, 2),
                     "-" if size is None else fmt(extra / chunks * 1e3, 2)])
    headers = ["how", "chunk", "chunks", "wall [s]", "wall vs simulate_many", "CPU [s]", "CPU IQR [s]",
               "CPU per case [ms]", "CPU vs simulate_many", "extra CPU per case [us]", "extra CPU per chunk [ms]"]
    table = format_table(headers, rows)
    side = format_table(["measure", "value"], [
        *[[f"one 1-case chunk of a 1 us simulation, {label}: wall / CPU (all its processes)",
           f"{fmt(cost[0] * 1e3)} ms / {fmt(cost[1] * 1e3)} ms"] for label, cost in chunk_cost.items()],
        ["bytes shipped home per case, whole trajectory (101 x 10 states + 2 outputs)", f"{full:.0f}"],
        ["bytes shipped home per case, reduce='final'", f"{final:.0f}"],
        ["pickled model (n = 4 cart)", f"{len(blob) / 1024:.0f} KiB"],
        ["idle Dask LocalCluster (scheduler, 2 nannies, 2 workers): CPU per second of wall", f"{fmt(dask_idle * 1e3)} ms"],
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
            "medians of interleaved repeats, not pinned (this measures parallel throughput); the machine was "
            "heavily loaded by other jobs (load average 5-10 on 2 cores during the run), so wall times mostly "
            "measure them; CPU time summed over every process taking part is the figure to compare",
            "extra CPU per case / per chunk: (CPU - simulate_many's CPU) / cases or / chunks",
            "every contestant's trajectories were checked bit-identical to simulate_many's",
        ]) + "\n" + table + "\n\n" + side + "\n"
        print("wrote", ", ".join(map(str, write_results("sweep", text, rows, headers))))


if __name__ == "__main__":
    main()
