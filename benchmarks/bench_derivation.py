"""Derivation time: eomc's KanesMethod/LagrangesMethod vs SymPy 1.14's, n-link pendulum on a cart.

Times (CPU, ``time.process_time``) forming the equations of motion of PyDy's
n-link pendulum on a cart (tests/zoo.py):

* "Kane total": the whole model script -- frames, points, v2pt_theory (SymPy's
  kinematics, identical for both) plus KanesMethod + kanes_equations;
* "Kane derive": KanesMethod + kanes_equations alone, the kinematics built first;
* Lagrange (n <= 15): the whole Lagrange model script, both tools;
* operations after CSE: ``count_ops`` of ``sympy.cse`` of mass_matrix_full and
  forcing_full (n <= --ops-max, because SymPy's CSE of SymPy's own large
  expressions takes minutes).

SymPy's cache is cleared before every measurement so no run profits from an
earlier one.  Medians of repeats where a run takes under ~2 s.

    python3 benchmarks/bench_derivation.py                 # n = 1,2,5,10,20,30,40,60
    python3 benchmarks/bench_derivation.py --n 1,5,10,20,40
    python3 benchmarks/bench_derivation.py --quick
"""
import pathlib
import statistics
import sys
import time

import sympy as sm
import sympy.physics.mechanics as sme
from sympy.core.cache import clear_cache

_HERE = pathlib.Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE), str(_HERE.parent / "tests")]

import zoo  # noqa: E402
from common import environment_header, fmt, format_table, parse_args, ratio, write_results  # noqa: E402

import eomc.mechanics as em  # noqa: E402

DEFAULT_N = [1, 2, 5, 10, 20, 30, 40, 60]
LAGRANGE_MAX = 15


def _cpu(func):
    clear_cache()
    t0 = time.process_time()
    out = func()
    return time.process_time() - t0, out


def _median(func, repeat, cheap=2.0):
    """Median CPU seconds of func(); repeats only while a run is cheap."""
    samples, out = [], None
    for _ in range(repeat):
        dt, out = _cpu(func)
        samples.append(dt)
        if dt > cheap:
            break
    return statistics.median(samples), out


def _derive_only(n, mech):
    parts = zoo.n_link_pendulum_on_cart_kinematics(n, mech)
    clear_cache()
    t0 = time.process_time()
    km = mech.KanesMethod(parts["frame"], q_ind=parts["q"], u_ind=parts["u"],
                          kd_eqs=parts["kd_eqs"])
    km.kanes_equations(parts["bodies"], parts["loads"])
    return time.process_time() - t0


def cse_ops(system):
    exprs = list(system.mass_matrix_full) + list(system.forcing_full)
    repl, reduced = sm.cse(exprs)
    return int(sm.count_ops([r[1] for r in repl]) + sm.count_ops(reduced))


def _eomc_lagrange():
    try:
        return em.LagrangesMethod
    except AttributeError:
        return None


def measure(n, repeat, ops_max, sympy_max, sympy_derive_max):
    row = {"n": n}
    row["eomc_total"], ours = _median(lambda: zoo.n_link_pendulum_on_cart(n, em)[0], repeat)
    row["eomc_derive"] = statistics.median(_derive_only(n, em) for _ in range(min(repeat, 3)))
    ref = None
    if n <= sympy_max:
        row["sympy_total"], ref = _median(lambda: zoo.n_link_pendulum_on_cart(n, sme)[0],
                                          repeat if n <= 10 else 1)
        if n <= sympy_derive_max:
            row["sympy_derive"] = _derive_only(n, sme)
    if n <= ops_max:
        row["eomc_ops"] = cse_ops(ours)
        row["sympy_ops"] = cse_ops(ref) if ref is not None else None
    if n <= LAGRANGE_MAX:
        if _eomc_lagrange() is not None:
            row["eomc_lag"], _ = _median(
                lambda: zoo.n_link_pendulum_on_cart_lagrange(n, em)[0], repeat)
        if n <= sympy_max:
            row["sympy_lag"], _ = _median(
                lambda: zoo.n_link_pendulum_on_cart_lagrange(n, sme)[0], repeat if n <= 5 else 1)
    return row


HEADERS = ["n", "eomc Kane total s", "SymPy Kane total s", "ratio",
           "eomc Kane derive s", "SymPy Kane derive s", "ratio",
           "ops eomc", "ops SymPy", "eomc Lagrange s", "SymPy Lagrange s", "ratio"]


def table_row(r):
    g = r.get
    return [r["n"], g("eomc_total"), g("sympy_total"), ratio(g("sympy_total"), g("eomc_total")),
            g("eomc_derive"), g("sympy_derive"), ratio(g("sympy_derive"), g("eomc_derive")),
            g("eomc_ops"), g("sympy_ops"), g("eomc_lag"), g("sympy_lag"),
            ratio(g("sympy_lag"), g("eomc_lag"))]


def main(argv=None):
    def extra(p):
        p.add_argument("--ops-max", type=int, default=20,
                       help="largest n for the CSE operation counts (default 20)")
        p.add_argument("--sympy-max", type=int, default=60,
                       help="largest n timed with SymPy (default 60)")
        p.add_argument("--sympy-derive-max", type=int, default=40,
                       help="largest n for SymPy's derive-only time (default 40; it doubles SymPy's cost)")
    args = parse_args("Derivation time, eomc vs SymPy", DEFAULT_N, default_repeat=3,
                      argv=argv, extra=extra)
    rows = []
    for n in args.n:
        r = measure(n, args.repeat, args.ops_max, args.sympy_max, args.sympy_derive_max)
        rows.append(table_row(r))
        print(" | ".join(fmt(c) for c in rows[-1]), flush=True)
    table = format_table(HEADERS, rows)
    print(table)
    if not args.no_write:
        notes = ["times are CPU seconds (time.process_time), SymPy's cache cleared before each run",
                 "'total' = the whole model script incl. SymPy's kinematics (v2pt_theory), "
                 "'derive' = KanesMethod + kanes_equations only",
                 "ops = sympy.count_ops after sympy.cse of mass_matrix_full and forcing_full",
                 "n/a = not measured at that size (see --ops-max, --sympy-max, Lagrange n <= 15)"]
        text = environment_header("Derivation time: n-link pendulum on a cart", args, notes)
        write_results("derivation", text + "\n" + table + "\n",
                      csv_rows=rows, csv_headers=HEADERS)
    return 0


if __name__ == "__main__":
    sys.exit(main())
