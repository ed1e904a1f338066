"""Issue 31 item 4: how the recursive rhs of the relative-coordinate n-link cart grows with n.

One executable holds every n's rhs (benchmarks/tree_models/cart_rel_joints.py, --formulation
recursive, literal parameters, eomc's default flags on this machine) beside MuJoCo's mj_forward
and Pinocchio's ABA on the same carts (as bench_tree.py: tree_models/cart_mjcf.py,
tree_models/pin_aba.cpp).  Every contestant (each n, each tool) is timed in every round for
about 20 ms of thread CPU time over 256 random states, the order rotated from round to round,
pinned to core CORE; the table gives medians over the rounds.  So the times of different n
come from the same minutes of the same machine, and the exponents between them are not a
comparison of runs made at different loads.

Beside the time: the rhs's operation count (NAME.json), its code size (bytes of machine code
of NAME_rhs and its sub-functions in the harness's object file), and, with --valgrind,
valgrind's count (callgrind) of the instructions executed per call with its simulated first-level
instruction- and data-cache misses (the machine here is a virtual one without hardware
counters, so `perf stat` has nothing to count).  The exponents: between consecutive n
(local) and least-squares fits of log time against log n.

--variant LABEL=DIR: the builds in DIR/n<N>/ (the same models built from another checkout, say)
are timed beside the default ones in the same executable, for an A/B of code generation.
--chain LABEL=K: a variant built with the looped rhs's threshold (compiler/tree/chain_loop.py,
CHAIN_LOOP_MIN_LINKS) set to K: 1000000 is the straight-line rhs at every n, 2 the loops at
every n (built in DIR/LABEL/n<N>/ beside --builds DIR, or in a temporary directory).
--core K: the core to pin to (default 0).
Usage: python benchmarks/bench_cart_scaling.py [n ...] [--rounds R] [--valgrind] [--core K]
       [--builds DIR] [--variant LABEL=DIR] [--chain LABEL=K] [--write]   (--write: results/cart_scaling.md)
"""
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
MODELS = HERE / "tree_models"
ROOT = HERE.parent
CORE = [0]          # the core to pin to (--core)
NS = 256

sys.path.insert(0, str(HERE))
from bench_tree import LIB_FLAGS, _mujoco, _pinocchio  # noqa: E402
from common import C_CLOCK_AND_RNG, cold_build  # noqa: E402

