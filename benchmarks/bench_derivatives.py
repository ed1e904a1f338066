"""Issue 30: eomc's jac_x and jac_id against Pinocchio's analytic derivatives, one C harness.

Contestants (per model, one harness, pinned to one core (--core, default 0), thread CPU, interleaved with the order
rotated every round, ~20 ms blocks, median of rounds; ns per call):
  * eomc ``jac_x`` (d xdot/dx, nx x nx) and ``jac_id`` (d tau/dx at given u', nu x nx) of a
    ``--formulation recursive`` build with functions rhs, jac_x, inverse_dynamics, jac_id
    (runtime parameters at the model's defaults), the generated C compiled into the harness
    with gcc -O2;
  * Pinocchio ``computeABADerivatives`` and ``computeRNEADerivatives`` (header-only from the
    pin / cmeel wheels, g++ -O2 -std=c++17, benchmarks/tree_models/pin_derivatives.cpp) on the
    same model: pinocchio.buildModelFromUrdf's (free-flyer root for floating bases) or, for the
    cart, the model of tree_models/pin_aba.cpp, written to text and rebuilt in C++.
Models: SD/FAST's n-link cart (tree_models/cart_rel_joints.py; runtime parameters, gravity along
-y) and URDF robots from example-robot-data with limits off (UR10, Panda, Go2, G1 29-dof, Talos
full body; the last three floating).

Agreement, before timing, in Python at 8 random states: jac_id against the pin wheel's
computeRNEADerivatives, jac_x's acceleration rows against computeABADerivatives (zero torques
and inputs).  On a floating base eomc's coordinates are body XYZ Euler angles, Pinocchio
differentiates along its Lie-group tangent: its d/dq is eomc's d/dq times K = dq'/du (the
kinematic rows of jac_x).  Also the C++ model rebuilt from text against the wheel's (RNEA
derivatives at state 0).

Usage: python benchmarks/bench_derivatives.py [--cart 4,8,20,40,80] [--robots ur10,panda,go2,g1,talos]
       [--rounds 9] [--write]      (--write: appends a section to results/derivatives.md, row by row)
"""
import argparse
import datetime
import os
import platform
import runpy
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
MODELS = HERE / "tree_models"
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(ROOT / "tests"))

ROBOTS = {   # example-robot-data path, floating base
    "ur10": ("ur_description/urdf/ur10_robot.urdf", False),
    "panda": ("panda_description/urdf/panda.urdf", False),
    "go2": ("go2_description/urdf/go2.urdf", True),
    "g1": ("g1_description/urdf/g1_29dof_rev_1_0.urdf", True),
    "talos": ("talos_data/robots/talos_full_v2.urdf", True),
}
NS = 32

