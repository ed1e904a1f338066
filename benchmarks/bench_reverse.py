"""Reverse mode: the cost of vjp (λᵀ·∂rhs/∂[x; p]) and hvp ((∂²(λᵀ rhs)/∂x²)·v) against rhs,
jac_x and the ways to get the same numbers without them, one C harness.

Contestants (per model, one harness pinned to core 1, thread CPU, interleaved with the order
rotated every round, ~20 ms blocks, median of rounds; ns per call), all generated C of one
build (functions rhs, jac_x, jac_p, jvp, vjp, hvp; gcc -O2):
  * rhs; jac_x; jvp with one direction;
  * vjp with the parameter part (gp) and without it (gp = NULL);
  * "jac_x + jac_p, then λᵀ·[J, Jp]": what a vjp costs without reverse mode;
  * hvp; "central differences of vjp" (2 vjp calls: what a Hessian-vector product costs
    without forward-over-reverse, at half the digits);
  * jac_p and jac_r alone (what each derivative function costs, in rhs calls: issue 30).
Models: SD/FAST's n-link cart (tree_models/cart_rel_joints.py; runtime parameters), both
formulations where the build is quick, and URDF robots from example-robot-data with limits
off (UR10, Panda fixed; Go2 floating), recursive formulation.

Agreement, before timing: vjp against λᵀ·[jac_x, jac_p] (relative, max over states) and hvp
against central differences of vjp.

Usage: python benchmarks/bench_reverse.py [--cart 4,8,20] [--robots ur10,panda,go2,g1] [--rounds 9] [--write] [--out NAME]
"""
import argparse
import datetime
import os
import platform
import runpy
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(ROOT / "tests"))

ROBOTS = {
    "ur10": ("ur_description/urdf/ur10_robot.urdf", False),
    "panda": ("panda_description/urdf/panda.urdf", False),
    "go2": ("go2_description/urdf/go2.urdf", True),
    "g1": ("g1_description/urdf/g1_29dof_rev_1_0.urdf", True),
}
NS = 16
FUNCTIONS = ["rhs", "jac_x", "jac_p", "jac_r", "jvp", "vjp", "hvp"]
LABELS = ("rhs", "jac_x", "jvp (1 direction)", "vjp (x and p)", "vjp (x only)",
          "jac_x + jac_p, then λᵀ·[J, Jp]", "hvp", "central differences of vjp (2 vjp)", "jac_p", "jac_r")

