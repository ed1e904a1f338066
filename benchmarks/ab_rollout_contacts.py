"""Two eomc checkouts' rollouts with contacts, side by side: bench_rollout_contacts's contestants
(eomc.rollout implicitfast, checked, scalar and lanes=True; mujoco.rollout implicitfast and Euler;
one thread on both sides, or --threads k on both) on the same models and starts, each checkout in processes of its own
(its venv's runtime and its compiler's model C), the processes alternating A B / B A round by
round.  Why: a change to the generated C or to the runtime's library cannot be timed against
another library in one process, and numbers from another day or load are no baseline (the
project's rule: main's library and the branch's in the same run, interleaved).

Steps per CPU-second = NROLL * steps / median process CPU time (per side, pooled over its
processes' repeats); each side's ratios are against the mujoco.rollout it timed in its own
processes.  The eomc rows' final states are hashed: the two sides' scalar and lanes rollouts
should agree bit for bit when the change keeps bits.  Pin the whole run to one core:

    taskset -c 1 python benchmarks/ab_rollout_contacts.py \\
        --a main=/path/venv-main/bin/python:/path/main-checkout \\
        --b branch=/path/venv/bin/python:/path/branch-checkout --models ant,humanoid --rounds 3 --repeat 3

Each side's EOMC_CACHE_DIR is --cache-dir/<label>.  The table is printed (Markdown), not written.
"""
import argparse
import hashlib
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

CONTESTANTS = ("eomc scalar", "eomc lanes", "mujoco implicitfast", "mujoco euler")


