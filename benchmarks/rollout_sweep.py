"""eomc.rollout on every real MJCF file: its rows against simulate, threads and lanes.

"Test on real files nobody here wrote": ``eomc.rollout`` promises each row equal to
``simulate`` of that start bit for bit, with any thread count, and ``lanes=True`` (implicitfast in
SIMD lanes) the scalar rows to the lanes' sin/cos.  The benchmarks check that on five models
(bench_rollout_contacts); here every MJCF file of gymnasium's ``envs/mujoco/assets`` and of
dm_control's suite, with the starts a Monte Carlo or an RL reset makes:

- the file's start with every speed uniform in +-0.5 (seed 0), ``--rows`` rows (default 16);
- the rollout's default method at the file's timestep for ``--t-final`` (implicitfast on a model
  with contacts' fast path, else RK4), one thread: each row's status; three rows (0, 5, 11)
  against ``simulate`` of the same start (x_final bit for bit, and the status: the verdicts); the
  same rollout on two threads
  (bit for bit); thread CPU of the second call (the first does the model's one-time work); with
  ``lanes=True`` where the model has NAME_implicit_batch: rows equal to the
  scalar ones, else the largest |difference| (the lanes' vector sin/cos are 1 ulp of libm's, and a
  contact run is chaotic), and the CPU of both;
- ``eomc.Rollout`` as an environment calls it (3 calls of 5 steps at the file's timestep, each call
  from the rows the last one ended on) against ``eomc.rollout`` of the same rows: states, statuses,
  messages and method equal;
- the default adaptive rollout (``t_final`` only: method "auto") of 4 rows for 0.2 s against
  ``simulate`` (x_final bit for bit, and the status).

Each model is built with its default functions plus implicit_batch when it has ground contacts,
else with its default functions alone (every URDF: fixed base, no contacts), as a user's build.  Prints a table and
writes benchmarks/results/rollout_sweep.md (hand-written notes kept).

    python benchmarks/rollout_sweep.py                   # all 31 files: ~10 min CPU, most of it building
    python benchmarks/rollout_sweep.py -k manipulator -k hopper --no-write
"""
import argparse
import os
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import environment_header, format_table, write_results  # noqa: E402
from default_sweep import model_files  # noqa: E402

SIM_ROWS = (0, 5, 11)


def build(path, cache_dir):
    """(model, CPU s of its build): the model with implicit_batch where it has ground contacts, else its default functions (what
    ``eomc.compile`` gives a user).  Since implicit is built on request for a tree without contacts
    too (session 53), asking for it no longer fails there: such a model is built again by default, so
    its rows run the default build's fixed step (the whole jac_x), not the on-request one."""
    import eomc
    from eomc.compiler.emit.signatures import FUNCTION_ORDER, ON_REQUEST
    from eomc.errors import ModelError
    from eomc.runtime.switching import find_switches
    default = tuple(f for f in FUNCTION_ORDER if f not in ON_REQUEST)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if path.suffix == ".xml":
            t0 = time.process_time()
            try:
                m = eomc.compile(str(path), cache_dir=cache_dir, functions=default + ("implicit_batch",),
                                 progress=False)
                if find_switches(m).contacts:
                    return m, time.process_time() - t0
            except ModelError:      # bodies touching each other but no ground: no fast path to batch
                pass
        t0 = time.process_time()
        return eomc.compile(str(path), cache_dir=cache_dir, progress=False), time.process_time() - t0


def starts(model, rows):
    x0 = np.array(model.initial_state if model.initial_state is not None else np.zeros(model.nx), dtype=float)
    X0 = np.tile(x0, (rows, 1))
    X0[:, model.nq:model.nq + model.nu] += np.random.default_rng(0).uniform(-0.5, 0.5, (rows, model.nu))
    return X0


def counts(status):
    vals, n = np.unique(status, return_counts=True)
    return " ".join(f"{v}: {k}" for v, k in zip(vals, n))


def timed(f):
    t0 = time.thread_time()
    out = f()
    return out, time.thread_time() - t0


