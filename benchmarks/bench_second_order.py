"""Issue 30: eomc's second-order inverse dynamics (``hess_id``) against Pinocchio's
``ComputeRNEASecondOrderDerivatives``, one C harness.

Contestants (per model, pinned to one core (``--core``, 1 unless told), thread CPU, interleaved with the order rotated every
round, ~20 ms blocks, median of rounds; ns per call):
  * eomc ``hess_id`` (∂²τ/∂x², nu x nx x nx; since 2026-11-29 the analytic second-order
    kernel, compiler/tree/second_order.py, for these one-speed-joint trees: the model's
    metadata ``hess_id`` says which algorithm it got) of a ``--formulation recursive`` build
    with functions rhs, inverse_dynamics, jac_id, hess_id, the generated C compiled into the
    harness with the flags eomc builds it with on this machine (gcc -O2, plus -mavx2
    -ffp-contract=off -fno-ipa-ra on an AVX2 x86-64: the kernel's triple loop then runs 4 k a
    step; ``--portable``: -O2 alone: since session 17 the C then holds the kernel's AVX2 twin,
    NAME_rnea_hess_avx2, which NAME_hess_id takes when the CPU has AVX2 -- so on this CPU eomc's
    -O2 kernel runs AVX2 where Pinocchio's -O2 build runs SSE2, each library's default build;
    the header says so);
  * Pinocchio ``ComputeRNEASecondOrderDerivatives`` (Singh, Russell & Wensing 2022; header-only
    from the pin / cmeel wheels, g++ -O2 -std=c++17 with the same instruction-set flag (-mavx2)
    as eomc's C, benchmarks/tree_models/pin_derivatives.cpp,
    whose Python bindings do not export it) on the same model, built as in
    bench_derivatives.py.  Pinocchio also returns dM/dq (∂²τ/∂q∂u'), which ``hess_id`` does not
    (it is ``jac_id``'s derivative in u', M itself); eomc returns both mixed blocks (∂²τ/∂q∂u
    and ∂²τ/∂u∂q), Pinocchio one.
Models: the cart, UR10, Panda, and the floating bases Go2, G1, Talos (eomc's free joint: body XYZ
Euler angles, body-frame speeds).  On a floating base Pinocchio differentiates along its
Lie-group tangent and eomc's hess_id along its coordinates (the change brings K⁻¹ and K's own
derivative): such a model is built twice, as eomc builds it and along the tangent
(second_order.TANGENT, Pinocchio's quantities; a third contestant), see :func:`build`; and a third
time with second_order.ZERO set (a fourth contestant): Pinocchio writes only the entries of its
tensors on the tree's support paths (zeroed once, when its Data is made), and so does eomc's hess_id
by default (since session 13; before, it zeroed its whole output first: most of it, on a branched
tree, Talos 500 k numbers, 4 MB a call), into an output the harness zeroed once; the ZERO build
zeroes every call (same bits, checked).

Agreement, before timing: the C++ tensors ∂²τ/∂q², ∂²τ/∂u², ∂²τ/∂q∂u at 4 random states
against eomc's (Python ``model.hess_id``), largest difference relative to the largest entry.

``--limits``: the robots built as ``eomc.compile("robot.urdf")`` builds them, with their joint limits
on (the default; their damping and friction as declared), and a third contestant, the same
model's hess_id on the forward-over-reverse path it had before the kernel covered joint laws
(forced, built under another name and linked into the same harness).  Pinocchio has no joint
laws: its agreement is taken with the laws' own entries (row i's (q_i, u_i) block) left out;
the two eomc paths are compared on every entry.

Usage: python benchmarks/bench_second_order.py [--cart 4,8,20] [--robots ur10,panda,go2] [--limits] [--portable] [--core 0]
       [--rounds 7] [--pin-obj FILE.o (compiled with the same flags)] [--write]
"""
import argparse
import datetime
import os
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))

import bench_derivatives as bd  # noqa: E402  (model building, states, Pinocchio's text model)

