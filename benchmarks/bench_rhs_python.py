"""Issue 3 §8c: cost of one right-hand-side evaluation called from Python, per call.

Every tool evaluates xdot for the same n-link cart with the same parameters,
cycling over 1,000 varied states (so no tool sees one state over and over),
and is checked against SymPy's lambdified rhs at random states (~1e-10)
before it is timed:

- eomc model.rhs(t, x, p, r) with the default cffi backend and with
  backend="cython", and model.rhs_many over a batch of 10,000 states (time
  per state); ratios use the faster of the two eomc backends;
- PyDy 0.9.4 generate_ode_function(generator='cython'): f(x, t, r, p).copy()
  (the copy, because PyDy may hand back one buffer it reuses);
- sympy.lambdify (numpy, cse=True) of M and F, then numpy.linalg.solve;
- symengine.Lambdify of [M, F] (LLVM backend when symengine has it), then
  numpy.linalg.solve;
- Pinocchio pin.aba(model, data, q, v, tau), the model built from joints
  (prismatic-X cart + revolute-Z links); its relative-angle states are
  precomputed outside the timed loop.

Goals (issue 3 §8c): eomc rhs >= 5x faster than PyDy's Cython for n <= 8, and
faster than Pinocchio's aba from Python for n <= 12.
"""
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import (Timing, environment_header, format_table, parse_args,  # noqa: E402
                    ratio, write_results)
import models  # noqa: E402

DEFAULT_N = [4, 8, 12, 20]
NSTATES = 1000
NBATCH = 10_000
R = np.array([0.0])


def per_call(call, xs, repeat):
    """Timing (seconds per call) of `call(x)` over the list `xs`, `repeat` passes."""
    for x in xs[:100]:
        call(x)
    samples = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        for x in xs:
            call(x)
        samples.append((time.perf_counter() - t0) / len(xs))
    return Timing(samples)


def competitors(n, kane, specified, tmp):
    """name -> (call(x) for timing, rhs(x, r) for checking); plus notes."""
    import pinocchio as pin
    tools, notes = {}, []
    f, p = models.pydy_ode_function(n, kane, specified, "cython", tmp)
    tools["PyDy Cython"] = (lambda x: f(x, 0.0, R, p).copy(),
                            lambda x, r: f(x, 0.0, r, p).copy())
    lam = models.sympy_lambdified_rhs(n, kane, specified)
    tools["sympy lambdify"] = (lambda x: lam(x, R), lam)
    se_rhs, backend = models.symengine_lambdified_rhs(n, kane, specified)
    tools[f"symengine {backend}"] = (lambda x: se_rhs(x, R), se_rhs)
    notes.append(f"symengine Lambdify backend: {backend}")
    pmodel, pdata = models.pinocchio_model(n)
    tau = np.zeros(n + 1)
    aba = pin.aba
    tools["Pinocchio aba"] = (lambda qv: aba(pmodel, pdata, qv[0], qv[1], tau),
                              models.pinocchio_rhs(n))
    return tools, notes


def eomc_tools(n, tmp):
    """name -> (call, check) for eomc's rhs; rhs_many handled separately."""
    ok, why = models.eomc_status()
    if not ok:
        return None, f"eomc: not available ({why})"
    try:
        model = models.eomc_compile(n, tmp, functions=["rhs"])
        p = models.eomc_p(model, n)
        rhs = model.rhs
        tools = {"eomc rhs": (lambda x: rhs(0.0, x, p, R), lambda x, r: rhs(0.0, x, p, r))}
        try:
            cy = models.eomc_compile(n, Path(tmp) / "cy", functions=["rhs"], backend="cython")
            crhs = cy.rhs
            tools["eomc rhs cython"] = (lambda x: crhs(0.0, x, p, R),
                                        lambda x, r: crhs(0.0, x, p, r))
        except Exception as exc:  # noqa: BLE001 - the Cython backend is optional here
            print(f"eomc cython backend failed: {type(exc).__name__}: {exc}", file=sys.stderr)
        return model, (tools, p)
    except Exception as exc:  # noqa: BLE001 - a half-landed eomc must not kill the run
        return None, f"eomc: failed ({type(exc).__name__}: {str(exc)[:200]})"


