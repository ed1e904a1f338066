"""NAME_energy and NAME_poses as loops over the bodies (compiler/tree/body_loops.py) against the
straight-line functions of another checkout (``--before PYTHON``: main's venv), interleaved in one run.

Per robot (example-robot-data, floating base, limits on as by default; G1 and Talos full body by
default), ``--repeat`` rounds, each contestant in turn:

- Python: a fresh child derives and generates the default function set without the generation
  cache (bench_derivative_build's phases child: the driver's stage timer read as CPU time);
- gcc: ``cc -c`` of each contestant's NAME.c with the library's flags (user + sys of the child);
- per call: both libraries (``cc -shared`` of the same C) loaded into one C harness, which times
  NAME_energy and NAME_poses in turn on 16 seeded random states (thread CPU time, ``--calls``
  passes of the 16 a round), and checks the two contestants' values: the energy's largest difference
  in units of |E|'s ulp, the poses' in ulp of max(|value|, 1).

    python benchmarks/bench_body_loops.py --before /work/venvs/main/bin/python [--robots g1,talos]
        [--repeat 3] [--calls 2000]
Medians; the load is printed beside the table.
"""
import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "tests"))

from bench_derivative_build import ROBOTS, gcc_cpu, library_flags, phases  # noqa: E402
from helpers.robots import robot_path  # noqa: E402

HARNESS = r"""
#include <dlfcn.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
typedef int (*fn_t)(double, const double *, const double *, const double *, double *, double *);
static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}
static int cmp(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}
/* argv: data.bin name fn size rounds calls lib... ; data: nx np nr (as doubles), 16 states, p, r */
int main(int argc, char **argv)
{
    FILE *f = fopen(argv[1], "rb");
    double head[3];
    int nx, np, nr, size = atoi(argv[4]), rounds = atoi(argv[5]), calls = atoi(argv[6]), nlib = argc - 7;
    int i, c, k, s;
    if (!f || fread(head, sizeof(double), 3, f) != 3) return 2;
    nx = (int)head[0]; np = (int)head[1]; nr = (int)head[2];
    double *X = malloc(sizeof(double) * 16 * nx), *p = malloc(sizeof(double) * (np + 1)),
           *r = malloc(sizeof(double) * (nr + 1)), *out = malloc(sizeof(double) * size * 16 * nlib);
    if (fread(X, sizeof(double), 16 * nx, f) != (size_t)(16 * nx) || fread(p, sizeof(double), np, f) != (size_t)np
        || fread(r, sizeof(double), nr, f) != (size_t)nr) return 3;
    fclose(f);
    fn_t fn[8];
    char sym[256];
    snprintf(sym, sizeof sym, "%s_%s", argv[2], argv[3]);
    for (c = 0; c < nlib; c++) {
        void *h = dlopen(argv[7 + c], RTLD_NOW | RTLD_LOCAL);
        if (!h) { fprintf(stderr, "%s\n", dlerror()); return 4; }
        fn[c] = (fn_t)dlsym(h, sym);
        if (!fn[c]) return 5;
        for (s = 0; s < 16; s++)
            if (fn[c](0.0, X + s * nx, p, r, out + (c * 16 + s) * size, NULL)) return 6;
    }
    double *t = malloc(sizeof(double) * rounds * nlib);
    for (k = 0; k < rounds; k++)
        for (c = 0; c < nlib; c++) {
            double t0 = now();
            for (i = 0; i < calls; i++)
                for (s = 0; s < 16; s++) fn[c](0.0, X + s * nx, p, r, out + (c * 16 + s) * size, NULL);
            t[c * rounds + k] = (now() - t0) / (calls * 16.0) * 1e9;
        }
    for (c = 0; c < nlib; c++) {
        qsort(t + c * rounds, rounds, sizeof(double), cmp);
        printf("%.1f %.1f\n", t[c * rounds + rounds / 2], t[c * rounds]);
    }
    double worst = 0.0;     /* contestants 1.. against 0, in ulp of max(|value|, 1) */
    for (c = 1; c < nlib; c++)
        for (i = 0; i < 16 * size; i++) {
            double a = out[i], b = out[c * 16 * size + i], sc = fabs(a) > 1.0 ? fabs(a) : 1.0;
            if (size == 1) sc = fabs(a);
            double d = fabs(a - b) / (sc * 2.220446049250313e-16);
            if (d > worst) worst = d;
        }
    printf("%.2f\n", worst);
    return 0;
}
"""


def harness(work):
    from eomc.compiler.build.toolchain import find_compiler
    src, exe = work / "harness.c", work / "harness"
    src.write_text(HARNESS)
    subprocess.run([*find_compiler().argv, "-O2", str(src), "-o", str(exe), "-ldl", "-lm"], check=True)
    return exe