NAGREE = 4
HARNESS = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "@NAME@.h"
@OLDINC@
@NZINC@
int pin_setup(const char *path);
void pin_rnea_second_order(const double *q, const double *v, const double *a);
void pin_copy_rnea_second_order(double *qq, double *vv, double *qv, double *aq);
#define NS @NS@
#define NX @NX@
#define NU @NU@
#define PQ @PQ@
static const double X[NS][NX] = {@X@};
static const double UD[NS][NU] = {@UD@};
static const double Q[NS][PQ] = {@Q@};
static const double V[NS][NU] = {@V@};
static const double A[NS][NU] = {@A@};
static const double P[] = {@P@};   /* the model's parameter defaults */
static const double R[] = {@R@};   /* zero inputs */
static double out[NU * NX * NX], out3[NU * NX * NX], work[@WORK@], qq[NU * NU * NU], vv[NU * NU * NU], qv[NU * NU * NU], aq[NU * NU * NU];
static double tnow(void) { struct timespec ts; clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return ts.tv_sec * 1e9 + ts.tv_nsec; }
static double call(int c, int i) {
    if (c == 0) { if (@NAME@_hess_id(0.0, X[i], UD[i], P, R, out, work)) exit(5); return out[NX]; }
    @OLDCALL@
    @NZCALL@
    pin_rnea_second_order(Q[i], V[i], A[i]);
    return 0.0;
}
int main(int argc, char **argv) {
    int i, k, c, round;
    double sum = 0.0;
    (void)argc;
    pin_setup(argv[1]);
    for (i = 0; i < @NAGREE@; i++) {
        pin_rnea_second_order(Q[i], V[i], A[i]);
        pin_copy_rnea_second_order(qq, vv, qv, aq);
        for (k = 0; k < NU * NU * NU; k++) printf("pin %d %.17g %.17g %.17g\n", i, qq[k], vv[k], qv[k]);
    }
    for (round = 0; round < @ROUNDS@; round++) {
        for (c = 0; c < @NC@; c++) {
            int cc = (c + round) % @NC@; long calls = 0; double t0 = tnow(), t1;
            do { for (i = 0; i < NS; i++) sum += call(cc, i); calls += NS; t1 = tnow(); }
            while (t1 - t0 < 2e7);
            printf("time %d %.1f\n", cc, (t1 - t0) / calls);
        }
    }
    printf("checksum %g\n", sum);
    return 0;
}
"""
LABELS = ("eomc hess_id", "Pinocchio ComputeRNEASecondOrderDerivatives", "eomc hess_id, old path")
TANGENT = "eomc hess_id along the tangent"     # the third contestant of a floating base (see build)
# the fourth of a floating base: hess_id built with second_order.ZERO set, its whole output zeroed every
# call (the default before session 13); the default leaves the entries off the support paths as the
# caller zeroed them once (Pinocchio's contract: its tensors are zeroed when its Data is made, and its
# second-order RNEA writes only the entries on the paths): the harness's buffers are static (zero)
# and never cleared (see build)
ZEROED = "eomc hess_id, zeroed every call"


def eomc_flags(portable):
    """The flags eomc builds a model's C with on this machine: -O2, plus (unless ``portable``)
    compiler/build/toolchain.py's machine flags (-mavx2 -ffp-contract=off -fno-ipa-ra on an
    AVX2 x86-64 with gcc).  Why: the kernel's triple loop runs 4 k a step with AVX2, 2 without."""
    if portable:
        return ["-O2"]
    from eomc.compiler.build.toolchain import find_compiler, machine_flags
    return ["-O2", *machine_flags(find_compiler())]


