"""Issue 3 §8b: ns per call of the generated NAME_rhs, timed in a C loop.

For each n, eomc builds the n-link cart (rhs only, the build's own flags); a
small C harness (written here, compiled with gcc -O2) links the built
libNAME.so, fills NSTATES varied states (q in [-pi, pi], u in [-2, 2]) and
calls NAME_rhs over them NCALLS times per repeat; the median of the repeats
is reported.  A checksum of the outputs keeps the compiler from removing the
calls, and the harness's first output is compared with model.rhs from Python
so the harness is known to call the right thing.

The SD/FAST rows are QUOTED from issue 3 §8b (its generated code compiled with
gcc -O2 "on this kind of machine"), not measured here.
"""
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import (environment_header, format_table, median_iqr, parse_args,  # noqa: E402
                    ratio, write_results)
import models  # noqa: E402

DEFAULT_N = [4, 8, 12, 20]
NSTATES = 1000
NCALLS = 100_000
SDFAST = {4: 248, 8: 623, 12: 1540, 20: 3900}          # ns, quoted from issue 3 §8b
SDFAST_ON = {4: 221, 8: 509, 12: 933, 20: 1673}        # its O(n) mode, quoted

HARNESS = r"""
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "@NAME@.h"

static const double P[@NPARAM@] = {@PARAMS@};

static double now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

int main(int argc, char **argv) {
    const int nx = @NX@, nq = @NQ@, nstates = atoi(argv[1]);
    const long ncalls = atol(argv[2]);
    const int repeat = atoi(argv[3]);
    double *X = malloc(sizeof(double) * nx * nstates);
    double *xdot = malloc(sizeof(double) * nx);
    double *work = malloc(sizeof(double) * (@WORK@ + 1));
    double r[@NINPUT@ + 1] = {0.0};
    unsigned long long s = 88172645463325252ULL;
    for (int i = 0; i < nx * nstates; ++i) {      /* xorshift: reproducible states */
        s ^= s << 13; s ^= s >> 7; s ^= s << 17;
        double u01 = (double)(s >> 11) / 9007199254740992.0;
        X[i] = (i % nx < nq) ? (2.0 * u01 - 1.0) * 3.141592653589793 : (2.0 * u01 - 1.0) * 2.0;
    }
    if (@NAME@_rhs(0.0, X, P, r, xdot, work) != 0) { fprintf(stderr, "rhs failed\n"); return 2; }
    printf("first");
    for (int j = 0; j < nx; ++j) printf(" %.17g", xdot[j]);
    printf("\n");
    for (int j = 0; j < nx; ++j) printf("%s%.17g", j ? " " : "state0 ", X[j]);
    printf("\n");
    double checksum = 0.0;
    for (int k = 0; k < repeat; ++k) {
        double t0 = now();
        int st = 0;
        for (long i = 0; i < ncalls; ++i) {
            st |= @NAME@_rhs(0.0, X + (i % nstates) * nx, P, r, xdot, work);
            checksum += xdot[nx - 1];
        }
        double t1 = now();
        if (st) { fprintf(stderr, "rhs status %d\n", st); return 3; }
        printf("ns %.3f\n", 1e9 * (t1 - t0) / (double)ncalls);
    }
    printf("checksum %.17g\n", checksum);
    free(X); free(xdot); free(work);
    return 0;
}
"""


def build_harness(model, p, tmp):
    """Compile the harness against model's library; return the executable's path."""
    lib = Path(model.library_path)
    src = (HARNESS.replace("@NAME@", model.name).replace("@NX@", str(model.nx))
           .replace("@NQ@", str(model.nq)).replace("@NPARAM@", str(model.nparam))
           .replace("@NINPUT@", str(model.ninput)).replace("@WORK@", str(model.work_size))
           .replace("@PARAMS@", ", ".join(repr(float(v)) for v in p)))
    c = Path(tmp) / f"harness_{model.name}.c"
    exe = Path(tmp) / f"harness_{model.name}"
    c.write_text(src)
    libname = lib.name[3:-3]  # libNAME.so -> NAME
    cmd = ["gcc", "-O2", "-std=c99", str(c), f"-I{Path(model.header_path).parent}",
           f"-L{lib.parent}", f"-l{libname}", f"-Wl,-rpath,{lib.parent}", "-lm", "-o", str(exe)]
    subprocess.run(cmd, check=True, capture_output=True, text=True)
    return exe


