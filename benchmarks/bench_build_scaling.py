"""Issue 8 items 4-5: builds that grow about linearly.

Three measurements, each in the same run:

1. The Whipple bicycle, every function, cold (fresh caches): CPU seconds per stage
   (start-up and imports, derive, generate, compile), in a fresh process per repeat.
2. gcc on the generated C, unsplit against split (compiler/emit/split.py): CPU seconds
   and peak RSS of `gcc -O2 -fPIC -std=c99 -c MODEL.c`, for the shipped absolute-angle
   n-link cart (rhs only) at several n and the bicycle.  "Unsplit" is the same
   generator with the split threshold set out of reach.
3. The cost at run time: ns per call of rhs (and of the bicycle's jac_x, the function
   split there) in a C harness, thread CPU time, pinned to one core, unsplit and split
   interleaved.  Code placement moves large straight-line functions by up to 40%
   (performance report §1d), so every figure is the mean of two link orders
   (harness first, model first), each the median of its repeats.
"""
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import environment_header, format_table, write_results  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
HEADERS = ROOT / "runtime" / "c"
BICYCLE = ROOT / "examples" / "whipple_bicycle.py"
CART = ROOT / "examples" / "n_link_cart.py"
CART_REL = ROOT / "benchmarks" / "tree_models" / "cart_rel_kane.py"
CART_JOINTS = ROOT / "benchmarks" / "tree_models" / "cart_rel_joints.py"
CFLAGS = ["-O2", "-fPIC", "-std=c99"]
PIN = ["taskset", "-c", "1"] if os.path.exists("/usr/bin/taskset") else []

STAGE_RUNNER = r"""
import os, resource, sys, time
t0 = time.process_time()
if len(sys.argv) > 3:     # an older eomc.compiler (and its templates) from a git archive
    import importlib.util, eomc
    for name in ("compiler", "templates"):
        where = os.path.join(sys.argv[3], name)
        spec = importlib.util.spec_from_file_location(
            "eomc." + name, os.path.join(where, "__init__.py"), submodule_search_locations=[where])
        module = importlib.util.module_from_spec(spec)
        sys.modules["eomc." + name] = module
        setattr(eomc, name, module)
        spec.loader.exec_module(module)
from eomc.compiler import driver
assert len(sys.argv) == 3 or driver.__file__.startswith(sys.argv[3]), driver.__file__
imports = time.process_time() - t0

def cpu():
    c = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + c.ru_utime + c.ru_stime

T = {}

class CpuProgress(driver.Progress):
    def stage(self, label):
        inner = super().stage(label)
        class _S:
            def __enter__(s):
                s.start = cpu(); inner.__enter__()
            def __exit__(s, *exc):
                inner.__exit__(*exc); T[label + "_cpu"] = cpu() - s.start
        return _S()

driver.Progress = CpuProgress       # compile() builds its own Progress: this one
kw = {}
if os.environ.get("EOMC_BENCH_FORMULATION"):      # the front-end rows: rhs only, one formulation
    kw = dict(functions=["rhs"], formulation=os.environ["EOMC_BENCH_FORMULATION"])
driver.compile(sys.argv[1], progress=False, output_dir=sys.argv[2], **kw)
t = T
print("STAGES", imports, t["derive_cpu"], t["generate_cpu"], t["compile_cpu"], t["load_cpu"])
"""

HARNESS = r"""#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "NAME.h"

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return (double)ts.tv_sec * 1e9 + (double)ts.tv_nsec;
}

static int cmp(const void *a, const void *b)
{
    double d = *(const double *)a - *(const double *)b;
    return (d > 0) - (d < 0);
}

int main(int argc, char **argv)
{
    const eomc_model *m = NAME_model();
    int (*fn)(double, const double *, const double *, const double *, double *, double *) =
        argv[1][0] == 'j' ? m->jac_x : m->rhs;
    long calls = atol(argv[2]);
    int nx = m->nx, i, k, rounds = 9;
    double x[4096], r[64], *out = malloc(sizeof(double) * (size_t)(nx * nx + 1)), t[9], sink = 0.0;
    const double *p = m->param_defaults;
    unsigned long s = 12345;
    (void)argc;
    for (i = 0; i < nx; i++) {
        s = s * 6364136223846793005UL + 1442695040888963407UL;
        x[i] = 0.2 + 0.6 * (double)(s >> 11) / 9007199254740992.0;
    }
    for (i = 0; i < 64; i++) r[i] = 0.1;
    for (k = 0; k < rounds; k++) {
        double t0 = now();
        long c;
        for (c = 0; c < calls; c++) {
            if (fn(0.0, x, p, r, out, NULL) != EOMC_OK) return 1;
            sink += out[0];
        }
        t[k] = (now() - t0) / (double)calls;
    }
    qsort(t, (size_t)rounds, sizeof(double), cmp);
    printf("%.3f %g\n", t[rounds / 2], sink);
    free(out);
    return 0;
}
"""