def run(model, ref, data, tmp, pin_obj, rounds, old=None, cflags=("-O2",), tangent=False, core=1, zeroed=None):
    """(median ns per contestant, agreement[, old path's agreement]): the harness compiled and run
    pinned to ``core``; ``old``: the same model on the forced reverse path (``--limits``), or with
    ``tangent`` its build along the free joint's tangent (a floating base, :func:`build`): the
    agreement with Pinocchio is then the tangent build's, and the second figure is the
    coordinate build's against central differences of its jac_id; ``zeroed``: the same model with
    second_order.ZERO set (a fourth contestant, index 3), whose bits from an output filled with
    NaN must equal hess_id's (``model.hess_id``: a new zeroed array; checked at the agreement states)."""
    X, UD, Q, V, A = data
    name, nu, nq = model.name, model.nu, model.nq
    if old is not None:
        assert list(old.param_defaults) == list(model.param_defaults)
    assert zeroed is None or old is not None, "the fourth contestant is a floating base's (index 3)"
    src = (HARNESS.replace("@NAME@", name).replace("@NC@", str(2 + (old is not None) + (zeroed is not None)))
           .replace("@OLDINC@", f'#include "{old.name}.h"' if old is not None else "")
           .replace("@OLDCALL@", "if (c == 2) { if (%s_hess_id(0.0, X[i], UD[i], P, R, out, work)) exit(6); "
                    "return out[NX]; }" % old.name if old is not None else "").replace("@NS@", str(bd.NS)).replace("@NX@", str(model.nx))
           .replace("@NU@", str(nu)).replace("@PQ@", str(ref.model.nq)).replace("@ROUNDS@", str(rounds))
           .replace("@NZINC@", f'#include "{zeroed.name}.h"' if zeroed is not None else "")
           .replace("@NZCALL@", "if (c == 3) { if (%s_hess_id(0.0, X[i], UD[i], P, R, out3, work)) exit(7); "
                    "return out3[NX]; }" % zeroed.name if zeroed is not None else "")
           .replace("@NAGREE@", str(NAGREE)).replace("@WORK@", str(max(model.work_size, old.work_size if old is not None else 0, 1)))
           .replace("@X@", bd.c_array(X)).replace("@UD@", bd.c_array(UD)).replace("@Q@", bd.c_array(Q))
           .replace("@V@", bd.c_array(V)).replace("@A@", bd.c_array(A))
           .replace("@P@", ", ".join(repr(float(v)) for v in model.param_defaults) or "0.0")
           .replace("@R@", ", ".join("0.0" for _ in range(max(model.ninput, 1)))))
    c = tmp / f"h2_{name}.c"
    c.write_text(src)
    objs = []
    units = [(c, tmp / f"h2_{name}.o"), (model.source_path, tmp / f"m2_{name}.o")]
    incs = [f"-I{model.directory}"]
    for m in (old, zeroed):
        if m is not None:
            units.append((m.source_path, tmp / f"m2_{m.name}.o"))
            incs.append(f"-I{m.directory}")
    for s, o in units:
        subprocess.run(["gcc", *cflags, "-std=c99", *incs, f"-I{ROOT / 'runtime' / 'c'}", "-c",
                        str(s), "-o", str(o)], check=True)
        objs.append(str(o))
    exe = tmp / f"h2_{name}"
    subprocess.run(["g++", *objs, str(pin_obj), "-o", str(exe), "-lm"], check=True)
    (tmp / f"pin2_{name}.txt").write_text(bd.pin_text(ref.model, ref.gravity))
    out = subprocess.run(["taskset", "-c", str(core), str(exe), str(tmp / f"pin2_{name}.txt")], capture_output=True,
                         text=True, check=True).stdout
    nv, iv = ref.model.nv, ref.iv
    pin = {}
    times = {}
    labels = LABELS[:2] + ((TANGENT,) if tangent else LABELS[2:]) + (ZEROED,)
    for line in out.splitlines():
        p = line.split()
        if p[0] == "pin":
            pin.setdefault(int(p[1]), []).append([float(v) for v in p[2:]])
        elif p[0] == "time":
            times.setdefault(labels[int(p[1])], []).append(float(p[2]))
    worst, worst_old = 0.0, 0.0
    for i in range(NAGREE):
        T = np.array(pin[i]).reshape(nv, nv, nv, 3)
        qq, vv, qv = (T[..., k][np.ix_(iv, iv, iv)] for k in range(3))
        H = model.hess_id(0.0, X[i], UD[i])
        if zeroed is not None:    # the same bits, every entry written by the build that zeroes
            full = np.full(H.size, np.nan)
            t, xc, p, rc = zeroed._args(0.0, X[i], None, None)
            assert zeroed._kernel("hess_id")(t, xc, UD[i], p, rc, full, zeroed._work()[1]) == 0
            assert np.array_equal(full.reshape(H.shape), H), f"{zeroed.name}: not hess_id's bits"
        if tangent:
            worst_old = max(worst_old, against_differences(model, X[i], UD[i], H))
            H = old.hess_id(0.0, X[i], UD[i])
        elif old is not None:
            Ho = old.hess_id(0.0, X[i], UD[i])
            worst_old = max(worst_old, np.max(np.abs(H - Ho)) / np.max(np.abs(Ho)))
            H = H.copy()        # the laws' own entries: Pinocchio's (it has no joint laws)
            for r in range(nu):
                H[r, r, r], H[r, nq + r, nq + r] = qq[r, r, r], vv[r, r, r]
                H[r, r, nq + r] = H[r, nq + r, r] = qv[r, r, r]
        scale = max(np.max(np.abs(qq)), np.max(np.abs(vv)), np.max(np.abs(qv)))
        # Pinocchio's d2tau_dqdv(i, j, k) = d2 tau_i / dq_j dv_k (measured: q along the columns,
        # whatever its header's comment says), eomc's [i, j, nq + k]
        diff = max(np.max(np.abs(H[:, :nq, :nq] - qq)), np.max(np.abs(H[:, nq:nq + nu, nq:nq + nu] - vv)),
                   np.max(np.abs(H[:, :nq, nq:nq + nu] - qv)))
        worst = max(worst, diff / scale)
    return {k: float(np.median(v)) for k, v in times.items()}, worst, worst_old


