"""One NAME_implicit call in C: the broad-phase build (the default) against the straight-line one.

    python benchmarks/bench_implicit_call.py [--models ant,humanoid]

Why: implicitfast's step is mostly its NAME_implicit call (the humanoid's ~70 %), and the
broad phase (compiler/emit/guards.py: a body's contact forces and K, C slopes skipped far from
the ground) and NAME_finite_wide are meant to make it cheaper with the same numbers.  Each
gymnasium model is built twice -- as shipped, and with NAME_implicit printed straight
(compiler/formulations/recursive.tree_implicit_body replaced by the plain body) -- and a C
harness linked with each model's .c calls NAME_implicit at ~100 states along the model's own
1 s implicitfast run from qpos0, 200 times each; thread CPU, best of 7, both binaries pinned
to core 1 and alternated.  The two builds' outputs are compared at those states (equal up to
the sign of a zero).  Prints a table; results are quoted in benchmarks/results/fixedstep.md.
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

DT = {"hopper": 0.002, "walker2d": 0.002, "ant": 0.01, "humanoid": 0.003}


def build(name, cache, straight=False):
    import eomc
    import eomc.compiler.formulations.recursive as recursive
    from eomc.compiler.mjcf.model import MjcfModel
    shipped = recursive.tree_implicit_body
    if straight:
        recursive.tree_implicit_body = (lambda ctx, prog, guards, size:
                                        recursive.plain_body(ctx, prog, "imp", (size,), "out"))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = eomc.compile(MjcfModel(gym_xml(name)), name=f"ic_{name}", functions=("rhs", "outputs", "implicit"),
                                 cache_dir=Path(cache) / ("straight" if straight else "guarded"), progress=False)
    finally:
        recursive.tree_implicit_body = shipped
    return model, next((Path(cache) / ("straight" if straight else "guarded")).rglob(f"ic_{name}.c"))


def terms(model, X):
    """NAME_implicit's outputs at the rows of X (t = 0, default parameters and inputs)."""
    ffi = model.ffi
    fp = ffi.addressof(model.model_lib, f"{model.name}_implicit")
    r = model._default_r if model.ninput else ffi.NULL
    out = np.zeros((len(X), model.metadata["implicit"]["layout"]["size"]))
    for k, x in enumerate(np.ascontiguousarray(X)):
        assert fp(0.0, ffi.from_buffer("double[]", x), model._default_p, r, ffi.from_buffer("double[]", out[k]),
                  ffi.NULL) == 0
    return out


HARNESS = """#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <time.h>
#include "{h}"
static const double X[{n}][{nx}] = {{{X}}};
static const double P[] = {{{P}}};
static double R[{nr}];
static double OUT[{size}];
int main(void) {{
    struct timespec a, b; double best = 1e9; int rep, k, i, st = 0;
    for (rep = 0; rep < {reps}; rep++) {{
        clock_gettime(CLOCK_THREAD_CPUTIME_ID, &a);
        for (i = 0; i < 200; i++) for (k = 0; k < {n}; k++) st |= {call};
        clock_gettime(CLOCK_THREAD_CPUTIME_ID, &b);
        double t = ((b.tv_sec - a.tv_sec) * 1e9 + (b.tv_nsec - a.tv_nsec)) / (200.0 * {n});
        if (t < best) best = t;
    }}
    printf("%.1f %d\\n", best, st);
    return 0;
}}
"""


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", default="ant,humanoid")
    args = parser.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in [m for m in args.models.split(",") if m]:
            guarded, gc = build(name, tmp)
            straight, sc = build(name, tmp, straight=True)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                run = guarded.simulate(guarded.initial_state, (0.0, 1.0), method="implicitfast", dt=DT[name])
            X = run.x[::max(1, len(run.x) // 100)]
            a, b = terms(guarded, X), terms(straight, X)
            same = bool(np.array_equal(np.abs(a), np.abs(b)))
            meta = guarded.metadata
            fmt = lambda v: ",".join(repr(float(x)) for x in v)  # noqa: E731
            times = {}
            for tag, c in (("straight", sc), ("guarded", gc)):
                h = Path(tmp) / f"h_{name}_{tag}.c"
                h.write_text(HARNESS.format(h=f"ic_{name}.h", n=len(X), nx=guarded.nx,
                                            X=",".join("{" + fmt(x) + "}" for x in X), P=fmt(meta["param_defaults"]),
                                            nr=max(1, meta["ninput"]), size=meta["implicit"]["layout"]["size"],
                                            reps=7, call=f"ic_{name}_implicit(0.0, X[k], P, R, OUT, NULL)"))
                exe = Path(tmp) / f"h_{name}_{tag}"
                subprocess.run(["cc", "-O2", "-std=c99", "-I", str(c.parent), str(h), str(c), "-lm", "-o", str(exe)],
                               check=True)
                times[tag] = exe
            best = {"straight": [], "guarded": []}
            for _ in range(3):
                for tag in ("straight", "guarded"):
                    out = subprocess.run(["taskset", "-c", "1", str(times[tag])], capture_output=True, text=True,
                                         check=True).stdout.split()
                    assert out[1] == "0", f"{name} {tag}: status {out[1]}"
                    best[tag].append(float(out[0]))
            s, g = min(best["straight"]), min(best["guarded"])
            rows.append((name, len(X), s, g, s / g, same))
    print("| model | states | straight-line ns/call | broad phase + finite_wide ns/call | ratio | equal but for zero signs |")
    print("|---|--:|--:|--:|--:|---|")
    for name, n, s, g, r, same in rows:
        print(f"| {name} | {n} | {s:.0f} | {g:.0f} | {r:.2f}x | {same} |")
    return 0 if all(r[-1] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