def one_file(path, cache_dir, rows, t_final, urdf_dt=0.001):
    """The row of the table for one file, and the first warning (or failure) seen."""
    import mujoco

    import eomc
    m, b_cpu = build(path, cache_dir)
    dt = float(mujoco.MjModel.from_xml_path(str(path)).opt.timestep) if path.suffix == ".xml" else urdf_dt
    n = max(1, int(round(t_final / dt)))
    X0 = starts(m, rows)
    first = []
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        kw = dict(steps=n, dt=dt, raise_on_failure=False)
        eomc.rollout(m, X0, threads=1, **kw)        # the first call's one-time work (the model's rules) not timed
        one, cpu1 = timed(lambda: eomc.rollout(m, X0, threads=1, **kw))
        method = one.method
        two = eomc.rollout(m, X0, threads=2, **kw)
        sims = {i: m.simulate(X0[i], (0, n * dt), method=method, dt=dt, raise_on_failure=False)
                for i in SIM_ROWS if i < rows}
        sim_eq = sum(np.array_equal(r.x_final, one.x[i]) and r.status == one.status[i] for i, r in sims.items())
        if "implicit_batch" in m.functions and method == "implicitfast":
            eomc.rollout(m, X0, threads=1, lanes=True, **kw)
            lanes, cpu_l = timed(lambda: eomc.rollout(m, X0, threads=1, lanes=True, **kw))
            same = int(sum(np.array_equal(a, b) for a, b in zip(lanes.x, one.x)))
            diff = float(np.max(np.abs(lanes.x - one.x)))
            lanes_cell = (f"{same}/{rows} equal" + (f", max {diff:.2g}" if same < rows else "")
                          + ("" if np.array_equal(lanes.status, one.status) else ", statuses differ"))
            lanes_cpu = f"{cpu_l:.3f}"
        else:
            lanes_cell, lanes_cpu = "-", "-"
        # eomc.Rollout, as an environment calls it: 3 calls of 5 steps, each from the last call's rows
        ro, X, kept = eomc.Rollout(m, dt=dt, threads=1, raise_on_failure=False), X0, 0
        for _ in range(3):
            a, b = ro(X, steps=5), eomc.rollout(m, X, steps=5, dt=dt, threads=1, raise_on_failure=False)
            kept += (np.array_equal(a.x, b.x) and np.array_equal(a.status, b.status) and a.messages == b.messages
                     and a.method == b.method)
            X = a.x
        auto = eomc.rollout(m, X0[:4], t_final=0.2, raise_on_failure=False)
        autos = [m.simulate(X0[i], (0, 0.2), raise_on_failure=False) for i in range(4)]
        auto_eq = sum(np.array_equal(r.x_final, auto.x[i]) and r.status == auto.status[i] for i, r in enumerate(autos))
    for w in seen:
        first.append(f"{w.category.__name__}: {str(w.message)}")
    k = len([i for i in SIM_ROWS if i < rows])
    row = [m.nx, f"{b_cpu:.1f}", f"{dt:g} x {n}", method, counts(one.status), f"{sim_eq}/{k}",
           "yes" if np.array_equal(one.x, two.x) and np.array_equal(one.status, two.status) else "NO",
           f"{cpu1:.3f}", lanes_cell, lanes_cpu, f"{kept}/3", f"{auto_eq}/4", counts(auto.status)]
    return row, (first[0] if first else ""), len(seen)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-k", action="append", default=[], help="substring of the file labels to run")
    parser.add_argument("--rows", type=int, default=16)
    parser.add_argument("--t-final", type=float, default=0.5, help="simulated seconds of the fixed-step rollouts")
    parser.add_argument("--cache-dir", help="build cache (default: a fresh temporary one)")
    parser.add_argument("--urdf", action="store_true", help="example-robot-data's URDFs instead (their default "
                        "build: fixed base, joint limits; dt --urdf-dt), written as rollout_sweep_urdf.md")
    parser.add_argument("--urdf-dt", type=float, default=0.001)
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args()
    suffix = ".urdf" if args.urdf else ".xml"
    files = [f for f in model_files() if f[2].suffix == suffix and (not args.k or any(k in f[1] for k in args.k))]
    cache = args.cache_dir or tempfile.mkdtemp(prefix="eomc_rollout_sweep_")
    started, loads, rows = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), [], []
    for i, (group, label, path) in enumerate(files, 1):
        loads.append(os.getloadavg()[0])
        try:
            cells, warn, nwarn = one_file(path, cache, args.rows, args.t_final, args.urdf_dt)
            cells.append(f"{nwarn}: {warn[:110]}" if nwarn else "")
        except Exception as exc:  # noqa: BLE001 -- the row says what broke
            cells = ["-"] * 13 + [f"FAILED {type(exc).__name__}: {str(exc)[:110]}"]
        rows.append([group, label, *cells])
        print(f"[{i}/{len(files)}] {group} {label}: {cells[4]}; simulate {cells[5]}, threads {cells[6]}, "
              f"lanes {cells[8]}, Rollout {cells[10]}, auto {cells[11]}", flush=True)
    header = ["set", "file", "nx", "build CPU s", "dt x steps", "method", "statuses (16 rows)",
              "rows = simulate", "2 threads = 1", "CPU s, 1 thread", "lanes vs scalar rows", "lanes CPU s",
              "Rollout calls = rollout", "auto rows = simulate", "auto statuses", "warnings: first"]
    header[6] = f"statuses ({args.rows} rows)"
    text = "\n".join([
        environment_header(f"eomc.rollout on every real {'URDF' if args.urdf else 'MJCF'} file: rows against simulate, "
                           "threads and lanes", args=True),
        f"- started {started}; 1-min load while it ran: min {min(loads):.1f}, median "
        f"{sorted(loads)[len(loads) // 2]:.1f}, max {max(loads):.1f} (2 shared cores; CPU is thread CPU)",
        f"- starts: the file's start, every speed uniform in +-0.5 (seed 0); fixed-step rollouts "
        f"{args.t_final:g} s at the file's timestep (a URDF: --urdf-dt {args.urdf_dt:g}); rows {', '.join(map(str, SIM_ROWS))} against simulate "
        "(x_final bit for bit and the status); the adaptive default (method 'auto') 4 rows x 0.2 s; lanes: implicitfast in "
        "SIMD lanes where the model has NAME_implicit_batch (their vector sin/cos differ from libm's by 1 ulp, "
        "so a chaotic contact run's rows may part: the max |difference| is shown)",
        "", format_table(header, rows), ""])
    print(text)
    if not args.no_write:
        write_results("rollout_sweep_urdf" if args.urdf else "rollout_sweep", text, keep_notes=True)


if __name__ == "__main__":
    main()