class _Children:
    """CPU seconds and peak RSS of one child process (and its children: gcc's cc1), from
    wait4's rusage."""

    @staticmethod
    def run(argv, cwd=None, env=None, timeout=None):
        import threading
        with tempfile.TemporaryFile("w+") as errfile:
            proc = subprocess.Popen(argv, cwd=cwd, env=env, stdout=subprocess.PIPE,
                                    stderr=errfile, text=True)
            timer = threading.Timer(timeout, proc.kill) if timeout else None
            if timer:
                timer.start()
            out = proc.stdout.read()
            _, status, usage = os.wait4(proc.pid, 0)
            if timer:
                timer.cancel()
            errfile.seek(0)
            err = errfile.read()
        proc.returncode = os.waitstatus_to_exitcode(status)
        if timeout and proc.returncode == -9:
            raise subprocess.TimeoutExpired(argv, timeout)
        if proc.returncode != 0:
            raise RuntimeError(f"{' '.join(map(str, argv))} failed:\n{err}")
        return usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024.0, out


def bicycle_stages(repeat, baseline=None):
    """Per-stage CPU of a cold `eomc` compile of the bicycle, one fresh process each:
    {variant: medians}, the current checkout and (with ``baseline``, a directory holding
    an older ``compiler/`` and ``templates/``) the older generator, interleaved."""
    rows = {"current": [], "baseline": []} if baseline else {"current": []}
    for _ in range(repeat):
        for variant in rows:
            with tempfile.TemporaryDirectory(prefix="bsc_") as tmp:
                env = dict(os.environ, EOMC_CACHE_DIR=os.path.join(tmp, "cache"))
                argv = [sys.executable, "-c", STAGE_RUNNER, str(BICYCLE), os.path.join(tmp, "out")]
                if variant == "baseline":
                    argv.append(str(baseline))
                cpu, rss, out = _Children.run(argv, env=env)
                stages = [float(v) for v in out.split("STAGES", 1)[1].split()]
                rows[variant].append([cpu, rss] + stages)
    return {k: [statistics.median(col) for col in zip(*v)] for k, v in rows.items()}


CART_CLASSIC = ROOT / "benchmarks" / "tree_models" / "cart_rel_kane.py"
FRONT_END_TIMEOUT = 600


def front_end(cases, repeat, baseline):
    """Issue 19: cold `eomc build --formulation recursive --outputs rhs` of a System of joints
    and of the classic frames-and-points file with ``kanes_equations``, in fresh processes
    and caches, the current generator and (where feasible) ``baseline`` interleaved.
    {(label, variant): [(cpu, rss, imports, derive, generate, compile, load), ...]}; a
    baseline run that exceeds FRONT_END_TIMEOUT s is recorded as None."""
    rows = {}
    for _ in range(repeat):
        for label, path, n, with_baseline in cases:
            for variant in ("current", "baseline") if (baseline and with_baseline) else ("current",):
                with tempfile.TemporaryDirectory(prefix="bsc_fe_") as tmp:
                    env = dict(os.environ, EOMC_CACHE_DIR=os.path.join(tmp, "cache"),
                               EOMC_N_LINKS=str(n), EOMC_BENCH_FORMULATION="recursive")
                    argv = [sys.executable, "-c", STAGE_RUNNER, str(path), os.path.join(tmp, "out")]
                    if variant == "baseline":
                        argv.append(str(baseline))
                    try:
                        cpu, rss, out = _Children.run(argv, env=env, timeout=FRONT_END_TIMEOUT)
                        stages = [float(v) for v in out.split("STAGES", 1)[1].split()]
                        rows.setdefault((label, variant), []).append([cpu, rss] + stages)
                    except subprocess.TimeoutExpired:
                        rows.setdefault((label, variant), []).append(None)
                print(label, variant, rows[(label, variant)][-1], flush=True)
    return rows