HARNESS = r"""
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
@INCLUDES@
typedef int (*rhs_fn)(double, const double *, const double *, const double *, double *, double *);
#define NN @NN@
#define NE @NE@
static rhs_fn E[NE] = {@FNS@};
static const int EK[NE] = {@EK@};          /* which n each eomc contestant belongs to */
static const int NQ[NN] = {@NQS@};
static double *XS[NN];
static double out[@MAXNX@], ref[@MAXNX@], tau[@MAXNX@];
#ifdef WITH_MUJOCO
#include <mujoco/mujoco.h>
static mjModel *mjm[NN]; static mjData *mjd[NN];
static void mj_rhs(int k, const double *x, const double *r, double *o) {
    int j, nq = NQ[k];
    for (j = 0; j < nq; j++) { mjd[k]->qpos[j] = x[j]; mjd[k]->qvel[j] = x[nq + j]; o[j] = x[nq + j]; }
    mjd[k]->qfrc_applied[0] = r[0];
    mj_forward(mjm[k], mjd[k]);
    for (j = 0; j < nq; j++) o[nq + j] = mjd[k]->qacc[j];
}
#define NMJ NN
#else
#define NMJ 0
#endif
#ifdef WITH_PIN
int pin_add(int nl, double m0, double m, double l, double g);
void pin_rhs_k(int k, const double *q, const double *v, const double *tau, double *a);
static void p_rhs(int k, const double *x, const double *r, double *o) {
    int j, nq = NQ[k];
    tau[0] = r[0];
    for (j = 0; j < nq; j++) o[j] = x[nq + j];
    pin_rhs_k(k, x, x + nq, tau, o + nq);
}
#define NPIN NN
#else
#define NPIN 0
#endif
""" + C_CLOCK_AND_RNG + r"""
#define NS @NS@
static const double r[1] = {1.3};
/* contestant c: eomc builds 0..NE-1, then MuJoCo per n, then Pinocchio per n */
static int nof(int c) { return c < NE ? EK[c] : c < NE + NMJ ? c - NE : c - NE - NMJ; }
static void call(int c, int i) {
    int k = nof(c);
    const double *x = XS[k] + (size_t)i * 2 * NQ[k];
    if (c < NE) E[c](0.0, x, NULL, r, out, NULL);
#ifdef WITH_MUJOCO
    else if (c < NE + NMJ) mj_rhs(k, x, r, out);
#endif
#ifdef WITH_PIN
    else p_rhs(k, x, r, out);
#endif
}
int main(int argc, char **argv) {
    int i, j, k, c, round, nc = NE + NMJ + NPIN;
    double sum = 0.0;
    for (k = 0; k < NN; k++) {
        int nq = NQ[k];
        XS[k] = malloc(sizeof(double) * NS * 2 * nq);
        for (i = 0; i < NS; i++) for (j = 0; j < 2 * nq; j++)
            XS[k][i * 2 * nq + j] = j < nq ? (j == 0 ? 2 * rnd() - 1 : 3.14159265358979 * (2 * rnd() - 1))
                                           : 2 * rnd() - 1;
#ifdef WITH_MUJOCO
        { char err[1000]; mjm[k] = mj_loadXML(argv[4 + k], NULL, err, sizeof err);
          if (!mjm[k]) { printf("mujoco: %s\n", err); return 1; }
          mjd[k] = mj_makeData(mjm[k]); }
#endif
#ifdef WITH_PIN
        pin_add(nq - 1, 2.0, 0.5, 0.75, 9.81);
#endif
    }
    if (argc > 2 && !strcmp(argv[1], "calls")) {   /* under valgrind: contestant argv[3], argv[2] calls */
        long n = atol(argv[2]); c = atoi(argv[3]);
        for (i = 0; i < n; i++) { call(c, i % NS); sum += out[NQ[nof(c)]]; }
        printf("checksum %g\n", sum);
        return 0;
    }
    for (c = 0; c < nc; c++) {          /* every contestant against the first build of its n */
        double worst = 0.0;
        int nx = 2 * NQ[nof(c)], first = 0;
        while (EK[first] != nof(c)) first++;
        for (i = 0; i < 64; i++) {
            E[first](0.0, XS[nof(c)] + (size_t)i * nx, NULL, r, ref, NULL);
            call(c, i);
            for (j = 0; j < nx; j++) { double d = fabs(out[j] - ref[j]) / (fabs(ref[j]) > 1 ? fabs(ref[j]) : 1);
                if (d > worst || d != d) worst = d; }
        }
        printf("agree %d %.3g\n", c, worst);
    }
    for (round = 0; round < @ROUNDS@; round++) {
        for (j = 0; j < nc; j++) {
            long calls = 0; double t0, t1;
            c = (j + round) % nc;
            t0 = tnow();
            do { for (i = 0; i < NS; i++) { call(c, i); sum += out[NQ[nof(c)]]; } calls += NS; t1 = tnow(); }
            while (t1 - t0 < 2e7);
            printf("time %d %.2f\n", c, (t1 - t0) / calls);
        }
    }
    printf("checksum %g\n", sum);
    return 0;
}
"""


def renamed_copy(src_dir, name, label, dest):
    """The generated C and header of ``src_dir`` with ``name`` renamed ``name_label`` (so two
    builds of one model can share a translation unit); returns (dir, new name)."""
    new = f"{name}_{label}"
    dest.mkdir(parents=True, exist_ok=True)
    for ext in (".c", ".h"):
        text = (src_dir / f"{name}{ext}").read_text()
        (dest / f"{new}{ext}").write_text(re.sub(rf"\b{name}", new, text))
    for extra in src_dir.glob("eomc_*.h"):
        shutil.copy(extra, dest / extra.name)
    return dest, new


def rhs_code_bytes(obj, name):
    """Bytes of machine code of ``name``_rhs and its sub-functions in the object file ``obj``."""
    out = subprocess.run(["nm", "-S", "--defined-only", str(obj)], capture_output=True, text=True,
                         check=True).stdout
    total = 0
    for line in out.splitlines():
        parts = line.split()
        if len(parts) == 4 and parts[2] in "tT" and re.fullmatch(rf"{name}_rhs(_part\d+_\d+|_rep\d+)?", parts[3]):
            total += int(parts[1], 16)
    return total


