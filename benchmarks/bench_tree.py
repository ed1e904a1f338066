"""Issue 8: the recursive formulation vs Kane's on the relative-coordinate n-link cart.

For each n: a cold build (fresh cache; derive + generate + gcc, rhs only, literal
parameters) in a child process, timed in CPU seconds (user+sys of the child) and
wall; then one C harness per n linking both generated rhs functions, timed in
thread CPU time, contestants interleaved, pinned to core 1, median of rounds.
  kane:      benchmarks/tree_models/cart_rel_kane.py (hand-built frames, sum-of-angles,
             the performance report's n_link_cart_rel.py), --formulation kane
  recursive: benchmarks/tree_models/cart_rel_joints.py (SymPy System of joints, no
             form_eoms), --formulation recursive
Same states (q0..qn relative, u = q'), same parameters; the harness checks the two
rhs agree before timing.  Peers (MuJoCo, Pinocchio) are not built here.
Usage: python benchmarks/bench_tree.py [n ...] [--kane-max N]
"""
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
MODELS = HERE / "tree_models"
ROOT = HERE.parent
EOMC = [sys.executable, "-m", "eomc"]

HARNESS = r"""
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
@INCLUDES@
static double tnow(void) { struct timespec ts; clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return ts.tv_sec * 1e9 + ts.tv_nsec; }
static unsigned long long s = 0x9E3779B97F4A7C15ULL;
static double rnd(void) { unsigned long long z = (s += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL; z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    z ^= z >> 31; return (z >> 11) * (1.0 / 9007199254740992.0); }
#define NS 1024
int main(void) {
    const int nx = @NX@, nq = @NQ@, nc = @NC@;
    static double X[NS][@NX@], out[@NX@], ref[@NX@];
    double r[1] = {1.3}, worst = 0.0, sum = 0.0;
    int i, k, c, round;
    for (i = 0; i < NS; i++) for (k = 0; k < nx; k++)
        X[i][k] = k < nq ? (k == 0 ? 2 * rnd() - 1 : 3.14159265358979 * (2 * rnd() - 1)) : 2 * rnd() - 1;
    for (i = 0; i < 64; i++) {
        @FIRST@(0.0, X[i], NULL, r, ref, NULL);
        for (c = 1; c < nc; c++) {
            @CALLC@
            for (k = 0; k < nx; k++) { double d = fabs(out[k] - ref[k]) / (fabs(ref[k]) > 1 ? fabs(ref[k]) : 1);
                if (d > worst) worst = d; }
        }
    }
    printf("agree %.3g\n", worst);
    for (round = 0; round < @ROUNDS@; round++) {
        for (c = 0; c < nc; c++) {
            int cc = (c + round) % nc; long calls = 0; double t0 = tnow(), t1;
            do { for (i = 0; i < NS; i++) { @CALL@ sum += out[nq]; } calls += NS; t1 = tnow(); }
            while (t1 - t0 < 2e7);
            printf("time %d %.2f\n", cc, (t1 - t0) / calls);
        }
    }
    printf("checksum %g\n", sum);
    return 0;
}
"""