def child(models, repeat, cache_dir, out, bench_dir, threads=1):
    """One process: each model's contestants, interleaved repeat by repeat (the eomc of the
    process's Python; bench_rollout_contacts from its checkout's benchmarks/, bench_dir)."""
    sys.path.insert(0, bench_dir)
    import numpy as np
    import mujoco
    from mujoco import rollout as mj_rollout

    import eomc
    import bench_rollout_contacts as R
    warnings.simplefilter("ignore")
    res = {"load": os.getloadavg()[0], "eomc": eomc.__file__}
    for name in models:
        em, mm, me, _fine, height, pose = R._models(name, cache_dir)
        dt = float(mm.opt.timestep)
        nstep = int(round(1.0 / dt))
        X0, S0 = R.starts(em, mm, height, pose)
        ctrl = np.zeros((R.NROLL, nstep, mm.nu))
        datas = [mujoco.MjData(mm) for _ in range(threads)]
        with mj_rollout.Rollout(nthread=threads) as ro:
            run = {"eomc scalar": lambda: eomc.rollout(em, X0, steps=nstep, dt=dt, threads=threads, method="implicitfast",
                                                       raise_on_failure=False),
                   "eomc lanes": lambda: eomc.rollout(em, X0, steps=nstep, dt=dt, threads=threads, method="implicitfast",
                                                      lanes=True, raise_on_failure=False),
                   "mujoco implicitfast": lambda: ro.rollout([mm] * R.NROLL, datas, S0, ctrl, nstep=nstep)[0],
                   "mujoco euler": lambda: ro.rollout([me] * R.NROLL, datas, S0, ctrl, nstep=nstep)[0]}
            cpu = {c: [] for c in run}
            digest = {}
            for _ in range(repeat):
                for c, f in run.items():
                    c0 = time.process_time()
                    got = f()
                    cpu[c].append(time.process_time() - c0)
                    if c.startswith("eomc"):
                        digest[c] = hashlib.sha1(np.ascontiguousarray(got.x).tobytes()).hexdigest()[:12]
                        digest[c + " rows ok"] = int(got.ok.sum())
        res[name] = {"cpu": cpu, "digest": digest, "steps": R.NROLL * nstep}
    res["load_end"] = os.getloadavg()[0]
    Path(out).write_text(json.dumps(res))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--a", required=True, help="label=PYTHON:CHECKOUT (its benchmarks/ is imported)")
    parser.add_argument("--b", required=True, help="label=PYTHON:CHECKOUT")
    parser.add_argument("--models", default="ant,humanoid")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--repeat", type=int, default=3, help="interleaved repeats in each process")
    parser.add_argument("--cache-dir", default=tempfile.gettempdir() + "/ab_rollout_contacts")
    parser.add_argument("--threads", type=int, default=1, help="threads on both sides (eomc.rollout threads=, "
                        "mujoco.rollout nthread= with one MjData each)")
    parser.add_argument("--child", nargs=4, metavar=("MODELS", "CACHE", "OUT", "BENCH"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.child[0].split(","), args.repeat, args.child[1], args.child[2], args.child[3], args.threads)
        return
    sides = {}
    for spec in (args.a, args.b):
        label, rest = spec.split("=", 1)
        python, checkout = rest.split(":", 1)
        sides[label] = (python, Path(checkout))
    models = args.models.split(",")
    runs = {label: [] for label in sides}
    tmp = Path(tempfile.mkdtemp(prefix="ab_rollout_"))
    for r in range(args.rounds):
        order = list(sides) if r % 2 == 0 else list(sides)[::-1]
        for label in order:
            python, checkout = sides[label]
            cache = Path(args.cache_dir) / label
            out = tmp / f"{label}_{r}.json"
            # this file run by the side's Python (the side's checkout may predate it)
            subprocess.run([python, __file__, "--a", args.a, "--b", args.b, "--repeat", str(args.repeat),
                            "--threads", str(args.threads), "--child",
                            args.models, str(cache), str(out), str(checkout / "benchmarks")],
                           env=dict(os.environ, EOMC_CACHE_DIR=str(cache)), check=True, stdout=subprocess.DEVNULL)
            runs[label].append(json.loads(out.read_text()))
            print(f"round {r + 1} {label} done (load {runs[label][-1]['load']:.1f})", file=sys.stderr, flush=True)
    loads = [x for label in runs for run in runs[label] for x in (run["load"], run["load_end"])]
    a, b = list(sides)
    print(f"1-min load over the run {min(loads):.1f}-{max(loads):.1f}; {args.rounds} processes a side, "
          f"{args.repeat} repeats each; steps per CPU-second ({args.threads} thread{'s' if args.threads > 1 else ''}, "
          f"process CPU: all threads)\n")
    print(f"| model | contestant | {a} | {b} | {b}/{a} | {a} vs mujoco implicitfast | {b} vs mujoco implicitfast "
          f"| {b} vs mujoco euler |")
    print("|---|---|---:|---:|---:|---:|---:|---:|")
    said = []
    for m in models:
        sps = {(label, c): runs[label][0][m]["steps"] / statistics.median(
            [t for run in runs[label] for t in run[m]["cpu"][c]]) for label in runs for c in CONTESTANTS}
        for c in CONTESTANTS:
            print(f"| {m} | {c} | {sps[a, c]:.4g} | {sps[b, c]:.4g} | {sps[b, c] / sps[a, c]:.3f} | "
                  f"{sps[a, c] / sps[a, 'mujoco implicitfast']:.2f} | {sps[b, c] / sps[b, 'mujoco implicitfast']:.2f} | "
                  f"{sps[b, c] / sps[b, 'mujoco euler']:.2f} |")
        for c in ("eomc scalar", "eomc lanes"):
            digests = {label: {run[m]["digest"][c] for run in runs[label]} for label in runs}
            same = len(digests[a] | digests[b]) == 1
            said.append(f"- {m} {c}: final states {'bit-equal on both sides' if same else f'DIFFER: {digests}'}; "
                        f"rows ok {runs[a][0][m]['digest'][c + ' rows ok']} / {runs[b][0][m]['digest'][c + ' rows ok']}")
    print("\n" + "\n".join(said))


if __name__ == "__main__":
    main()