def build_all(ns, builds_dir, chain_min=None):
    """{n: (dir, meta)}: cold builds, or the ones already in ``builds_dir``/n<N>/
    (``chain_min``: built with CHAIN_LOOP_MIN_LINKS set to it)."""
    import json
    out = {}
    prelude = (None if chain_min is None else
              f"from eomc.compiler.tree import chain_loop\nchain_loop.CHAIN_LOOP_MIN_LINKS = {int(chain_min)}")
    for n in ns:
        d = builds_dir / f"n{n}"
        if not (d / f"cartjoints{n}.c").is_file():
            cpu, wall, meta, _ = cold_build(MODELS / "cart_rel_joints.py", n, "recursive", d, "rhs", prelude=prelude)
            print(f"n={n}: built in {cpu:.1f} s CPU ({wall:.1f} s wall)", flush=True)
        meta = json.loads((d / f"cartjoints{n}.json").read_text())
        out[n] = (d, meta)
    return out


def harness(ns, builds, tmp, rounds):
    """Compile the one executable: (path, its args, per contestant (label, n), code bytes per label and n)."""
    incs, fns, ek, labels = [], [], [], []
    for label, n, d, name in builds:
        incs.append(f'#include "{d}/{name}.c"')
        fns.append(f"{name}_rhs")
        ek.append(str(ns.index(n)))
        labels.append((label, n))
    mj, pin = _mujoco(), _pinocchio(tmp)
    src = (HARNESS.replace("@INCLUDES@", "\n".join(incs)).replace("@NN@", str(len(ns)))
           .replace("@NE@", str(len(builds))).replace("@FNS@", ", ".join(fns)).replace("@EK@", ", ".join(ek))
           .replace("@NQS@", ", ".join(str(n + 1) for n in ns)).replace("@MAXNX@", str(2 * max(ns) + 2))
           .replace("@NS@", str(NS)).replace("@ROUNDS@", str(rounds)))
    c = tmp / "scaling.c"
    c.write_text(src)
    inc = sorted({f"-I{d}" for _, _, d, _ in builds}) + [f"-I{ROOT / 'runtime' / 'c'}"]
    extra, libs, args = [], [], []
    if mj:
        sys.path.insert(0, str(MODELS))
        from cart_mjcf import mjcf
        for n in ns:
            xml = tmp / f"cart{n}.xml"
            xml.write_text(mjcf(n))
            args.append(str(xml))
        extra = ["-DWITH_MUJOCO", f"-I{mj[0]}"]
        libs = [str(mj[1]), f"-Wl,-rpath,{mj[1].parent}"]
        labels += [("mujoco", n) for n in ns]
    if pin:
        extra.append("-DWITH_PIN")
        labels += [("pinocchio", n) for n in ns]
    obj, exe = tmp / "scaling.o", tmp / "scaling"
    subprocess.run(["gcc", *LIB_FLAGS, *inc, *extra, "-c", str(c), "-o", str(obj)], check=True)
    subprocess.run(["g++" if pin else "gcc", str(obj), *([str(pin)] if pin else []), *libs,
                    "-o", str(exe), "-lm"], check=True)
    code = {(label, n): rhs_code_bytes(obj, name) for label, n, _, name in builds}
    return exe, args, labels, code