def against_differences(model, x, ud, H, h=1e-5):
    """Largest difference of hess_id ``H`` from central differences of jac_id, relative to the largest entry."""
    fd = np.stack([(model.jac_id(0.0, x + h * e, ud) - model.jac_id(0.0, x - h * e, ud)) / (2 * h)
                   for e in np.eye(model.nx)], axis=2)
    return float(np.max(np.abs(H - fd)) / np.max(np.abs(fd)))


def build_limited(case, cache):
    """(kernel Model, old-path Model, Pinocchio reference) of a robot with its joint limits on."""
    import warnings
    import eomc
    import eomc.compiler.tree.second_order as so
    from eomc.compiler.urdf import from_urdf
    from helpers.robots import PinRef, joints_of, robot_path
    rel, floating = bd.ROBOTS[case]
    if floating:
        sys.exit(f"{case}: floating bases are not compared (see the module doc)")
    path = robot_path(rel)
    system = from_urdf(path)      # for Pinocchio's joint order; the models are built from the file (its laws)
    fns = ["rhs", "inverse_dynamics", "jac_id", "hess_id"]
    models = []
    for suffix, forced in (("_lim", False), ("_limold", True)):
        orig = so.second_order_plan
        if forced:
            so.second_order_plan = lambda plan: (None, "forced by bench_second_order.py --limits")
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                models.append(eomc.compile(str(path), case + suffix, functions=fns, formulation="recursive",
                                           cache_dir=cache, progress=False))
        finally:
            so.second_order_plan = orig
    kernel, old = models
    assert kernel.metadata["hess_id"].startswith("analytic"), kernel.metadata["hess_id"]
    assert old.metadata["hess_id"].startswith("forward over reverse"), old.metadata["hess_id"]
    ref = PinRef(path, joints_of(system), floating=False)
    ref.gravity = ref.model.gravity.linear
    return kernel, old, ref


