"""Issue 8: the recursive formulation vs Kane's on the relative-coordinate n-link cart.

For each n: a cold build (fresh cache; derive + generate + gcc, rhs only, literal
parameters) in a child process, timed in CPU seconds (user+sys of the child) and
wall; then one C harness per n linking both generated rhs functions, timed in
thread CPU time, contestants interleaved, pinned to core CORE (0), median of rounds.
  kane:      benchmarks/tree_models/cart_rel_kane.py (hand-built frames, sum-of-angles,
             the performance report's n_link_cart_rel.py), --formulation kane
  recursive: benchmarks/tree_models/cart_rel_joints.py (SymPy System of joints, no
             form_eoms), --formulation recursive
Same states (q0..qn relative, u = q'), same parameters; the harness checks the two
rhs agree before timing.  Peer in the same executable, when the `mujoco` wheel is installed:
MuJoCo's mj_forward through its C API (libmujoco from the wheel), qpos/qvel copied in and the
cart force in qfrc_applied, qacc out (benchmarks/tree_models/cart_mjcf.py); and, when the `pin`
and `cmeel-eigen` wheels are installed, Pinocchio's ABA compiled header-only from their headers
(benchmarks/tree_models/pin_aba.cpp, the performance report's harness; g++ -O2 -std=c++17).
Usage: python benchmarks/bench_tree.py [n ...] [--kane-max N] [--write]  (--write: results/tree.md)
"""
import os
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
MODELS = HERE / "tree_models"
ROOT = HERE.parent
CORE = 0          # session 8: helpers pin by task (this one: core 0)

from common import C_CLOCK_AND_RNG  # noqa: E402

# the harness #includes the generated C: compiled with eomc's default flags on this machine
# (-O2, plus -mavx2 -ffp-contract=off on AVX2; benchmarks/results/machine_flags.md)
def _lib_flags():
    from eomc.compiler.build import DEFAULT_CFLAGS, find_compiler
    from eomc.compiler.build.toolchain import machine_flags
    return [*DEFAULT_CFLAGS, *machine_flags(find_compiler())]


LIB_FLAGS = _lib_flags()

HARNESS = r"""
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
@INCLUDES@
#ifdef WITH_MUJOCO
#include <mujoco/mujoco.h>
static mjModel *mjm; static mjData *mjd;
static void mj_rhs(const double *x, const double *r, double *out, int nq) {
    int k;
    for (k = 0; k < nq; k++) { mjd->qpos[k] = x[k]; mjd->qvel[k] = x[nq + k]; out[k] = x[nq + k]; }
    mjd->qfrc_applied[0] = r[0];
    mj_forward(mjm, mjd);
    for (k = 0; k < nq; k++) out[nq + k] = mjd->qacc[k];
}
#endif
#ifdef WITH_PIN
void pin_setup(int nl, double m0, double m, double l, double g);
void pin_rhs(const double *q, const double *v, const double *tau, double *a);
static double pin_tau[@NX@];
static void p_rhs(const double *x, const double *r, double *out, int nq) {
    int k;
    pin_tau[0] = r[0];
    for (k = 0; k < nq; k++) out[k] = x[nq + k];
    pin_rhs(x, x + nq, pin_tau, out + nq);
}
#endif
""" + C_CLOCK_AND_RNG + r"""#define NS 1024
int main(int argc, char **argv) {
    const int nx = @NX@, nq = @NQ@, nc = @NC@;
    static double X[NS][@NX@], out[@NX@], ref[@NX@];
    double r[1] = {1.3}, worst[8] = {0.0}, sum = 0.0;
    int i, k, c, round;
#ifdef WITH_MUJOCO
    char err[1000];
    mjm = mj_loadXML(argv[1], NULL, err, sizeof err);
    if (!mjm) { printf("mujoco: %s\n", err); return 1; }
    mjd = mj_makeData(mjm);
#endif
    (void)argc; (void)argv;
#ifdef WITH_PIN
    pin_setup(nq - 1, 2.0, 0.5, 0.75, 9.81);
#endif
    for (i = 0; i < NS; i++) for (k = 0; k < nx; k++)
        X[i][k] = k < nq ? (k == 0 ? 2 * rnd() - 1 : 3.14159265358979 * (2 * rnd() - 1)) : 2 * rnd() - 1;
    for (i = 0; i < 64; i++) {
        @FIRST@(0.0, X[i], NULL, r, ref, NULL);
        for (c = 1; c < nc; c++) {
            @CALLC@
            for (k = 0; k < nx; k++) { double d = fabs(out[k] - ref[k]) / (fabs(ref[k]) > 1 ? fabs(ref[k]) : 1);
                if (d > worst[c]) worst[c] = d; }
        }
    }
    for (c = 1; c < nc; c++) printf("agree %d %.3g\n", c, worst[c]);
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
    sys.path.insert(0, str(HERE))
    from common import cold_build as build
    return build(model, n, formulation, outdir, "rhs")


def _mujoco():
    try:
        import mujoco
    except ImportError:
        return None
    d = Path(mujoco.__file__).parent
    lib = sorted(d.glob("libmujoco.so*"))
    return (d / "include", lib[0], mujoco.__version__) if lib and (d / "include").is_dir() else None


_PIN = []


def _pinocchio(tmp):
    """pin_aba.o compiled once from the wheels' headers, or None."""
    if not _PIN:
        sys.path.insert(0, str(HERE))
        from common import compile_pinocchio
        _PIN.append(compile_pinocchio(MODELS / "pin_aba.cpp", tmp / "pin_aba.o"))
    return _PIN[0]


