"""Reverse sweeps through body–body pairs and ground contacts (issues 30 and 33): hvp ÷ jac_x and vjp ÷ rhs
on gymnasium's humanoid with its 109 self-pairs (the default: one table call, its reverse twin eomc_pairs_bar
and that twin's tangent, compiler/contact/table.py) beside the same ratios without them (``--pairs
trees``), both with the floor geom removed (humanoid_without_floor), and the stock file (its floor: the
ground law's guarded second derivative, compiler/passes/diff.cusp_pow, and its self-pairs).  Issue 30's
bar: hvp ≤ 4× one jac_x.

Contestants (per model: rhs, jac_x, vjp with its parameter part, hvp), all generated C of one build
each (functions rhs, jac_x, vjp, hvp; gcc -O2), one C harness per model, both pinned to core 1,
thread CPU, ~20 ms blocks, the four functions rotated every round and the two models' harnesses
alternated round by round; median of rounds, ns per call.  States: the model's initial pose with
noise (q ± 0.15, u N(0, 1)), NS of them; the table reports how many self-pair points are pressed
(depth > 0) on average, ground points likewise, and the agreement checked before timing (vjp against
jac_xᵀ·λ, hvp against Richardson central differences of jac_x).

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

from bench_reverse import HARNESS_HEAD, build_harness  # noqa: E402

NS = 8
FUNCTIONS = ["rhs", "jac_x", "vjp", "hvp", "outputs"]
LABELS = ("rhs", "jac_x", "vjp", "hvp")
# label: (the pairs option, the stock file with its floor)
MODES = {"self-pairs (default)": (True, False), "--pairs trees": ("trees", False),
         "stock file: floor + self-pairs": (True, True)}

HARNESS = HARNESS_HEAD + r"""static double xdot[NX], gx[NX], gp[NP + 1], J[NX * NX], out[NX];
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
"""


def humanoid_file():
    import gymnasium
    return Path(os.path.dirname(gymnasium.__file__), "envs/mujoco/assets/humanoid.xml")


def humanoid_without_floor(tmp):
    """gymnasium's humanoid.xml without its floor geom: the self-pairs' cost alone.  (Before the guarded
    second derivative of the ground law, hvp with the floor was non-finite wherever a foot was off the
    ground: the law's δ₊^{3/2} had the second derivative ∞·0 there.)"""
    import re
    text = humanoid_file().read_text()
    text, n = re.subn(r'<geom[^>]*name="floor"[^>]*/>', "", text, count=1)     # (the second is in a comment)
    assert n == 1
    path = tmp / "humanoid.xml"
    path.write_text(text)
    return path


def build(mode, cache, path, floor):
    import eomc
    from eomc.compiler.mjcf.model import MjcfModel
    name = "humf" if floor else "hum" if mode is True else "humt"
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


def pressed(model, X, pairs=True):
    """Points pressed (depth > 0) per state on average: the self-pairs' (pairs) or the ground's."""
    names = list(model.output_names)
    depth = [i for i, k in enumerate(names) if k.startswith("depth_") and ("__" in k) == pairs]
    if not depth:
        return 0.0
    return float(np.mean([np.count_nonzero(np.array(list(model.outputs(0.0, x).values()))[depth] > 0) for x in X]))


def richardson(f, x, v, h=1e-4):
    """d f(x + s v)/ds at 0, central differences with Richardson's step (tests/compiler/contact:
    plain ones at h = 1e-6 are rounding-bound against the contacts' stiff entries)."""
    def central(step):
        return (f(x + step * v) - f(x - step * v)) / (2 * step)
    return (4 * central(h / 2) - central(h)) / 3


def compile_harness(model, X, L, V, tmp):
    return build_harness(HARNESS, model, X, L, V, tmp, NS)


def main():
    from common import environment_header, write_results
    rounds = int(sys.argv[sys.argv.index("--rounds") + 1]) if "--rounds" in sys.argv else 9
    with tempfile.TemporaryDirectory() as td:
        tmp = Path(td)
        cache = Path(sys.argv[sys.argv.index("--cache") + 1]) if "--cache" in sys.argv else tmp / "cache"
        paths = {False: humanoid_without_floor(tmp), True: humanoid_file()}
        exes, info = {}, {}
        for label, (mode, floor) in MODES.items():
            model, secs = build(mode, cache, paths[floor], floor)
            rng = np.random.default_rng(1)
            X = states(model, rng)
            L, V = rng.normal(size=(2, NS, model.nx))
            err = max(np.abs(model.vjp(0.0, x, lam)[1] - model.jac_x(0.0, x).T @ lam).max()
                      / np.abs(model.jac_x(0.0, x).T @ lam).max() for x, lam in zip(X, L))
            herr = max(np.abs(model.hvp(0.0, x, lam, v) - richardson(lambda y: model.jac_x(0.0, y), x, v).T @ lam).max()
                       / np.abs(model.hvp(0.0, x, lam, v)).max() for x, lam, v in zip(X[:3], L, V))
            info[label] = (secs, pressed(model, X), err, herr, model.nx, pressed(model, X, pairs=False))
            exes[label] = compile_harness(model, X, L, V, tmp)
            print(f"{label}: built in {secs:.1f} s CPU, {info[label][1]:.1f} self-pair points pressed, "
                  f"{info[label][5]:.1f} ground points pressed, "
                  f"vjp vs jac_xᵀλ {err:.1e}, hvp vs differences of jac_x {herr:.1e}", flush=True)
        times = {label: {k: [] for k in LABELS} for label in MODES}
        loads = []
        for r in range(rounds):
            order = list(MODES)[r % len(MODES):] + list(MODES)[:r % len(MODES)]     # rotated round by round
            for label in (order if r % 2 == 0 else order[::-1]):
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
        secs, npress, err, herr, nx, nground = info[label]
        rows.append(f"| {label} | {nx} | {npress:.1f} | {nground:.1f} | {m['rhs']:.0f} | {m['jac_x']:.0f} | {m['vjp']:.0f} | "
                    f"{m['hvp']:.0f} | {m['vjp'] / m['rhs']:.2f} | {m['hvp'] / m['jac_x']:.2f} | {secs:.0f} | {err:.0e} "
                    f"| {herr:.0e} |")
    a, b, f = med["self-pairs (default)"], med["--pairs trees"], med["stock file: floor + self-pairs"]
    text = "\n".join([
        environment_header("Reverse sweeps through the humanoid's self-pairs and floor (hvp / jac_x, vjp / rhs)"), "",
        f"gymnasium humanoid, without its floor (humanoid_without_floor) and the stock file, {NS} states (initial pose, q ± 0.15, u N(0, 1)), {rounds} rounds, core 1, "
        f"thread CPU, ns per call (median); load {min(loads):.1f}-{max(loads):.1f} during the timing.", "",
        "| build | nx | self-pair points pressed | ground points pressed | rhs ns | jac_x ns | vjp ns | hvp ns | vjp / rhs | hvp / jac_x "
        "| build s CPU (rhs, jac_x, vjp, hvp, outputs) | vjp vs jac_xᵀλ | hvp vs differences of jac_x |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|", *rows, "",
        f"With the self-pairs: hvp {a['hvp'] / a['jac_x']:.2f}x one jac_x (bar: 4x), vjp {a['vjp'] / a['rhs']:.2f}x rhs; "
        f"without: {b['hvp'] / b['jac_x']:.2f}x, {b['vjp'] / b['rhs']:.2f}x.  Self-pairs over none: rhs "
        f"{a['rhs'] / b['rhs']:.2f}x, jac_x {a['jac_x'] / b['jac_x']:.2f}x, vjp {a['vjp'] / b['vjp']:.2f}x, "
        f"hvp {a['hvp'] / b['hvp']:.2f}x.  The stock file (floor + self-pairs): hvp {f['hvp'] / f['jac_x']:.2f}x "
        f"its jac_x, vjp {f['vjp'] / f['rhs']:.2f}x its rhs; the floor over none: rhs {f['rhs'] / a['rhs']:.2f}x, "
        f"jac_x {f['jac_x'] / a['jac_x']:.2f}x, hvp {f['hvp'] / a['hvp']:.2f}x."])
    print(text)
    if "--no-write" not in sys.argv:
        write_results("pair_reverse", text, keep_notes=True)


if __name__ == "__main__":
    main()
