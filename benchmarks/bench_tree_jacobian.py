"""Issue 8: jac_x of the recursive formulation on the relative-coordinate n-link cart.

For each n:
  * cold builds (fresh cache, derive + generate + gcc, rhs + jac_x, literal parameters)
    in a child process, CPU seconds of the child (user + sys, gcc included), wall beside:
      new:  this checkout, --formulation recursive (tangent of RNEA at the solved u',
            M⁻¹ by the articulated-body recursion; compiler/tree/derivatives.py)
      old:  the same command run on the checkout before that work (--old COMMIT,
            through a shadow copy of its packages): differentiates CRBA's M and RNEA's
            b column by column and solves with an LDLᵀ (up to --old-max links)
      kane: benchmarks/tree_models/cart_rel_kane.py, --formulation kane (up to --kane-max)
  * one C harness per n, pinned to core 1, thread CPU time, contestants interleaved
    (order rotated every round), median of rounds, ns per call of d xdot/dx (nx x nx):
      new jac_x; kane jac_x (when built); Pinocchio's computeABADerivatives compiled
      header-only from the pin/cmeel wheels (benchmarks/tree_models/pin_aba_derivatives.cpp,
      g++ -O2 -std=c++17); central differences of the new rhs (2·nx rhs calls, h = 1e-6·max(1,|x|)).
    The harness first checks every contestant against the new jac_x at 16 states
    (largest difference over the largest entry).
  * Radau at n = --radau-n (default 40): x0 with the first link at 0.5 rad, 2 s, rtol 1e-6,
    atol 1e-9; eomc's C Radau (analytic jac_x), scipy's solve_ivp Radau on the compiled
    rhs with the compiled jac_x and with scipy's own finite-difference Jacobian (jac=None).
    Error: max over the state at t = 2 s against eomc DOP853 at rtol = atol = 1e-12.
    Thread CPU seconds of each run (one run each; pinned).
  * --stiff-radau (alone: skips everything above): the stiff variant
    benchmarks/tree_models/cart_rel_joints_stiff.py (a spring-damper k = 200, c = 300 at every
    pin) at n = --radau-n, built with --formulation recursive; x0: every link at 0.3 rad relative
    to its parent, cart at 3 m/s; 1 s, rtol 1e-6, atol 1e-9; eomc's C Radau (analytic jac_x),
    scipy Radau with the compiled jac_x and with finite differences, eomc's DOP853 (its
    stiffness detector may stop it; the row then says where) and DOP853 with the detector off.  Error: max over the state at
    t = 1 s against eomc's Radau at rtol 1e-10, atol 1e-12.  Median thread CPU of --rounds
    (default 5) interleaved rounds, order rotated, pinned to core 1.  With --write its table is
    appended to results/tree_jacobian.md as a new section.
Usage: python benchmarks/bench_tree_jacobian.py [n ...] [--kane-max N] [--old-max N]
       [--old COMMIT] [--radau-n N] [--write]     (--write: results/tree_jacobian.md)
       python benchmarks/bench_tree_jacobian.py --stiff-radau [--radau-n N] [--rounds R] [--write]
"""
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
MODELS = HERE / "tree_models"
ROOT = HERE.parent
OLD_COMMIT = "2f1cd74"      # main before the O(n^2) jac_x

from common import C_CLOCK_AND_RNG  # noqa: E402

