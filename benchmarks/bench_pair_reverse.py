"""Reverse sweeps through body–body pairs (issues 30 and 33): hvp ÷ jac_x and vjp ÷ rhs on gymnasium's
humanoid (its floor geom removed: see humanoid_without_floor) with its 109 self-pairs (the default: one table call, its reverse twin eomc_pairs_bar and
that twin's tangent, compiler/contact/table.py) beside the same ratios without them (``--pairs
trees``).  Issue 30's bar: hvp ≤ 4× one jac_x.

Contestants (per model: rhs, jac_x, vjp with its parameter part, hvp), all generated C of one build
each (functions rhs, jac_x, vjp, hvp; gcc -O2), one C harness per model, both pinned to core 1,
thread CPU, ~20 ms blocks, the four functions rotated every round and the two models' harnesses
alternated round by round; median of rounds, ns per call.  States: the model's initial pose with
noise (q ± 0.15, u N(0, 1)), NS of them; the table reports how many self-pair points are pressed
(depth > 0) on average, and the agreement checked before timing (vjp against jac_xᵀ·λ).

Usage: taskset -c 1 python benchmarks/bench_pair_reverse.py [--rounds 9] [--no-write]
"""
import os
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))

NS = 8
FUNCTIONS = ["rhs", "jac_x", "vjp", "hvp", "outputs"]
LABELS = ("rhs", "jac_x", "vjp", "hvp")
MODES = {"self-pairs (default)": True, "--pairs trees": "trees"}

