"""implicitfast's model calls and physics verdicts over many starts: one integrator library against another.

    python benchmarks/bench_fixedstep_verdicts.py [--models hopper,walker2d,ant,humanoid] [--seeds 0-10]
        [--library main=/path/to/_eomc_integrators.so --library branch=-] [--error-rows 16] [--rollout]
        [--orientation quaternion,euler]

Why: a change to the fixed step's split rule (runtime/c/eomc_fixedstep.c) changes the paths of chaotic
runs, and its verdicts (sub-steps left unsolved, energy flags) move by one or two over 64 starts whatever
the rule does (session 26: main's humanoid had 0 unsolved sub-steps over bench_rollout_contacts' 64
starts, seed 0, and 2-5 on most other seeds).  So a rule is judged here over several seeds of those
starts, each library in its own process (the integrator library is opened once per process), the
same starts for every library.

Per model (gymnasium's MJCF as bench_rollout_contacts builds it; go2 and g1 from its urdf_mjcf),
seed and library: the qpos0 run (the start pose at rest: bench_fixedstep's row) and NROWS starts of
bench_rollout_contacts.starts with its rng seeded by the seed (seed 0: its own 64 starts), each one
``simulate(method="implicitfast")`` over 1 s at the file's timestep with its verdicts:
model calls (stats nfev), sub-steps left unsolved (stats rejected) and the rows holding them, rows
with a non-zero status, rows whose energy verdict says "the integration is wrong here" or "more than
the tolerance explains", rows warned of a penetration, rows whose energy rose by more than 10 mJ (and
the largest rise); with --error-rows k, on seed 0 the first k starts' error against the library's own
Radau at rtol = atol = 1e-9 (max |q - q_ref| over bench_fixedstep.compared_q at t = 1: median / mean /
max); with --rollout, eomc.rollout's and the lanes rollout's rows with a non-zero status and rows not
clean.  Counts are summed over the seeds.  No timing here (bench_fixedstep.py: time per simulated
second against mj_step).

--library NAME=PATH[=ORIENTATION] (repeatable): an integrator library (a built
runtime/_eomc_integrators*.so, e.g. copied from another checkout); PATH "-": the installed one;
ORIENTATION (euler or quaternion): that library's orientation alone, whatever --orientation says
(e.g. main's Euler default beside a branch's quaternion).  Default: the installed one alone.
--orientation quaternion,euler: each library with eomc's free joints as MuJoCo's quaternion and
as body-XYZ angles (MjcfModel(orientation=...)), a worker process each, from the same starts
(the unit quaternion for zero angles); default quaternion alone (MjcfModel's default).
"""
import argparse
import json
import os
import re
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import environment_header, format_table, write_results  # noqa: E402

MODELS = ("hopper", "walker2d", "ant", "humanoid")
RISE = 0.01          # J: a row whose energy rose by more than this is counted as rising


def _seeds(text):
    out = []
    for part in text.split(","):
        a, _, b = part.partition("-")
        out += list(range(int(a), int(b or a) + 1))
    return out


def _starts(R, em, mm, height, pose, seed):
    """bench_rollout_contacts.starts with its rng seeded by ``seed`` (0: its own starts)."""
    orig = np.random.default_rng
    np.random.default_rng = lambda *a: orig(seed)
    try:
        return R.starts(em, mm, height, pose)[0]
    finally:
        np.random.default_rng = orig


def _row(em, x0, dt, T):
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        r = em.simulate(x0, (0.0, T), method="implicitfast", dt=dt, t_eval=[T], raise_on_failure=False)
    words = " | ".join(str(w.message) for w in seen)
    rises = [float(v) for v in re.findall(r"rose by ([0-9.eE+-]+)", words)]
    return r, dict(calls=int(r.stats["nfev"]), unsolved=int(r.stats["rejected"]), status=int(r.status),
                   wrong="wrong here" in words, tol="more than the tolerance" in words,
                   pen="penetrated" in words, rise=max(rises) if rises else 0.0)


def worker(args):
    """One library (this process's), every model and seed: JSON lines on stdout."""
    import eomc
    import eomc.runtime.native as native
    if args.worker != "-":
        native._library_path = lambda: Path(args.worker)
    import bench_fixedstep as B
    import bench_rollout_contacts as R
    for name in args.models.split(","):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            em, mm, _, _, height, pose = R._models(name, args.cache_dir, args.orientation)
        dt = float(mm.opt.timestep)
        nstep = int(round(1.0 / dt))
        T = nstep * dt
        for seed in _seeds(args.seeds):
            X0 = _starts(R, em, mm, height, pose, seed)[:args.rows]
            x00 = X0[0].copy()
            x00[em.nq:] = 0.0
            out = dict(model=name, seed=seed, qpos0=_row(em, x00, dt, T)[1]["calls"], rows=[], errors=[])
            for i, x0 in enumerate(X0):
                r, row = _row(em, x0, dt, T)
                out["rows"].append(row)
                if seed == 0 and i < args.error_rows:
                    ref = em.simulate(x0, (0.0, T), method="radau", rtol=1e-9, atol=1e-9, t_eval=[T],
                                      max_steps=10 ** 7, raise_on_failure=False)
                    if ref.status == 0:
                        out["errors"].append(float(np.abs(B.compared_q(em, mm, x=r.x[-1])
                                                          - B.compared_q(em, mm, x=ref.x[-1])).max()))
            if args.rollout:
                for lanes in (False, True):
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore")
                        ro = eomc.rollout(em, X0, steps=nstep, dt=dt, threads=1, method="implicitfast",
                                          lanes=lanes, raise_on_failure=False)
                    out["lanes" if lanes else "rollout"] = [int(np.sum(ro.status != 0)), int(np.sum(~ro.clean))]
            print(json.dumps(out), flush=True)


