"""SymPy-keyword ``KanesMethod.linearize``: eomc vs SymPy 1.14 on the Whipple bicycle.

The model is ``examples/whipple_bicycle.py`` (Meijaard et al. 2007), read once
with eomc's ``KanesMethod`` and once -- up to its model definition, text
unchanged except for the import line and ``constraint_solver='CRAMER'`` (SymPy's default LU divides by zero
upright; eomc's default is Cramer's rule for 3 dependent speeds) -- with
SymPy's.  Both then call

    KM.linearize(op_point=<upright, rolling at speed v>, A_and_B=True, linear_solver="CRAMER")

-- SymPy's own bicycle test's call -- with the parameters left symbolic and
v a symbol.  Timed: thread CPU seconds of the ``linearize`` call alone (the
equations are formed before), pinned to one core, eomc and SymPy interleaved,
SymPy's cache cleared before each call.  The two A matrices are compared
after substituting the paper's parameters at v = 0..10 m/s (max abs difference).

    python3 benchmarks/bench_linearize.py            # eomc x3, SymPy x1 (SymPy takes minutes)
    python3 benchmarks/bench_linearize.py --quick    # eomc only
"""
import os
import pathlib
import statistics
import sys
import time

import sympy as sm
from sympy.core.cache import clear_cache

_HERE = pathlib.Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE)]

from common import environment_header, fmt, format_table, parse_args, ratio, write_results  # noqa: E402

EXAMPLE = _HERE.parent / "examples" / "whipple_bicycle.py"


def load(tool):
    """Run the example with eomc's or SymPy's mechanics; returns its namespace."""
    src = EXAMPLE.read_text()
    if tool == "sympy":
        src = src.replace("from eomc.mechanics import", "from sympy.physics.mechanics import")
        src = src.replace("velocity_constraints=contact_velocity)",
                          "velocity_constraints=contact_velocity, constraint_solver='CRAMER')")
        assert "sympy.physics.mechanics import" in src and "'CRAMER'" in src
        src = src[:src.index("\ndef consistent_speeds")]   # eomc-only helpers follow
    ns = {"__name__": f"whipple_{tool}", "__file__": str(EXAMPLE)}
    exec(compile(src, str(EXAMPLE), "exec"), ns)
    return ns


def operating_point(ns, v):
    km = ns["system"]
    by_name = {s.name: s for s in km.u}
    rR, rF = (next(p for p in ns["parameters"] if p.name == n) for n in ("rR", "rF"))
    op = {s: 0 for s in list(km.q) + list(km.u)}
    op.update({by_name["u5"]: -v / rR, by_name["u6"]: -v / rF})
    op.update({s.diff(): 0 for s in km.u})
    return op


def linearize(ns, v):
    km = ns["system"]
    clear_cache()
    t0 = time.thread_time()
    A, B, r = km.linearize(op_point=operating_point(ns, v), A_and_B=True, linear_solver="CRAMER")
    return time.thread_time() - t0, A


def max_difference(ns, A_eomc, A_sympy, v):
    nums = {k: sm.Float(val, 30) for k, val in ns["parameters"].items()}
    worst = 0.0
    for speed in range(11):
        sub = {**nums, v: speed}
        a = sm.Matrix(A_eomc.xreplace(sub)).evalf(30)
        b = sm.Matrix(A_sympy.xreplace(sub)).evalf(30)
        worst = max(worst, max(float(abs(x)) for x in (a - b)))
    return worst


def main():
    args = parse_args(__doc__, default_n=[0], default_repeat=3)
    try:
        os.sched_setaffinity(0, {1})
    except (AttributeError, OSError):
        pass
    v = sm.Symbol("v")
    eomc_ns = load("eomc")
    times_eomc, times_sympy = [], []
    A_e = A_s = None
    dt, A_e = linearize(eomc_ns, v)
    times_eomc.append(dt)
    print(f"eomc   linearize: {dt:.3f} s", flush=True)
    if not args.quick:
        sympy_ns = load("sympy")
        dt, A_s = linearize(sympy_ns, v)
        times_sympy.append(dt)
        print(f"SymPy  linearize: {dt:.3f} s", flush=True)
    for _ in range(2):
        dt, _A = linearize(eomc_ns, v)
        times_eomc.append(dt)
        print(f"eomc   linearize: {dt:.3f} s", flush=True)
    te = statistics.median(times_eomc)
    ts = statistics.median(times_sympy) if times_sympy else None
    diff = max_difference(eomc_ns, A_e, A_s, v) if A_s is not None else None
    rows = [["Whipple bicycle, A_and_B=True, CRAMER", te, ts, ratio(ts, te),
             len(times_eomc), len(times_sympy), fmt(diff) if diff is not None else "n/a"]]
    headers = ["model / call", "eomc s", "SymPy 1.14 s", "SymPy / eomc", "eomc runs", "SymPy runs",
               "max |A_eomc - A_SymPy| (v = 0..10)"]
    table = format_table(headers, rows)
    print(table)
    if args.no_write:
        return
    notes = ["times are thread CPU seconds (time.thread_time) of KanesMethod.linearize alone, "
             "equations formed before; pinned to CPU 1; SymPy's cache cleared before each call",
             "eomc: median of 3 runs interleaved around SymPy's single run (SymPy takes minutes)",
             "A compared after substituting the paper's parameters (30-digit Floats), v = 0..10 m/s"]
    text = environment_header("SymPy-keyword linearize: Whipple bicycle", args, notes) + "\n" + table + "\n"
    text += ("\n## Reading the table\n\n"
             "- eomc's `linearize(op_point=..., A_and_B=..., linear_solver=...)` returns SymPy 1.14's "
             "results from its own FastLinearizer (compiler/mechanics/linearizer.py): the Jacobians are "
             "evaluated at the operating point by a chain rule on the sub-expressions' values instead of "
             "being formed symbolically and substituted afterwards (where SymPy spends ~95 % of its time).\n")
    for path in write_results("linearize", text, [rows[0][:6] + [diff]], headers):
        print("wrote", path)


if __name__ == "__main__":
    main()