HARNESS = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <time.h>
#include "@NAME@.h"
#define NS @NS@
#define NX @NX@
#define NP @NP@
static const double X[NS][NX] = {@X@};
static const double L[NS][NX] = {@L@};
static const double V[NS][NX] = {@V@};
static const double P[] = {@P@};
static const double R[] = {@R@};
static double xdot[NX], gx[NX], gp[NP + 1], J[NX * NX], out[NX];
static double tnow(void) { struct timespec ts; clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return ts.tv_sec * 1e9 + ts.tv_nsec; }
static void call(int c, int i) {
    switch (c) {
    case 0: @NAME@_rhs(0.0, X[i], P, R, xdot, NULL); break;
    case 1: @NAME@_jac_x(0.0, X[i], P, R, J, NULL); break;
    case 2: @NAME@_vjp(0.0, X[i], P, R, L[i], xdot, gx, gp, NULL); break;
    case 3: @NAME@_hvp(0.0, X[i], P, R, L[i], V[i], out, NULL); break;
    }
}
int main(int argc, char **argv) {
    int i, c, round = argc > 1 ? atoi(argv[1]) : 0;
    double sum = 0.0;
    for (c = 0; c < 4; c++) {
        int cc = (c + round) % 4; long calls = 0; double t0 = tnow(), t1;
        do { for (i = 0; i < NS; i++) { call(cc, i); sum += out[0] + gx[0] + J[0] + xdot[0]; } calls += NS; t1 = tnow(); }
        while (t1 - t0 < 2e7);
        printf("time %d %.1f\n", cc, (t1 - t0) / calls);
    }
    printf("checksum %g\n", sum);
    return 0;
}
""".replace("#include <stdio.h>", "#include <stdio.h>\n#include <stdlib.h>")


def c_array(a):
    return ", ".join("{" + ", ".join(repr(float(v)) for v in row) + "}" for row in a)


def humanoid_without_floor(tmp):
    """gymnasium's humanoid.xml without its floor geom: with the floor, hvp is non-finite at every state
    where a foot is off the ground (the ground law's δ₊^{3/2} has the second derivative ∞·0 there,
    with or without self-pairs), and a timing of a failing call says little."""
    import re
    import gymnasium
    text = Path(os.path.dirname(gymnasium.__file__), "envs/mujoco/assets/humanoid.xml").read_text()
    text, n = re.subn(r'<geom[^>]*name="floor"[^>]*/>', "", text, count=1)     # (the second is in a comment)
    assert n == 1
    path = tmp / "humanoid.xml"
    path.write_text(text)
    return path


def build(mode, cache, path):
    import eomc
    from eomc.compiler.mjcf.model import MjcfModel
    name = "hum" if mode is True else "humt"
    t0 = time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(MjcfModel(path, pairs=mode), name, functions=FUNCTIONS, cache_dir=cache, progress=False)
    return model, time.process_time() - t0


def states(model, rng):
    X = np.tile(np.asarray(model.initial_state, dtype=float), (NS, 1))
    X[:, :model.nq] += rng.uniform(-0.15, 0.15, (NS, model.nq))
    X[:, model.nq:] = rng.normal(size=(NS, model.nu))
    return X


def pressed(model, X):
    names = list(model.output_names)
    depth = [i for i, k in enumerate(names) if k.startswith("depth_") and "__" in k]
    if not depth:
        return 0.0
    return float(np.mean([np.count_nonzero(np.array(list(model.outputs(0.0, x).values()))[depth] > 0) for x in X]))


def compile_harness(model, X, L, V, tmp):
    name = model.name
    src = (HARNESS.replace("@NAME@", name).replace("@NS@", str(NS)).replace("@NX@", str(model.nx))
           .replace("@NP@", str(model.nparam)).replace("@X@", c_array(X)).replace("@L@", c_array(L))
           .replace("@V@", c_array(V))
           .replace("@P@", ", ".join(repr(float(v)) for v in model.param_defaults) or "0.0")
           .replace("@R@", ", ".join("0.0" for _ in range(max(model.ninput, 1)))))
    c = tmp / f"h_{name}.c"
    c.write_text(src)
    objs = []
    for s, o in ((c, tmp / f"h_{name}.o"), (model.source_path, tmp / f"m_{name}.o")):
        subprocess.run(["gcc", "-O2", "-std=c99", f"-I{model.directory}", f"-I{ROOT / 'runtime' / 'c'}",
                        "-c", str(s), "-o", str(o)], check=True)
        objs.append(str(o))
    exe = tmp / f"h_{name}"
    subprocess.run(["gcc", *objs, "-o", str(exe), "-lm"], check=True)
    return exe


def main():
    from common import environment_header, write_results
    rounds = int(sys.argv[sys.argv.index("--rounds") + 1]) if "--rounds" in sys.argv else 9
    with tempfile.TemporaryDirectory() as td:
        tmp = Path(td)
        cache = Path(sys.argv[sys.argv.index("--cache") + 1]) if "--cache" in sys.argv else tmp / "cache"
        path = humanoid_without_floor(tmp)
        exes, info = {}, {}
        for label, mode in MODES.items():
            model, secs = build(mode, cache, path)
            rng = np.random.default_rng(1)
            X = states(model, rng)
            L, V = rng.normal(size=(2, NS, model.nx))
            err = max(np.abs(model.vjp(0.0, x, lam)[1] - model.jac_x(0.0, x).T @ lam).max()
                      / np.abs(model.jac_x(0.0, x).T @ lam).max() for x, lam in zip(X, L))
            h = 1e-6
            herr = max(np.abs(model.hvp(0.0, x, lam, v) - (model.jac_x(0.0, x + h * v) - model.jac_x(0.0, x - h * v)).T
                              @ lam / (2 * h)).max() / np.abs(model.hvp(0.0, x, lam, v)).max()
                       for x, lam, v in zip(X[:3], L, V))
            info[label] = (secs, pressed(model, X), err, herr, model.nx)
            exes[label] = compile_harness(model, X, L, V, tmp)
            print(f"{label}: built in {secs:.1f} s CPU, {info[label][1]:.1f} self-pair points pressed, "
                  f"vjp vs jac_xᵀλ {err:.1e}, hvp vs differences of jac_x {herr:.1e}", flush=True)
        times = {label: {k: [] for k in LABELS} for label in MODES}
        loads = []
        for r in range(rounds):
            for label in (list(MODES) if r % 2 == 0 else list(MODES)[::-1]):
                loads.append(os.getloadavg()[0])
                out = subprocess.run(["taskset", "-c", "1", str(exes[label]), str(r)], capture_output=True,
                                     text=True, check=True).stdout
                for line in out.splitlines():
                    if line.startswith("time"):
                        _, k, v = line.split()
                        times[label][LABELS[int(k)]].append(float(v))
    med = {label: {k: statistics.median(v) for k, v in t.items()} for label, t in times.items()}
    rows = []
    for label in MODES:
        m = med[label]
        secs, npress, err, herr, nx = info[label]
        rows.append(f"| {label} | {nx} | {npress:.1f} | {m['rhs']:.0f} | {m['jac_x']:.0f} | {m['vjp']:.0f} | "
                    f"{m['hvp']:.0f} | {m['vjp'] / m['rhs']:.2f} | {m['hvp'] / m['jac_x']:.2f} | {secs:.0f} | {err:.0e} "
                    f"| {herr:.0e} |")
    a, b = med["self-pairs (default)"], med["--pairs trees"]
    text = "\n".join([
        environment_header("Reverse sweeps through the humanoid's self-pairs (hvp / jac_x, vjp / rhs)"), "",
        f"gymnasium humanoid without its floor (humanoid_without_floor: why), {NS} states (initial pose, q ± 0.15, u N(0, 1)), {rounds} rounds, core 1, "
        f"thread CPU, ns per call (median); load {min(loads):.1f}-{max(loads):.1f} during the timing.", "",
        "| build | nx | self-pair points pressed | rhs ns | jac_x ns | vjp ns | hvp ns | vjp / rhs | hvp / jac_x "
        "| build s CPU (rhs, jac_x, vjp, hvp, outputs) | vjp vs jac_xᵀλ | hvp vs differences of jac_x |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|", *rows, "",
        f"With the self-pairs: hvp {a['hvp'] / a['jac_x']:.2f}x one jac_x (bar: 4x), vjp {a['vjp'] / a['rhs']:.2f}x rhs; "
        f"without: {b['hvp'] / b['jac_x']:.2f}x, {b['vjp'] / b['rhs']:.2f}x.  Self-pairs over none: rhs "
        f"{a['rhs'] / b['rhs']:.2f}x, jac_x {a['jac_x'] / b['jac_x']:.2f}x, vjp {a['vjp'] / b['vjp']:.2f}x, "
        f"hvp {a['hvp'] / b['hvp']:.2f}x."])
    print(text)
    if "--no-write" not in sys.argv:
        write_results("pair_reverse", text, keep_notes=True)


if __name__ == "__main__":
    main()
