"""Stiff-contact work-precision: Solo12 standing on four compliant feet (examples/quadruped_stand.py).

    python benchmarks/bench_contact.py [--t-final 1.0] [--repeat 3]

Contestants, interleaved per tolerance, thread CPU time, median of --repeat runs:
eomc's Radau IIA(5) and DOP853 (loops in C, feedback K in C) and scipy's solve_ivp
Radau and LSODA on the same compiled rhs (feedback and the Jacobian jac_x + jac_r·K
through Python).  Error: max abs over the final state's base position and joint
angles against a Radau run at rtol = atol = 1e-12.  Prints a Markdown table.
"""
import argparse
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples"))
import quadruped_stand as qs  # noqa: E402


def _cpu(fn):
    t0 = time.thread_time()
    out = fn()
    return time.thread_time() - t0, out


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--t-final", type=float, default=1.0)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--tols", default="1e-4,1e-6,1e-8")
    a = ap.parse_args(argv)
    import scipy
    from scipy.integrate import solve_ivp
    import eomc
    model = qs.build()
    x0, K, x_ref = qs.stance(model)
    nq = sum(1 for n in model.state_names if n.startswith("q_"))
    T = a.t_final
    r0 = np.zeros(len(model.input_names))
    ref = model.simulate(x0, (0, T), r=r0, K=K, x_ref=x_ref, method="radau", rtol=1e-12, atol=1e-12,
                         max_steps=10**7).x_final

    def err(x):
        return float(np.max(np.abs(x[:nq] - ref[:nq])))

    def fun(t, x):
        return model.rhs(t, x, r=K @ (x_ref - x))

    def jac(t, x):
        r = K @ (x_ref - x)
        return model.jacobian(t, x, r=r) - model.input_jacobian(t, x, r=r) @ K

    def eomc_run(method, tol):
        return lambda: model.simulate(x0, (0, T), r=r0, K=K, x_ref=x_ref, method=method, rtol=tol,
                                      atol=tol, max_steps=10**7, t_eval=[T]).x_final

    def scipy_run(method, tol):
        def go():
            kw = {"jac": jac} if method == "Radau" else {}
            sol = solve_ivp(fun, (0, T), x0, method=method, rtol=tol, atol=tol, **kw)
            return sol.y[:, -1]
        return go
    rows = []
    for tol in [float(t) for t in a.tols.split(",")]:
        runs = {"eomc radau": eomc_run("radau", tol), "eomc dop853": eomc_run("dop853", tol),
                "scipy Radau": scipy_run("Radau", tol), "scipy LSODA": scipy_run("LSODA", tol)}
        times = {k: [] for k in runs}
        errors = {}
        for _ in range(a.repeat):        # interleaved
            for name, run in runs.items():
                try:
                    dt, x = _cpu(run)
                except Exception as exc:     # DOP853 gives up on stiffness: that is the result
                    times[name].append(float("nan"))
                    errors[name] = f"stopped: {str(exc).split(';')[0].split(': ', 1)[-1][:70]}"
                    continue
                times[name].append(dt)
                errors[name] = err(x)
        for name in runs:
            rows.append((tol, name, errors[name], float(np.median(times[name]))))
    load = os.getloadavg()
    print(f"# Stiff contact work-precision (Solo12 standing, {T} s)\n")
    print(f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; load {load[0]:.1f} {load[1]:.1f} "
          f"{load[2]:.1f} on {os.cpu_count()} cores; Python {platform.python_version()}, numpy "
          f"{np.__version__}, scipy {scipy.__version__}, eomc {eomc.__version__}; thread CPU time, "
          f"median of {a.repeat}, contestants interleaved.\n")
    print("| rtol = atol | method | error (max abs, q) | CPU time (s) |")
    print("|---|---|---|---|")
    for tol, name, e, t in rows:
        print(f"| {tol:g} | {name} | {e if isinstance(e, str) else f'{e:.2e}'} | {t:.4f} |")


if __name__ == "__main__":
    main(sys.argv[1:])