def run_timing(exe, args, labels):
    out = subprocess.run(["taskset", "-c", str(CORE[0]), str(exe), "time", "0", "0", *args], capture_output=True,
                         text=True, check=True).stdout
    agree = {labels[int(line.split()[1])]: float(line.split()[2]) for line in out.splitlines()
             if line.startswith("agree ")}
    times = {}
    for line in out.splitlines():
        if line.startswith("time"):
            _, k, v = line.split()
            times.setdefault(labels[int(k)], []).append(float(v))
    return agree, {k: sorted(v)[len(v) // 2] for k, v in times.items()}, times


def cache_sim(exe, args, labels, builds, calls=1000):
    """{(label, n): (instructions, I1 misses, D1 misses, data refs) per call} of the eomc rhs
    (sin and cos included) under valgrind's cache simulation (callgrind, collecting inside
    NAME_rhs only) (first-level caches 32 kB 8-way 64 B lines, as this CPU's)."""
    res = {}
    for c, (label, n, _, name) in enumerate(builds):
        with tempfile.TemporaryDirectory() as d:
            cg = Path(d) / "cg.out"
            subprocess.run(["valgrind", "--tool=callgrind", "--cache-sim=yes", "--I1=32768,8,64",
                            "--D1=32768,8,64", "--LL=1048576,16,64", f"--toggle-collect={name}_rhs",
                            f"--callgrind-out-file={cg}", str(exe), "calls", str(calls), str(c), *args],
                           capture_output=True, text=True, check=True)
            ev = summary = None
            for line in cg.read_text().splitlines():
                if line.startswith("events:"):
                    ev = line.split()[1:]
                if line.startswith("summary:"):
                    summary = [int(v) for v in line.split()[1:]]
            v = dict(zip(ev, summary))
            res[(label, n)] = tuple(x / calls for x in (v["Ir"], v["I1mr"], v["D1mr"] + v["D1mw"],
                                                         v["Dr"] + v["Dw"]))
    return res


def exponents(ns, ts):
    """(local exponents between consecutive n, fits over n >= 8, over n >= 20, over n >= 40)."""
    import numpy as np
    local = [math.log(ts[k + 1] / ts[k]) / math.log(ns[k + 1] / ns[k]) for k in range(len(ns) - 1)]
    fits = {}
    for lo in (8, 20, 40):
        pts = [(n, ts[k]) for k, n in enumerate(ns) if n >= lo]
        if len(pts) >= 2:
            fits[lo] = float(np.polyfit(np.log([p[0] for p in pts]), np.log([p[1] for p in pts]), 1)[0])
    return local, fits


def table_text(ns, labels_eomc, meta, med, agree, code, cg):
    lines = []
    peers = [p for p in ("mujoco", "pinocchio") if ("%s" % p, ns[0]) in med]
    head = (["n", "ops"] + [f"{lb} rhs ns" for lb in labels_eomc] + [f"{lb} ns/op" for lb in labels_eomc]
            + [f"{lb} code kB" for lb in labels_eomc]
            + [{"mujoco": "MuJoCo mj_forward ns", "pinocchio": "Pinocchio ABA ns"}[p] for p in peers]
            + [f"{p}/{labels_eomc[0]}" for p in peers] + [f"rel. diff of u' vs {labels_eomc[0]}"])
    lines += ["| " + " | ".join(head) + " |", "|" + "--:|" * len(head)]
    for n in ns:
        ops = sum(meta[n]["op_counts"]["rhs"].values())
        row = [str(n), str(ops)] + [f"{med[(lb, n)]:.0f}" for lb in labels_eomc]
        row += [f"{med[(lb, n)] / ops:.3f}" for lb in labels_eomc]
        row += [f"{code[(lb, n)] / 1024:.1f}" for lb in labels_eomc]
        row += [f"{med[(p, n)]:.0f}" for p in peers]
        row += [f"{med[(p, n)] / med[(labels_eomc[0], n)]:.2f}" for p in peers]
        row += [" / ".join(f"{agree[(k, n)]:.1e}" for k in labels_eomc[1:] + peers) or "-"]
        lines.append("| " + " | ".join(row) + " |")
    lines += ["", "Exponents of time against n (local: between consecutive n; fit: least squares of log time "
              "against log n over the n named):", "",
              "| contestant | " + " | ".join(f"{a}→{b}" for a, b in zip(ns, ns[1:]))
              + " | fit n ≥ 8 | fit n ≥ 20 | fit n ≥ 40 |", "|---|" + "--:|" * (len(ns) + 2)]
    ops_by_n = {n: sum(meta[n]["op_counts"]["rhs"].values()) for n in ns}
    series = [(f"{lb} rhs", {n: med[(lb, n)] for n in ns}) for lb in labels_eomc]
    series += [(p, {n: med[(p, n)] for n in ns}) for p in peers]
    series += [("operation count", ops_by_n)]
    for title, ts in series:
        local, fits = exponents(ns, [ts[n] for n in ns])
        lines.append(f"| {title} | " + " | ".join(f"{e:.3f}" for e in local) + " | "
                     + " | ".join(f"{fits[lo]:.3f}" if lo in fits else "-" for lo in (8, 20, 40)) + " |")
    if cg:
        lines += ["", "Per rhs call under valgrind's callgrind (sin and cos included; instructions executed, simulated misses of a "
                  "32 kB 8-way first-level instruction cache and of a 32 kB data cache, data reads + writes):", "",
                  "| n | contestant | instructions | instructions/op | I1 misses | I1 misses/op | D1 misses | "
                  "data refs/op | ns/instruction |", "|--:|---|--:|--:|--:|--:|--:|--:|--:|"]
        for n in ns:
            for lb in labels_eomc:
                ir, i1, d1, dr = cg[(lb, n)]
                ops = ops_by_n[n]
                lines.append(f"| {n} | {lb} | {ir:.0f} | {ir / ops:.2f} | {i1:.0f} | {i1 / ops:.3f} | {d1:.0f} | "
                             f"{dr / ops:.2f} | {med[(lb, n)] / ir:.4f} |")
    return "\n".join(lines)


def main(argv):
    write = "--write" in argv
    use_cg = "--valgrind" in argv
    argv = [a for a in argv if a not in ("--write", "--valgrind")]
    rounds, builds_dir, variants, chains = 11, None, [], []
    while any(a.startswith("--") for a in argv):
        i = next(k for k, a in enumerate(argv) if a.startswith("--"))
        key, val = argv[i], argv[i + 1]
        argv = argv[:i] + argv[i + 2:]
        if key == "--rounds":
            rounds = int(val)
        elif key == "--builds":
            builds_dir = Path(val)
        elif key == "--variant":
            label, d = val.split("=", 1)
            variants.append((label, Path(d)))
        elif key == "--chain":
            label, k = val.split("=", 1)
            chains.append((label, int(k)))
        elif key == "--core":
            CORE[0] = int(val)
        else:
            raise SystemExit(f"unknown option {key}")
    ns = [int(a) for a in argv] or [4, 8, 20, 40, 80, 160]
    start_load = " ".join(f"{v:.2f}" for v in os.getloadavg())
    tmp = Path(tempfile.mkdtemp(prefix="bench_cart_scaling_"))
    built = build_all(ns, builds_dir or tmp / "builds")
    meta = {n: m for n, (_, m) in built.items()}
    builds = [("eomc", n, d, f"cartjoints{n}") for n, (d, _) in built.items()]
    for label, k in chains:
        vdir = (builds_dir or tmp / "builds") / label
        build_all(ns, vdir, chain_min=k)
        variants.append((label, vdir))
    for label, vdir in variants:
        for n in ns:
            d, name = renamed_copy(vdir / f"n{n}", f"cartjoints{n}", label, tmp / label / f"n{n}")
            builds.append((label, n, d, name))
    exe, args, labels, code = harness(ns, builds, tmp, rounds)
    agree, med, _ = run_timing(exe, args, labels)
    (tmp / "medians.txt").write_text(repr({"agree": agree, "med": med, "code": code}))
    table = table_text(ns, ["eomc"] + [lb for lb, _ in variants], meta, med, agree, code, None)
    print(table, flush=True)
    if use_cg:
        table = table_text(ns, ["eomc"] + [lb for lb, _ in variants], meta, med, agree, code,
                           cache_sim(exe, args, labels, builds))
        print(table)
    if write:
        write_up(table, start_load)
    return med


def write_up(table, start_load):
    from common import environment_header, peer_versions, write_results
    end_load = " ".join(f"{v:.2f}" for v in os.getloadavg())
    notes = [f"load average at start: {start_load}, at the end: {end_load} (2 cores shared with other jobs)",
             "peers: " + ", ".join(peer_versions(("mujoco", "pinocchio"))) + " (MuJoCo prebuilt library through "
             "its C API; Pinocchio header-only, g++ -O2 -std=c++17)",
             f"generated C and harness compiled together with eomc's default flags on this machine: "
             f"{' '.join(LIB_FLAGS)}; pinned to core {CORE[0]}; thread CPU time"]
    text = (environment_header("Cart rhs scaling: time, operations and code size against n, one run",
                               notes=notes) + "\n" + (__doc__ or "") + "\n" + table + "\n")
    print(write_results("cart_scaling", text, keep_notes=True))


if __name__ == "__main__":
    main(sys.argv[1:])
