"""Issue 29: simulate()'s fixed Python cost per call on the contact models (hopper, ant).

Each call is ``model.simulate(x0, (0, 1), t_eval=11 points, rtol=atol=tol)`` with the default
method, as bench_contact_wp.py times it.  Thread CPU per call (medians over rounds, pinned to
one core); the integrator's C call (``eomc_integrate_ex``) is timed from inside the same call,
so "Python" = total - C is what simulate() adds around it (argument checks, bindings, outputs,
result, verdict, events).  ``--label`` names the row (e.g. the commit measured); rows
accumulate in benchmarks/results/simulate_overhead.md across runs of different commits.

    cd /tmp && python /path/to/benchmarks/bench_simulate_overhead.py --label main
"""
import argparse
import gc
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "examples"))
from common import RESULTS_DIR, environment_header, pin_to_one_core, write_results  # noqa: E402

T_GRID = np.linspace(0.0, 1.0, 11)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--label", required=True)
    ap.add_argument("--models", default="hopper,ant")
    ap.add_argument("--tols", default="1e-2,1e-4")
    ap.add_argument("--calls", type=int, default=40, help="calls per round")
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--cache-dir", default=None)
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    core = pin_to_one_core()
    import warnings
    import mujoco
    import bench_fixedstep as fs
    warnings.simplefilter("ignore")       # the ant's limit notes: issued, not printed
    rows = []
    for name in args.models.split(","):
        base = mujoco.MjModel.from_xml_path(str(fs.gym_xml(name)))
        model = fs.eomc_model(name, args.cache_dir)
        x0 = fs.eomc_start(model, base)
        lib = model.integrators
        inner = type(lib).eomc_integrate_ex
        c_time = [0.0]

        def timed(self, *a, inner=inner):
            t0 = time.thread_time()
            try:
                return inner(self, *a)
            finally:
                c_time[0] += time.thread_time() - t0
        type(lib).eomc_integrate_ex = timed
        try:
            for tol in map(float, args.tols.split(",")):
                def call():
                    return model.simulate(x0, (0, 1.0), rtol=tol, atol=tol, t_eval=T_GRID,
                                          max_steps=10 ** 6, raise_on_failure=False)
                for _ in range(5):
                    call()
                total, inside = [], []
                for _ in range(args.rounds):
                    gc.collect()
                    c_time[0] = 0.0
                    t0 = time.thread_time()
                    for _ in range(args.calls):
                        call()
                    total.append((time.thread_time() - t0) / args.calls)
                    inside.append(c_time[0] / args.calls)
                tot, c = statistics.median(total), statistics.median(inside)
                py = statistics.median([t - i for t, i in zip(total, inside)])
                rows.append((name, tol, tot * 1e3, c * 1e3, py * 1e3))
                print(f"{args.label} {name} rtol {tol:g}: total {tot*1e3:.3f} ms, C {c*1e3:.3f} ms, "
                      f"Python {py*1e3:.3f} ms ({py / tot:.0%})", flush=True)
        finally:
            type(lib).eomc_integrate_ex = inner
    if args.no_write:
        return
    md = RESULTS_DIR / "simulate_overhead.md"
    old = []      # the rows of earlier runs (the table's lines up to its first non-table line)
    if md.exists() and "\n## Rows\n" in md.read_text():
        for line in md.read_text().split("\n## Rows\n", 1)[1].strip().splitlines()[2:]:
            if not line.startswith("| "):
                break
            old.append(line)
    head = environment_header("simulate()'s Python cost per call (bench_simulate_overhead.py)", args, notes=(
        f"core {core}; thread CPU per call, medians of {args.rounds} rounds x {args.calls} calls; "
        "C = the integrator's eomc_integrate_ex call timed inside; Python = total - C",))
    load = os.getloadavg()[0]
    new = [f"| {args.label} | {core} | {load:.1f} | {n} | {t:g} | {a:.3f} | {c:.3f} | {p:.3f} | {p / a:.0%} |" for n, t, a, c, p in rows]
    table = ["| label | core | load | model | rtol | total ms | C ms | Python ms | Python share |",
             "|---|--:|--:|---|--:|--:|--:|--:|--:|"] + old + new
    write_results("simulate_overhead", head + "\n## Rows\n" + "\n".join(table) + "\n", keep_notes=True)


if __name__ == "__main__":
    main()
