"""Issue 21 §5: the cart-pole identification (examples/identify_cartpole.py), Jacobian by
sensitivities against least_squares' finite differences of whole simulations.

Same problem, same start, same noise (seed 0) for every contestant:
- ``sensitivities``: one simulate(..., sensitivities=[m_cart, m_pole, c]) per Jacobian;
- ``2-point`` / ``3-point``: scipy.optimize.least_squares' own forward / central
  differences of the residuals (each residual is one simulation).
Fits run interleaved, --repeat times; CPU is the process's thread time, median.
"""
import importlib.util
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import environment_header, format_table, parse_args, pin_to_one_core, write_results  # noqa: E402

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "identify_cartpole.py"
JACOBIANS = ("sensitivities", "2-point", "3-point")


def load_example():
    spec = importlib.util.spec_from_file_location("identify_cartpole", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def main(argv=None):
    args = parse_args(__doc__.splitlines()[0], [0], default_repeat=5, argv=argv)
    pin_to_one_core()
    ex = load_example()
    model = ex.build()
    problem = ex.Problem(model, [0.0, 0.2, 0.0, 0.0])
    cpu = {j: [] for j in JACOBIANS}
    last = {}
    for _ in range(args.repeat):
        for jac in JACOBIANS:
            t0 = time.thread_time()
            sol, cov, _, sims = ex.fit(problem, jac)
            cpu[jac].append(time.thread_time() - t0)
            last[jac] = (sol, cov, sims)
    rows = []
    base = float(np.median(cpu["sensitivities"]))
    for jac in JACOBIANS:
        sol, cov, sims = last[jac]
        rep = ex.report(problem, sol, cov)
        est = ", ".join(f"{name} {e:.4f} ± {h:.4f}" for name, _, e, h, _ in rep)
        inside = sum(1 for *_, ok in rep if ok)
        med = float(np.median(cpu[jac]))
        rows.append([jac, sol.nfev, sol.njev or "", sims, f"{med * 1e3:.1f}", f"{med / base:.2f}",
                     f"{sol.cost:.4g}", f"{inside}/{len(rep)}", est])
    headers = ["Jacobian", "residual evaluations", "Jacobians", "simulations", "CPU ms (median)",
               "x sensitivities", "final cost", "true value inside 95 %", "estimates ± 95 %"]
    table = format_table(headers, rows)
    truth = ", ".join(f"{k} {v}" for k, v in ex.TRUE.items())
    print(table)
    if not args.no_write:
        notes = [f"true parameters: {truth}; start: {', '.join(f'{k} {v}' for k, v in ex.GUESS.items())}",
                 f"{ex.T_MEAS.size} measurement instants of q_cart (sigma {ex.SIGMA[0]}) and q_pole "
                 f"(sigma {ex.SIGMA[1]}, plus the bias); rtol = atol = {ex.TOL:g}; method='lm'",
                 "every fit ends with one simulation with sensitivities for the covariance (counted in "
                 "simulations and CPU for all three)",
                 "one process pinned to one core; contestants interleaved; thread CPU time, medians of "
                 f"{args.repeat}"]
        text = (environment_header("Identification of the cart-pole: sensitivities vs finite differences",
                                   args, notes) + "\n" + table + "\n")
        write_results("identification", text)


if __name__ == "__main__":
    main()