def front_end_table(rows, baseline):
    out = []
    for (label, variant), runs in rows.items():
        done = [r for r in runs if r is not None]
        name = "current" if variant == "current" else f"baseline {baseline}"
        if not done:
            out.append([label, name, f"> {FRONT_END_TIMEOUT} (killed)", "", "", "", "", "", len(runs)])
            continue
        cpu, rss, imports, derive, generate, compile_, load = [statistics.median(c) for c in zip(*done)]
        out.append([label, name, f"{cpu:.2f}", f"{rss:.0f}", f"{imports:.2f}", f"{derive:.2f}",
                    f"{generate:.2f}", f"{compile_ + load:.2f}", len(done)])
    return format_table(["model", "generator", "total CPU s", "peak RSS MB", "imports",
                         "derive (model file + tree)", "generate", "compile + load", "runs"], out)


def main_front_end(args):
    cases = []
    for n in args.front_end:
        cases.append((f"System of joints n={n}", CART_JOINTS, n, True))
        # the classic file's own kanes_equations took 29 s at n = 40, > 7 min at n = 80
        cases.append((f"frames and points + kanes_equations n={n}", CART_CLASSIC, n, n <= 40))
    with tempfile.TemporaryDirectory(prefix="bsc_base_") as base:
        baseline = extract(args.baseline, Path(base)) if args.baseline else None
        rows = front_end(cases, args.repeat, baseline)
    notes = ["each build: `eomc build MODEL --formulation recursive --outputs rhs` in a fresh process "
             "and cache (the model file runs in 'derive'); medians of the runs",
             "baseline: the older `eomc.compiler` and templates from `git archive` with today's "
             "runtime and facade, interleaved with the current one; the classic file's baseline "
             "at n > 40 is not run (its own kanes_equations alone took > 7 min)"]
    text = [environment_header("Build scaling: the front end of the recursive formulation "
                               "(issue 19)", args, notes),
            "## Cold recursive builds, rhs only", "",
            front_end_table(rows, args.baseline), ""]
    print("\n".join(text))
    write_results(args.out, "\n".join(text))


def extract(commit, directory):
    """``compiler/`` and ``templates/`` of ``commit`` into ``directory`` (git archive)."""
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", commit, "compiler", "templates"],
                             capture_output=True, check=True).stdout
    subprocess.run(["tar", "-x", "-C", str(directory)], input=archive, check=True)
    return directory


def generated(path, n, functions, formulation="kane"):
    """{split?: GeneratedModel} of a model file, derived once, generated unsplit (the split
    threshold out of reach) and split (no generation cache)."""
    from eomc.compiler.emit import split
    from eomc.compiler.model import model_spec
    from eomc.compiler.formulations.select import generate_formulation
    if n is not None:
        os.environ["EOMC_N_LINKS"] = str(n)
    try:
        spec = model_spec(str(path), formulation=formulation)
    finally:
        os.environ.pop("EOMC_N_LINKS", None)
    saved, out = split.SPLIT_MIN, {}
    for split_on in (False, True):
        split.SPLIT_MIN = saved if split_on else 10 ** 9
        try:
            out[split_on] = generate_formulation(spec, functions, False, formulation)
        finally:
            split.SPLIT_MIN = saved
    return out


def write_model(gm, directory):
    directory.mkdir(parents=True, exist_ok=True)
    (directory / f"{gm.name}.c").write_text(gm.c_source)
    (directory / f"{gm.name}.h").write_text(gm.header)
    for name in ("eomc_model.h",):
        (directory / name).write_text((HEADERS / name).read_text())


def gcc_cost(directory, name):
    """(CPU s, peak RSS MB) of one compile.  Measured by /usr/bin/time when present: a
    child forked from this Python process starts with the parent's resident pages, so
    wait4's peak RSS would report Python's size for small compiles."""
    argv = ["gcc", *CFLAGS, "-c", f"{name}.c", "-o", f"{name}.o"]
    if not os.path.exists("/usr/bin/time"):
        return _Children.run(argv, cwd=directory)[:2]
    report = Path(directory) / "time.txt"
    subprocess.run(["/usr/bin/time", "-f", "%U %S %M", "-o", str(report), *argv], cwd=directory,
                   check=True, capture_output=True)
    user, system, kb = report.read_text().split()[-3:]
    return float(user) + float(system), float(kb) / 1024.0