def timing(builds, n, tmp, rounds):
    nx, nq = 2 * (n + 1), n + 1
    incs = "\n".join(f'#include "{d}/{m["name"]}.c"' for d, m in builds)
    names = [m["name"] for _, m in builds]
    calls = [f"{nm}_rhs(0.0, X[i], NULL, r, out, NULL);" for nm in names]
    mj = _mujoco()
    if mj:
        calls.append("mj_rhs(X[i], r, out, nq);")
    pin = _pinocchio(tmp)
    if pin:
        calls.append("p_rhs(X[i], r, out, nq);")
    call = "switch (cc) {" + " ".join(f"case {k}: {c} break;" for k, c in enumerate(calls)) + "}"
    callc = "switch (c) {" + " ".join(f"case {k}: {c} break;" for k, c in enumerate(calls)) + "}"
    src = (HARNESS.replace("@INCLUDES@", incs).replace("@NX@", str(nx)).replace("@NQ@", str(nq))
           .replace("@NC@", str(len(calls))).replace("@FIRST@", f"{names[0]}_rhs")
           .replace("@CALLC@", callc).replace("@CALL@", call).replace("@ROUNDS@", str(rounds)))
    c = tmp / f"h{n}.c"
    c.write_text(src)
    exe = tmp / f"h{n}"
    inc = [f"-I{d}" for d, _ in builds] + [f"-I{ROOT / 'runtime' / 'c'}"]
    extra, libs, args = [], [], []
    if mj:
        sys.path.insert(0, str(MODELS))
        from cart_mjcf import mjcf
        xml = tmp / f"cart{n}.xml"
        xml.write_text(mjcf(n))
        extra = ["-DWITH_MUJOCO", f"-I{mj[0]}"]
        libs = [str(mj[1]), f"-Wl,-rpath,{mj[1].parent}"]
        args = [str(xml)]
    if pin:
        extra.append("-DWITH_PIN")
    obj = tmp / f"h{n}.o"
    subprocess.run(["gcc", *LIB_FLAGS, *inc, *extra, "-c", str(c), "-o", str(obj)], check=True)
    subprocess.run(["g++" if pin else "gcc", str(obj), *([str(pin)] if pin else []), *libs,
                    "-o", str(exe), "-lm"], check=True)
    out = subprocess.run(["taskset", "-c", str(CORE), str(exe), *args], capture_output=True, text=True,
                         check=True).stdout
    agree = {int(line.split()[1]): float(line.split()[2]) for line in out.splitlines()
             if line.startswith("agree ")}
    times = {}
    for line in out.splitlines():
        if line.startswith("time"):
            _, k, v = line.split()
            times.setdefault(int(k), []).append(float(v))
    med = {k: sorted(v)[len(v) // 2] for k, v in times.items()}
    return agree, med


def main(argv):
    write = "--write" in argv
    argv = [a for a in argv if a != "--write"]
    start_load = " ".join(f"{v:.2f}" for v in os.getloadavg())
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
        agree_by, med = timing(builds, n, tmp, rounds=7)
        for k, (_, meta) in enumerate(builds):
            label = "recursive" if meta["name"].startswith("cartjoints") else "kane"
            cells[label]["ns"] = med[k]
        peers = [p for p, on in (("mujoco", _mujoco()), ("pinocchio", _PIN and _PIN[0])) if on]
        for k, peer in enumerate(peers):
            cells[peer] = {"ns": med[len(builds) + k]}
        labels = ["recursive" if m["name"].startswith("cartjoints") else "kane" for _, m in builds] + peers
        agree = {labels[k]: v for k, v in agree_by.items()}
        print(f"n={n}: agree {agree}; " + ", ".join(f"{k} {v['ns']:.0f} ns" for k, v in cells.items()),
              flush=True)
        rows.append((n, cells, agree))
    table = table_text(rows)
    print(table)
    if write:
        write_up(rows, table, start_load)
    return table


SDFAST_ON_OPS = {4: 838, 8: 1834, 12: 2830, 20: 4822, 40: 9802}   # issue 8: its printed counts


def write_up(rows, table, start_load):
    sys.path.insert(0, str(HERE))
    from common import environment_header, peer_versions, write_results
    versions = peer_versions(("mujoco", "pinocchio"))
    end_load = " ".join(f"{v:.2f}" for v in os.getloadavg())
    notes = [f"load average at start: {start_load}, at the end: {end_load} (a shared 2-core machine, "
             f"other jobs building and testing beside this run): rhs times are thread CPU time, "
             f"builds are CPU seconds of the build process with wall beside them",
             "peers: " + ", ".join(versions) + " (MuJoCo prebuilt library through its C API; "
             "Pinocchio header-only, g++ -O2 -std=c++17)"]
    ops = ["", "Operation counts of rhs (adds + muls + divs + calls) against SD/FAST O(N)'s printed "
           "count for sdstate + sdderiv (quoted from issue 8, not run here):", "",
           "| n | recursive | SD/FAST O(N) | recursive / SD/FAST |", "|--:|--:|--:|--:|"]
    for n, cells, _ in rows:
        sd = SDFAST_ON_OPS.get(n)
        ops.append(f"| {n} | {cells['recursive']['ops']} | {sd or '-'} | "
                   f"{cells['recursive']['ops'] / sd:.2f} |" if sd else
                   f"| {n} | {cells['recursive']['ops']} | - | - |")
    notes.append(f"generated C and harness compiled together with eomc's default flags on this machine: "
                 f"{' '.join(LIB_FLAGS)}")
    text = (environment_header("Joint trees: recursive vs Kane formulation, relative-coordinate n-link "
                               "cart", notes=notes) + "\n" + (__doc__ or "") + "\n" + table + "\n"
            + "\n".join(ops) + "\n" + growth(rows) + "\n")
    print(write_results("tree", text, keep_notes=True))


def growth(rows):
    """Issue 31 item 4: the exponent of a least-squares fit of log(recursive rhs time) against log n
    (n >= 8, where the constant part no longer dominates), and the same for the operation count."""
    import numpy as np
    pts = [(n, c["recursive"]["ns"], c["recursive"]["ops"]) for n, c, _ in rows if n >= 8 and "ns" in c["recursive"]]
    if len(pts) < 2:
        return ""
    n, ns, ops = (np.log([p[k] for p in pts]) for k in range(3))
    t_exp, o_exp = float(np.polyfit(n, ns, 1)[0]), float(np.polyfit(n, ops, 1)[0])
    line = (f"\nGrowth of the recursive rhs, n = {', '.join(str(p[0]) for p in pts)} (least-squares fit of "
            f"log against log n): time ~ n^{t_exp:.3f}, operations ~ n^{o_exp:.3f} (issue 31's target: "
            f"time no faster than n^1.05)")
    print(line)
    return line


def _cell(cells, label, key, fmt="{:.0f}"):
    return fmt.format(cells[label][key]) if label in cells and key in cells[label] else "-"


def table_text(rows):
    head = ("| n | recursive ops | kane ops | recursive rhs ns | kane rhs ns | MuJoCo mj_forward ns | "
            "Pinocchio ABA ns | kane/recursive | MuJoCo/recursive | Pinocchio/recursive | "
            "recursive build CPU s (wall) | "
            "kane build CPU s (wall) | rel. diff of u' from recursive: kane / MuJoCo / Pinocchio |")
    lines = [head, "|" + "--:|" * (head.count("|") - 1)]
    for n, cells, agree in rows:
        r = cells["recursive"]
        kr = f"{cells['kane']['ns'] / r['ns']:.2f}" if "kane" in cells else "-"
        mr = f"{cells['mujoco']['ns'] / r['ns']:.2f}" if "mujoco" in cells else "-"
        pr = f"{cells['pinocchio']['ns'] / r['ns']:.2f}" if "pinocchio" in cells else "-"
        kb = (f"{cells['kane']['cpu']:.2f} ({cells['kane']['wall']:.2f})" if "kane" in cells else "-")
        lines.append(f"| {n} | {r['ops']} | {_cell(cells, 'kane', 'ops')} | {r['ns']:.0f} | "
                     f"{_cell(cells, 'kane', 'ns')} | {_cell(cells, 'mujoco', 'ns')} | "
                     f"{_cell(cells, 'pinocchio', 'ns')} | {kr} | {mr} | {pr} | "
                     f"{r['cpu']:.2f} ({r['wall']:.2f}) | {kb} | "
                     + " / ".join(f"{agree[k]:.1e}" if k in agree else "-"
                                  for k in ("kane", "mujoco", "pinocchio")) + " |")
    return "\n".join(lines)


if __name__ == "__main__":
    main(sys.argv[1:])