def cold_build(model, n, formulation, outdir):
    env = dict(os.environ, EOMC_N_LINKS=str(n), EOMC_CACHE_DIR=tempfile.mkdtemp(prefix="eomc_tb_"))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(EOMC + ["build", str(model), "-o", str(outdir), "--fold-parameters",
                                  "--outputs", "rhs", "--formulation", formulation, "-q"],
                          env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode:
        raise RuntimeError(proc.stderr)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    meta = json.loads(next(outdir.glob("*.json")).read_text())
    return cpu, wall, meta, (after.ru_maxrss) / 1024


def timing(builds, n, tmp, rounds):
    nx, nq = 2 * (n + 1), n + 1
    incs = "\n".join(f'#include "{d}/{m["name"]}.c"' for d, m in builds)
    names = [m["name"] for _, m in builds]
    call = "switch (cc) {" + " ".join(f"case {k}: {nm}_rhs(0.0, X[i], NULL, r, out, NULL); break;"
                                      for k, nm in enumerate(names)) + "}"
    callc = "switch (c) {" + " ".join(f"case {k}: {nm}_rhs(0.0, X[i], NULL, r, out, NULL); break;"
                                      for k, nm in enumerate(names)) + "}"
    src = (HARNESS.replace("@INCLUDES@", incs).replace("@NX@", str(nx)).replace("@NQ@", str(nq))
           .replace("@NC@", str(len(names))).replace("@FIRST@", f"{names[0]}_rhs")
           .replace("@CALLC@", callc).replace("@CALL@", call).replace("@ROUNDS@", str(rounds)))
    c = tmp / f"h{n}.c"
    c.write_text(src)
    exe = tmp / f"h{n}"
    inc = [f"-I{d}" for d, _ in builds] + [f"-I{ROOT / 'runtime' / 'c'}"]
    subprocess.run(["gcc", "-O2", "-std=c99", *inc, str(c), "-o", str(exe), "-lm"], check=True)
    out = subprocess.run(["taskset", "-c", "1", str(exe)], capture_output=True, text=True, check=True).stdout
    agree = float(out.split("agree ")[1].split()[0])
    times = {}
    for line in out.splitlines():
        if line.startswith("time"):
            _, k, v = line.split()
            times.setdefault(int(k), []).append(float(v))
    med = {k: sorted(v)[len(v) // 2] for k, v in times.items()}
    return agree, med


def main(argv):
    kane_max = 20
    if "--kane-max" in argv:
        i = argv.index("--kane-max")
        kane_max = int(argv[i + 1])
        argv = argv[:i] + argv[i + 2:]
    ns = [int(a) for a in argv] or [4, 8, 12, 20, 40, 80]
    tmp = Path(tempfile.mkdtemp(prefix="bench_tree_"))
    rows = []
    for n in ns:
        builds, cells = [], {}
        for label, model, form in (("recursive", MODELS / "cart_rel_joints.py", "recursive"),
                                   ("kane", MODELS / "cart_rel_kane.py", "kane")):
            if label == "kane" and n > kane_max:
                continue
            out = tmp / f"{label}{n}"
            cpu, wall, meta, rss = cold_build(model, n, form, out)
            ops = sum(meta["op_counts"]["rhs"].values())
            cells[label] = {"cpu": cpu, "wall": wall, "ops": ops}
            builds.append((out, meta))
            print(f"n={n} {label}: build {cpu:.2f} s CPU ({wall:.2f} s wall), rhs ops {ops}", flush=True)
        agree, med = timing(builds, n, tmp, rounds=7)
        for k, (_, meta) in enumerate(builds):
            label = "recursive" if meta["name"].startswith("cartjoints") else "kane"
            cells[label]["ns"] = med[k]
        print(f"n={n}: agree {agree:.2g}; " + ", ".join(f"{k} {v['ns']:.0f} ns" for k, v in cells.items()),
              flush=True)
        rows.append((n, cells, agree))
    print("\n| n | recursive ops | kane ops | recursive rhs ns | kane rhs ns | kane/recursive | "
          "recursive build CPU s (wall) | kane build CPU s (wall) | agreement |")
    print("|--:|--:|--:|--:|--:|--:|--:|--:|--:|")
    for n, cells, agree in rows:
        r, k = cells["recursive"], cells.get("kane")
        print(f"| {n} | {r['ops']} | {k['ops'] if k else '-'} | {r['ns']:.0f} | "
              f"{k['ns']:.0f} | {k['ns'] / r['ns']:.2f} | " if k else
              f"| {n} | {r['ops']} | - | {r['ns']:.0f} | - | - | ", end="")
        print(f"{r['cpu']:.2f} ({r['wall']:.2f}) | " + (f"{k['cpu']:.2f} ({k['wall']:.2f})" if k else "-")
              + f" | {agree:.1e} |")


if __name__ == "__main__":
    main(sys.argv[1:])