def summary(name, library, runs):
    rows = [r for run in runs for r in run["rows"]]
    errors = [e for run in runs for e in run["errors"]]
    err = (f"{np.median(errors):.3f} / {np.mean(errors):.3f} / {np.max(errors):.3f}" if errors else "")
    roll = ""
    if all("rollout" in run for run in runs):
        roll = " / ".join(f"{sum(run[k][0] for run in runs)}, {sum(run[k][1] for run in runs)}"
                          for k in ("rollout", "lanes"))
    return [name, library, len(runs), len(rows), runs[0]["qpos0"], sum(r["calls"] for r in rows),
            f"{sum(r['unsolved'] for r in rows)} ({sum(r['unsolved'] > 0 for r in rows)})",
            sum(r["status"] != 0 for r in rows), sum(r["wrong"] for r in rows), sum(r["tol"] for r in rows),
            sum(r["pen"] for r in rows),
            f"{sum(r['rise'] > RISE for r in rows)} ({max(r['rise'] for r in rows):.3g} J)", err, roll]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", default=",".join(MODELS))
    parser.add_argument("--seeds", default="0", help="e.g. 0-10 or 0,3,5")
    parser.add_argument("--rows", type=int, default=64, help="starts per seed (at most 64)")
    parser.add_argument("--error-rows", type=int, default=0, help="seed 0's first k starts against Radau 1e-9")
    parser.add_argument("--rollout", action="store_true", help="also eomc.rollout's and the lanes rollout's rows")
    parser.add_argument("--library", action="append", default=[], help="NAME=PATH (PATH '-': the installed one)")
    parser.add_argument("--cache-dir", default=os.environ.get("EOMC_CACHE_DIR"))
    parser.add_argument("--no-write", action="store_true")
    parser.add_argument("--orientation", default="quaternion", help="quaternion, euler or both (comma-separated)")
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        return worker(args)
    libraries = [lib.split("=", 2) for lib in args.library] or [["installed", "-"]]
    orientations = [o for o in args.orientation.split(",") if o]
    pinned = [lib for lib in libraries if len(lib) == 3]
    if len(orientations) > 1 or orientations != ["quaternion"] or pinned:    # one column: library, orientation
        libraries = [[f"{lib[0]}, {o}", lib[1], o] for lib in libraries
                     for o in (lib[2:] if len(lib) == 3 else orientations)]
    else:
        libraries = [[label, path, "quaternion"] for label, path in libraries]
    results = {}
    for label, path, orientation in libraries:
        cmd = [sys.executable, __file__, "--worker", path, "--models", args.models, "--seeds", args.seeds,
               "--rows", str(args.rows), "--error-rows", str(args.error_rows),
               "--orientation", orientation] + (["--rollout"] if args.rollout else [])
        if args.cache_dir:
            cmd += ["--cache-dir", args.cache_dir]
        done = subprocess.run(cmd, check=True, stdout=subprocess.PIPE, text=True)
        for line in done.stdout.splitlines():
            run = json.loads(line)
            results.setdefault((run["model"], label), []).append(run)
    table = format_table(
        ["model", "library", "seeds", "rows", "qpos0 calls", "calls", "unsolved (rows)", "status != 0",
         "energy: wrong", "energy: tol", "penetrated", f"rising > {RISE * 1e3:g} mJ (largest)",
         "error vs Radau 1e-9: median / mean / max", "rollout, lanes: status != 0, not clean"],
        [summary(m, label, results[(m, label)]) for m in args.models.split(",") for label, _, _ in libraries])
    print(table)
    if not args.no_write:
        text = environment_header("implicitfast: model calls and physics verdicts over many starts", args=args,
                                  notes=[f"libraries: {', '.join(f'{a} = {b}' for a, b, _ in libraries)}",
                                         f"seeds {args.seeds}, {args.rows} starts each (bench_rollout_contacts."
                                         f"starts), 1 s at each file's timestep; counts summed over the seeds"])
        write_results("fixedstep_verdicts", text + "\n" + table + "\n", keep_notes=True)


if __name__ == "__main__":
    main()
