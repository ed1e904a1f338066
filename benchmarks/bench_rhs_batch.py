"""Issue 31 item 1: states per second of NAME_rhs_batch (SIMD lanes) against the scalar rhs.

Per model, `eomc build MODEL --outputs rhs,rhs_batch` (child process, fresh cache, auto
formulation, parameters at run time); one C harness per lane width (-DEOMC_BATCH_LANES=4: AVX2,
=8: AVX-512F) links the model's C and times, in thread CPU time (CLOCK_THREAD_CPUTIME_ID),
pinned to one core (taskset -c CORE, --core, 0 unless told):

* scalar: NAME_rhs over 1024 states stored one after another (array of structures, the best
  case for the scalar call);
* batch: one NAME_rhs_batch call over the same 1024 states stored as columns (nx x 1024).

The harnesses are compiled with the flags eomc builds its libraries with on this machine
(-O2 -std=c99 and, on x86-64 with AVX2, compiler/build/toolchain.MACHINE_FLAGS: -mavx2
-ffp-contract=off), so the scalar rhs is the one a default build runs (the looped rhs's links'
sin and cos take their AVX2 lanes only under __AVX2__).  The scalar rhs is the batch build's
own NAME_rhs; the bench also builds the model with `--outputs rhs` (named s) and compares the two
NAME_rhs texts (column "scalar rhs": looped, limb routines or straight-line; "= rhs-only build" when
they agree).  Where they do not (until session 23 G1: a build with rhs_batch wrote no limb routines,
tree/limbs.py; now its lanes run them too), the harness links the rhs-only build too and times its
s_rhs as the scalar contestant, so the speed-up is always against the scalar rhs users get without
rhs_batch.

The two contestants alternate within a round, both executables alternate round by round, and
the table gives medians over rounds (the scalar column is the median of both harnesses'
scalar rounds: the same code).  Each harness first checks the batch against the scalar rhs on
all 1024 states (max relative difference, and the share of bit-identical values: sin/cos differ
within 1 ulp, the rest is the same arithmetic).

Models: the cart auto sees (benchmarks/tree_models/cart_rel_joints.py, n = 4, 20, 40), UR10
and Panda (fixed base), Go2 and G1 29-dof (--floating-base, --limits off).

Usage: python benchmarks/bench_rhs_batch.py [--rounds 9] [--core 0] [--write] [--function jac_x] [names...]
(--write: results/rhs_batch.md, keeping its hand-written notes)

--function jac_x: the same for NAME_jac_x_batch against the scalar jac_x (nx*nx outputs per
state; `--outputs rhs,jac_x,jac_x_batch`), written to results/jac_x_batch.md.

--function outputs: NAME_outputs_batch against the scalar outputs (`--outputs
rhs,outputs,outputs_batch`) on the example models that have outputs (double pendulum: energy and
tip, Kane; cart-pole: tip, Kane; the n-link cart, n = 10: energy; the Whipple bicycle), written to
results/outputs_batch.md.
"""
import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT / "tests"))

from common import C_CLOCK_AND_RNG, write_results  # noqa: E402