HARNESS = r"""
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
@INCLUDES@
#define NX @NX@
#define NQ @NQ@
#ifdef WITH_PIN
void pin_setup(int nl, double m0, double m, double l, double g);
void pin_jac(const double *q, const double *v, const double *tau, double *out);
static double pin_tau[NQ];
static void p_jac(const double *x, const double *r, double *out) {
    pin_tau[0] = r[0];
    pin_jac(x, x + NQ, pin_tau, out);
}
#endif
static void fd_jac(const double *x, const double *r, double *out) {
    double xp[NX], fp[NX], fm[NX];
    int i, j;
    memcpy(xp, x, sizeof xp);
    for (j = 0; j < NX; j++) {
        double h = 1e-6 * (fabs(x[j]) > 1.0 ? fabs(x[j]) : 1.0);
        xp[j] = x[j] + h; @RHS@(0.0, xp, NULL, r, fp, NULL);
        xp[j] = x[j] - h; @RHS@(0.0, xp, NULL, r, fm, NULL);
        xp[j] = x[j];
        for (i = 0; i < NX; i++) out[i * NX + j] = (fp[i] - fm[i]) / (2.0 * h);
    }
}
""" + C_CLOCK_AND_RNG + r"""#define NS 64
static double X[NS][NX], out[NX * NX], ref[NX * NX];
int main(void) {
    const int nc = @NC@;
    double r[1] = {1.3}, worst[8] = {0.0}, sum = 0.0;
    int i, k, c, round;
#ifdef WITH_PIN
    pin_setup(NQ - 1, 2.0, 0.5, 0.75, 9.81);
#endif
    for (i = 0; i < NS; i++) for (k = 0; k < NX; k++)
        X[i][k] = k < NQ ? (k == 0 ? 2 * rnd() - 1 : 3.14159265358979 * (2 * rnd() - 1)) : 2 * rnd() - 1;
    for (i = 0; i < 16; i++) {
        double big = 1.0, d;
        @FIRST@(0.0, X[i], NULL, r, ref, NULL);
        for (k = 0; k < NX * NX; k++) if (fabs(ref[k]) > big) big = fabs(ref[k]);
        for (c = 1; c < nc; c++) {
            @CALLC@
            for (k = 0; k < NX * NX; k++) { d = fabs(out[k] - ref[k]) / big; if (d > worst[c]) worst[c] = d; }
        }
    }
    for (c = 1; c < nc; c++) printf("agree %d %.3g\n", c, worst[c]);
    for (round = 0; round < @ROUNDS@; round++) {
        for (c = 0; c < nc; c++) {
            int cc = (c + round) % nc; long calls = 0; double t0 = tnow(), t1;
            do { for (i = 0; i < NS; i++) { @CALL@ sum += out[NQ * NX]; } calls += NS; t1 = tnow(); }
            while (t1 - t0 < 5e7);
            printf("time %d %.1f\n", cc, (t1 - t0) / calls);
        }
    }
    printf("checksum %g\n", sum);
    return 0;
}
"""


def old_package(commit, tmp):
    """A directory to put first on PYTHONPATH so ``python -m eomc`` runs ``commit``'s compiler
    and facade (the runtime, unchanged by the jac_x work and holding built extensions, is this
    checkout's)."""
    src = tmp / f"old_{commit}"
    src.mkdir()
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", commit], capture_output=True, check=True)
    subprocess.run(["tar", "-x", "-C", str(src)], input=archive.stdout, check=True)
    pkg = tmp / f"oldpkg_{commit}"
    shutil.copytree(src / "facade", pkg / "eomc")
    for sub, where in (("compiler", src), ("templates", src), ("runtime", ROOT)):
        (pkg / "eomc" / sub).symlink_to(where / sub)
    return pkg


def cold_build(model, n, formulation, outdir, pythonpath=None):
    sys.path.insert(0, str(HERE))
    from common import cold_build as build
    cpu, wall, meta, _ = build(model, n, formulation, outdir, "rhs,jac_x", pythonpath)
    ops = {f: sum(meta["op_counts"][f].values()) for f in ("rhs", "jac_x")}
    return {"cpu": cpu, "wall": wall, "ops": ops["jac_x"], "rhs_ops": ops["rhs"], "meta": meta,
            "dir": outdir}


_PIN = []


def pinocchio_object(tmp):
    """pin_aba_derivatives.o compiled once from the wheels' headers, or None."""
    if not _PIN:
        sys.path.insert(0, str(HERE))
        from common import compile_pinocchio
        _PIN.append(compile_pinocchio(MODELS / "pin_aba_derivatives.cpp", tmp / "pin_jac.o",
                                      extra_includes=[MODELS]))
    return _PIN[0]


