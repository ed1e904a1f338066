"""Issue 31 S2, piece 1: NAME_implicit_batch (SIMD lanes, a contact's depth branch as a mask per
lane) against the scalar NAME_implicit, per state, on the contact models of
bench_rollout_contacts.py (the gym hopper, Go2 and G1 from example-robot-data's URDF, as that
script builds them).

Why these states: the lanes run a branch's block when one of its lanes takes it, so the cost
depends on the mix of contacts in touch.  The states are the rollout's own: bench_rollout_contacts'
64 starts run for one simulated second by eomc.rollout (checked implicitfast, every step
recorded), 1024 of those states drawn at random (seed 0).

A C harness linked against the model's own library (the build eomc.rollout loads, plus
implicit_batch: ``functions`` = the defaults and "implicit_batch") times, in thread CPU time,
pinned to one core (--core, 0 unless told): scalar, NAME_implicit over the 1024 states stored one
after another; batch, NAME_implicit_batch over the same states one group of lanes (the machine's
4 or 8) per call, each group's states and results stored as columns, group after group -- what a
rollout in lanes hands it.  Each contestant writes its results into one buffer, reused state
after state (group after group), as a rollout's row does step after step.  (One call over all 1024 states as columns spends half its time
writing the results: a state's 928 doubles (Go2) 8 KB apart, a cache line each.)  The
two alternate within a round; medians over rounds.  The harness first checks the batch against
the scalar call on every state (max relative difference, share of identical values).

    taskset -c 0 python benchmarks/bench_implicit_batch.py [--rounds 9] [--write] [hopper go2 g1]
"""
import argparse
import statistics
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

from eomc.compiler.build.builder import machine_lanes

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))

from common import C_CLOCK_AND_RNG, environment_header, write_results  # noqa: E402
import bench_fixedstep as B  # noqa: E402
import bench_rollout_contacts as RC  # noqa: E402

NS = 1024
HARNESS = r"""
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "NAME.h"
#define NS 1024
""" + C_CLOCK_AND_RNG + r"""
/* the states in blocks of BLK (one group of lanes), each block's states as columns and its
   results likewise, one block after another: what a lanes rollout hands NAME_implicit_batch.
   keep = 0 (the timed runs): every block's results into one buffer, as the scalar runs write
   every state's into one (a rollout's row reuses its buffer step after step) */
static int batch(const double *S, double *OUT, const eomc_model *m, int *st, double *work, int nx, int no, int keep)
{
    int b, worst = 0;
    for (b = 0; b < NS; b += BLK) {
        int s = NAME_implicit_batch(BLK, 0.0, S + (size_t)b * nx, m->param_defaults, NULL, OUT + (size_t)b * no * keep,
                                    st + b, work);
        if (s && !worst) worst = s;
    }
    return worst;
}

int main(int argc, char **argv) {
    const eomc_model *m = NAME_model();
    const int nx = m->nx, no = NOUT, rounds = atoi(argv[1]);
    double *X = malloc(sizeof(double) * nx * NS), *S = malloc(sizeof(double) * nx * NS);
    double *OUT = malloc(sizeof(double) * no * NS), *out = malloc(sizeof(double) * no * NS);
    double *work = malloc(sizeof(double) * (m->work_size + 1)), worst = 0.0, same = 0.0, sum = 0.0;
    double *r = calloc((size_t)m->ninput + 1, sizeof(double));   /* zero inputs (the batch: R = NULL) */
    int *st = malloc(sizeof(int) * NS), i, k, c, round;
    FILE *f = fopen(argv[2], "rb");
    (void)argc;
    if (f == NULL || fread(X, sizeof(double), (size_t)nx * NS, f) != (size_t)nx * NS) { printf("no states\n"); return 1; }
    fclose(f);
    for (i = 0; i < NS; i++) for (k = 0; k < nx; k++) S[(i / BLK) * BLK * nx + k * BLK + i % BLK] = X[i * nx + k];
    if (batch(S, OUT, m, st, work, nx, no, 1)) { printf("batch failed\n"); return 1; }
    for (i = 0; i < NS; i++) {
        if (NAME_implicit(0.0, X + i * nx, m->param_defaults, r, out + i * no, work)) { printf("scalar failed\n"); return 1; }
        for (k = 0; k < no; k++) { double a = OUT[(i / BLK) * BLK * no + k * BLK + i % BLK], b = out[i * no + k];
            double d = fabs(a - b) / (fabs(b) > 1 ? fabs(b) : 1);
            if (d > worst) worst = d;
            same += a == b; }
    }
    printf("agree %.3g %.4f\n", worst, same / ((double)no * NS));
    for (round = 0; round < rounds; round++)
        for (c = 0; c < 2; c++) {
            int cc = (c + round) % 2; long done = 0; double t0 = tnow(), t1;
            do { if (cc == 0) { for (i = 0; i < NS; i++) NAME_implicit(0.0, X + i * nx, m->param_defaults, r, out, work); }
                 else batch(S, OUT, m, st, work, nx, no, 0);
                 sum += cc ? OUT[0] : out[0];
                 done += NS; t1 = tnow(); } while (t1 - t0 < 2e8);
            printf("time %d %.3f\n", cc, (t1 - t0) / done);
        }
    printf("checksum %g\n", sum);
    (void)rnd;
    return 0;
}
"""


