"""mass_matrix, forcing and inverse_dynamics: the loop kernel NAME_dyn against the straight-line
recursions, per model, at run time and at build time (issue 30; which one the compiler picks for
each function is ``compiler/tree/lower.dynamics_kernel_functions``).

Each model is built twice with the default function set, in fresh child processes and fresh
caches, with the kernel forced on or off per function (``lower.DYN_KERNEL_MIN_PAIRS``; builds
k, s, h, c: see --variants).  Per build: CPU = user + sys of the child and its C compiler
(eomc.compile; the imports excluded), bytes of C of the three functions plus what only they
use (``NAME_dyn_inputs``, ``NAME_dyn`` and its helpers).

Run time: both builds' C compiled (gcc -O2) into one harness, pinned to core 1, thread CPU time,
the six contestants (3 functions x 2 builds) interleaved with the order rotated every round,
~20 ms blocks over 32 random states, median of rounds; ns per call.  Before timing the harness
checks that both builds return the same M, forcing and tau (largest relative difference).

Models: the n-link cart (tree_models/cart_rel_joints.py; n = 4 has 10 states, at or below
TANGENT_MIN_STATES, where the kernel is never used: listed for completeness), UR10, Panda, Go2,
G1 (example-robot-data, limits off as in bench_derivatives: Panda's finger mimic and the like
would keep the analytic plan, and so the kernel, away) and a URDF chain of 200 revolute links
(bench_urdf_build.chain_text).

    python benchmarks/bench_dynamics_kernel.py [--cases cart4,cart20,cart80,ur10,panda,go2,g1,chain200]
        [--variants k,s] [--rounds 9] [--write]   (--write: appends a section to results/dynamics_kernel.md)
"""
import argparse
import datetime
import json
import os
import platform
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(ROOT / "tests"))

ROBOTS = {"ur10": ("ur_description/urdf/ur10_robot.urdf", False),
          "panda": ("panda_description/urdf/panda.urdf", False),
          "go2": ("go2_description/urdf/go2.urdf", True),
          "g1": ("g1_description/urdf/g1_29dof_rev_1_0.urdf", True)}
# DYN_KERNEL_MIN_PAIRS per function: k = the kernel for all three, s = straight-line for all three,
# h = the kernel for mass_matrix only, c = the compiler's own choice (its thresholds as they are)
VARIANTS = {"k": (0, 0, 0), "s": (10 ** 9,) * 3, "h": (0, 10 ** 9, 10 ** 9), "c": None}
FUNCS = ("mass_matrix", "forcing", "inverse_dynamics")
NS = 32


def system_of(case, work):
    """(system, compile keyword arguments) of one case."""
    if case.startswith("cart"):
        import runpy
        import warnings
        os.environ["EOMC_N_LINKS"] = case[4:]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            mod = runpy.run_path(str(HERE / "tree_models" / "cart_rel_joints.py"))
        return mod["system"], dict(parameters=mod["parameters"], inputs=mod["inputs"])
    from eomc.compiler.urdf import from_urdf
    if case.startswith("chain"):
        from bench_urdf_build import chain_text
        path = Path(work) / f"{case}.urdf"
        path.write_text(chain_text(int(case[5:])))
        return from_urdf(str(path)), {}
    from helpers.robots import robot_path
    rel, floating = ROBOTS[case]
    return from_urdf(robot_path(rel), floating_base=floating, limits=False), {}


def build_one(case, variant, work):
    """Child process: one default build; prints JSON of its CPU, C sizes and paths."""
    import warnings
    import eomc
    from eomc.compiler.tree import lower
    if VARIANTS[variant] is not None:
        lower.DYN_KERNEL_MIN_PAIRS = dict(zip(FUNCS, VARIANTS[variant]))
    choose, seen = lower.dynamics_kernel_functions, []
    lower.dynamics_kernel_functions = lambda plan, fns: seen.append(sum(plan.dep) + plan.nd) or choose(plan, fns)
    system, kw = system_of(case, work)
    name = f"{case}_{variant}"
    r0 = resource.getrusage(resource.RUSAGE_SELF)
    c0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(system, name, formulation="recursive", cache_dir=Path(work) / f"cache_{name}",
                             progress=False, **kw)
    r1 = resource.getrusage(resource.RUSAGE_SELF)
    c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (r1.ru_utime + r1.ru_stime - r0.ru_utime - r0.ru_stime
           + c1.ru_utime + c1.ru_stime - c0.ru_utime - c0.ru_stime)
    src = Path(model.source_path).read_text()
    print(json.dumps(dict(cpu=cpu, size=kernel_bytes(src, name), total=len(src), c=str(model.source_path),
                          dir=str(model.directory), nx=model.nx, nu=model.nu, np=len(model.param_defaults),
                          p=[float(v) for v in model.param_defaults], nr=model.ninput,
                          kernel=[f for f in FUNCS if f"{name}_dyn(an, " in _body(src, f"{name}_{f}")], pairs=seen[0] if seen else None)))