HARNESS = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <time.h>
#include "@NAME@.h"
int pin_setup(const char *path);
void pin_aba_derivatives(const double *q, const double *v, const double *tau);
void pin_rnea_derivatives(const double *q, const double *v, const double *a);
void pin_copy_rnea(double *dq, double *dv);
#define NS @NS@
#define NX @NX@
#define NU @NU@
#define PQ @PQ@
static const double X[NS][NX] = {@X@};
static const double UD[NS][NU] = {@UD@};
static const double Q[NS][PQ] = {@Q@};
static const double V[NS][NU] = {@V@};
static const double A[NS][NU] = {@A@};
static const double TAU[NU] = {0};
static const double P[] = {@P@};   /* the model's parameter defaults */
static const double R[] = {@R@};   /* zero inputs */
static double out[NX * NX], dq[NU * NU], dv[NU * NU];
static double tnow(void) { struct timespec ts; clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return ts.tv_sec * 1e9 + ts.tv_nsec; }
static void call(int c, int i) {
    switch (c) {
    case 0: @NAME@_jac_x(0.0, X[i], P, R, out, NULL); break;
    case 1: @NAME@_jac_id(0.0, X[i], UD[i], P, R, out, NULL); break;
    case 2: pin_aba_derivatives(Q[i], V[i], TAU); break;
    case 3: pin_rnea_derivatives(Q[i], V[i], A[i]); break;
    }
}
int main(int argc, char **argv) {
    int i, k, c, round;
    double sum = 0.0;
    (void)argc;
    pin_setup(argv[1]);
    pin_rnea_derivatives(Q[0], V[0], A[0]);
    pin_copy_rnea(dq, dv);
    for (k = 0; k < NU * NU; k++) printf("rnea0 %.17g %.17g\n", dq[k], dv[k]);
    for (round = 0; round < @ROUNDS@; round++) {
        for (c = 0; c < 4; c++) {
            int cc = (c + round) % 4; long calls = 0; double t0 = tnow(), t1;
            do { for (i = 0; i < NS; i++) { call(cc, i); sum += out[NX]; } calls += NS; t1 = tnow(); }
            while (t1 - t0 < 2e7);
            printf("time %d %.1f\n", cc, (t1 - t0) / calls);
        }
    }
    printf("checksum %g\n", sum);
    return 0;
}
"""
LABELS = ("eomc jac_x", "eomc jac_id", "Pinocchio computeABADerivatives", "Pinocchio computeRNEADerivatives")


def pin_text(model, gravity):
    """pinocchio.Model -> the text pin_derivatives.cpp reads."""
    rows = ["gravity " + " ".join(repr(float(g)) for g in gravity)]
    for i in range(1, model.njoints):
        j = model.joints[i]
        sn = j.shortname()
        axis = (j.extract().axis if sn in ("JointModelRevoluteUnaligned", "JointModelPrismaticUnaligned")
                else np.zeros(3))
        P, I = model.jointPlacements[i], model.inertias[i]
        vals = (list(axis) + list(np.asarray(P.rotation).reshape(-1)) + list(P.translation) + [I.mass]
                + list(I.lever) + list(np.asarray(I.inertia).reshape(-1)))
        rows.append(f"{model.names[i]} {model.parents[i]} {sn} " + " ".join(repr(float(v)) for v in vals))
    return "\n".join(rows) + "\n"


class CartRef:
    """Pinocchio's cart (tree_models/pin_aba.cpp's model) reading eomc's vectors (same order)."""

    def __init__(self, n, m0=2.0, m=0.5, l=0.75, g=9.81):
        import pinocchio as pin
        model = pin.Model()
        model.gravity = pin.Motion(np.array([0.0, -g, 0.0]), np.zeros(3))
        parent = model.addJoint(0, pin.JointModelPX(), pin.SE3.Identity(), "cart")
        model.appendBodyToJoint(parent, pin.Inertia(m0, np.zeros(3), np.zeros((3, 3))), pin.SE3.Identity())
        offset = np.zeros(3)
        for i in range(n):
            parent = model.addJoint(parent, pin.JointModelRZ(), pin.SE3(np.eye(3), offset), f"link{i}")
            lever = np.array([0.0, -l, 0.0])
            model.appendBodyToJoint(parent, pin.Inertia(m, lever, np.zeros((3, 3))), pin.SE3.Identity())
            offset = lever
        self.model, self.data = model, model.createData()
        self.iv = list(range(n + 1))
        self.gravity = model.gravity.linear

    def q(self, q):
        return np.asarray(q, dtype=float)

    def v(self, v):
        return np.asarray(v, dtype=float)


FUNCTIONS = ["rhs", "jac_x", "inverse_dynamics", "jac_id"]


def build_case(case, cache, functions=FUNCTIONS, name=None):
    """(eomc Model, Pinocchio reference, floating) of one case (a robot's model named ``name``, default the case)."""
    import eomc
    if case.startswith("cart"):
        n = int(case[4:])
        os.environ["EOMC_N_LINKS"] = str(n)
        mod = runpy.run_path(str(MODELS / "cart_rel_joints.py"))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = eomc.compile(mod["system"], f"cart{n}", parameters=mod["parameters"], inputs=mod["inputs"],
                                 functions=functions, formulation="recursive", cache_dir=cache, progress=False)
        return model, CartRef(n), False
    from eomc.compiler.urdf import from_urdf
    from helpers.robots import PinRef, joints_of, robot_path
    rel, floating = ROBOTS[case]
    path = robot_path(rel)
    system = from_urdf(path, floating_base=floating, limits=False)
    model = eomc.compile(system, name or case, functions=functions, formulation="recursive", cache_dir=cache,
                         progress=False)
    ref = PinRef(path, joints_of(system), floating=floating)
    ref.gravity = ref.model.gravity.linear
    return model, ref, floating


def states(model, ref, floating, rng):
    """NS random states: eomc (x, u'), Pinocchio (q, v, a)."""
    nq, nu = model.nq, model.nu
    X, UD, Q, V, A = [], [], [], [], []
    for _ in range(NS):
        q = rng.uniform(-np.pi, np.pi, nq)
        if floating:
            q[:3], q[3:6] = rng.uniform(-1, 1, 3), rng.uniform(-1.2, 1.2, 3)
        v, a = rng.uniform(-1, 1, nu), rng.normal(size=nu)
        X.append(np.concatenate([q, v, np.zeros(model.nx - nq - nu)]))
        UD.append(a)
        Q.append(ref.q(q))
        V.append(ref.v(v))
        A.append(ref.v(a))
    return [np.array(z) for z in (X, UD, Q, V, A)]


