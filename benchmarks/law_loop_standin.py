"""A stand-in for the joint laws as a loop (issue 30's build bar, benchmarks/results/derivative_build.md,
session 24): G1's 29 limit-law slopes (∂τ/∂q, ∂τ/∂u of one joint, the statements as NAME_dyn_inputs
prints them, with the generated `eomc_fmax`) written three ways, then gcc's CPU on each and a call each.

    A  as generated: straight-line, 4 joints per EOMC_NOINLINE part (-O1)
    B  one static helper of the law's shape, called in a loop over tables of each joint's x and p indices
    C  B with the inputs gathered into arrays first (so gcc could vectorize over joints)

gcc: `-c` with the library's flags (-O2 -fPIC -std=c99 -mavx2 -ffp-contract=off -fno-ipa-ra), user + sys
of the child, ``--repeat`` times.  A call: a dlopen harness, thread CPU, 16 states whose coordinates
cross the limits, rounds of 2000 calls rotated over the libraries (each loaded as two byte-identical
copies, against the copy hazard), medians of 31 rounds; the outputs are compared with memcmp first.

    python benchmarks/law_loop_standin.py [--joints 29] [--repeat 3] [--dir /tmp/law_standin]
"""
import argparse
import re
import resource
import subprocess
import tempfile
from pathlib import Path

FLAGS = ["-O2", "-fPIC", "-std=c99", "-mavx2", "-ffp-contract=off", "-fno-ipa-ra"]
FMAX = """static inline double eomc_fmax(double a, double b)
{
    return a > b ? a : (b != b ? a : b);
}
"""


def block(k, q, u, lo, hi, eps, kk, d, out0, out1):
    """One joint's slopes, as G1's NAME_dyn_inputs prints them (its temporaries renamed)."""
    t = f"j{k}_"
    return f"""    const double {t}du = {d}*{u};
    const double {t}a = {q} - {lo};
    const double {t}fa = eomc_fmax({t}a, 0.0);
    const double {t}A = {t}fa + {eps};
    const double {t}iA2 = 1.0/({t}A*{t}A);
    const double {t}fa2 = ({t}fa*{t}fa);
    const double {t}ha = (({t}a) > 0.0 ? 1.0 : 0.0);
    const double {t}sa = {t}du/{t}A;
    const double {t}ga = {t}fa*{t}iA2*{t}ha;
    const double {t}b = {hi} - {q};
    const double {t}fb = eomc_fmax({t}b, 0.0);
    const double {t}B = {t}fb + {eps};
    const double {t}iB2 = 1.0/({t}B*{t}B);
    const double {t}fb2 = ({t}fb*{t}fb);
    const double {t}hb = (({t}b) > 0.0 ? 1.0 : 0.0);
    const double {t}iB = 1.0/{t}B;
    const double {t}gb = {t}fb*{t}iB2*{t}hb;
    const double {t}iA3 = 1.0/({t}A*{t}A*{t}A);
    const double {t}c1 = {t}fa*{t}sa + {t}fa*{kk};
    const double {t}iB3 = 1.0/({t}B*{t}B*{t}B);
    const double {t}c2 = {t}fb*{kk} - {t}du*{t}fb*{t}iB;
    {out0} = -2.0*{t}ga*{t}c1 - 2.0*{t}gb*{t}c2 + {t}iB2*{t}fb2*(-{t}du*{t}gb - {t}hb*{kk} + {t}hb*{t}iB*{d}*{u}) - {t}iA2*{t}fa2*({t}ha*{t}sa + {t}ha*{kk} - {t}du*{t}ga) + 2.0*{t}fa2*{t}ha*{t}iA3*{t}c1 + 2.0*{t}fb2*{t}hb*{t}iB3*{t}c2;
    {out1} = -{t}iA3*{d}*({t}fa*{t}fa*{t}fa) - {t}iB3*{d}*({t}fb*{t}fb*{t}fb);
"""


def joint(k):
    """Joint k's state and parameter entries: q = x[6 + k], u = x[41 + k], p[5k .. 5k + 4]."""
    return (f"x[{6 + k}]", f"x[{41 + k}]") + tuple(f"p[{5 * k + i}]" for i in range(5))