def measure(n, repeat):
    """{column: seconds per call or None}, notes."""
    kane, specified = models.sympy_kane(n)
    reference = models.sympy_lambdified_rhs(n, kane, specified)
    xs = list(models.random_states(n, NSTATES, seed=n))
    qvs = [models.to_pinocchio(x, n) for x in xs]
    out, notes = {}, []
    with tempfile.TemporaryDirectory(prefix="bench_rhs_py_") as tmp:
        tools, more = competitors(n, kane, specified, tmp)
        notes += more
        model, eo = eomc_tools(n, Path(tmp) / "eomc")
        if model is not None:
            tools = {**eo[0], **tools}
        else:
            notes.append(eo)
        for name, (call, check) in tools.items():
            models.check_against(reference, check, n, name)
            out[name] = per_call(call, qvs if name == "Pinocchio aba" else xs, repeat).median
        out["eomc rhs_many/state"] = None
        if model is not None:
            X = models.random_states(n, NBATCH, seed=n + 100)
            p = eo[1]
            model.rhs_many(0.0, X[:10], p, R)
            samples = []
            for _ in range(repeat):
                t0 = time.perf_counter()
                model.rhs_many(0.0, X, p, R)
                samples.append((time.perf_counter() - t0) / NBATCH)
            out["eomc rhs_many/state"] = Timing(samples).median
    return out, notes


def main(argv=None):
    args = parse_args(__doc__.splitlines()[0], DEFAULT_N, default_repeat=7, argv=argv)
    cols = ["eomc rhs", "eomc rhs cython", "eomc rhs_many/state", "PyDy Cython", "sympy lambdify",
            "symengine", "Pinocchio aba"]
    headers = (["n"] + [f"{c} [µs]" for c in cols]
               + ["PyDy/best eomc", "aba/best eomc", "goal"])
    rows, notes = [], []
    for n in args.n:
        res, more = measure(n, args.repeat)
        notes += [f"n={n}: {m}" for m in more if m not in notes]
        res = {("symengine" if k.startswith("symengine") else k): v for k, v in res.items()}
        us = [None if res.get(c) is None else res[c] * 1e6 for c in cols]
        ours = [res[k] for k in ("eomc rhs", "eomc rhs cython") if res.get(k) is not None]
        best = min(ours) if ours else None
        r_pydy = ratio(res.get("PyDy Cython"), best)
        r_pin = ratio(res.get("Pinocchio aba"), best)
        if r_pydy is None:
            goal = "eomc n/a"
        else:
            want = [] if n > 8 else [r_pydy >= 5]
            want += [] if n > 12 else [r_pin > 1]
            goal = "n/a (n>12)" if not want else ("met" if all(want) else "MISSED")
        rows.append([n, *us, r_pydy, r_pin, goal])
        print(format_table(headers, [rows[-1]]).splitlines()[-1], flush=True)
    table = format_table(headers, rows)
    print(table)
    backends = sorted({m.split(": ")[-1] for m in notes if "backend" in m})
    header = environment_header(
        "RHS cost from Python, per call (issue 3 §8c)", args,
        notes=[f"µs per call: median of {args.repeat} passes over {NSTATES} varied states; "
               f"rhs_many: per state of a {NBATCH}-state batch",
               "every tool is checked against sympy.lambdify at random states (<= 1e-10 rel) "
               "before timing",
               "PyDy: generate_ode_function(generator='cython'), the returned array copied",
               f"symengine Lambdify backend: {', '.join(backends) or 'n/a'}",
               "Pinocchio: pin.aba(model, data, q, v, tau), prismatic-X cart + revolute-Z "
               "joints built with the pin package; relative-angle states precomputed",
               "eomc rhs: default cffi backend; eomc rhs cython: compile(backend='cython'); "
               "ratios use the faster of the two ('best eomc')",
               "goal: eomc rhs >= 5x faster than PyDy Cython for n <= 8, and faster than "
               "Pinocchio aba for n <= 12",
               *[m for m in notes if "backend" not in m]])
    if not args.no_write:
        paths = write_results("rhs_python", header + "\n" + table + "\n",
                              csv_rows=rows, csv_headers=headers)
        print("wrote", ", ".join(str(p) for p in paths))
    return 0


if __name__ == "__main__":
    sys.exit(main())