_DEF = re.compile(r"^(?:static )?(?:inline )?(?:EOMC_NOINLINE )?(?:int|void|double) (\w+)\(", re.M)


def _body(src, fn):
    """The C text of function ``fn`` (to its closing brace at column 0)."""
    i = src.find(f"int {fn}(")
    return src[i:src.find("\n}", i)] if i >= 0 else ""


def kernel_bytes(src, name):
    """Bytes of C of the three functions, their parts and what only they use."""
    marks = [(m.start(), m.group(1)) for m in _DEF.finditer(src)] + [(len(src), None)]
    own = tuple(f"{name}_{f}" for f in FUNCS) + (f"{name}_dyn",)
    return sum(end - start for (start, fn), (end, _) in zip(marks, marks[1:]) if fn.startswith(own))


HARNESS = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <math.h>
#include <time.h>
#include "@K@.h"
#include "@S@.h"
#define NS @NS@
#define NX @NX@
#define NU @NU@
static const double X[NS][NX] = {@X@};
static const double UD[NS][NU] = {@UD@};
static const double P[] = {@P@};
static const double R[] = {@R@};
static double out[6][NU * NU];
static double tnow(void) { struct timespec ts; clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return ts.tv_sec * 1e9 + ts.tv_nsec; }
static void call(int c, int i) {
    switch (c) {
    case 0: @K@_mass_matrix(0.0, X[i], P, R, out[0], NULL); break;
    case 1: @S@_mass_matrix(0.0, X[i], P, R, out[1], NULL); break;
    case 2: @K@_forcing(0.0, X[i], P, R, out[2], NULL); break;
    case 3: @S@_forcing(0.0, X[i], P, R, out[3], NULL); break;
    case 4: @K@_inverse_dynamics(0.0, X[i], UD[i], P, R, out[4], NULL); break;
    case 5: @S@_inverse_dynamics(0.0, X[i], UD[i], P, R, out[5], NULL); break;
    }
}
int main(void) {
    int i, k, c, round;
    double sum = 0.0, d[3] = {0, 0, 0}, s[3] = {0, 0, 0};
    for (i = 0; i < NS; i++) {
        for (c = 0; c < 6; c++) call(c, i);
        for (c = 0; c < 3; c++) {
            int n = c == 0 ? NU * NU : NU;
            for (k = 0; k < n; k++) {
                double a = fabs(out[2 * c][k] - out[2 * c + 1][k]), b = fabs(out[2 * c + 1][k]);
                if (a > d[c]) d[c] = a;
                if (b > s[c]) s[c] = b;
            }
        }
    }
    printf("agree %.3g %.3g %.3g\n", d[0] / s[0], d[1] / s[1], d[2] / s[2]);
    for (round = 0; round < @ROUNDS@; round++) {
        for (c = 0; c < 6; c++) {
            int cc = (c + round) % 6; long calls = 0; double t0 = tnow(), t1;
            do { for (i = 0; i < NS; i++) { call(cc, i); sum += out[cc][0]; } calls += NS; t1 = tnow(); }
            while (t1 - t0 < 2e7);
            printf("time %d %.1f\n", cc, (t1 - t0) / calls);
        }
    }
    printf("checksum %g\n", sum);
    return 0;
}
"""


def c_array(a):
    return ", ".join("{" + ", ".join(repr(float(v)) for v in row) + "}" for row in a)


def harness(case, va, vb, k, s, work, rounds, rng):
    nx, nu = k["nx"], k["nu"]
    X = rng.uniform(-1.0, 1.0, (NS, nx))
    UD = rng.uniform(-1.0, 1.0, (NS, nu))
    src = (HARNESS.replace("@K@", f"{case}_{va}").replace("@S@", f"{case}_{vb}").replace("@NS@", str(NS))
           .replace("@NX@", str(nx)).replace("@NU@", str(nu)).replace("@ROUNDS@", str(rounds))
           .replace("@X@", c_array(X)).replace("@UD@", c_array(UD))
           .replace("@P@", ", ".join(repr(v) for v in k["p"]) or "0.0")
           .replace("@R@", ", ".join("0.0" for _ in range(max(k["nr"], 1)))))
    h = Path(work) / f"h_{case}.c"
    h.write_text(src)
    objs = []
    for c, inc in ((h, [k["dir"], s["dir"]]), (Path(k["c"]), [k["dir"]]), (Path(s["c"]), [s["dir"]])):
        o = c.with_suffix(".bench.o")
        subprocess.run(["gcc", "-O2", "-std=c99", *[f"-I{d}" for d in inc], f"-I{ROOT / 'runtime' / 'c'}", "-c",
                        str(c), "-o", str(o)], check=True)
        objs.append(str(o))
    exe = Path(work) / f"h_{case}"
    subprocess.run(["gcc", *objs, "-o", str(exe), "-lm"], check=True)
    out = subprocess.run(["taskset", "-c", "1", str(exe)], capture_output=True, text=True, check=True).stdout
    agree = [float(v) for v in out.splitlines()[0].split()[1:]]
    times = {}
    for line in out.splitlines():
        if line.startswith("time"):
            _, c, v = line.split()
            times.setdefault(int(c), []).append(float(v))
    return {c: float(np.median(v)) for c, v in times.items()}, agree


def header(rounds):
    from bench_derivatives import checkout_state
    commit, dirty, cpu = checkout_state()
    load = os.getloadavg()
    return (f"\n## {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC — commit {commit}"
            f"{' + uncommitted ' + dirty if dirty else ''}\n\n"
            f"{cpu}; load {load[0]:.1f}/{load[1]:.1f}/{load[2]:.1f}; Python {platform.python_version()}; "
            f"gcc -O2; taskset -c 1, thread CPU, 6 contestants interleaved, ~20 ms blocks, median of {rounds} "
            "rounds; ns per call, A / B (A / B as a ratio). Builds: k = the loop kernel NAME_dyn for all three, s = the "
            "straight-line recursions for all three, h = the kernel for mass_matrix only, c = the compiler's choice "
            "(DYN_KERNEL_MIN_PAIRS as committed); build = CPU s of a "
            "default build (eomc.compile, gcc included); C = kB of C of the three functions and what only "
            "they use. `pairs` = entries of M's triangle (dofs x support), the compiler's threshold measure.\n\n"
            "| model | A / B | nx | pairs | mass_matrix ns | forcing ns | inverse_dynamics ns | "
            "build CPU s | C kB | agree |\n|---|---|--:|--:|--:|--:|--:|--:|--:|--:|\n")


def row(r):
    t = r["times"]
    cells = [f"{t[2 * i]:.0f} / {t[2 * i + 1]:.0f} ({t[2 * i] / t[2 * i + 1]:.2f})" for i in range(3)]
    return (f"| {r['case']} | {r['va']} / {r['vb']} | {r['nx']} | {r['pairs']} | " + " | ".join(cells)
            + f" | {r['a']['cpu']:.1f} / {r['b']['cpu']:.1f} | {r['a']['size'] / 1e3:.0f} / {r['b']['size'] / 1e3:.0f}"
            + f" | {max(r['agree']):.1e} |")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--cases", default="cart4,cart20,cart80,ur10,panda,go2,g1,chain200")
    ap.add_argument("--rounds", type=int, default=9)
    ap.add_argument("--variants", default="k,s", help="the two builds compared: k (the kernel for all three), "
                    "s (straight-line for all three), h (the kernel for mass_matrix only), c (the compiler's choice)")
    ap.add_argument("--write", action="store_true")
    ap.add_argument("--build-one", nargs=3, help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.build_one:
        return build_one(*a.build_one)
    va, vb = a.variants.split(",")
    work = Path(tempfile.mkdtemp(prefix="eomc_bdk_"))
    rng = np.random.default_rng(30)
    rows = []
    for case in filter(None, a.cases.split(",")):
        built = {}
        for v in (va, vb):
            p = subprocess.run([sys.executable, __file__, "--build-one", case, v, str(work)], capture_output=True,
                               text=True)
            if p.returncode:
                sys.exit(f"{case} ({v}) did not build: {p.stderr.strip()[-800:]}")
            built[v] = json.loads(p.stdout.strip().splitlines()[-1])
        times, agree = harness(case, va, vb, built[va], built[vb], work, a.rounds, rng)
        r = dict(case=case, nx=built[va]["nx"], pairs=built[va]["pairs"] or "-", times=times, agree=agree,
                 a=built[va], b=built[vb], va=va, vb=vb)
        rows.append(r)
        if a.write:
            with open(HERE / "results" / "dynamics_kernel.md", "a") as f:
                f.write((header(a.rounds) if len(rows) == 1 else "") + row(r) + "\n")
        print(row(r), f"(kernel in {va}: {built[va]['kernel']}, in {vb}: {built[vb]['kernel']})", flush=True)
    print(header(a.rounds) + "".join(row(r) + "\n" for r in rows))


if __name__ == "__main__":
    main()