def build(case, cache):
    """(eomc Model with hess_id, Pinocchio reference, the tangent build or None, the build that
    zeroes its output every call or None) of one case.

    A floating base (Go2, G1, Talos: eomc's free joint, body XYZ Euler angles, body-frame speeds)
    is built twice: as eomc builds it (hess_id along the coordinates, the Euler angles) and with
    the kernel's entries left along the free joint's tangent (second_order.TANGENT: Pinocchio's
    Lie-group tangent, the same quantities as its tensors; the change to the coordinates, per row
    two 3x3 blocks over the row's columns plus K's derivative, is what it leaves out), and a third
    time along the coordinates with second_order.ZERO set (the whole output zeroed every call; by
    default the entries off the support paths, most of a branched tree's output, are left as the
    caller zeroed them once: Pinocchio's contract)."""
    import eomc.compiler.tree.second_order as so
    fns = ["rhs", "inverse_dynamics", "jac_id", "hess_id"]
    model, ref, floating = bd.build_case(case, cache, functions=fns)
    if not floating:
        return model, ref, None, None
    so.TANGENT = True
    try:
        xi = bd.build_case(case, cache / "tangent", functions=fns, name=case + "_xi")[0]
    finally:
        so.TANGENT = False
    so.ZERO = True
    try:
        zeroed = bd.build_case(case, cache / "zeroed", functions=fns, name=case + "_z")[0]
    finally:
        so.ZERO = False
    return model, ref, xi, zeroed


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--cart", default="4,8,20")
    ap.add_argument("--robots", default="ur10,panda")
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--pin-obj", default="", help="an already compiled pin_derivatives.o (saves minutes)")
    ap.add_argument("--cache", default="", help="a build cache directory to keep between runs")
    ap.add_argument("--limits", action="store_true", help="robots with their joint limits on, and the old path")
    ap.add_argument("--portable", action="store_true",
                    help="eomc's C with -O2 only (eomc build --portable), Pinocchio with -O2")
    ap.add_argument("--core", type=int, default=1, help="the core the harness is pinned to")
    ap.add_argument("--write", action="store_true")
    a = ap.parse_args()
    cflags = eomc_flags(a.portable)
    isa = [f for f in cflags if f.startswith("-m")]     # Pinocchio gets the same instruction set
    cases = [f"cart{n}" for n in a.cart.split(",") if n] + [r for r in a.robots.split(",") if r]
    tmp = Path(tempfile.mkdtemp(prefix="eomc_so_"))
    if a.pin_obj:
        pin_obj = Path(a.pin_obj)
    else:
        from common import compile_pinocchio
        pin_obj = compile_pinocchio(bd.MODELS / "pin_derivatives.cpp", tmp / "pin_derivatives.o", flags=isa)
        if pin_obj is None:
            sys.exit("Pinocchio's headers (pin / cmeel wheels) are needed")
    rng = np.random.default_rng(30)
    rows = []
    if a.limits:
        cases = [c for c in cases if not c.startswith("cart")]
    for case in cases:
        cache = Path(a.cache) if a.cache else tmp / "cache"
        if a.limits:
            model, old, ref = build_limited(case, cache)
            zeroed = None
        else:
            model, ref, old, zeroed = build(case, cache)
        data = bd.states(model, ref, old is not None and not a.limits, rng)
        times, agree, agree_old = run(model, ref, data, tmp, pin_obj, a.rounds, old, cflags,
                                      tangent=old is not None and not a.limits, core=a.core, zeroed=zeroed)
        ops = model.metadata["op_counts"]
        row = dict(case=case, nx=model.nx, times=times, agree=agree, agree_old=agree_old,
                   ops={f: sum(ops[f].values()) for f in ("jac_id", "hess_id")})
        rows.append(row)
        render = render_limited if a.limits else render_row
        if a.write:
            with open(HERE / "results" / "second_order.md", "a") as f:
                f.write((header(a.rounds, a.limits, cflags, isa, floating(cases), a.core) if len(rows) == 1 else "")
                        + render(row) + "\n")
        print(render(row), flush=True)


def floating(cases):
    """Whether some case is a floating base (its rows have a third contestant, the tangent build)."""
    return any(bd.ROBOTS.get(c, (None, False))[1] for c in cases)


