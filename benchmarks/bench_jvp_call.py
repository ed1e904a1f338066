"""One NAME_jvp call in C: k directions in one call (lanes), the same without lanes, k calls.

    python benchmarks/bench_jvp_call.py [--n 8] [--out]

Why: forward sensitivities pay one jvp call per stage (DOP853) or per stage and iteration
(Radau's staggered step) for all k columns.  jvp computes the primal (A, b, the factor) once
per call and then each direction's tangent, parameter column and solve; the tangent runs
four directions at a time (compiler/emit/bodies.lane_directions).  This measures, on the
n-link cart (Kane, the sensitivity benchmarks' model), per call: rhs; jvp with k = 1, 4, 18
sensitivity directions [S_j; e_j] in one call, built as shipped (lanes) and with the
per-direction loop the lanes replaced (the "scalar" build: lane_directions patched to the
old loop); and k separate one-direction calls (each redoing the primal).  A C harness linked
with each build's .c calls at 512 states along the model's own 10 s run, thread CPU, best of
7, both binaries pinned to core 1 and alternated, 3 rounds.  The builds' outputs are
compared at those states (bit for bit).
"""
import argparse
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import environment_header, format_table, write_results  # noqa: E402
import models  # noqa: E402

KS = (1, 4, 18)


def build(n, cache, scalar=False):
    import eomc.compiler.emit.bodies as bodies
    shipped = bodies.lane_directions
    if scalar:
        def per_direction(pr, seeds, nx, nd, tangents, ng, kin, body, tail):
            ind = bodies.IND
            lines = [f"{ind}for (d = 0; d < k; d++) {{", f"{ind * 2}dx = dirs + (size_t)d * {nd};"]
            return [], lines + [ind * 2 + x for x in kin + body + tail] + [f"{ind}}}"]
        bodies.lane_directions = per_direction
    try:
        from bench_sensitivity import build as sens_build
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return sens_build_in(sens_build, n, Path(cache) / ("scalar" if scalar else "lanes"))
    finally:
        bodies.lane_directions = shipped


def sens_build_in(sens_build, n, cache):
    """bench_sensitivity's model, in its own cache directory (the two builds differ)."""
    import eomc
    compile_ = eomc.compile
    eomc.compile = lambda *a, **kw: compile_(*a, cache_dir=cache, progress=False, **kw)
    try:
        return sens_build(n)
    finally:
        eomc.compile = compile_


HARNESS = """#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <string.h>
#include <time.h>
#include "model.h"
#define NS {ns}
static const double X[NS][{nx}] = {{{X}}};
static const double P[] = {{{P}}};
static double R[{nr}];
static double D[{kmax}][{nd}], XD[{nx}], OUT[{kmax}][{nx}];
static double W[MODEL_WORK_LEN];
static double now(void) {{ struct timespec a; clock_gettime(CLOCK_THREAD_CPUTIME_ID, &a); return a.tv_sec * 1e9 + a.tv_nsec; }}
int main(void) {{
    static const int ks[] = {{{ks}}};
    double best[1 + 2 * {nk}], t; int rep, i, s, a, j, st = 0;
    for (i = 0; i < 1 + 2 * {nk}; i++) best[i] = 1e30;
    for (j = 0; j < {kmax}; j++) {{
        for (i = 0; i < {nx}; i++) D[j][i] = 0.01 * (i + 1) * (j + 1);
        D[j][{nx} + j % {np}] = 1.0;
    }}
    for (rep = 0; rep < 7; rep++) {{
        t = now();
        for (i = 0; i < {reps}; i++) for (s = 0; s < NS; s++) st |= model_rhs(0.0, X[s], P, R, XD, W);
        t = (now() - t) / ({reps} * NS); if (t < best[0]) best[0] = t;
        for (a = 0; a < {nk}; a++) {{
            t = now();
            for (i = 0; i < {reps}; i++) for (s = 0; s < NS; s++) st |= model_jvp(0.0, X[s], P, R, ks[a], &D[0][0], XD, &OUT[0][0], W);
            t = (now() - t) / ({reps} * NS); if (t < best[1 + a]) best[1 + a] = t;
            t = now();
            for (i = 0; i < {reps}; i++) for (s = 0; s < NS; s++)
                for (j = 0; j < ks[a]; j++) st |= model_jvp(0.0, X[s], P, R, 1, D[j], XD, OUT[j], W);
            t = (now() - t) / ({reps} * NS); if (t < best[1 + {nk} + a]) best[1 + {nk} + a] = t;
        }}
    }}
    for (i = 0; i < 1 + 2 * {nk}; i++) printf("%.1f ", best[i]);
    printf("%d\\n", st);
    return 0;
}}
"""