def build_harness(directory, name):
    """Two executables with the same code in two link orders."""
    (directory / "harness.c").write_text(HARNESS.replace("NAME", name))
    exes = []
    for order, files in (("a", ["harness.c", f"{name}.c"]), ("b", [f"{name}.c", "harness.c"])):
        exe = directory / f"bench_{order}"
        subprocess.run(["gcc", *CFLAGS, "-o", str(exe), *files, "-lm"], cwd=directory, check=True)
        exes.append(exe)
    return exes


def ns_per_call(exe, function, calls):
    out = subprocess.run([*PIN, str(exe), function, str(calls)], capture_output=True, text=True,
                         check=True).stdout
    return float(out.split()[0])


def main():
    import argparse
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="*", default=[20, 40],
                    help="links of the shipped absolute-angle cart (Kane, rhs only)")
    ap.add_argument("--rel", type=int, nargs="*", default=[12, 20],
                    help="links of the relative-coordinate cart, Kane (rhs only)")
    ap.add_argument("--rec", type=int, nargs="*", default=[20, 40, 80],
                    help="links of the relative-coordinate cart, recursive formulation (rhs only)")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--stages", type=int, default=3, help="repeats of the bicycle stage timing")
    ap.add_argument("--out", default="build_scaling")
    ap.add_argument("--chunk", type=int, help="override split.CHUNK (to explore)")
    ap.add_argument("--split-min", type=int, help="override split.SPLIT_MIN (to explore)")
    ap.add_argument("--no-bicycle", action="store_true", help="skip the bicycle (stages and gcc)")
    ap.add_argument("--baseline", help="git commit whose generator the bicycle stages are compared "
                                       "with, in the same run (e.g. the commit before the speed-ups)")
    ap.add_argument("--front-end", type=int, nargs="*",
                    help="only the issue-19 front-end rows: cold recursive rhs builds of the System "
                         "of joints and of the classic frames-and-points cart at these n (with "
                         "--baseline: the older generator too, where it finishes in time)")
    args = ap.parse_args()
    if args.front_end:
        return main_front_end(args)
    from eomc.compiler.emit import split
    split.CHUNK = args.chunk or split.CHUNK
    split.SPLIT_MIN = args.split_min or split.SPLIT_MIN
    notes = [f"split thresholds: runs longer than {split.SPLIT_MIN} statements, "
             f"chunks of {split.CHUNK} statements or {split.CHUNK_BYTES // 1000} kB of C",
             f"gcc flags: {' '.join(CFLAGS)} (eomc's defaults)"]
    text = [environment_header("Build scaling: generation and gcc (issue 8, items 4-5)", args, notes)]

    stage_rows = []
    if not args.no_bicycle:
        with tempfile.TemporaryDirectory(prefix="bsc_base_") as base:
            baseline = extract(args.baseline, Path(base)) if args.baseline else None
            stages = bicycle_stages(args.stages, baseline)
        for variant, (cpu, rss, imports, derive, generate, compile_, load) in stages.items():
            label = "current" if variant == "current" else f"baseline {args.baseline}"
            stage_rows.append([label, f"{cpu:.2f}", f"{rss:.0f}", f"{imports:.2f}", f"{derive:.2f}",
                               f"{generate:.2f}", f"{compile_:.2f}", f"{load:.2f}",
                               f"{cpu - imports - derive - generate - compile_ - load:.2f}"])
        text += ["## Whipple bicycle, every function, cold", "",
                 f"Median of {args.stages} fresh processes per variant (fresh caches, variants "
                 "interleaved), CPU seconds (process + children). The baseline runs the older "
                 "`eomc.compiler` and templates from `git archive` with today's runtime and facade.", "",
                 format_table(["generator", "total CPU s", "peak RSS MB", "imports", "derive",
                               "generate", "compile", "load", "rest (interpreter, export)"],
                              stage_rows), ""]

    cases = [(f"cart abs Kane n={n} rhs", CART, n, ["rhs"], "kane") for n in args.n]
    cases += [(f"cart rel Kane n={n} rhs", CART_REL, n, ["rhs"], "kane") for n in args.rel]
    cases += [(f"cart rel recursive n={n} rhs", CART_JOINTS, n, ["rhs"], "recursive")
              for n in args.rec]
    if not args.no_bicycle:
        cases.append(("bicycle all", BICYCLE, None, None, "kane"))
    gcc_rows, ns_rows = [], []
    with tempfile.TemporaryDirectory(prefix="bsc_gcc_") as tmp:
        for label, path, n, functions, formulation in cases:
            variants = {}
            for split_on, gm in generated(path, n, functions, formulation).items():
                d = Path(tmp) / f"{label.replace(' ', '_').replace('=', '')}_{int(split_on)}"
                print(label, "split" if split_on else "unsplit", f"{len(gm.c_source) / 1024:.0f} kB",
                      flush=True)
                write_model(gm, d)
                variants[split_on] = (d, gm)
            costs = {False: [], True: []}
            for _ in range(args.repeat):                      # interleaved
                for split_on in (False, True):
                    d, gm = variants[split_on]
                    costs[split_on].append(gcc_cost(d, gm.name))
            med = {k: (statistics.median(c for c, _ in v), max(r for _, r in v))
                   for k, v in costs.items()}
            size = {k: len(v[1].c_source) / 1024 for k, v in variants.items()}
            parts = variants[True][1].c_source.count("EOMC_NOINLINE void")
            gcc_rows.append([label, f"{size[False]:.0f}", f"{med[False][0]:.2f}", f"{med[False][1]:.0f}",
                             f"{size[True]:.0f}", parts, f"{med[True][0]:.2f}", f"{med[True][1]:.0f}",
                             f"{med[False][0] / med[True][0]:.2f}"])
            print(gcc_rows[-1], flush=True)
            fns = ["rhs"] + (["jac_x"] if functions is None else [])
            exes = {k: build_harness(d, gm.name) for k, (d, gm) in variants.items()}
            for fn in fns:
                probe = ns_per_call(exes[False][0], fn, 100)
                calls = max(50, int(2e7 / max(probe, 1.0)))     # ~20 ms per round
                samples = {(k, o): [] for k in (False, True) for o in (0, 1)}
                for _ in range(args.repeat):
                    for o in (0, 1):
                        for k in (False, True):
                            samples[(k, o)].append(ns_per_call(exes[k][o], fn, calls))
                per = {key: statistics.median(v) for key, v in samples.items()}
                whole = (per[(False, 0)] + per[(False, 1)]) / 2
                cut = (per[(True, 0)] + per[(True, 1)]) / 2
                ns_rows.append([label, fn, f"{per[(False, 0)]:.0f} / {per[(False, 1)]:.0f}",
                                f"{per[(True, 0)]:.0f} / {per[(True, 1)]:.0f}",
                                f"{whole:.0f}", f"{cut:.0f}", f"{cut / whole:.2f}"])
                print(ns_rows[-1], flush=True)
    text += ["## gcc on the generated C: unsplit vs split", "",
             f"`gcc {' '.join(CFLAGS)} -c MODEL.c`; CPU seconds (median of {args.repeat}, "
             "interleaved) and peak RSS (largest of the repeats). Unsplit = the same generator "
             "with the threshold out of reach.", "",
             format_table(["model", "unsplit kB of C", "unsplit gcc CPU s", "unsplit gcc RSS MB",
                           "split kB of C", "sub-functions", "split gcc CPU s", "split gcc RSS MB",
                           "gcc speed-up"], gcc_rows), "",
             "## Run time: ns per call, unsplit vs split", "",
             f"C harness, thread CPU time, `taskset -c 1`, median of 9 rounds per process, "
             f"{args.repeat} processes per layout, interleaved; link orders a = harness first, "
             "b = model first; the mean of the two orders is compared.", "",
             format_table(["model", "function", "unsplit a / b ns", "split a / b ns",
                           "unsplit mean", "split mean", "split / unsplit"], ns_rows), ""]
    path = write_results(args.out, "\n".join(text))
    print("\n".join(text))
    print(path)


if __name__ == "__main__":
    main()