def sources(nj):
    tables = "".join(f"static const int {n}[{nj}] = {{{', '.join(str(f(k)) for k in range(nj))}}};\n"
                     for n, f in (("qi", lambda k: 6 + k), ("ui", lambda k: 41 + k), ("pi_", lambda k: 5 * k),
                                  ("oi", lambda k: 2 * k)))
    a = "#include <math.h>\n" + FMAX + '#define EOMC_NOINLINE __attribute__((noinline, optimize("O1")))\n'
    parts = []
    for i in range(0, nj, 4):
        a += f"static EOMC_NOINLINE void part{i}(const double *x, const double *p, double *an)\n{{\n"
        a += "".join(block(k, *joint(k), f"an[{2 * k}]", f"an[{2 * k + 1}]") for k in range(i, min(nj, i + 4)))
        a += "}\n"
        parts.append(f"part{i}")
    a += "void slopes(const double *x, const double *p, double *an)\n{\n" + "".join(
        f"    {n}(x, p, an);\n" for n in parts) + "}\n"
    names = ("q", "u", "lo", "hi", "eps", "kk", "d")
    b = ("#include <math.h>\n" + FMAX + tables
         + f"static void law0({', '.join('double ' + n for n in names)}, double *out)\n{{\n"
         + block(0, *names, "out[0]", "out[1]") + "}\n"
         + "void slopes(const double *x, const double *p, double *an)\n{\n    int k;\n"
         + f"    for (k = 0; k < {nj}; k++) {{\n        const double *pp = p + pi_[k];\n"
         + "        law0(x[qi[k]], x[ui[k]], pp[0], pp[1], pp[2], pp[3], pp[4], an + oi[k]);\n    }\n}\n")
    body = block(0, *[f"{n}[k]" for n in names], "dq[k]", "dv[k]").replace("\n    ", "\n        ")
    c = ("#include <math.h>\n" + FMAX + tables
         + "void slopes(const double *x, const double *p, double *an)\n{\n"
         + f"    double {', '.join(f'{n}[{nj}]' for n in names + ('dq', 'dv'))};\n    int k;\n"
         + f"    for (k = 0; k < {nj}; k++) {{\n        const double *pp = p + pi_[k];\n"
         + "        q[k] = x[qi[k]]; u[k] = x[ui[k]]; lo[k] = pp[0]; hi[k] = pp[1]; eps[k] = pp[2]; "
         + "kk[k] = pp[3]; d[k] = pp[4];\n    }\n"
         + f"    for (k = 0; k < {nj}; k++) {{\n    " + body + "    }\n"
         + f"    for (k = 0; k < {nj}; k++) {{ an[oi[k]] = dq[k]; an[oi[k] + 1] = dv[k]; }}\n}}\n")
    return {"A": a, "B": b, "C": c}


HARNESS = r"""
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
typedef void (*fn)(const double *, const double *, double *);
static double now(void) { struct timespec t; clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t); return t.tv_sec + 1e-9 * t.tv_nsec; }
static int cmp(const void *a, const void *b) { double d = *(const double *)a - *(const double *)b; return (d > 0) - (d < 0); }
int main(int argc, char **argv)
{
    enum { NS = 16, ROUNDS = 31, CALLS = 2000, NJ = @NJ@ };
    int nlib = argc - 1, i, s, r, n, bad = 0;
    fn f[16];
    static double x[NS][2 * NJ + 12], p[5 * NJ], an[16][2 * NJ], t[16][ROUNDS];
    for (i = 0; i < nlib; i++) {
        void *h = dlopen(argv[i + 1], RTLD_NOW | RTLD_LOCAL);
        if (!h) { printf("%s\n", dlerror()); return 1; }
        f[i] = (fn)dlsym(h, "slopes");
    }
    srand(3);
    for (i = 0; i < NJ; i++) { p[5*i] = -1.0; p[5*i+1] = 1.0; p[5*i+2] = 0.01; p[5*i+3] = 1e3; p[5*i+4] = 10.0; }
    for (s = 0; s < NS; s++) for (i = 0; i < 2 * NJ + 12; i++) x[s][i] = 2.4 * rand() / RAND_MAX - 1.2;
    for (s = 0; s < NS; s++) {
        for (i = 0; i < nlib; i++) f[i](x[s], p, an[i]);
        for (i = 1; i < nlib; i++) if (memcmp(an[0], an[i], sizeof an[0])) { printf("DIFF %s state %d\n", argv[i + 1], s); bad = 1; }
    }
    for (r = 0; r < ROUNDS; r++)
        for (n = 0; n < nlib; n++) {
            double t0;
            i = (n + r) % nlib;
            t0 = now();
            for (s = 0; s < CALLS; s++) f[i](x[s % NS], p, an[i]);
            t[i][r] = (now() - t0) / CALLS * 1e9;
        }
    for (i = 0; i < nlib; i++) { qsort(t[i], ROUNDS, sizeof(double), cmp); printf("%s %.0f ns\n", argv[i + 1], t[i][ROUNDS / 2]); }
    if (!bad) printf("same bits: yes\n");
    return bad;
}
"""


def gcc_cpu(cwd, args):
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(["gcc", *args], cwd=cwd, check=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--joints", type=int, default=29)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--dir", default="")
    a = ap.parse_args()
    work = Path(a.dir or tempfile.mkdtemp(prefix="law_standin_"))
    work.mkdir(parents=True, exist_ok=True)
    for k, text in sources(a.joints).items():
        (work / f"{k}.c").write_text(text)
    times = {k: [] for k in "ABC"}
    for _ in range(a.repeat):
        for k in "ABC":
            times[k].append(gcc_cpu(work, [*FLAGS, "-c", f"{k}.c", "-o", f"{k}.o"]))
    libs = []
    for k in "ABC":
        subprocess.run(["gcc", *FLAGS, "-shared", f"{k}.c", "-o", f"lib{k}.so", "-lm"], cwd=work, check=True)
        (work / f"lib{k}2.so").write_bytes((work / f"lib{k}.so").read_bytes())
        libs += [f"./lib{k}.so", f"./lib{k}2.so"]
    (work / "harness.c").write_text(HARNESS.replace("@NJ@", str(a.joints)))
    subprocess.run(["gcc", "-O2", "harness.c", "-o", "harness", "-ldl"], cwd=work, check=True)
    text = {k: re.search(r"^\s*(\d+)", subprocess.run(["size", f"{k}.o"], cwd=work, capture_output=True,
                                                        text=True).stdout.splitlines()[1]).group(1) for k in "ABC"}
    print(f"{a.joints} joints, in {work}")
    for k in "ABC":
        print(f"{k}: gcc -c " + " / ".join(f"{t:.2f}" for t in times[k]) + f" s, .text {text[k]} bytes")
    print(subprocess.run(["./harness", *libs], cwd=work, capture_output=True, text=True).stdout, end="")


if __name__ == "__main__":
    main()