def run_harness(exe, model, p, repeat):
    """(median ns, IQR ns); checks the harness's first output against model.rhs."""
    out = subprocess.run([str(exe), str(NSTATES), str(NCALLS), str(repeat)], check=True,
                         capture_output=True, text=True).stdout.splitlines()
    first = np.array([float(v) for v in out[0].split()[1:]])
    x0 = np.array([float(v) for v in out[1].split()[1:]])
    expect = model.rhs(0.0, x0, p, np.zeros(model.ninput))
    err = np.max(np.abs(first - expect)) / max(1.0, np.max(np.abs(expect)))
    if not err < 1e-12:
        raise AssertionError(f"C harness disagrees with model.rhs by {err:.3g}")
    ns = [float(line.split()[1]) for line in out if line.startswith("ns ")]
    med, q1, q3 = median_iqr(ns)
    return med, q3 - q1, min(ns)


def main(argv=None):
    args = parse_args(__doc__.splitlines()[0], DEFAULT_N, default_repeat=9, argv=argv)
    headers = ["n", "eomc rhs [ns]", "IQR [ns]", "best repeat [ns]", "ops (add+mul+div+call)", "adds", "muls",
               "divs", "calls", "ns/op", "SD/FAST [ns] (quoted)", "SD/FAST O(n) [ns] (quoted)",
               "SD/FAST / eomc", "goal"]
    rows, notes = [], []
    ok, why = models.eomc_status()
    with tempfile.TemporaryDirectory(prefix="bench_rhs_c_") as tmp:
        for n in args.n:
            if not ok:
                rows.append([n, None, None, None, None, None, None, None, None, None,
                             SDFAST.get(n), SDFAST_ON.get(n), None, "eomc n/a"])
                notes.append(f"n={n}: eomc: not available ({why})")
                continue
            model = models.eomc_compile(n, Path(tmp) / "cache", functions=["rhs"])
            p = models.eomc_p(model, n)
            ns, iqr, best = run_harness(build_harness(model, p, tmp), model, p, args.repeat)
            oc = model.metadata["op_counts"]["rhs"]
            ops = sum(oc.get(k, 0) for k in ("adds", "muls", "divs", "calls"))
            sd, sdo = SDFAST.get(n), SDFAST_ON.get(n)
            goal = "n/a"
            if sd is not None:
                met = ns <= sd and (n > 12 or ns <= sdo)
                goal = ("met" if met else "MISSED") + (" (<= both rows)" if n <= 12 else " (<= first row)")
            rows.append([n, ns, iqr, best, ops, oc.get("adds"), oc.get("muls"), oc.get("divs"),
                         oc.get("calls"), ns / ops, sd, sdo, ratio(sd, ns), goal])
            print(format_table(headers, [rows[-1]]).splitlines()[-1], flush=True)
    table = format_table(headers, rows)
    print(table)
    header = environment_header(
        "RHS cost in C, ns per call (issue 3 §8b)", args,
        notes=[f"eomc: median of {args.repeat} repeats of {NCALLS} calls cycling over {NSTATES} "
               "varied states; harness gcc -O2 linked to the built libNAME.so "
               "(library built with eomc's default flags)",
               "ops: model.metadata['op_counts']['rhs'] (adds+muls+divs+calls; calls are "
               "sin/cos/sqrt...); ns/op = ns per call / ops",
               "SD/FAST rows are QUOTED from issue 3 §8b, NOT measured here",
               "best repeat = fastest of the repeats: the least disturbed by other jobs on "
               "this shared machine (the SD/FAST figures were taken on a quiet one)",
               "goal: <= SD/FAST at every n <= 20 and <= its O(n) mode for n <= 12",
               *notes])
    if not args.no_write:
        paths = write_results("rhs_c", header + "\n" + table + "\n",
                              csv_rows=rows, csv_headers=headers)
        print("wrote", ", ".join(str(p) for p in paths))
    return 0


if __name__ == "__main__":
    sys.exit(main())
