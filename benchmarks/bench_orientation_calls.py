"""One model call in C, free joints as body-XYZ angles and as MuJoCo's quaternion: rhs, NAME_implicit, NAME_energy.

    python benchmarks/bench_orientation_calls.py [--models ant,humanoid] [--rounds 3]

Why: ``MjcfModel(orientation="quaternion")`` writes the free joint without sin/cos (one
division instead of six trigonometric calls, docs/urdf.md#quaternion-coordinates), and
implicitfast's step is mostly its NAME_implicit call; this says what one call of each costs in
either coordinate.  NAME_energy: the rollout's energy watch calls it at every step of a
quaternion model (eomc_integrators.c fs_watch: the fast path's terms hold the energy at the
step's end before normalisation, so with quaternions it is evaluated again).

Each gymnasium model is built both ways (bench_fixedstep.eomc_model: the XML as shipped, the
default functions), and a C harness linked with each build's .c calls the function at ~100
states along the build's own 1 s implicitfast run from qpos0 (bench_fixedstep.eomc_start), 200
passes per block, best of 7 blocks (thread CPU); the two builds' harnesses run in alternating
processes pinned to core 1, ``--rounds`` times; cells are the median of the rounds' bests.
"""
import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_fixedstep as B  # noqa: E402

FUNCTIONS = ("rhs", "implicit", "energy")
HARNESS = """#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <time.h>
#include "{name}.h"
static const double X[{n}][{nx}] = {{{X}}};
static const double P[] = {{{P}}};
static double R[{nr}];
static double OUT[{size}];
static double WORK[{work}];
typedef int (*fn)(double, const double *, const double *, const double *, double *, double *);
static double best(fn f, int *st) {{
    struct timespec a, b; double t_best = 1e9; int rep, k, i;
    for (rep = 0; rep < 7; rep++) {{
        clock_gettime(CLOCK_THREAD_CPUTIME_ID, &a);
        for (i = 0; i < 200; i++) for (k = 0; k < {n}; k++) *st |= f(0.0, X[k], P, R, OUT, WORK);
        clock_gettime(CLOCK_THREAD_CPUTIME_ID, &b);
        double t = ((b.tv_sec - a.tv_sec) * 1e9 + (b.tv_nsec - a.tv_nsec)) / (200.0 * {n});
        if (t < t_best) t_best = t;
    }}
    return t_best;
}}
int main(void) {{
    int st = 0;
    double rhs = best({name}_rhs, &st), imp = best({name}_implicit, &st), en = best({name}_energy, &st);
    printf("%.1f %.1f %.1f %d\\n", rhs, imp, en, st);
    return 0;
}}
"""


def harness(model, tmp):
    """(executable, states): the harness of one build, at ~100 states of its own implicitfast run."""
    import mujoco
    base = mujoco.MjModel.from_xml_path(str(B.gym_xml(model.name.split("_")[1])))
    x0 = B.eomc_start(model, base)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run = model.simulate(x0, (0.0, 1.0), method="implicitfast", dt=float(base.opt.timestep))
    X = run.x[::max(1, len(run.x) // 100)]
    meta = model.metadata
    src = Path(model.source_path)
    fmt = lambda v: ",".join(repr(float(x)) for x in v)  # noqa: E731
    h = Path(tmp) / f"h_{model.name}.c"
    h.write_text(HARNESS.format(name=model.name, n=len(X), nx=model.nx, X=",".join("{" + fmt(x) + "}" for x in X),
                                P=fmt(meta["param_defaults"]), nr=max(1, meta["ninput"]),
                                size=max(meta["implicit"]["layout"]["size"], model.nx, 8),
                                work=f"{model.name.upper()}_WORK_LEN"))
    exe = Path(tmp) / f"h_{model.name}"
    extra = [str(p) for p in Path(model.directory).glob("eomc_batch.c")]
    subprocess.run(["cc", "-O2", "-std=c99", "-mavx2", "-ffp-contract=off", "-I", str(model.directory), str(h),
                    str(src), *extra, "-lm", "-o", str(exe)], check=True)
    return exe, len(X)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", default="ant,humanoid")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--cache-dir", default=os.environ.get("EOMC_CACHE_DIR"))
    args = parser.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in [m for m in args.models.split(",") if m]:
            exes = {}
            for orientation in ("euler", "quaternion"):
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    model = B.eomc_model(name, args.cache_dir, orientation=orientation)
                exes[orientation] = harness(model, tmp)
            times = {o: [] for o in exes}
            for _ in range(args.rounds):
                for o, (exe, _) in exes.items():
                    out = subprocess.run(["taskset", "-c", "1", str(exe)], capture_output=True, text=True,
                                         check=True).stdout.split()
                    assert out[3] == "0", f"{name} {o}: status {out[3]}"
                    times[o].append([float(v) for v in out[:3]])
            med = {o: [statistics.median(t[i] for t in times[o]) for i in range(3)] for o in times}
            for i, f in enumerate(FUNCTIONS):
                e, q = med["euler"][i], med["quaternion"][i]
                rows.append((name, f, exes["euler"][1], e, q, e / q))
    print(f"load {open('/proc/loadavg').read().split()[:3]}; {args.rounds} rounds, median of best-of-7")
    print("| model | function | states | euler ns/call | quaternion ns/call | euler / quaternion |")
    print("|---|---|--:|--:|--:|--:|")
    for name, f, n, e, q, r in rows:
        print(f"| {name} | {f} | {n} | {e:.0f} | {q:.0f} | {r:.2f}x |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