HARNESS = r"""
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "m.h"
#if ALONE
#include "s.h"
#define SCALAR_MODEL s_model()
#else
#define SCALAR_MODEL m_model()
#endif
#define NS 1024
#if JACX
#define BATCH m_jac_x_batch
#define SCALAR jac_x
#elif OUTS
#define BATCH m_outputs_batch
#define SCALAR outputs
#else
#define BATCH m_rhs_batch
#define SCALAR rhs
#endif
""" + C_CLOCK_AND_RNG + r"""int main(int argc, char **argv) {
    const eomc_model *m = m_model(), *sm = SCALAR_MODEL;
    int nx = m->nx, nq = m->nq, nr = m->ninput, i, k, c, round, rounds = atoi(argv[1]);
    int no = JACX ? nx * nx : OUTS ? m->noutput : nx;
    double *X = malloc(sizeof(double) * nx * NS), *S = malloc(sizeof(double) * nx * NS);
    double *XD = malloc(sizeof(double) * no * NS), *xd = malloc(sizeof(double) * no * NS);
    double *R = calloc((size_t)(nr + 1) * NS, sizeof(double)), *r = calloc(nr + 1, sizeof(double));
    double worst = 0.0, same = 0.0, sum = 0.0, work[1];
    int *st = malloc(sizeof(int) * NS);
    (void)argc;
    for (i = 0; i < NS; i++) for (k = 0; k < nx; k++) {
        double v = k < nq ? 3.0 * (2 * rnd() - 1) : 2 * rnd() - 1;
        X[i * nx + k] = v; S[k * NS + i] = v; }
    if (BATCH(NS, 0.0, S, m->param_defaults, nr ? R : NULL, XD, st, work)) { printf("batch failed\n"); return 1; }
    for (i = 0; i < NS; i++) {
        sm->SCALAR(0.0, X + i * nx, m->param_defaults, r, xd + i * no, work);
        for (k = 0; k < no; k++) { double a = XD[k * NS + i], b = xd[i * no + k];
            double d = fabs(a - b) / (fabs(b) > 1 ? fabs(b) : 1);
            if (d > worst) worst = d; same += a == b; }
    }
    printf("agree %.3g %.4f\n", worst, same / ((double)no * NS));
    for (round = 0; round < rounds; round++)
        for (c = 0; c < 2; c++) {
            int cc = (c + round) % 2; long done = 0; double t0 = tnow(), t1;
            do { if (cc == 0) { for (i = 0; i < NS; i++) sm->SCALAR(0.0, X + i * nx, m->param_defaults, r, xd + i * no, work); }
                 else BATCH(NS, 0.0, S, m->param_defaults, nr ? R : NULL, XD, st, work);
                 sum += cc ? XD[0] : xd[0];
                 done += NS; t1 = tnow(); } while (t1 - t0 < 2e7);
            printf("time %d %.3f\n", cc, (t1 - t0) / done);
        }
    printf("checksum %g\n", sum);
    return 0;
}
"""


def models():
    from helpers.robots import robot_path
    out = [(f"cart n={n}", HERE / "tree_models" / "cart_rel_joints.py", {"EOMC_N_LINKS": str(n)}, [])
           for n in (4, 20, 40)]
    out.append(("UR10", robot_path("ur_description/urdf/ur10_robot.urdf"), {}, []))
    out.append(("Panda", robot_path("panda"), {}, []))
    out.append(("Go2", robot_path("go2_description/urdf/go2.urdf"), {}, ["--floating-base", "--limits", "off"]))
    out.append(("G1", robot_path("g1_description/urdf/g1_29dof_rev_1_0.urdf"), {},
                ["--floating-base", "--limits", "off"]))
    return out


def output_models():
    ex = ROOT / "examples"
    return [("double pendulum", ex / "double_pendulum.py", {}, []), ("cart-pole", ex / "cart_pole_system.py", {}, []),
            ("n-link cart n=10", ex / "n_link_cart.py", {"EOMC_N_LINKS": "10"}, []),
            ("Whipple bicycle", ex / "whipple_bicycle.py", {}, [])]


OUTPUTS = {"rhs": "rhs,rhs_batch", "jac_x": "rhs,jac_x,jac_x_batch", "outputs": "rhs,outputs,outputs_batch"}


def build(model, env, flags, outdir, fn="rhs"):
    env = dict(os.environ, EOMC_CACHE_DIR=tempfile.mkdtemp(prefix="eomc_rb_"), **env)
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "eomc", "build", str(model), "-o", str(outdir), "--name", "m",
                           "--outputs", OUTPUTS[fn], "-q", *flags], env=env, capture_output=True, text=True)
    if proc.returncode:
        raise RuntimeError((proc.stderr.strip().splitlines() or ["?"])[-1])
    return json.loads((outdir / "m.json").read_text()), time.perf_counter() - start


def scalar_text(path, fn, name="m"):
    """NAME_fn's definition in the C file at ``path`` (with its NAME_fn_part* sub-functions)."""
    import re
    text = path.read_text()
    parts = re.findall(rf"^static[^\n]*\b{name}_{fn}_part\d+\(.*?^}}$", text, flags=re.M | re.S)
    start = text.index(f"\nint {name}_{fn}(")
    return "\n".join(parts) + text[start:text.index("\n}\n", start)]


