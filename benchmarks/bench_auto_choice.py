"""Issue 31 item 5: does `auto` keep the faster rhs?  Both forms of the same model, measured.

Per model, `eomc build MODEL --outputs rhs --fold-parameters` with ``--formulation kane`` and
``--formulation recursive`` (each in a child process, fresh cache); then one C harness links
both rhs, checks they agree on 64 random states, and times them in thread CPU time
(CLOCK_THREAD_CPUTIME_ID), contestants interleaved round by round, pinned to core 1
(taskset -c 1), median of the rounds.  The old pick is what auto did before (fewer rhs
operations), the new one what it does now (eomc.compiler.formulations.select.rhs_cost): both computed
from the two builds' operation counts, exactly as auto compares them.

Models: the cart System auto sees (benchmarks/tree_models/cart_rel_joints.py, n = 1-4), and
the UR10 and Kinova arms from example-robot-data.  Bounded build wall time: a model whose
build fails is reported, not hidden.
The harness compiles both forms' C with the flags of eomc's default build on this machine
(LIB_FLAGS: -O2 plus -mavx2 -ffp-contract=off on AVX2), so the times are what auto's pick runs at.
Usage: python benchmarks/bench_auto_choice.py [--rounds 9] [--write]  (--write: results/auto_choice.md)
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT / "tests"))

from common import C_CLOCK_AND_RNG  # noqa: E402
from eomc.compiler.build import DEFAULT_CFLAGS, find_compiler  # noqa: E402
from eomc.compiler.build.toolchain import machine_flags  # noqa: E402

# the harness compiles both rhs with the flags eomc's default build uses on this machine
# (benchmarks/results/machine_flags.md): what auto's pick runs with
LIB_FLAGS = [*DEFAULT_CFLAGS, *machine_flags(find_compiler())]

HARNESS = r"""
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <time.h>
#include "@K@.h"
#include "@R@.h"
#define NX @NX@
#define NQ @NQ@
#define NR @NR@
#define NS 256
""" + C_CLOCK_AND_RNG + r"""int main(void) {
    static double X[NS][NX], a[NX], b[NX], r[NR + 1];
    double worst = 0.0, sum = 0.0;
    int i, k, c, round;
    for (k = 0; k <= NR; k++) r[k] = 0.5 * (2 * rnd() - 1);
    for (i = 0; i < NS; i++) for (k = 0; k < NX; k++)
        X[i][k] = k < NQ ? 3.0 * (2 * rnd() - 1) : 2 * rnd() - 1;
    for (i = 0; i < 64; i++) {
        @K@_rhs(0.0, X[i], NULL, r, a, NULL);
        @R@_rhs(0.0, X[i], NULL, r, b, NULL);
        for (k = 0; k < NX; k++) { double d = fabs(a[k] - b[k]) / (fabs(b[k]) > 1 ? fabs(b[k]) : 1);
            if (d > worst) worst = d; }
    }
    printf("agree %.3g\n", worst);
    for (round = 0; round < @ROUNDS@; round++)
        for (c = 0; c < 2; c++) {
            int cc = (c + round) % 2; long calls = 0; double t0 = tnow(), t1;
            do { for (i = 0; i < NS; i++) {
                    if (cc == 0) @K@_rhs(0.0, X[i], NULL, r, a, NULL);
                    else @R@_rhs(0.0, X[i], NULL, r, a, NULL);
                    sum += a[NQ]; }
                 calls += NS; t1 = tnow(); } while (t1 - t0 < 2e7);
            printf("time %d %.2f\n", cc, (t1 - t0) / calls);
        }
    printf("checksum %g\n", sum);
    return 0;
}
"""


def models():
    from helpers.robots import robot_path
    out = [(f"cart n={n}", HERE / "tree_models" / "cart_rel_joints.py", {"EOMC_N_LINKS": str(n)})
           for n in (1, 2, 3, 4)]
    out.append(("UR10", robot_path("ur_description/urdf/ur10_robot.urdf"), {}))
    out.append(("Kinova", robot_path("kinova_description/robots/kinova.urdf"), {}))
    return out


def build(model, env, form, outdir):
    env = dict(os.environ, EOMC_CACHE_DIR=tempfile.mkdtemp(prefix="eomc_ac_"), **env)
    name = f"m_{form}"
    proc = subprocess.run([sys.executable, "-m", "eomc", "build", str(model), "-o", str(outdir),
                           "--name", name, "--fold-parameters", "--outputs", "rhs",
                           "--formulation", form, "-q"], env=env, capture_output=True, text=True)
    if proc.returncode:
        raise RuntimeError(proc.stderr.strip().splitlines()[-1])
    return json.loads((outdir / f"{name}.json").read_text())


def measure(label, model, env, tmp, rounds):
    from eomc.compiler.formulations.select import rhs_cost
    d = tmp / label.replace(" ", "_").replace("=", "")
    d.mkdir()
    metas = {f: build(model, env, f, d) for f in ("kane", "recursive")}
    mk = metas["kane"]
    nx, nq, nr = mk["nx"], mk["nq"], mk["ninput"]
    src = (HARNESS.replace("@K@", "m_kane").replace("@R@", "m_recursive").replace("@NX@", str(nx))
           .replace("@NQ@", str(nq)).replace("@NR@", str(nr)).replace("@ROUNDS@", str(rounds)))
    (d / "h.c").write_text(src)
    rt = ROOT / "runtime" / "c"
    subprocess.run(["gcc", *LIB_FLAGS, f"-I{d}", f"-I{rt}", str(d / "h.c"), str(d / "m_kane.c"),
                    str(d / "m_recursive.c"), "-o", str(d / "h"), "-lm"], check=True)
    out = subprocess.run(["taskset", "-c", "1", str(d / "h")], capture_output=True, text=True,
                         check=True).stdout
    times = {0: [], 1: []}
    agree = None
    for line in out.splitlines():
        if line.startswith("time"):
            _, k, v = line.split()
            times[int(k)].append(float(v))
        elif line.startswith("agree"):
            agree = float(line.split()[1])
    ns = {f: sorted(times[k])[len(times[k]) // 2] for k, f in ((0, "kane"), (1, "recursive"))}
    counts = {f: metas[f]["op_counts"]["rhs"] for f in metas}
    ops = {f: sum(c.values()) for f, c in counts.items()}
    cost = {f: rhs_cost(c, f) for f, c in counts.items()}
    old = "recursive" if ops["recursive"] < ops["kane"] else "kane"
    new = "recursive" if cost["recursive"] < cost["kane"] else "kane"
    return dict(label=label, ns=ns, counts=counts, ops=ops, cost=cost, old=old, new=new, agree=agree)


def table(rows):
    head = ("| model | kane rhs ns | recursive rhs ns | faster | kane ops (calls, divs) | "
            "recursive ops (calls, divs) | kane cost | recursive cost | old pick (ops) | "
            "new pick (cost) | new pick / best time | agreement |")
    lines = [head, "|" + "--:|" * (head.count("|") - 1)]
    for r in rows:
        if "error" in r:
            lines.append(f"| {r['label']} | build failed: {r['error']} |" + " |" * 10)
            continue
        ns, c = r["ns"], r["counts"]
        fast = min(ns, key=ns.get)
        lines.append(
            f"| {r['label']} | {ns['kane']:.0f} | {ns['recursive']:.0f} | {fast} | "
            f"{r['ops']['kane']} ({c['kane']['calls']}, {c['kane']['divs']}) | "
            f"{r['ops']['recursive']} ({c['recursive']['calls']}, {c['recursive']['divs']}) | "
            f"{r['cost']['kane']} | {r['cost']['recursive']} | {r['old']} | {r['new']} | "
            f"{ns[r['new']] / ns[fast]:.2f} | {r['agree']:.1e} |")
    return "\n".join(lines)


def main(argv):
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=9)
    ap.add_argument("--write", action="store_true")
    ap.add_argument("-k", action="append", default=[], help="only models whose label contains this")
    args = ap.parse_args(argv)
    start = " ".join(f"{v:.2f}" for v in os.getloadavg())
    tmp = Path(tempfile.mkdtemp(prefix="bench_auto_"))
    rows = []
    for label, model, env in models():
        if args.k and not any(k in label for k in args.k):
            continue
        try:
            rows.append(measure(label, model, env, tmp, args.rounds))
        except (RuntimeError, subprocess.CalledProcessError) as exc:
            rows.append({"label": label, "error": str(exc)[:120]})
        print(rows[-1], flush=True)
    text = table(rows)
    print(text)
    if args.write:
        from common import environment_header, write_results
        end = " ".join(f"{v:.2f}" for v in os.getloadavg())
        notes = [f"load average at start: {start}, at the end: {end} (a shared 2-core machine, "
                 f"other engineers' builds and tests running beside this): times are thread CPU time",
                 f"both rhs compiled into the harness with eomc's default flags on this machine: "
                 f"{' '.join(LIB_FLAGS)}"]
        print(write_results("auto_choice", environment_header(
            "auto's choice of formulation: both forms' rhs measured", notes=notes)
            + "\n" + (__doc__ or "") + "\n" + text + "\n"))
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(HERE))
    sys.exit(main(sys.argv[1:]))