# The harnesses' common head (this file's and bench_pair_reverse.py's): the model's states X,
# weights L and directions V at NS points, its parameters P and inputs R, a thread-CPU clock.
HARNESS_HEAD = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "@NAME@.h"
#define NS @NS@
#define NX @NX@
#define NP @NP@
static const double X[NS][NX] = {@X@};
static const double L[NS][NX] = {@L@};
static const double V[NS][NX] = {@V@};
static const double P[] = {@P@};
static const double R[] = {@R@};
static double tnow(void) { struct timespec ts; clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return ts.tv_sec * 1e9 + ts.tv_nsec; }
"""
HARNESS = HARNESS_HEAD + r"""static double xdot[NX], gx[NX], gp[NP + 1], J[NX * NX], Jp[NX * (NP + 1)], Jr[NX * @NR@], out[NX], dirs[NX + NP], xs[NX];
static void call(int c, int i) {
    int a, b;
    switch (c) {
    case 0: @NAME@_rhs(0.0, X[i], P, R, xdot, NULL); break;
    case 1: @NAME@_jac_x(0.0, X[i], P, R, J, NULL); break;
    case 2: for (a = 0; a < NX; a++) dirs[a] = V[i][a];
            @NAME@_jvp(0.0, X[i], P, R, 1, dirs, xdot, out, NULL); break;
    case 3: @NAME@_vjp(0.0, X[i], P, R, L[i], xdot, gx, gp, NULL); break;
    case 4: @NAME@_vjp(0.0, X[i], P, R, L[i], NULL, gx, NULL, NULL); break;
    case 5: @NAME@_jac_x(0.0, X[i], P, R, J, NULL);
            @NAME@_jac_p(0.0, X[i], P, R, Jp, NULL);
            for (b = 0; b < NX; b++) gx[b] = 0.0;
            for (b = 0; b < NP; b++) gp[b] = 0.0;
            for (a = 0; a < NX; a++) {
                for (b = 0; b < NX; b++) gx[b] += L[i][a] * J[a * NX + b];
                for (b = 0; b < NP; b++) gp[b] += L[i][a] * Jp[a * NP + b];
            }
            break;
    case 6: @NAME@_hvp(0.0, X[i], P, R, L[i], V[i], out, NULL); break;
    case 7: for (a = 0; a < NX; a++) xs[a] = X[i][a] + 1e-6 * V[i][a];
            @NAME@_vjp(0.0, xs, P, R, L[i], NULL, out, NULL, NULL);
            for (a = 0; a < NX; a++) xs[a] = X[i][a] - 1e-6 * V[i][a];
            @NAME@_vjp(0.0, xs, P, R, L[i], NULL, gx, NULL, NULL);
            for (a = 0; a < NX; a++) out[a] = (out[a] - gx[a]) / 2e-6;
            break;
    case 8: @NAME@_jac_p(0.0, X[i], P, R, Jp, NULL); out[0] = Jp[0]; break;
    case 9: @NAME@_jac_r(0.0, X[i], P, R, Jr, NULL); out[0] = Jr[0]; break;
    }
}
#define NCALLS 10
int main(void) {
    int i, c, round;
    double sum = 0.0;
    for (round = 0; round < @ROUNDS@; round++) {
        for (c = 0; c < NCALLS; c++) {
            int cc = (c + round) % NCALLS; long calls = 0; double t0 = tnow(), t1;
            do { for (i = 0; i < NS; i++) { call(cc, i); sum += out[0] + gx[0]; } calls += NS; t1 = tnow(); }
            while (t1 - t0 < 2e7);
            printf("time %d %.1f\n", cc, (t1 - t0) / calls);
        }
    }
    printf("checksum %g\n", sum);
    return 0;
}
"""


def build_case(case, formulation, cache):
    import eomc
    if case.startswith("cart"):
        n = int(case[4:])
        os.environ["EOMC_N_LINKS"] = str(n)
        mod = runpy.run_path(str(HERE / "tree_models" / "cart_rel_joints.py"))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return eomc.compile(mod["system"], f"cart{n}{formulation[0]}", parameters=mod["parameters"],
                                inputs=mod["inputs"], functions=FUNCTIONS, formulation=formulation,
                                cache_dir=cache, progress=False)
    from eomc.compiler.urdf import from_urdf
    from helpers.robots import robot_path
    rel, floating = ROBOTS[case]
    system = from_urdf(robot_path(rel), floating_base=floating, limits=False)
    return eomc.compile(system, case, functions=FUNCTIONS, formulation=formulation, cache_dir=cache,
                        progress=False)


def c_array(a):
    return ", ".join("{" + ", ".join(repr(float(v)) for v in row) + "}" for row in a)


def build_harness(template, model, X, L, V, tmp, ns):
    """The harness ``template`` (HARNESS_HEAD + its calls) filled for ``model`` at its ``ns`` states X,
    weights L, directions V, compiled with the model's C at -O2: the executable's path."""
    name = model.name
    src = (template.replace("@NAME@", name).replace("@NS@", str(ns)).replace("@NX@", str(model.nx))
           .replace("@NP@", str(model.nparam)).replace("@NR@", str(max(model.ninput, 1)))
           .replace("@X@", c_array(X)).replace("@L@", c_array(L)).replace("@V@", c_array(V))
           .replace("@P@", ", ".join(repr(float(v)) for v in model.param_defaults) or "0.0")
           .replace("@R@", ", ".join("0.0" for _ in range(max(model.ninput, 1)))))
    c = tmp / f"h_{name}.c"
    c.write_text(src)
    objs = []
    for s, o in ((c, tmp / f"h_{name}.o"), (model.source_path, tmp / f"m_{name}.o")):
        subprocess.run(["gcc", "-O2", "-std=c99", f"-I{model.directory}", f"-I{ROOT / 'runtime' / 'c'}",
                        "-c", str(s), "-o", str(o)], check=True)
        objs.append(str(o))
    exe = tmp / f"h_{name}"
    subprocess.run(["gcc", *objs, "-o", str(exe), "-lm"], check=True)
    return exe


def agreement(model, X, L, V):
    p = np.asarray(model.param_defaults, dtype=float)
    r = np.zeros(model.ninput)
    ev, eh = 0.0, 0.0
    for x, lam, v in zip(X[:4], L[:4], V[:4]):
        _, gx, gp = model.vjp(0.0, x, lam, p=p, r=r)
        ref = np.concatenate([lam @ model.jacobian(0.0, x, p=p, r=r), lam @ model.jac_p(0.0, x, p=p, r=r)])
        got = np.concatenate([gx, gp])
        ev = max(ev, np.max(np.abs(got - ref)) / max(1.0, np.max(np.abs(ref))))
        h = 1e-5
        fd = (model.vjp(0.0, x + h * v, lam, p=p, r=r)[1] - model.vjp(0.0, x - h * v, lam, p=p, r=r)[1]) / (2 * h)
        eh = max(eh, np.max(np.abs(model.hvp(0.0, x, lam, v, p=p, r=r) - fd)) / max(1.0, np.max(np.abs(fd))))
    return ev, eh


def harness(model, X, L, V, tmp, rounds):
    name = model.name
    exe = build_harness(HARNESS.replace("@ROUNDS@", str(rounds)), model, X, L, V, tmp, NS)
    out = subprocess.run(["taskset", "-c", "1", str(exe)], capture_output=True, text=True, check=True).stdout
    times = {}
    for line in out.splitlines():
        if line.startswith("time"):
            _, k, v = line.split()
            times.setdefault(LABELS[int(k)], []).append(float(v))
    return {k: float(np.median(v)) for k, v in times.items()}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cart", default="4,8,20")
    ap.add_argument("--kane", default="4,8", help="cart sizes also built with Kane's formulation")
    ap.add_argument("--robots", default="ur10,panda,go2")
    ap.add_argument("--rounds", type=int, default=9)
    ap.add_argument("--write", action="store_true")
    ap.add_argument("--out", default="reverse",
                    help="results file name under benchmarks/results/ (a subset of the models "
                         "goes to its own file, not over reverse.md's full table)")
    ap.add_argument("--cache", default=None, help="build cache directory kept between runs")
    args = ap.parse_args()
    cases = [(f"cart{n}", "recursive") for n in args.cart.split(",") if n]
    cases += [(f"cart{n}", "kane") for n in args.kane.split(",") if n]
    cases += [(r, "recursive") for r in args.robots.split(",") if r]
    rows = []
    with tempfile.TemporaryDirectory() as td:
        tmp = Path(td)
        cache = Path(args.cache) if args.cache else tmp / "cache"
        for case, form in cases:
            t0 = time.process_time()
            model = build_case(case, form, cache)
            build = time.process_time() - t0
            rng = np.random.default_rng(1)
            X = rng.uniform(-1, 1, (NS, model.nx)) * 0.5
            L, V = rng.normal(size=(2, NS, model.nx))
            ev, eh = agreement(model, X, L, V)
            t = harness(model, X, L, V, tmp, args.rounds)
            rows.append((case, form, model.nx, model.nparam, build, t, ev, eh))
            print(render(rows[-1]), flush=True)
    text = header(args.rounds) + "\n".join(render(r) for r in rows) + "\n"
    if args.write:
        path = HERE / "results" / f"{args.out}.md"
        path.write_text(text)
        print(f"wrote {path}")


def header(rounds):
    load = os.getloadavg()
    import eomc
    return (f"# Reverse mode: vjp and hvp against rhs, jac_x and their substitutes\n\n"
            f"{datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M UTC}, {platform.processor() or platform.machine()}, "
            f"load {load[0]:.1f}/{load[1]:.1f}, eomc {eomc.__version__}, gcc -O2, pinned to core 1, thread CPU, "
            f"{rounds} interleaved rounds (median), {NS} random states; ns per call.  "
            f"vjp err: max relative difference to λᵀ·[jac_x, jac_p]; hvp err: to central differences "
            f"of vjp (h = 1e-5).  Build: CPU s of the whole build (all seven functions).\n\n"
            "| model | formulation | nx | nparam | build s | rhs | jac_x | jvp | vjp (x, p) | vjp (x) | "
            "jac_x + jac_p + λᵀJ | hvp | CD of vjp | jac_p | jac_r | vjp/rhs | hvp/jac_x | "
            "jac_x/rhs | jac_p/rhs | jac_r/rhs | jvp/rhs | vjp err | hvp err |\n"
            "|---|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|\n")


def render(r):
    case, form, nx, npar, build, t, ev, eh = r
    cells = [t[k] for k in LABELS]
    return (f"| {case} | {form} | {nx} | {npar} | {build:.1f} | " + " | ".join(f"{c:.0f}" for c in cells)
            + f" | {t['vjp (x and p)'] / t['rhs']:.2f} | {t['hvp'] / t['jac_x']:.2f} | "
            + " | ".join(f"{t[k] / t['rhs']:.2f}" for k in ("jac_x", "jac_p", "jac_r", "jvp (1 direction)"))
            + f" | {ev:.1e} | {eh:.1e} |")


if __name__ == "__main__":
    main()