def agreement(model, ref, X, UD):
    """Largest relative differences of jac_id and jac_x against the pin wheel, 8 states."""
    import pinocchio as pin
    nq, nu = model.nq, model.nu
    worst = {"jac_id": 0.0, "jac_x": 0.0}
    iv = ref.iv
    rel = lambda a, b: float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300))
    for x, a in zip(X[:8], UD[:8]):
        q, v = x[:nq], x[nq:nq + nu]
        Jx = model.jac_x(0.0, x)
        K = Jx[:nq, nq:nq + nu]
        Jid = model.jac_id(0.0, x, a)
        pin.computeRNEADerivatives(ref.model, ref.data, ref.q(q), ref.v(v), ref.v(a))
        dq, dv = ref.data.dtau_dq[np.ix_(iv, iv)], ref.data.dtau_dv[np.ix_(iv, iv)]
        worst["jac_id"] = max(worst["jac_id"], rel(Jid[:, :nq] @ K, dq), rel(Jid[:, nq:nq + nu], dv))
        pin.computeABADerivatives(ref.model, ref.data, ref.q(q), ref.v(v), np.zeros(ref.model.nv))
        dq, dv = ref.data.ddq_dq[np.ix_(iv, iv)], ref.data.ddq_dv[np.ix_(iv, iv)]
        worst["jac_x"] = max(worst["jac_x"], rel(Jx[nq:nq + nu, :nq] @ K, dq), rel(Jx[nq:nq + nu, nq:nq + nu], dv))
    return worst


def c_array(a):
    return ", ".join("{" + ", ".join(repr(float(v)) for v in row) + "}" for row in a)


def harness(model, ref, data, tmp, pin_obj, rounds, flags=(), core=0):
    X, UD, Q, V, A = data
    name = model.name
    src = (HARNESS.replace("@NAME@", name).replace("@NS@", str(NS)).replace("@NX@", str(model.nx))
           .replace("@NU@", str(model.nu)).replace("@PQ@", str(ref.model.nq)).replace("@ROUNDS@", str(rounds))
           .replace("@X@", c_array(X)).replace("@UD@", c_array(UD)).replace("@Q@", c_array(Q))
           .replace("@V@", c_array(V)).replace("@A@", c_array(A))
           .replace("@P@", ", ".join(repr(float(v)) for v in model.param_defaults) or "0.0")
           .replace("@R@", ", ".join("0.0" for _ in range(max(model.ninput, 1)))))
    c = tmp / f"h_{name}.c"
    c.write_text(src)
    d = model.directory
    objs = []
    for s, o in ((c, tmp / f"h_{name}.o"), (model.source_path, tmp / f"m_{name}.o")):
        subprocess.run(["gcc", "-O2", *flags, "-std=c99", f"-I{d}", f"-I{ROOT / 'runtime' / 'c'}", "-c", str(s),
                        "-o", str(o)], check=True)
        objs.append(str(o))
    exe = tmp / f"h_{name}"
    subprocess.run(["g++", *objs, str(pin_obj), "-o", str(exe), "-lm"], check=True)
    (tmp / f"pin_{name}.txt").write_text(pin_text(ref.model, ref.gravity))
    out = subprocess.run(["taskset", "-c", str(core), str(exe), str(tmp / f"pin_{name}.txt")], capture_output=True,
                         text=True, check=True).stdout
    nv = ref.model.nv
    r0 = np.array([[float(v) for v in line.split()[1:]] for line in out.splitlines() if line.startswith("rnea0")])
    import pinocchio as pin
    pin.computeRNEADerivatives(ref.model, ref.data, Q[0], V[0], A[0])
    text_model = max(np.max(np.abs(r0[:, 0].reshape(nv, nv) - ref.data.dtau_dq)),
                     np.max(np.abs(r0[:, 1].reshape(nv, nv) - ref.data.dtau_dv))) / np.max(np.abs(ref.data.dtau_dq))
    times = {}
    for line in out.splitlines():
        if line.startswith("time"):
            _, k, v = line.split()
            times.setdefault(LABELS[int(k)], []).append(float(v))
    return {k: float(np.median(v)) for k, v in times.items()}, float(text_model)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--cart", default="4,8,20,40,80")
    ap.add_argument("--robots", default="ur10,panda,go2,g1,talos")
    ap.add_argument("--rounds", type=int, default=9)
    ap.add_argument("--cache", default="", help="a build cache directory to keep between runs (keys hold "
                    "eomc's compiler sources, so a changed compiler rebuilds)")
    ap.add_argument("--pin-obj", default="", help="pin_derivatives.cpp already compiled (saves minutes)")
    ap.add_argument("--write", action="store_true")
    ap.add_argument("--core", type=int, default=0, help="the core the harness is pinned to")
    ap.add_argument("--machine", action="store_true", help="compile eomc's C and Pinocchio alike with the "
                    "machine flags eomc's own builds use on this machine (-mavx2 -ffp-contract=off), not -O2 alone")
    a = ap.parse_args()
    from eomc.compiler.build.toolchain import MACHINE_FLAGS
    flags = MACHINE_FLAGS if a.machine else ()
    cases = [f"cart{n}" for n in a.cart.split(",") if n] + [r for r in a.robots.split(",") if r]
    from common import compile_pinocchio
    tmp = Path(tempfile.mkdtemp(prefix="eomc_bd_"))
    cache = Path(a.cache) if a.cache else tmp / "cache"
    pin_obj = (Path(a.pin_obj) if a.pin_obj
               else compile_pinocchio(MODELS / "pin_derivatives.cpp", tmp / "pin_derivatives.o", flags=flags))
    if pin_obj is None:
        sys.exit("Pinocchio's headers (pin / cmeel wheels) are needed")
    rng = np.random.default_rng(30)
    rows = []
    for case in cases:
        t0 = time.time()
        model, ref, floating = build_case(case, cache)
        built = time.time() - t0
        data = states(model, ref, floating, rng)
        agree = agreement(model, ref, data[0], data[1])
        times, text_model = harness(model, ref, data, tmp, pin_obj, a.rounds, flags, a.core)
        ops = model.metadata["op_counts"]
        row = dict(case=case, nx=model.nx, nu=model.nu, times=times, agree=agree, text=text_model,
                   ops={f: sum(ops[f].values()) for f in ("rhs", "jac_x", "jac_id")}, build=built)
        rows.append(row)
        if a.write:      # row by row: a long run interrupted keeps what it measured
            with open(HERE / "results" / "derivatives.md", "a") as f:
                f.write((header(a.rounds, flags, a.core) if len(rows) == 1 else "") + render_row(row) + "\n")
        print(f"{case}: nx {model.nx}  " + "  ".join(f"{k} {v:.0f} ns" for k, v in times.items())
              + f"  ABA/jac_x {times[LABELS[2]] / times[LABELS[0]]:.2f}  RNEA/jac_id {times[LABELS[3]] / times[LABELS[1]]:.2f}"
              f"  agree {agree}  text model {text_model:.1e}  (built in {built:.1f} s wall)", flush=True)
    print(header(a.rounds, flags, a.core) + "".join(render_row(r) + "\n" for r in rows))