def outputs(model, X, k):
    nx, npar = model.nx, model.nparam
    D = np.zeros((k, nx + npar))
    for j in range(k):
        D[j, :nx] = 0.01 * (np.arange(nx) + 1) * (j + 1)
        D[j, nx + j % npar] = 1.0
    return np.array([model.jvp(0.0, x, D)[1] for x in X])


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=8)
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args(argv)
    rows, csv_rows = [], []
    with tempfile.TemporaryDirectory() as tmp:
        builds = {tag: build(args.n, tmp, scalar=tag == "scalar") for tag in ("scalar", "lanes")}
        model = builds["lanes"]
        run = model.simulate(models.initial_state(args.n), (0.0, 10.0), t_eval=np.linspace(0, 10, 512),
                             method="dop853", rtol=1e-8, atol=1e-8)
        X = run.x
        same = all(np.array_equal(outputs(builds["scalar"], X[::16], k), outputs(model, X[::16], k)) for k in KS)
        fmt = lambda v: ",".join(repr(float(x)) for x in v)  # noqa: E731
        exes = {}
        for tag, m in builds.items():
            c = Path(m.directory) / "model.c"
            h = Path(tmp) / f"h_{tag}.c"
            h.write_text(HARNESS.format(ns=len(X), nx=m.nx, nd=m.nx + m.nparam, np=m.nparam, kmax=max(KS),
                                        X=",".join("{" + fmt(x) + "}" for x in X), P=fmt(m.param_defaults),
                                        nr=max(1, m.ninput), ks=",".join(map(str, KS)), nk=len(KS), reps=40))
            exe = Path(tmp) / f"h_{tag}"
            subprocess.run(["cc", "-O2", "-std=c99", "-I", str(c.parent), str(h), str(c), "-lm", "-o", str(exe)],
                           check=True)
            exes[tag] = exe
        best = {tag: None for tag in exes}
        for _ in range(3):
            for tag, exe in exes.items():
                out = subprocess.run(["taskset", "-c", "1", str(exe)], capture_output=True, text=True,
                                     check=True).stdout.split()
                assert out[-1] == "0", f"{tag}: status {out[-1]}"
                v = np.array([float(x) for x in out[:-1]])
                best[tag] = v if best[tag] is None else np.minimum(best[tag], v)
    nk = len(KS)
    rhs = min(best["scalar"][0], best["lanes"][0])
    for a, k in enumerate(KS):
        lanes, scalar, calls = best["lanes"][1 + a], best["scalar"][1 + a], best["lanes"][1 + nk + a]
        rows.append([str(args.n), str(k), f"{rhs:.0f}", f"{calls:.0f}", f"{scalar:.0f}", f"{lanes:.0f}",
                     f"{lanes / rhs:.2f}", f"{(lanes - rhs) / k / rhs:.2f}", f"{scalar / lanes:.2f}",
                     f"{calls / lanes:.2f}"])
        csv_rows.append([args.n, k, rhs, calls, scalar, lanes])
    headers = ["n", "k", "rhs ns", "k calls of one direction ns", "one call, no lanes ns", "one call, lanes ns",
               "lanes / rhs", "per direction / rhs", "no lanes / lanes", "k calls / lanes"]
    table = format_table(headers, rows)
    print(table)
    print(f"outputs of the two builds bit for bit equal: {same}")
    if not args.no_write:
        text = environment_header("One NAME_jvp call in C, n-link cart (Kane)", args) + "\n" + table + \
            f"\n\nOutputs of the lanes and no-lanes builds bit for bit equal at 32 states, k = {KS}: {same}\n"
        write_results("jvp_call", text, csv_rows, ["n", "k", "rhs_ns", "k_calls_ns", "no_lanes_ns", "lanes_ns"])
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