def shared(c_path, flags):
    """The library of one NAME.c (beside its NAME.h and the shipped headers)."""
    from eomc.compiler.build.toolchain import find_compiler
    lib = c_path.with_suffix(".so")
    subprocess.run([*find_compiler().argv, *flags, "-shared", "-fPIC", c_path.name, "-o", lib.name, "-lm"],
                   cwd=c_path.parent, check=True, capture_output=True)
    return lib


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--before", required=True, help="the Python of the other checkout (main's venv)")
    ap.add_argument("--robots", default="g1,talos")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--calls", type=int, default=2000)
    ap.add_argument("--rounds", type=int, default=15)
    a = ap.parse_args()
    import numpy as np
    from eomc.compiler.build.builder import SHIPPED_HEADERS, shipped_c_dir
    work = Path(tempfile.mkdtemp(prefix="eomc_bbl_"))
    exe = harness(work)
    print(f"load at start {os.getloadavg()[0]:.2f}", flush=True)
    rows = []
    for key in filter(None, a.robots.split(",")):
        rel, fb = ROBOTS[key]
        args = [str(robot_path(rel))] + (["--floating-base"] if fb else [])
        py = {"before": [], "after": []}
        for kind in py:
            (work / key / kind).mkdir(parents=True)
            for n in SHIPPED_HEADERS:
                (work / key / kind / n).write_bytes((shipped_c_dir() / n).read_bytes())
        for _ in range(a.repeat):
            for kind in ("before", "after"):
                env = dict(os.environ, EOMC_CACHE_DIR=tempfile.mkdtemp(prefix="eomc_bblc_"))
                py[kind].append(phases(args + [f"--c-out={work / key / kind / 'model.c'}"], env,
                                       a.before if kind == "before" else None))
        if any(r["err"] for k in py for r in py[k]):
            print(f"| {key} | {[r['err'] for k in py for r in py[k] if r['err']][0]} |")
            continue
        text = (work / key / "after" / "model.c").read_text()
        name = re.search(r'^#include "(\w+)\.h"', text, re.M).group(1)
        paths = {}
        for kind in py:
            d = work / key / kind
            (d / "model.h").replace(d / f"{name}.h")
            (d / "model.c").replace(d / f"{name}.c")
            paths[kind] = d / f"{name}.c"
        flags = library_flags(text)
        gcc = {k: [] for k in py}
        for _ in range(a.repeat):
            for kind in py:
                gcc[kind].append(gcc_cpu(paths[kind], flags))
        libs = {k: shared(paths[k], flags) for k in py}
        from eomc.cli.common import with_options
        from eomc.compiler.driver import generate
        spec, g = generate(*with_options(args[0], None, floating_base=fb), use_cache=True)
        meta = g.metadata
        nx, npar, nr = meta["nx"], len(meta["param_names"]), len(meta.get("input_names") or [])
        rng = np.random.default_rng(2026)
        X = rng.normal(size=(16, nx)) * np.where(np.arange(16) < 8, 0.3, 1.5)[:, None]
        data = np.concatenate([[nx, npar, nr], X.ravel(), np.asarray(meta["param_defaults"], float),
                               np.zeros(nr)])
        (work / key / "data.bin").write_bytes(data.astype(np.float64).tobytes())
        calls = {}
        for fn, size in (("energy", 1), ("poses", meta["poses"]["size"])):
            res = subprocess.run(["taskset", "-c", os.environ.get("BENCH_CORE", "0"), str(exe), str(work / key / "data.bin"),
                                  name, fn, str(size), str(a.rounds), str(a.calls), str(libs["before"]),
                                  str(libs["after"])], capture_output=True, text=True, check=True).stdout.split()
            calls[fn] = [float(v) for v in res]
        m = {k: statistics.median(v) for k, v in gcc.items()}
        gen = {k: statistics.median(r["generate"] for r in py[k]) for k in py}
        der = {k: statistics.median(r["derive"] for r in py[k]) for k in py}
        e, pz = calls["energy"], calls["poses"]
        rows.append(f"| {key} | {gen['before']:.2f} | {gen['after']:.2f} | {gen['after'] - gen['before']:+.2f} | "
                    f"{m['before']:.2f} | {m['after']:.2f} | {m['after'] - m['before']:+.2f} | "
                    f"{os.path.getsize(paths['before']) / 1e3:.0f} / {os.path.getsize(paths['after']) / 1e3:.0f} | "
                    f"{e[0]:.0f} / {e[2]:.0f} ({e[2] / e[0]:.2f}x) | {pz[0]:.0f} / {pz[2]:.0f} ({pz[2] / pz[0]:.2f}x) | "
                    f"{e[4]:.1f} / {pz[4]:.1f} |")
        print(rows[-1], flush=True)
        print(f"  ({key}: derive before/after {der['before']:.2f} / {der['after']:.2f}; generate each run: before "
              + " / ".join(f"{r['generate']:.2f}" for r in py["before"]) + "; after "
              + " / ".join(f"{r['generate']:.2f}" for r in py["after"]) + "; gcc each run: before "
              + " / ".join(f"{x:.2f}" for x in gcc["before"]) + "; after " + " / ".join(f"{x:.2f}" for x in gcc["after"])
              + f"; load now {os.getloadavg()[0]:.2f})", flush=True)
    print()
    print("| robot | generate CPU s before | after | change | gcc -c s before | after | change | C kB before / after | "
          "energy ns per call before / after | poses ns before / after | after vs before: energy ulp of |E| / "
          "poses ulp |")
    print("|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|")
    print("\n".join(rows))


if __name__ == "__main__":
    main()
