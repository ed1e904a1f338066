"""What skipping a joint limit's sides inside the range (compiler/tree/zero_guards.py) saves per call.

    python benchmarks/bench_limit_guards.py [--models humanoid,ant] [--no-write]

gymnasium's models as shipped (limits on), built twice in one process: as the compiler builds
them and with with_threshold_guards switched off.  Each build's rhs and NAME_implicit are timed
in a C harness (thread CPU, best of 9 blocks over ~100 states of a 1-s default run, -O2
-march=native), the two builds' executables alternating 5 times, pinned to one core; the
outputs of the two builds at those states are compared (max relative difference).
"""
import argparse
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_fixedstep import gym_xml  # noqa: E402
from bench_implicit_call import HARNESS, terms as implicit_terms  # noqa: E402
from common import environment_header, write_results  # noqa: E402

def build(name, cache, guarded):
    import eomc
    import eomc.compiler.tree.emit as tree_emit
    from eomc.compiler.mjcf.model import MjcfModel
    shipped = tree_emit.with_threshold_guards
    if not guarded:
        tree_emit.with_threshold_guards = lambda program, guards=(): (program, list(guards))
    try:
        model = eomc.compile(MjcfModel(gym_xml(name)), name=f"lg_{name}", functions=("rhs", "implicit"),
                             cache_dir=cache, progress=False)
    finally:
        tree_emit.with_threshold_guards = shipped
    return model, next(Path(cache).rglob(f"lg_{name}.c"))


def rel(a, b):
    return float(np.max(np.abs(a - b) / np.maximum(1.0, np.abs(b))))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", default="humanoid,ant")
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tmp = Path(tmp)
        for name in [m for m in args.models.split(",") if m]:
            (g, gc), (s, sc) = build(name, tmp / "g", True), build(name, tmp / "s", False)
            run = g.simulate(g.initial_state, (0.0, 1.0))
            X = run.x[::max(1, len(run.x) // 100)]
            meta = g.metadata
            fmt = lambda v: ",".join(repr(float(x)) for x in v)  # noqa: E731
            diff = {"rhs": rel(g.rhs_many(0.0, X), s.rhs_many(0.0, X)),
                    "implicit": rel(implicit_terms(g, X), implicit_terms(s, X))}
            for fn, size, call in (("rhs", g.nx, f"lg_{name}_rhs(0.0, X[k], P, R, OUT, NULL)"),
                                   ("implicit", meta["implicit"]["layout"]["size"],
                                    f"lg_{name}_implicit(0.0, X[k], P, R, OUT, NULL)")):
                exes = {}
                for tag, c in (("guarded", gc), ("straight", sc)):
                    h = tmp / f"h_{name}_{fn}_{tag}.c"
                    h.write_text(HARNESS.format(h=f"lg_{name}.h", n=len(X), nx=g.nx, size=size, call=call,
                                                X=",".join("{" + fmt(x) + "}" for x in X),
                                                P=fmt(meta["param_defaults"]), nr=max(1, meta["ninput"]), reps=9))
                    exes[tag] = tmp / f"h_{name}_{fn}_{tag}"
                    subprocess.run(["cc", "-O2", "-march=native", "-std=c99", "-w", "-I", str(c.parent), str(h),
                                    str(c), "-lm", "-o", str(exes[tag])], check=True)
                best = {"guarded": [], "straight": []}
                for _ in range(5):
                    for tag in best:
                        out = subprocess.run(["taskset", "-c", "1", str(exes[tag])], capture_output=True, text=True,
                                             check=True).stdout.split()
                        assert out[1] == "0", f"{name} {fn} {tag}: status {out[1]}"
                        best[tag].append(float(out[0]))
                sm, gm = float(np.median(best["straight"])), float(np.median(best["guarded"]))
                rows.append((name, fn, len(X), sm, gm, sm / gm, diff[fn]))
    table = ["| model | function | states | limits computed every call, ns | limits' sides guarded, ns | ratio | max rel diff |",
             "|---|---|--:|--:|--:|--:|--:|"]
    table += [f"| {n} | {f} | {k} | {s:.0f} | {g:.0f} | {r:.3f}x | {d:.1e} |" for n, f, k, s, g, r, d in rows]
    text = "\n".join(table)
    print(text)
    if not args.no_write:
        write_results("limit_guards", environment_header("Joint limits' sides skipped inside the range", args)
                      + "\n" + text + "\n", keep_notes=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
