"""jac_x of closed trees, recursive vs Kane: build CPU, operation counts, and the call time of
model.jacobian() (thread CPU, median of interleaved batches, Python overhead included).

Run:  python benchmarks/bench_loops_jac.py   (from the repository root)
"""
import importlib.util, time, statistics, numpy as np, eomc, runpy, tempfile
spec = importlib.util.spec_from_file_location("bl", "benchmarks/bench_loops.py"); bl = importlib.util.module_from_spec(spec); spec.loader.exec_module(bl)
cache = tempfile.mkdtemp()
ns = runpy.run_path("examples/four_bar_system.py")
models = {"four_bar": (ns["system"], ns["parameters"], ns["initial_state"]), "chain_8": bl.closed_chain(8)}
for label, (system, params, x0) in models.items():
    ms = {}
    for f in ("recursive", "kane"):
        t0 = time.process_time()
        kw = dict(parameters=params, functions=["rhs", "jac_x"], formulation=f, cache_dir=cache, name=f"{label}_jt_{f}")
        if label == "four_bar": kw["inputs"] = ns["inputs"]
        ms[f] = eomc.compile(system, **kw)
        print(label, f, "build cpu", round(time.process_time() - t0, 2), "jac_x ops", sum(ms[f].metadata["op_counts"]["jac_x"].values()), "rhs ops", sum(ms[f].metadata["op_counts"]["rhs"].values()), flush=True)
    names = ms["kane"].state_names
    by = {str(k).replace("(t)", ""): float(v) for k, v in x0.items()}
    x = np.array([by[n] for n in names]); x[ms["kane"].nq:] = 0.3

    print("agree", np.max(abs(ms["recursive"].jacobian(0.0, x) - ms["kane"].jacobian(0.0, x))))
    res = {f: [] for f in ms}
    for b in range(9):
        for f, m in ms.items():
            t0 = time.thread_time_ns()
            for _ in range(3000):
                m.jacobian(0.0, x)
            res[f].append((time.thread_time_ns() - t0) / 3000)
    print(label, {f: round(statistics.median(v)) for f, v in res.items()}, "ns per jacobian() call incl. Python", flush=True)