def checkout_state():
    """(short commit, uncommitted changes as text, CPU model) for a results header."""
    commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True).stdout.strip()
    dirty = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "--untracked-files=no"],
                           capture_output=True, text=True).stdout.strip()
    cpu = next((line.split(":", 1)[1].strip() for line in open("/proc/cpuinfo") if line.startswith("model name")), "?")
    return commit, dirty, cpu


def header(rounds, flags=(), core=0):
    import pinocchio
    import eomc
    commit, dirty, cpu = checkout_state()
    extra = "".join(" " + f for f in flags)
    lines = [f"\n## {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC, eomc {commit}"
             f"{' (+ uncommitted changes)' if dirty else ''}\n",
             f"`python benchmarks/bench_derivatives.py` — {cpu}, load {os.getloadavg()[0]:.1f} at the end, "
             f"Python {platform.python_version()}, Pinocchio {pinocchio.__version__} (header-only, g++ -O2{extra}), "
             f"eomc {eomc.__version__}, gcc -O2{extra}; thread CPU, pinned to core {core}, 4 contestants interleaved, "
             f"median of {rounds} rounds, {NS} states cycled.  eomc: `--formulation recursive`, "
             "functions rhs, jac_x, inverse_dynamics, jac_id.\n",
             "| model | nx | eomc jac_x ns | Pinocchio ABA derivs ns | **ABA / jac_x** | eomc jac_id ns | "
             "Pinocchio RNEA derivs ns | **RNEA / jac_id** | ops rhs / jac_x / jac_id | agreement jac_x, jac_id |",
             "|---|--:|--:|--:|--:|--:|--:|--:|--|--|"]
    return "\n".join(lines) + "\n"


def render_row(r):
    t = r["times"]
    return (f"| {r['case']} | {r['nx']} | {t[LABELS[0]]:.0f} | {t[LABELS[2]]:.0f} | "
            f"**{t[LABELS[2]] / t[LABELS[0]]:.2f}** | {t[LABELS[1]]:.0f} | {t[LABELS[3]]:.0f} | "
            f"**{t[LABELS[3]] / t[LABELS[1]]:.2f}** | {r['ops']['rhs']} / {r['ops']['jac_x']} / "
            f"{r['ops']['jac_id']} | {r['agree']['jac_x']:.1e}, {r['agree']['jac_id']:.1e} |")


if __name__ == "__main__":
    main()