def timing(new, kane, n, tmp, rounds=7):
    """{label: median ns}, {label: agreement with new}."""
    builds = [("new", new)] + ([("kane", kane)] if kane else [])
    incs = "\n".join(f'#include "{b["dir"]}/{b["meta"]["name"]}.c"' for _, b in builds)
    calls = [(label, f'{b["meta"]["name"]}_jac_x(0.0, X[i], NULL, r, out, NULL);') for label, b in builds]
    pin = pinocchio_object(tmp)
    if pin:
        calls.append(("pinocchio", "p_jac(X[i], r, out);"))
    calls.append(("central differences", "fd_jac(X[i], r, out);"))
    case = lambda var: ("switch (" + var + ") {" + " ".join(f"case {k}: {c} break;" for k, (_, c)
                                                           in enumerate(calls)) + "}")
    src = (HARNESS.replace("@INCLUDES@", incs).replace("@NX@", str(2 * (n + 1)))
           .replace("@NQ@", str(n + 1)).replace("@NC@", str(len(calls)))
           .replace("@FIRST@", f'{new["meta"]["name"]}_jac_x').replace("@RHS@", f'{new["meta"]["name"]}_rhs')
           .replace("@CALLC@", case("c")).replace("@CALL@", case("cc")).replace("@ROUNDS@", str(rounds)))
    c = tmp / f"hj{n}.c"
    c.write_text(src)
    exe, obj = tmp / f"hj{n}", tmp / f"hj{n}.o"
    inc = [f"-I{b['dir']}" for _, b in builds] + [f"-I{ROOT / 'runtime' / 'c'}"]
    subprocess.run(["gcc", "-O2", "-std=c99", *inc, *(["-DWITH_PIN"] if pin else []), "-c", str(c),
                    "-o", str(obj)], check=True)
    subprocess.run(["g++" if pin else "gcc", str(obj), *([str(pin)] if pin else []), "-o", str(exe),
                    "-lm"], check=True)
    out = subprocess.run(["taskset", "-c", "1", str(exe)], capture_output=True, text=True,
                         check=True).stdout
    labels = [label for label, _ in calls]
    agree = {labels[int(line.split()[1])]: float(line.split()[2]) for line in out.splitlines()
             if line.startswith("agree ")}
    times = {}
    for line in out.splitlines():
        if line.startswith("time"):
            _, k, v = line.split()
            times.setdefault(labels[int(k)], []).append(float(v))
    return {k: sorted(v)[len(v) // 2] for k, v in times.items()}, agree


def radau(new, n):
    """Rows (label, steps, jac evaluations, rhs evaluations, error, thread CPU s)."""
    import eomc
    from scipy.integrate import solve_ivp
    os.sched_setaffinity(0, {1})
    model = eomc.load(new["dir"])
    x0 = np.zeros(model.nx)
    x0[1] = 0.5
    T = 2.0
    ref = model.simulate(x0, (0.0, T), method="dop853", rtol=1e-12, atol=1e-12, n_points=2)
    xref = np.asarray(ref.x)[-1]
    rows = []
    t0 = time.thread_time()
    res = model.simulate(x0, (0.0, T), method="radau", rtol=1e-6, atol=1e-9, n_points=2)
    cpu = time.thread_time() - t0
    st = res.stats
    rows.append(("eomc simulate, C Radau, compiled jac_x", st["steps"], st["njev"], st["nfev"],
                 float(np.max(np.abs(np.asarray(res.x)[-1] - xref))), cpu))
    r = np.zeros(model.ninput)
    fun = lambda t, x: model.rhs(t, x, r=r)
    for label, jac in (("scipy solve_ivp Radau, compiled jac_x", lambda t, x: model.jacobian(t, x, r=r)),
                       ("scipy solve_ivp Radau, finite-difference Jacobian (jac=None)", None)):
        t0 = time.thread_time()
        sol = solve_ivp(fun, (0.0, T), x0, method="Radau", rtol=1e-6, atol=1e-9, jac=jac)
        cpu = time.thread_time() - t0
        assert sol.success, sol.message
        rows.append((label, sol.t.size - 1, sol.njev, sol.nfev,
                     float(np.max(np.abs(sol.y[:, -1] - xref))), cpu))
    return rows


STIFF_BUILD = """
import sys
import eomc.compiler.emit.split as split
split.SPLIT_MIN = 10 ** 9
from eomc.cli import main
sys.exit(main(sys.argv[1:]))
"""


def stiff_build(n, outdir):
    """Build the stiff cart (rhs + jac_x, literal parameters) in a child process with the body
    splitting of compiler/emit/split.py turned off: at n >= 12 the split jac_x of this model
    does not compile (a temporary declared in the looped column body is renamed to a scratch
    slot of an earlier split run, ``const double S_[84] = ...``); the unsplit body does."""
    env = dict(os.environ, EOMC_N_LINKS=str(n), EOMC_CACHE_DIR=tempfile.mkdtemp(prefix="eomc_tj_"))
    proc = subprocess.run([sys.executable, "-c", STIFF_BUILD, "build",
                           str(MODELS / "cart_rel_joints_stiff.py"), "-o", str(outdir),
                           "--fold-parameters", "--outputs", "rhs,jac_x", "--formulation",
                           "recursive", "-q"], env=env, capture_output=True, text=True)
    if proc.returncode:
        raise RuntimeError(proc.stderr[-3000:])
    return outdir


def stiff_radau(outdir, rounds=5):
    """(rows, info): rows (label, steps, Jacobian evaluations, rhs evaluations, error, median
    thread CPU s, note), info: stiffness ratio and the reference's stats."""
    import eomc
    from scipy.integrate import solve_ivp
    os.sched_setaffinity(0, {1})
    model = eomc.load(outdir)
    nq = model.nq
    x0 = np.zeros(model.nx)
    x0[1:nq] = 0.3
    x0[nq] = 3.0
    T, r = 1.0, np.zeros(model.ninput)
    lam = np.abs(np.linalg.eigvals(model.jacobian(0.0, x0, r=r)))
    info = {"ratio": lam.max() / lam[lam > 1e-6].min(), "lam_max": lam.max(),
            "lam_min": lam[lam > 1e-6].min()}
    ref = model.simulate(x0, (0.0, T), method="radau", rtol=1e-10, atol=1e-12, n_points=2)
    xref = np.asarray(ref.x)[-1]
    info["ref"] = ref.stats

    def eomc_run(method, stiff_check=True):
        res = model.simulate(x0, (0.0, T), method=method, rtol=1e-6, atol=1e-9, n_points=2,
                             max_steps=10 ** 6, raise_on_failure=False, stiff_check=stiff_check)
        st = res.stats
        note = "" if st["status"] == 0 else (f"stopped at t = {st['t']:.3f} s (status {st['status']}): "
                                             f"stiffness detected, h·|λ| ≈ {st['stiff_hlambda']:.1f}"
                                             if st["stiff_hlambda"] else
                                             f"stopped at t = {st['t']:.3f} s (status {st['status']})")
        err = float(np.max(np.abs(np.asarray(res.x)[-1] - xref))) if st["status"] == 0 else None
        return st["steps"], st["njev"], st["nfev"], err, note

    def scipy_run(jac):
        calls = [0]     # scipy's nfev leaves out the rhs calls of its finite differences

        def counted(t, x):
            calls[0] += 1
            return model.rhs(t, x, r=r)
        sol = solve_ivp(counted, (0.0, T), x0, method="Radau", rtol=1e-6, atol=1e-9, jac=jac)
        assert sol.success, sol.message
        return (sol.t.size - 1, sol.njev, calls[0], float(np.max(np.abs(sol.y[:, -1] - xref))),
                f"scipy nfev {sol.nfev}" if sol.nfev != calls[0] else "")

    runs = [("eomc simulate, C Radau, compiled jac_x", lambda: eomc_run("radau")),
            ("scipy solve_ivp Radau, compiled jac_x",
             lambda: scipy_run(lambda t, x: model.jacobian(t, x, r=r))),
            ("scipy solve_ivp Radau, finite-difference Jacobian (jac=None)", lambda: scipy_run(None)),
            ("eomc simulate, C DOP853 (explicit)", lambda: eomc_run("dop853")),
            ("eomc simulate, C DOP853, stiff_check=False", lambda: eomc_run("dop853", False))]
    times, results = {label: [] for label, _ in runs}, {}
    for k in range(rounds):
        for label, run in runs[k % len(runs):] + runs[:k % len(runs)]:
            t0 = time.thread_time()
            results[label] = run()
            times[label].append(time.thread_time() - t0)
    rows = [(label, *results[label][:4], sorted(times[label])[len(times[label]) // 2],
             results[label][4]) for label, _ in runs]
    return rows, info


def stiff_table(rows, info, n, rounds):
    ref = info["ref"]
    base = rows[0][5]
    lines = [f"Stiff variant (cart_rel_joints_stiff.py: spring k = 200 N·m/rad and damper c = 300 "
             f"N·m·s/rad at every pin) at n = {n} ({2 * (n + 1)} states): links at 0.3 rad, cart at "
             f"3 m/s, 1 s, rtol 1e-6, atol 1e-9. Eigenvalues of jac_x at x0: |λ| from "
             f"{info['lam_min']:.3g} to {info['lam_max']:.4g} 1/s (stiffness ratio "
             f"{info['ratio']:.1e}). Error = max |x(1) - x_ref(1)| against eomc's Radau at rtol "
             f"1e-10, atol 1e-12 ({ref['steps']} steps, {ref['njev']} Jacobians). Thread CPU: "
             f"median of {rounds} interleaved rounds, pinned to core 1. rhs evaluations count every "
             f"call, finite differences included (scipy's own nfev leaves those out; it is given "
             f"in the note).", "",
             "| integrator and Jacobian | steps | Jacobian evaluations | rhs evaluations | error | "
             "thread CPU s | CPU / eomc Radau | note |", "|:--|--:|--:|--:|--:|--:|--:|:--|"]
    for label, steps, njev, nfev, err, cpu, note in rows:
        lines.append(f"| {label} | {steps} | {njev} | {nfev} | {_f(err, '{:.1e}')} | {cpu:.4f} | "
                     f"{cpu / base:.2f} | {note} |")
    return "\n".join(lines)


def stiff_main(n, rounds, write):
    start_load = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    tmp = Path(tempfile.mkdtemp(prefix="bench_tree_jac_stiff_"))
    t0 = time.perf_counter()
    outdir = stiff_build(n, tmp / f"stiff{n}")
    print(f"built the stiff cart n={n} in {time.perf_counter() - t0:.1f} s wall", flush=True)
    rows, info = stiff_radau(outdir, rounds)
    text = stiff_table(rows, info, n, rounds)
    print(text)
    if write:
        import datetime
        import scipy
        commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
                                capture_output=True, text=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "--",
                                "benchmarks", "compiler", "runtime", "facade", "templates"],
                               capture_output=True, text=True).stdout.strip()
        now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
        head = ["## Stiff Radau case (issue 8), `bench_tree_jacobian.py --stiff-radau --write`", "",
                f"- date: {now}; commit {commit}{' (with uncommitted benchmark edits)' if dirty else ''}",
                f"- uptime at start: {start_load}",
                "- the machine was heavily loaded (several agents building and testing on 2 cores); "
                "times are thread CPU time",
                f"- python {sys.version.split()[0]}, numpy {np.__version__}, scipy {scipy.__version__}",
                "- built with compiler/emit/split.py's body splitting off (see stiff_build: the split "
                "jac_x of this model does not compile at n >= 12)", ""]
        md = HERE / "results" / "tree_jacobian.md"
        old = md.read_text()
        md.write_text(old.rstrip("\n") + "\n\n" + "\n".join(head) + "\n" + text + "\n")
        print(f"appended to {md}")


def _opt(argv, flag, default, conv=int):
    if flag in argv:
        i = argv.index(flag)
        value = conv(argv[i + 1])
        del argv[i:i + 2]
        return value
    return default


def main(argv):
    argv = list(argv)
    write = "--write" in argv
    argv = [a for a in argv if a != "--write"]
    kane_max = _opt(argv, "--kane-max", 8)
    old_max = _opt(argv, "--old-max", 20)
    old_commit = _opt(argv, "--old", OLD_COMMIT, str)
    radau_n = _opt(argv, "--radau-n", 40)
    if "--stiff-radau" in argv:
        argv.remove("--stiff-radau")
        rounds = _opt(argv, "--rounds", 5)
        if argv:
            raise SystemExit(f"--stiff-radau takes only --radau-n, --rounds and --write, not {argv}")
        return stiff_main(radau_n, rounds, write)
    start_load = " ".join(f"{v:.2f}" for v in os.getloadavg())
    ns = [int(a) for a in argv] or [4, 8, 12, 20, 40]
    tmp = Path(tempfile.mkdtemp(prefix="bench_tree_jac_"))
    oldpkg = old_package(old_commit, tmp) if old_max > 0 else None
    rows, radau_rows = [], None
    for n in ns:
        cells = {}
        cells["new"] = cold_build(MODELS / "cart_rel_joints.py", n, "recursive", tmp / f"new{n}")
        if oldpkg and n <= old_max:
            cells["old"] = cold_build(MODELS / "cart_rel_joints.py", n, "recursive", tmp / f"old{n}",
                                      pythonpath=oldpkg)
        if n <= kane_max:
            cells["kane"] = cold_build(MODELS / "cart_rel_kane.py", n, "kane", tmp / f"kane{n}")
        for k, v in cells.items():
            print(f"n={n} {k}: build {v['cpu']:.2f} s CPU ({v['wall']:.2f} s wall), jac_x ops {v['ops']}, "
                  f"rhs ops {v['rhs_ops']}", flush=True)
        med, agree = timing(cells["new"], cells.get("kane"), n, tmp)
        print(f"n={n}: " + ", ".join(f"{k} {v:.0f} ns" for k, v in med.items()) + f"; agree {agree}",
              flush=True)
        rows.append((n, cells, med, agree))
        if n == radau_n:
            radau_rows = radau(cells["new"], n)
            for row in radau_rows:
                print(row, flush=True)
    text = tables(rows, radau_rows, radau_n)
    print(text)
    if write:
        write_up(text, start_load, old_commit)


def _f(x, fmt="{:.0f}"):
    return "-" if x is None else fmt.format(x)


def tables(rows, radau_rows, radau_n):
    head = ("| n | nx | new jac_x ops | old jac_x ops | kane jac_x ops | rhs ops | new/(nx·rhs) | "
            "build CPU s (wall): new | old | kane |")
    lines = ["Operation counts (adds + muls + divs + calls; the looped columns counted once per "
             "column) and cold builds of rhs + jac_x:", "", head, "|" + "--:|" * (head.count("|") - 1)]
    for n, cells, _, _ in rows:
        nx = 2 * (n + 1)
        new = cells["new"]
        b = lambda k: (f"{cells[k]['cpu']:.1f} ({cells[k]['wall']:.1f})" if k in cells else "-")
        lines.append(f"| {n} | {nx} | {new['ops']} | {_f(cells.get('old', {}).get('ops'))} | "
                     f"{_f(cells.get('kane', {}).get('ops'))} | {new['rhs_ops']} | "
                     f"{new['ops'] / (nx * new['rhs_ops']):.2f} | {b('new')} | {b('old')} | {b('kane')} |")
    head = ("| n | new jac_x ns | kane jac_x ns | Pinocchio computeABADerivatives ns | "
            "central differences ns | Pinocchio/new | differences/new | kane/new | "
            "max diff vs new: kane / Pinocchio / differences |")
    lines += ["", "d xdot/dx per call (thread CPU ns, median of 7 interleaved rounds, pinned to core 1):",
              "", head, "|" + "--:|" * (head.count("|") - 1)]
    for n, cells, med, agree in rows:
        nw = med["new"]
        ratio = lambda k: f"{med[k] / nw:.2f}" if k in med else "-"
        lines.append(f"| {n} | {nw:.0f} | {_f(med.get('kane'))} | {_f(med.get('pinocchio'))} | "
                     f"{_f(med.get('central differences'))} | {ratio('pinocchio')} | "
                     f"{ratio('central differences')} | {ratio('kane')} | "
                     + " / ".join(_f(agree.get(k), "{:.1e}") for k in ("kane", "pinocchio",
                                                                      "central differences")) + " |")
    if radau_rows:
        lines += ["", f"Radau at n = {radau_n} ({2 * (radau_n + 1)} states), 2 s, rtol 1e-6, atol 1e-9; "
                  "error = max |x(2) - x_ref(2)| against DOP853 at 1e-12:", "",
                  "| integrator and Jacobian | steps | Jacobian evaluations | rhs evaluations | error | "
                  "thread CPU s |", "|:--|--:|--:|--:|--:|--:|"]
        for label, steps, njev, nfev, err, cpu in radau_rows:
            lines.append(f"| {label} | {steps} | {njev} | {nfev} | {err:.1e} | {cpu:.3f} |")
    return "\n".join(lines)


def write_up(text, start_load, old_commit):
    sys.path.insert(0, str(HERE))
    from common import environment_header, peer_versions, write_results
    versions = peer_versions(("pinocchio", "scipy"))
    end_load = " ".join(f"{v:.2f}" for v in os.getloadavg())
    notes = [f"load average at start: {start_load}, at the end: {end_load} (a shared 2-core machine, "
             f"other jobs building and testing beside this run): call times are thread CPU time, "
             f"builds are CPU seconds of the build process and its gcc, with wall beside them",
             "peers: " + ", ".join(versions) + "; old = eomc at " + old_commit]
    header = environment_header("Joint trees: jac_x of the recursive formulation, relative-coordinate "
                                "n-link cart", notes=notes)
    print(write_results("tree_jacobian", header + "\n" + (__doc__ or "") + "\n" + text + "\n"))


if __name__ == "__main__":
    main(sys.argv[1:])