def scalar_kind(d, model, env, flags, fn):
    """How the batch build's scalar fn is written (looped / straight-line) and whether it is the
    C of a build without the batch function (`--outputs fn`)."""
    import re

    def kind(text):
        return ("looped" if re.search(r"\bL\d+_\d+\[\d+ \* k \+", text) else
                "limb routines" if re.search(r"\b[ms]_limb\d+_in\(", text) else "straight-line")
    mine = scalar_text(d / "m.c", fn)
    alone = d / "alone"
    alone.mkdir()
    env = dict(os.environ, EOMC_CACHE_DIR=tempfile.mkdtemp(prefix="eomc_rb_"), **env)
    proc = subprocess.run([sys.executable, "-m", "eomc", "build", str(model), "-o", str(alone), "--name", "s",
                           "--outputs", fn, "-q", *flags], env=env, capture_output=True, text=True)
    if proc.returncode:
        raise RuntimeError("the rhs-only build failed: " + ((proc.stderr.strip().splitlines() or ["?"])[-1]))
    theirs = scalar_text(alone / "s.c", fn, "s")
    if theirs == mine.replace("m_", "s_"):
        return f"{kind(mine)}, = {fn}-only build", None
    return f"{kind(theirs)} (the {fn}-only build's, timed; the batch build's: {kind(mine)})", alone


def harness_flags():
    """The flags eomc compiles a library with on this machine (toolchain.DEFAULT_CFLAGS without
    -fPIC, plus machine_flags: -mavx2 -ffp-contract=off where the CPU has AVX2)."""
    from eomc.compiler.build.toolchain import find_compiler, machine_flags
    return ["-O2", "-std=c99", *machine_flags(find_compiler())]


def measure(label, model, env, flags, tmp, rounds, fn="rhs", core=0):
    d = tmp / label.replace(" ", "_").replace("=", "")
    d.mkdir()
    meta, build_s = build(model, env, flags, d, fn)
    kind, alone = scalar_kind(d, model, env, flags, fn) if fn == "rhs" else ("", None)
    (d / "h.c").write_text(HARNESS)
    rt = ROOT / "runtime" / "c"
    exes, compile_s = {}, {}
    for lanes in (4, 8):
        exe = d / f"h{lanes}"
        start = time.perf_counter()
        subprocess.run(["gcc", *harness_flags(), f"-DEOMC_BATCH_LANES={lanes}", f"-DJACX={int(fn == 'jac_x')}", f"-DOUTS={int(fn == 'outputs')}",
                        f"-DALONE={int(alone is not None)}", f"-I{d}", f"-I{rt}",
                        *([f"-I{alone}", str(alone / "s.c")] if alone is not None else []),
                        str(d / "h.c"), str(d / "m.c"), "-o", str(exe), "-lm"], check=True)
        compile_s[lanes] = time.perf_counter() - start
        exes[lanes] = exe
    times = {("scalar", 4): [], ("scalar", 8): [], ("batch", 4): [], ("batch", 8): []}
    agree = {}
    for rnd in range(rounds):
        for lanes in ((4, 8) if rnd % 2 == 0 else (8, 4)):
            out = subprocess.run(["taskset", "-c", str(core), str(exes[lanes]), "1"], capture_output=True,
                                 text=True, check=True).stdout
            for line in out.splitlines():
                if line.startswith("time"):
                    _, k, v = line.split()
                    times[("batch" if k == "1" else "scalar", lanes)].append(float(v))
                elif line.startswith("agree"):
                    agree[lanes] = tuple(float(v) for v in line.split()[1:])
    scalar = statistics.median(times[("scalar", 4)] + times[("scalar", 8)])
    batch = {lanes: statistics.median(times[("batch", lanes)]) for lanes in (4, 8)}
    return dict(label=label, nx=meta["nx"], formulation=meta["formulation"],
                vectorized=meta[f"{fn}_batch"]["vectorized"], ops=sum(meta["op_counts"][fn].values()),
                scalar=scalar, batch=batch, agree=agree, build_s=build_s, compile_s=compile_s, kind=kind)