def build(name, cache_dir):
    """(model, starts X0, dt, steps): the case of bench_rollout_contacts with implicit_batch added."""
    import mujoco  # noqa: F401  (bench_rollout_contacts builds the MJCF with it)

    import eomc
    from eomc.compiler.emit.signatures import FUNCTION_ORDER, ON_REQUEST
    from eomc.compiler.mjcf.model import MjcfModel
    functions = tuple(f for f in FUNCTION_ORDER if f not in ON_REQUEST) + ("implicit_batch",)
    if name in RC.URDF:
        path, height, pose = RC.urdf_mjcf(name, cache_dir)
        mm = mujoco.MjModel.from_xml_path(str(path))
    else:
        path, height, pose = B.gym_xml(name), None, {}
        mm = B.mujoco_model(name, "IMPLICITFAST")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        em = eomc.compile(MjcfModel(path), name=f"ib_{name}", cache_dir=cache_dir, functions=functions)
    X0, _ = RC.starts(em, mm, height, pose)
    dt = float(mm.opt.timestep)
    return em, X0, dt, int(round(1.0 / dt))


def states(em, X0, dt, steps):
    """NS states drawn (seed 0) from the rollout's recorded trajectories, and the mean number
    of contacts in touch per state (a contact's stiffness block K nonzero)."""
    import eomc
    res = eomc.rollout(em, X0, steps=steps, dt=dt, threads=1, method="implicitfast", record="steps",
                       raise_on_failure=False)
    traj = res.x.reshape(-1, em.nx)
    traj = traj[np.isfinite(traj).all(axis=1)]
    X = traj[np.random.default_rng(0).choice(len(traj), NS, replace=False)]
    out = em.implicit_batch(0.0, X)
    at = em.metadata["implicit"]["layout"]
    nc = len(em.metadata["implicit"]["contacts"])
    K = out[:, at["contact"]:at["contact"] + 25 * nc].reshape(NS, nc, 25)[:, :, 7:16]
    return np.ascontiguousarray(X), float(np.mean((K != 0).any(axis=2).sum(axis=1))), nc


def measure(name, tmp, rounds, core, cache=None):
    em, X0, dt, steps = build(name, cache or tmp)
    X, touching, nc = states(em, X0, dt, steps)
    lib = Path(em.library_path)
    d = lib.parent
    (tmp / f"{name}.bin").write_bytes(X.tobytes())
    size = em.metadata["implicit"]["layout"]["size"]
    src = tmp / f"h_{name}.c"
    src.write_text(HARNESS.replace("NAME", em.name).replace("NOUT", str(size)))
    exe = tmp / f"h_{name}"
    subprocess.run(["gcc", "-O2", "-std=c99", f"-DBLK={machine_lanes()}", f"-I{d}", f"-I{ROOT / 'runtime' / 'c'}", str(src), str(lib),
                    f"-Wl,-rpath,{d}", "-o", str(exe), "-lm"], check=True)
    out = subprocess.run(["taskset", "-c", str(core), str(exe), str(rounds), str(tmp / f"{name}.bin")],
                         capture_output=True, text=True, check=True).stdout
    times = {0: [], 1: []}
    agree = None
    for line in out.splitlines():
        if line.startswith("time"):
            _, k, v = line.split()
            times[int(k)].append(float(v))
        elif line.startswith("agree"):
            agree = tuple(float(v) for v in line.split()[1:])
    return dict(label=name, nx=em.nx, size=size, ncontact=nc, touching=touching,
                vectorized=em.metadata["implicit_batch"]["vectorized"],
                scalar=statistics.median(times[0]), batch=statistics.median(times[1]), agree=agree)


def table(rows):
    head = ("| model | nx | NAME_implicit doubles | contacts | in touch per state (mean) | scalar ns/state | "
            "batch ns/state | speed-up | batch vs scalar: max rel. diff, share of identical values |")
    lines = [head, "|" + "|".join(["--"] * (head.count("|") - 1)) + "|"]
    for r in rows:
        lines.append(f"| {r['label']} | {r['nx']} | {r['size']} | {r['ncontact']} | {r['touching']:.2f} | "
                     f"{r['scalar']:.0f} | {r['batch']:.0f}{'' if r['vectorized'] else ' (not vectorized)'} | "
                     f"{r['scalar'] / r['batch']:.2f} | {r['agree'][0]:.2g}, {r['agree'][1]:.4f} |")
    return "\n".join(lines)


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=9)
    parser.add_argument("--core", type=int, default=0)
    parser.add_argument("--write", action="store_true")
    parser.add_argument("--cache", type=Path, default=None, help="eomc's cache (default: a fresh one)")
    parser.add_argument("names", nargs="*", default=["hopper", "go2", "g1"])
    args = parser.parse_args(argv)
    header = environment_header("implicit_batch: NAME_implicit in SIMD lanes vs the scalar call (issue 31 S2)",
                                vars(args))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.names:
            rows.append(measure(name, Path(tmp), args.rounds, args.core, args.cache))
            print(rows[-1], flush=True)
    text = table(rows)
    print(text)
    if args.write:
        write_results("implicit_batch", header + "\n" + f"benchmarks/bench_implicit_batch.py --rounds {args.rounds}: "
                      f"{NS} states per call drawn from the contact rollouts, thread CPU time, taskset -c {args.core}, "
                      "contestants interleaved, medians.  speed-up = scalar ns / batch ns.\n\n" + text + "\n",
                      keep_notes=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
