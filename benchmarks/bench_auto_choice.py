"""Issue 31 item 5: does `auto` keep the faster rhs?  Both forms of the same model, measured.

Per model, `eomc build MODEL --outputs rhs --fold-parameters` with ``--formulation kane`` and
``--formulation recursive`` (each in a child process, fresh cache); then one C harness links
both rhs, checks they agree on 64 random states, and times them in thread CPU time
(CLOCK_THREAD_CPUTIME_ID), contestants interleaved round by round, pinned to core 1
(taskset -c 1), median of the rounds over --copies harness executables (default 3, one process each)
that differ in code placement and stack offset (session 18's hazard); the range of the copies'
medians is in brackets.  The pick before is what select.rhs_cost's weights of sessions 9-25 chose
(Kane's flop 1.15, a call 25, a division 4; Kane's equations formed), the costs after and auto's pick
what it does now (eomc.compiler.formulations.select.rhs_cost, refitted by task autocost: --fit).
--json FILE keeps the rows; --fit FILE... refits the weights from them (no builds).

Models: the cart System auto sees (benchmarks/tree_models/cart_rel_joints.py, n = 1-6, 8, 20,
40), the UR10 and Kinova arms, every robot of benchmarks/results/urdf.md (UR5, Panda, Solo12
on a floating base) from example-robot-data, and its other trees of at most 6 speeds where the
two forms' costs are close or Kane's equations cost most of the build (so100, so101, hextilt's
5-joint arm, Bolt, Iris, finger_edu, the double pendulum URDF: task autoskip, results/auto_skip.md).  Auto's pick is what `--formulation auto` built
(a third build; its json's formulation): above 6 speeds on a URDF Model, on a chain of more than 3
joints (select.kane_skip_reason), or where the LDLT of
Kane's mass matrix alone costs as much as the recursive rhs, auto does not build Kane's form,
so Kane's rhs is built explicitly here to time it, within --kane-timeout seconds of wall time
(a build that does not finish is reported as such, with its CPU seconds, not hidden).
Builds run concurrently (--jobs), the timing harnesses one after another on core 1.
The harness compiles both forms' C with the flags of eomc's default build on this machine
(LIB_FLAGS: -O2 plus -mavx2 -ffp-contract=off on AVX2), so the times are what auto's pick runs at.
With --line the recursive form is also built with the looped rhs switched off
(compiler/tree/chain_loop.CHAIN_LOOP_MIN_LINKS = None: the straight-line rhs the loop replaced from a run
of 4 identical links) and timed beside the two, for information (auto does not choose between them).
With --portable the harness compiles at eomc's portable flags only (DEFAULT_CFLAGS, no -mavx2: what a
machine without AVX2, or another architecture, builds; the looped rhs then takes each link's sin and cos
from libm), and --write goes to results/auto_choice_portable.md.
With --default every form is the model's default build instead (`eomc build MODEL`: every default
function, outputs and energy among them, parameters not folded: the harness passes each form its own
default parameters), which is what auto picks for most users; --write goes to results/auto_choice_default.md.
Usage: python benchmarks/bench_auto_choice.py [--rounds 9] [--jobs 2] [--kane-timeout 1200] [--line] [--portable] [--default] [--write]  (--write: results/auto_choice.md)
"""
import argparse
import concurrent.futures
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
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
@INCLUDES@
#define NX @NX@
#define NQ @NQ@
#define NR @NR@
#define NC @NC@
#define NS 256
""" + C_CLOCK_AND_RNG + r"""static void call(int c, const double *x, const double *r, double *a) {
    switch (c) { @CASES@ }
}
int main(void) {
    static double X[NS][NX], a[NX], b[NX], r[NR + 1];
    volatile char stack_pad[PAD_STACK + 1];   /* per copy: moves the rhs's stack frames (session 18's hazard) */
    double worst = 0.0, sum = 0.0;
    int i, k, c, round;
    for (k = 0; k <= NR; k++) r[k] = 0.5 * (2 * rnd() - 1);
    for (i = 0; i < NS; i++) for (k = 0; k < NX; k++)
        X[i][k] = k < NQ ? 3.0 * (2 * rnd() - 1) : 2 * rnd() - 1;
    for (c = 1; c < NC; c++) for (i = 0; i < 64; i++) {
        call(0, X[i], r, a);
        call(c, X[i], r, b);
        for (k = 0; k < NX; k++) { double d = fabs(a[k] - b[k]) / (fabs(b[k]) > 1 ? fabs(b[k]) : 1);
            if (d > worst) worst = d; }
    }
    stack_pad[0] = 0;
    printf("agree %.3g\n", worst);
    for (round = 0; round < @ROUNDS@; round++)
        for (c = 0; c < NC; c++) {
            int cc = (c + round) % NC; long calls = 0; double t0 = tnow(), t1;
            do { for (i = 0; i < NS; i++) { call(cc, X[i], r, a); sum += a[NQ]; }
                 calls += NS; t1 = tnow(); } while (t1 - t0 < 2e7);
            printf("time %d %.2f\n", cc, (t1 - t0) / calls);
        }
    printf("checksum %g\n", sum);
    return 0;
}
"""

CART = HERE / "tree_models" / "cart_rel_joints.py"
DEFAULT_BUILD = False     # --default: the models' default builds (all default functions, parameters not folded)
BASELINE_PYTHON = None    # --baseline-python: another checkout's interpreter (main's venv) builds auto too


def models():
    """(label, model file, environment, extra build flags)."""
    from helpers.robots import robot_path
    out = [(f"cart n={n}", CART, {"EOMC_N_LINKS": str(n)}, []) for n in (1, 2, 3, 4, 5, 6, 8, 20, 40)]
    out.append(("UR10", robot_path("ur_description/urdf/ur10_robot.urdf"), {}, []))
    out.append(("Kinova", robot_path("kinova_description/robots/kinova.urdf"), {}, []))
    out.append(("UR5", robot_path("ur5"), {}, []))
    out.append(("Panda", robot_path("panda"), {}, []))
    out.append(("Solo12 (floating)", robot_path("solo12"), {}, ["--floating-base"]))
    # the example-robot-data arms auto forms Kane's equations for (<= 6 speeds) beside UR and Kinova, and the
    # small trees where Kane's rhs is cheaper by the cost model (task autoskip: does skipping Kane lose a win?)
    # SymPy mechanics examples (closed four-bar included) and the small example-robot-data trees (task autocost)
    for ex in ("double_pendulum", "cart_pole_system", "heavy_top", "four_bar_system", "biomechanical_arm"):
        out.append((ex, ROOT / "examples" / f"{ex}.py", {}, []))
    out.append(("TwoDofs", robot_path("asr_twodof_description/urdf/TwoDofs.urdf"), {}, []))
    out.append(("borinot", robot_path("borinot_description/urdf/borinot_flying_arm_2.urdf"), {}, []))
    for label, rel in (("so100", "so_arm_description/urdf/so100.urdf"), ("so101", "so_arm_description/urdf/so101.urdf"),
                       ("hextilt arm 5", "hextilt_description/urdf/hextilt_flying_arm_5.urdf"),
                       ("bolt", "bolt_description/robots/bolt.urdf"), ("iris", "iris_description/robots/iris.urdf"),
                       ("finger_edu", "finger_edu_description/robots/finger_edu.urdf"),
                       ("double pendulum (URDF)", "double_pendulum_description/urdf/double_pendulum.urdf")):
        out.append((label, robot_path(rel), {}, []))
    return out


# the straight-line recursive rhs (--line): eomc's CLI with the looped rhs switched off
NO_LOOP = ("import sys, eomc.compiler.tree.chain_loop as c; c.CHAIN_LOOP_MIN_LINKS = None; "
           "from eomc.cli import main; sys.exit(main(sys.argv[1:]))")


def build(model, env, flags, form, outdir, timeout=None):
    """Build one form's rhs in a child process with a fresh cache: its json metadata, or why not.
    ``form`` "line": the recursive form with the looped rhs off."""
    cache = tempfile.mkdtemp(prefix="eomc_ac_")
    try:
        return _build(model, dict(os.environ, EOMC_CACHE_DIR=cache, **env), flags, form, outdir, timeout)
    finally:
        shutil.rmtree(cache, ignore_errors=True)     # the fresh cache is not kept (the outputs are in outdir)


def _build(model, env, flags, form, outdir, timeout):
    name = f"m_{form}"
    start = ([sys.executable, "-c", NO_LOOP] if form == "line" else
             [BASELINE_PYTHON, "-m", "eomc"] if form == "baseline" else [sys.executable, "-m", "eomc"])
    cmd = [*start, "build", str(model), *flags, "-o", str(outdir), "--name", name,
           *([] if DEFAULT_BUILD else ["--fold-parameters", "--outputs", "rhs"]), "--formulation",
           {"line": "recursive", "baseline": "auto"}.get(form, form), "-q"]
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        _, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        err = None
    if err is None:
        return f"not built in {timeout:.0f} s wall"
    if proc.returncode:
        return (err.strip().splitlines() or ["failed"])[-1][:120]
    return json.loads((outdir / f"{name}.json").read_text())


def build_all(label, model, env, flags, tmp, kane_timeout, line=False):
    d = tmp / label.replace(" ", "_").replace("=", "").replace("(", "").replace(")", "")
    d.mkdir()
    out = {}
    for form in ("auto", "recursive", "kane") + (("line",) if line else ()) + (("baseline",) if BASELINE_PYTHON else ()):
        t0 = time.time()
        meta = build(model, env, flags, form, d, kane_timeout if form == "kane" else None)
        out[form] = (meta, time.time() - t0)
    return d, out


PAD_C = "void eomc_bench_pad(void) { __asm__ volatile (\".skip %d, 0x90\"); }\n"


def time_forms(d, forms, metas, rounds, copies=3):
    """Link every built form's rhs into one harness, check agreement, time them interleaved.
    ``copies`` harness executables differ in code placement (a padding function linked first, the
    forms' objects in rotated order) and stack offset (session 18's measurement hazard: byte-identical
    code ran 1.6x apart by where it landed); each runs in its own process.  Returns the median over
    all copies' rounds per form, the agreement, and per form the per-copy medians (the spread)."""
    m0 = metas[forms[0]]
    incl = "\n".join(f'#include "m_{f}.h"' for f in forms)
    # each form's own default parameters (a default build does not fold them; the forms' lists differ)
    incl += "\n" + "\n".join(f"static const double P_{f}[] = {{{', '.join(repr(float(v)) for v in metas[f]['param_defaults']) or '0'}}};"
                             for f in forms)
    cases = " ".join(f"case {i}: m_{f}_rhs(0.0, x, {'P_' + f if metas[f]['nparam'] else 'NULL'}, r, a, NULL); break;"
                     for i, f in enumerate(forms))
    src = (HARNESS.replace("@INCLUDES@", incl).replace("@CASES@", cases)
           .replace("@NX@", str(m0["nx"])).replace("@NQ@", str(m0["nq"])).replace("@NR@", str(m0["ninput"]))
           .replace("@NC@", str(len(forms))).replace("@ROUNDS@", str(rounds)))
    (d / "h.c").write_text(src)
    rt = ROOT / "runtime" / "c"
    exes = []
    for j in range(copies):
        (d / f"pad{j}.c").write_text(PAD_C % (16 + j * 208))
        objs = [str(d / f"m_{f}.c") for f in forms]
        objs = objs[j % len(objs):] + objs[:j % len(objs)]
        exe = d / f"h{j}"
        subprocess.run(["gcc", *LIB_FLAGS, f"-DPAD_STACK={j * 96}", f"-I{d}", f"-I{rt}", str(d / f"pad{j}.c"),
                        str(d / "h.c"), *objs, "-o", str(exe), "-lm"], check=True)
        exes.append(exe)
    times = {i: [] for i in range(len(forms))}
    per_copy = {i: [] for i in range(len(forms))}
    agree = None
    for exe in exes:
        out = subprocess.run(["taskset", "-c", "1", str(exe)], capture_output=True, text=True,
                             check=True).stdout
        mine = {i: [] for i in range(len(forms))}
        for line in out.splitlines():
            if line.startswith("time"):
                _, k, v = line.split()
                mine[int(k)].append(float(v))
            elif line.startswith("agree"):
                agree = float(line.split()[1])
        for i, v in mine.items():
            times[i] += v
            per_copy[i].append(sorted(v)[len(v) // 2])
    med = {f: sorted(times[i])[len(times[i]) // 2] for i, f in enumerate(forms)}
    return med, agree, {f: per_copy[i] for i, f in enumerate(forms)}


def cost_before(counts, form):
    """select.rhs_cost before task autocost (session 25): Kane's flop 1.15, a division 4, a call 25."""
    flops = counts.get("adds", 0) + counts.get("muls", 0)
    return round((1.15 if form == "kane" else 1.0) * flops + 4 * counts.get("divs", 0) + 25 * counts.get("calls", 0))


def measure(label, d, built, rounds, copies=3):
    from eomc.compiler.formulations.select import rhs_cost
    metas = {f: m for f, (m, _) in built.items() if isinstance(m, dict)}
    if "recursive" not in metas:
        return {"label": label, "error": f"recursive: {built['recursive'][0]}"}
    forms = [f for f in ("kane", "recursive", "line") if f in metas]
    ns, agree, spread = time_forms(d, forms, metas, rounds, copies)
    line_ns = ns.pop("line", None)
    forms = [f for f in forms if f != "line"]
    counts = {f: metas[f]["op_counts"]["rhs"] for f in forms}
    ops = {f: sum(c.values()) for f, c in counts.items()}
    nu = metas["recursive"]["nu"]
    cost = {f: rhs_cost(c, f, nu) for f, c in counts.items()}
    before = {f: cost_before(c, f) for f, c in counts.items()}
    # the pick before: the cost model of sessions 9-25 (before task autocost), Kane's equations formed
    old = min(before, key=before.get) if len(before) == 2 else None
    auto = metas.get("auto", {})
    if "baseline" in built:     # --baseline-python: the other checkout's pick replaces "pick before"
        base = metas.get("baseline")
        old = base["formulation"] if base else f"failed: {built['baseline'][0]}"
    return dict(label=label, nu=nu, ns=ns, counts=counts, ops=ops, cost=cost, cost_before=before, old=old,
                auto=auto.get("formulation", f"failed: {built['auto'][0]}"),
                auto_costs=auto.get("formulation_costs"), agree=agree, line_ns=line_ns, spread=spread,
                kane_build=(built["kane"][1], None if "kane" in metas else built["kane"][0]))


def table(rows):
    head = ("| model | speeds | kane rhs ns | recursive rhs ns | faster | kane ops (calls, divs) | "
            "recursive ops (calls, divs) | costs before (kane / recursive) | pick before | kane cost | recursive cost | "
            "auto's pick (its costs) | auto / best time | pick before / best time | agreement | kane build wall s |"
            + (" straight-line recursive rhs ns (--line) |" if any(r.get("line_ns") for r in rows) else ""))
    lines = [head, "|" + "--:|" * (head.count("|") - 1)]
    for r in rows:
        if "error" in r:
            lines.append(f"| {r['label']} | build failed: {r['error']} |" + " |" * 14)
            continue
        ns, c, ops = r["ns"], r["counts"], r["ops"]
        both = len(ns) == 2
        fast = min(ns, key=ns.get)
        k_wall, k_err = r["kane_build"]
        sp = r.get("spread") or {}
        cb = r.get("cost_before") or {}

        def cell(f):        # the median over all copies' rounds (the per-copy medians' range)
            if f not in ns:
                return "-"
            fmt = ".1f" if ns[f] < 100 else ".0f"
            return f"{ns[f]:{fmt}}" + (f" ({min(sp[f]):{fmt}}-{max(sp[f]):{fmt}})" if len(sp.get(f, ())) > 1 else "")
        kane_ns = cell("kane")
        kane_ops = f"{ops['kane']} ({c['kane']['calls']}, {c['kane']['divs']})" if "kane" in c else "-"
        costs = r["auto_costs"] or {}
        auto_cell = r["auto"] + (" (" + ", ".join(f"{k} {v}" for k, v in costs.items()) + ")" if costs else "")
        ratio = f"{ns[r['auto']] / ns[fast]:.2f}" if both and r["auto"] in ns else "-"
        before_ratio = f"{ns[r['old']] / ns[fast]:.2f}" if both and r.get("old") in ns else "-"
        kane_build = f"{k_wall:.0f}" + ("" if k_err is None else f" ({k_err})")
        agree = f"{r['agree']:.1e}" if both else "-"      # one form: nothing to compare
        lines.append(
            f"| {r['label']} | {r['nu']} | {kane_ns} | {cell('recursive')} | {fast if both else '-'} | "
            f"{kane_ops} | {ops['recursive']} ({c['recursive']['calls']}, {c['recursive']['divs']}) | "
            f"{cb.get('kane', '-')} / {cb['recursive']} | {r['old'] or '-'} | "
            f"{r['cost'].get('kane', '-')} | {r['cost']['recursive']} | {auto_cell} | "
            f"{ratio} | {before_ratio} | {agree} | {kane_build} |"
            + (f" {r['line_ns']:.0f} |" if r.get("line_ns") else (" - |" if "straight-line" in head else "")))
    return "\n".join(lines)


def fit(rows, per_speed=True):
    """The cost model's weights (select.rhs_cost) by least squares over every row where both forms were
    timed, of what the pick decides: the difference ns(kane) - ns(recursive) relative to the model's
    mean time, against kane_flops * (op_kane + per_speed * speeds) - recursive_flops * op_recursive
    + div * (divs_k - divs_r) + call * (calls_k - calls_r), non-negative weights (ns).  Returns the
    weights, the same in units of one recursive add/multiply, and per row (fitted, measured)."""
    import numpy as np
    from scipy.optimize import nnls
    names = ["op_kane", "op_recursive", "div", "call"] + (["op_kane_per_speed"] if per_speed else [])
    A, b, labels = [], [], []
    for r in rows:
        if "error" in r or len(r.get("ns", {})) != 2:
            continue
        k, c, ns = r["counts"]["kane"], r["counts"]["recursive"], r["ns"]
        fk, fr = k["adds"] + k["muls"], c["adds"] + c["muls"]
        x = [fk, -fr, k["divs"] - c["divs"], k["calls"] - c["calls"]] + ([fk * r["nu"]] if per_speed else [])
        mean = (ns["kane"] + ns["recursive"]) / 2
        A.append([v / mean for v in x])
        b.append((ns["kane"] - ns["recursive"]) / mean)
        labels.append(r["label"])
    A, b = np.array(A), np.array(b)
    w, _ = nnls(A, b)
    unit = w[1]
    return (dict(zip(names, map(float, w))), {n: float(v / unit) for n, v in zip(names, w)},
            {lab: (float(f), float(m)) for lab, f, m in zip(labels, A @ w, b)})


def _checkout(python):
    """The git commit of the eomc checkout ``python`` imports (or its path when not a git tree)."""
    where = subprocess.run([python, "-c", "import eomc, pathlib; print(pathlib.Path(eomc.__file__).parent.parent)"],
                           capture_output=True, text=True).stdout.strip()
    head = subprocess.run(["git", "-C", where, "log", "-1", "--format=%h %s"], capture_output=True, text=True).stdout
    return head.strip()[:60] or where


def main(argv):
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=9)
    ap.add_argument("--write", action="store_true")
    ap.add_argument("--jobs", type=int, default=2, help="builds run at once (timing is one at a time)")
    ap.add_argument("--kane-timeout", type=float, default=1200.0, help="wall seconds for Kane's build")
    ap.add_argument("-k", action="append", default=[], help="only models whose label contains this")
    ap.add_argument("--line", action="store_true", help="also time the straight-line recursive rhs")
    ap.add_argument("--copies", type=int, default=3,
                    help="harness executables with different code placement and stack offset, one process each")
    ap.add_argument("--json", help="also write the rows (counts, times, per-copy medians) to this file")
    ap.add_argument("--portable", action="store_true",
                    help="harness at eomc's portable flags (no -mavx2); --write to auto_choice_portable.md")
    ap.add_argument("--default", action="store_true",
                    help="the models' default builds (every default function, parameters not folded); "
                         "--write to auto_choice_default.md")
    ap.add_argument("--baseline-python", metavar="PYTHON",
                    help="another checkout's interpreter (e.g. a venv of main): its auto build's pick is the "
                         "table's 'pick before' (instead of the sessions 9-25 weights')")
    ap.add_argument("--fit", nargs="+", metavar="JSON",
                    help="fit the cost model's weights to the rows of these --json files (no builds)")
    args = ap.parse_args(argv)
    if args.fit:
        rows = [r for f in args.fit for r in json.loads(Path(f).read_text())]
        for per_speed in (False, True):
            ns_w, unit_w, rel = fit(rows, per_speed)
            print(f"per speed term {per_speed}: weights (ns)", {k: round(v, 4) for k, v in ns_w.items()})
            print("  weights (recursive adds/muls):", {k: round(v, 3) for k, v in unit_w.items()})
            for lab, (f, m) in rel.items():
                print(f"  {lab:24s} (kane - recursive) / mean: fitted {f:+.3f} measured {m:+.3f}"
                      + ("  wrong sign" if f * m < 0 and abs(m) > 0.05 else ""))
        return 0
    global LIB_FLAGS, DEFAULT_BUILD, BASELINE_PYTHON
    DEFAULT_BUILD, BASELINE_PYTHON = args.default, args.baseline_python
    if args.portable:
        LIB_FLAGS = list(DEFAULT_CFLAGS)
    start = " ".join(f"{v:.2f}" for v in os.getloadavg())
    tmp = Path(tempfile.mkdtemp(prefix="bench_auto_"))
    labels = [m[0] for m in models()]
    # -k: a label exactly ("cart n=2", not "cart n=20"), or else every label containing it
    chosen = [m for m in models() if not args.k or any(k == m[0] or (k not in labels and k in m[0])
                                                        for k in args.k)]
    with concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
        builds = [pool.submit(build_all, *m, tmp, args.kane_timeout, args.line) for m in chosen]
        rows = []
        for (label, *_), fut in zip(chosen, builds):
            try:
                rows.append(measure(label, *fut.result(), args.rounds, args.copies))
            except (RuntimeError, subprocess.CalledProcessError) as exc:
                rows.append({"label": label, "error": str(exc)[:120]})
            print(rows[-1], flush=True)
    text = table(rows)
    print(text)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1, default=str))
    if args.write:
        from common import environment_header, write_results
        end = " ".join(f"{v:.2f}" for v in os.getloadavg())
        notes = [f"load average at start: {start}, at the end: {end} (a shared 2-core machine, "
                 f"other engineers' builds and tests running beside this): times are thread CPU time",
                 f"--kane-timeout {args.kane_timeout:.0f} s, --rounds {args.rounds}",
                 (f"the rhs compiled into the harness with eomc's portable flags only (no machine flags: "
                  f"a build without AVX2): " if args.portable else
                  f"both rhs compiled into the harness with eomc's default flags on this machine: ")
                 + " ".join(LIB_FLAGS)]
        if args.line:
            notes.append("--line: the straight-line recursive rhs (the looped rhs switched off) timed beside them")
        if args.baseline_python:
            notes.append(f"'pick before': what `--formulation auto` built with {args.baseline_python} "
                         f"(eomc {_checkout(args.baseline_python)}), in the same run; its 'costs before' are still "
                         f"the sessions 9-25 weights'")
        if args.default:
            notes.append("--default: each form is the model's default build (`eomc build MODEL --formulation F`: "
                         "every default function, outputs and energy among them, parameters not folded)")
        print(write_results("auto_choice_portable" if args.portable else
                            "auto_choice_default" if args.default else "auto_choice", environment_header(
            "auto's choice of formulation: both forms' rhs measured"
            + (" (portable flags, no AVX2)" if args.portable else "")
            + (" (default builds)" if args.default else ""), notes=notes)
            + "\n" + (__doc__ or "") + "\n" + text + "\n", keep_notes=True))
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(HERE))
    sys.exit(main(sys.argv[1:]))