def header(rounds, limits=False, cflags=("-O2",), isa=(), three=False, core=1):
    import pinocchio
    import eomc
    commit, dirty, cpu = bd.checkout_state()
    return "\n".join([
        f"\n## {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC, eomc {commit}"
        f"{' (+ uncommitted changes)' if dirty else ''}\n",
        f"`python benchmarks/bench_second_order.py` — {cpu}, load {os.getloadavg()[0]:.1f} at the start, "
        f"Python {platform.python_version()}, Pinocchio {pinocchio.__version__} (header-only, g++ {' '.join(['-O2', *isa])}), "
        f"eomc {eomc.__version__}, gcc {' '.join(cflags)}; thread CPU, pinned to core {core}, "
        f"{'3' if limits else '2 (4 on a floating base)' if three else '2'} contestants interleaved, "
        f"median of {rounds} rounds, {bd.NS} states cycled.  eomc: `--formulation recursive`, functions rhs, "
        "inverse_dynamics, jac_id, hess_id.\n",
    ] + (["-O2 alone: eomc's C takes its kernel's AVX2 twin (NAME_rnea_hess_avx2, chosen per call by the CPU, the same "
          "bits) on this CPU, where Pinocchio's -O2 build runs SSE2 (each library's default build); the machine-flag "
          "rows compare both at AVX2.\n"] if not isa and _has_avx2() else []) + ([
        "`--limits`: the robots with their joint limits on (the default build); \"old path\": the same "
        "model's hess_id forced onto forward over reverse (what these builds got before the kernel "
        "covered joint laws), a third contestant in the same harness.  Pinocchio has no joint laws: its "
        "agreement leaves out the laws' own entries.\n",
        "| model (limits on) | nx | eomc hess_id ns, kernel | old path ns | **old / kernel** | "
        "Pinocchio 2nd-order RNEA ns | **Pinocchio / kernel** | kernel vs old path | vs Pinocchio (laws' entries out) |",
        "|---|--:|--:|--:|--:|--:|--:|--|--|"] if limits else [
        "Floating bases (eomc's free joint: body XYZ Euler angles, body-frame speeds): \"hess_id\" is "
        "along eomc's coordinates (what `model.hess_id` returns), \"tangent\" the same kernel with the free "
        "joint's entries left along its tangent, Pinocchio's convention (what its tensors are); agreement "
        "with Pinocchio is the tangent build's, and the coordinate build is checked against central "
        "differences of its jac_id.  Both write only the entries on the support paths and leave the rest as "
        "the caller zeroed them once (the default since session 13; Pinocchio's contract: its Data's tensors "
        "are zeroed when made, its second-order RNEA writes only those entries; the harness's outputs are "
        "zeroed once).  \"zeroed\": hess_id along the coordinates built with second_order.ZERO set, which "
        "zeroes its whole output every call (the default before); its bits equal hess_id's (checked at 4 states).\n",
        "| model | nx | eomc hess_id ns | eomc tangent ns | eomc zeroed ns | Pinocchio 2nd-order RNEA ns | "
        "**Pinocchio / hess_id** | **Pinocchio / tangent** | **Pinocchio / zeroed** | ops jac_id / hess_id | "
        "agreement with Pinocchio (q,q), (u,u), (q,u) | hess_id vs differences of jac_id |",
        "|---|--:|--:|--:|--:|--:|--:|--:|--:|--|--|--|"])) + "\n"


def _has_avx2():
    from eomc.runtime.cpu import cpu_features
    return "avx2" in (cpu_features() or ())


def render_limited(r):
    t = r["times"]
    k, o, p = t[LABELS[0]], t[LABELS[2]], t[LABELS[1]]
    return (f"| {r['case']} | {r['nx']} | {k:.0f} | {o:.0f} | **{o / k:.1f}** | {p:.0f} | **{p / k:.2f}** | "
            f"{r['agree_old']:.1e} | {r['agree']:.1e} |")


def render_row(r):
    t = r["times"]
    e, p, x, z = t[LABELS[0]], t[LABELS[1]], t.get(TANGENT), t.get(ZEROED)
    tang, ratio, fd = (f"{x:.0f}", f"**{p / x:.2f}**", f"{r['agree_old']:.1e}") if x else ("-", "-", "-")
    zl, zr = (f"{z:.0f}", f"**{p / z:.2f}**") if z else ("-", "-")
    return (f"| {r['case']} | {r['nx']} | {e:.0f} | {tang} | {zl} | {p:.0f} | **{p / e:.2f}** | {ratio} | {zr} | "
            f"{r['ops']['jac_id']} / {r['ops']['hess_id']} | {r['agree']:.1e} | {fd} |")


if __name__ == "__main__":
    main()