def table(rows, fn="rhs"):
    head = (f"| model | nx | form | scalar {fn} | {fn} ops | scalar {fn} ns/state | batch 4 lanes (AVX2) ns/state | "
            "batch 8 lanes (AVX-512) ns/state | speed-up 4 lanes | speed-up 8 lanes | "
            f"batch vs {fn}: max rel. diff, share of identical bits | harness compile s (8 lanes) |")
    lines = [head, "|" + "|".join(["--"] * (head.count("|") - 1)) + "|"]
    for r in rows:
        if "error" in r:
            lines.append(f"| {r['label']} | build failed: {r['error']} |")
            continue
        a = r["agree"].get(8) or r["agree"].get(4)
        lines.append(
            f"| {r['label']} | {r['nx']} | {r['formulation']}{'' if r['vectorized'] else ' (not vectorized)'} | "
            f"{r.get('kind') or '-'} | {r['ops']} | {r['scalar']:.1f} | {r['batch'][4]:.1f} | {r['batch'][8]:.1f} | "
            f"{r['scalar'] / r['batch'][4]:.2f} | {r['scalar'] / r['batch'][8]:.2f} | "
            f"{a[0]:.2g}, {a[1]:.3f} | {r['compile_s'][8]:.1f} |")
    return "\n".join(lines)


def environment():
    load = os.getloadavg()[0]
    cpu = next((ln.split(":", 1)[1].strip() for ln in open("/proc/cpuinfo") if ln.startswith("model name")), "?")
    flags = next((ln for ln in open("/proc/cpuinfo") if ln.startswith("flags")), "").split()
    gcc = subprocess.run(["gcc", "--version"], capture_output=True, text=True).stdout.splitlines()[0]
    simd = ", ".join(f for f in ("avx2", "fma", "avx512f") if f in flags)
    rev = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short=8", "HEAD"], capture_output=True,
                         text=True).stdout.strip() or "?"
    return (f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; {cpu} ({simd}); {gcc}; "
            f"Python {platform.python_version()}; eomc at {rev}; harnesses built with {' '.join(harness_flags())}; "
            f"load average {load:.1f} at the start (2 cores shared)")


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=9)
    parser.add_argument("--write", action="store_true")
    parser.add_argument("--core", type=int, default=0, help="the core the harnesses are pinned to")
    parser.add_argument("--function", choices=("rhs", "jac_x", "outputs"), default="rhs")
    parser.add_argument("names", nargs="*")
    args = parser.parse_args(argv)
    env_line = environment()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for label, model, env, flags in (output_models() if args.function == "outputs" else models()):
            if args.names and not any(n.lower() in label.lower() for n in args.names):
                continue
            try:
                row = measure(label, model, env, flags, Path(tmp), args.rounds, args.function, args.core)
            except (RuntimeError, subprocess.CalledProcessError) as exc:
                row = {"label": label, "error": str(exc)[:200]}
            print(row, flush=True)
            rows.append(row)
    text = table(rows, args.function)
    print(env_line)
    print(text)
    if args.write:
        what = {"jac_x": "jac_x_batch: Jacobians per second in SIMD lanes vs the scalar jac_x",
                "outputs": "outputs_batch: states' outputs per second in SIMD lanes vs the scalar outputs",
                "rhs": "rhs_batch: states per second in SIMD lanes vs the scalar rhs"}[args.function]
        how = "" if args.function == "rhs" else f"--function {args.function} "
        write_results(f"{args.function}_batch", f"# {what} (issue 31 item 1)\n\n"
                      f"{env_line}.  benchmarks/bench_rhs_batch.py {how}--rounds {args.rounds}: 1024 states per call, "
                      f"thread CPU time, taskset -c {args.core}, contestants interleaved, medians.  ns/state: lower is "
                      "better; speed-up = scalar ns / batch ns.\n\n" + text + "\n", keep_notes=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
