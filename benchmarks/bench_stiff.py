"""Issue 4 §7, second part: work-precision of implicit methods on a stiff chain.

The spring-damper chain of tests/zoo.py (`spring_damper_chain`), n masses,
alternating soft (k = 1, c = 0.1) and stiff, heavily damped (k = 1e6, c = 1e5)
links: eigenvalues from about -1e5 to O(1), so explicit methods crawl.  Over
10 s from a stretched start, at several tolerances:
- eomc model.simulate(method="radau") (generated Jacobian, loop in C);
- scipy solve_ivp Radau, BDF and LSODA, each given eomc's model.rhs and
  model.jacobian (so only the integrator and the Python loop differ).

Error = max-norm of x(10 s) minus a reference: solve_ivp Radau at rtol =
atol = 1e-12 with the same Jacobian, checked against eomc's radau at 1e-12
(their distance is printed).  Writes results/stiff_work_precision.{md,csv,png}.
"""
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import (RESULTS_DIR, Timing, environment_header, format_table, work_precision_figure,  # noqa: E402
                    parse_args, write_results)
import models  # noqa: E402,F401 - puts tests/ on sys.path
from zoo import spring_damper_chain  # noqa: E402

T_END = 10.0
TOLS = [1e-3, 1e-5, 1e-7, 1e-9]
R = np.array([0.0])


def chain_parameters(n):
    """name -> value: odd links stiff and heavily damped."""
    values = {}
    for i in range(1, n + 1):
        stiff = i % 2 == 0
        values[f"m{i}"] = 1.0
        values[f"k{i}"] = 1e6 if stiff else 1.0
        values[f"c{i}"] = 1e5 if stiff else 0.1
    return values


def build(n, tmp):
    import eomc
    try:
        import eomc.mechanics as mech
    except ImportError:
        import sympy.physics.mechanics as mech
    kane, _ = spring_damper_chain(n, mech)
    values = chain_parameters(n)
    syms = kane.mass_matrix_full.free_symbols | kane.forcing_full.free_symbols
    params = {s: values[str(s)] for s in syms if str(s) in values}
    model = eomc.compile(kane, name=f"stiffchain{n}", parameters=params, cache_dir=str(tmp))
    p = np.array([values[name] for name in model.param_names])
    x0 = np.concatenate([0.1 * np.arange(1, n + 1), np.zeros(n)])
    return model, p, x0


def scipy_run(model, p, x0, method, tol):
    rhs, jac = model.rhs, model.jacobian
    t0 = time.perf_counter()
    sol = solve_ivp(lambda t, x: rhs(t, x, p, R), (0.0, T_END), x0, method=method,
                    rtol=tol, atol=tol, jac=lambda t, x: jac(t, x, p, R))
    seconds = time.perf_counter() - t0
    if not sol.success:
        raise RuntimeError(sol.message)
    return seconds, sol.y[:, -1].copy(), sol.nfev, sol.njev


def eomc_run(model, p, x0, tol):
    t0 = time.perf_counter()
    res = model.simulate(x0, (0.0, T_END), p=p, r=R, method="radau", rtol=tol, atol=tol,
                         t_eval=np.array([0.0, T_END]))
    seconds = time.perf_counter() - t0
    st = res.stats
    return seconds, np.array(res.x[-1]), st.get("nfev"), st.get("njev")


def plot(points, path):
    series = {}
    for pt in points:
        series.setdefault(pt[0], []).append((pt[2], pt[6]))
    work_precision_figure([("stiff spring-damper chain, 10 s", series)], path)


def main(argv=None):
    args = parse_args(__doc__.splitlines()[0], [8], default_repeat=5, argv=argv)
    n = args.n[0]
    tols = TOLS[:2] if args.quick else TOLS
    ok, why = models.eomc_status()
    if not ok:
        print(f"eomc: not available ({why}); this benchmark needs eomc's rhs and Jacobian")
        return 1
    with tempfile.TemporaryDirectory(prefix="bench_stiff_") as tmp:
        model, p, x0 = build(n, tmp)
        ref = scipy_run(model, p, x0, "Radau", 1e-12)[1]
        check = eomc_run(model, p, x0, 1e-12)[1]
        notes = [f"reference: solve_ivp Radau rtol=atol=1e-12 with eomc's rhs and Jacobian; "
                 f"|ref - eomc radau(1e-12)|_inf = {np.max(np.abs(ref - check)):.2e}"]
        runners = {"eomc radau": lambda tol: eomc_run(model, p, x0, tol)}
        for method in ("Radau", "BDF", "LSODA"):
            runners[f"scipy {method}"] = lambda tol, m=method: scipy_run(model, p, x0, m, tol)
        points = []
        for name, run in runners.items():
            for tol in tols:
                samples = []
                try:
                    for _ in range(args.repeat):
                        seconds, final, nfev, njev = run(tol)
                        samples.append(seconds)
                except Exception as exc:  # noqa: BLE001
                    notes.append(f"{name} at tol={tol:g} failed: {type(exc).__name__}: {exc}")
                    continue
                timing = Timing(samples)
                points.append([name, tol, timing.median, timing.iqr, nfev, njev,
                               float(np.max(np.abs(final - ref)))])
                print(format_table(HEADERS, [points[-1]]).splitlines()[-1], flush=True)
    table = format_table(HEADERS, points)
    print(table)
    if args.no_write:
        return 0
    plot(points, RESULTS_DIR / "stiff_work_precision.png")
    header = environment_header(
        f"Stiff spring-damper chain (n={n}), implicit methods: eomc vs scipy (issue 4 §7)", args,
        notes=[f"wall time: median of {args.repeat} runs; scipy methods get eomc's model.rhs "
               "and model.jacobian; eomc radau outputs only t=0 and t=10",
               "links alternate soft (k=1, c=0.1) and stiff, heavily damped (k=1e6, c=1e5); "
               "masses 1; start: x_i = 0.1 i, at rest", *notes])
    write_results("stiff_work_precision",
                  header + "\n![work-precision](stiff_work_precision.png)\n\n" + table + "\n",
                  csv_rows=points, csv_headers=["tool", "tol", "wall_s", "iqr_s", "nfev", "njev",
                                                "error"])
    return 0


HEADERS = ["tool", "tol", "wall [s]", "IQR [s]", "rhs calls", "jac calls", "error"]

if __name__ == "__main__":
    sys.exit(main())
