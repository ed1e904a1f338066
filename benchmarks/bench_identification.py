"""Issue 21 §5: the cart-pole identification (examples/identify_cartpole.py), Jacobian by
sensitivities against least_squares' finite differences of whole simulations.

Same problem, same start, same noise (seed 0) for every contestant:
- ``sensitivities``: one simulate(..., sensitivities=[m_cart, m_pole, c]) per Jacobian;
- ``2-point`` / ``3-point``: scipy.optimize.least_squares' own forward / central
  differences of the residuals (each residual is one simulation).
Fits run interleaved, --repeat times; CPU is the process's thread time, median.

``--arm`` (issue 30): examples/identify_arm.py, all 60 inertial parameters of UR5 (10 per link)
from a simulated sum-of-sines experiment, fitted in the 36 identifiable combinations from a
start 30 % off.  Contestants, each from the same start on the same data: Levenberg-Marquardt
(least_squares) with the Jacobian from forward sensitivities vs least_squares' own '3-point' and
'2-point' differences of the windowed runs; L-BFGS-B on the adjoint gradient (eomc.gradient) vs
L-BFGS-B on '3-point' differences, both also stopped at the same iteration cap.  Plus the cost
of one derivative evaluation each.  Results: identification_arm.md.
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
    args = parse_args(__doc__.splitlines()[0], [0], default_repeat=5, argv=argv,
                      extra=lambda p: p.add_argument("--arm", action="store_true",
                                                     help="all inertial parameters of UR5 (identify_arm.py)"))
    if args.arm:
        return arm(args)
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


def arm(args):
    """The UR5 identification (examples/identify_arm.py): optimizers x derivatives."""
    import warnings
    spec = importlib.util.spec_from_file_location("identify_arm", EXAMPLE.parent / "identify_arm.py")
    ia = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(ia)
    core = pin_to_one_core()
    arm_, ex, pi_true, pi_prior, data, ident, fit = ia.setup()
    rank, cond = ia.data_rank(fit)
    cap = 5 if args.quick else 20
    full = None if args.quick else 3000
    contestants = [
        ("Levenberg-Marquardt", "forward sensitivities", lambda: ia.fit_gauss_newton(fit)),
        ("Levenberg-Marquardt", "'3-point' differences", lambda: ia.fit_gauss_newton(fit, "3-point")),
        ("Levenberg-Marquardt", "'2-point' differences", lambda: ia.fit_gauss_newton(fit, "2-point")),
        ("L-BFGS-B", "adjoint gradient", lambda: ia.fit_lbfgs(fit, maxiter=full or cap)),
        ("L-BFGS-B", f"adjoint gradient, {cap} iterations", lambda: ia.fit_lbfgs(fit, maxiter=cap)),
        ("L-BFGS-B", f"'3-point' differences, {cap} iterations", lambda: ia.fit_lbfgs(fit, "3-point", maxiter=cap)),
    ]
    start = ia.outcome(fit, pi_prior, pi_true)
    rows, cpu = [], {}
    for rep in range(args.repeat):          # interleaved; the slow runs (differences, full L-BFGS-B) once
        for k, (opt, der, run) in enumerate(contestants):
            if rep and k not in (0, 4):
                continue
            fit.simulations = 0
            t0 = time.thread_time()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                sol = run()
            cpu.setdefault(k, []).append(time.thread_time() - t0)
            if len(cpu[k]) == 1:
                pi = fit.pi(sol.x)
                try:        # a fit far from the truth may leave no consistent point along the null space
                    oc = ia.outcome(fit, ia.make_consistent(fit, pi)[0], pi_true).consistent
                except RuntimeError:
                    oc = "none found"
                rows.append((k, sol, fit.simulations, ia.outcome(fit, pi, pi_true), oc))
    base = float(np.median(cpu[0]))
    table_rows = [["start (the prior)", "", "", "", "", "", f"{start.cost:.3e}", f"{start.base_error:.2e}",
                   f"{start.base_error_norm:.2e}", f"{start.single_error:.2e}", f"{start.consistent}/6"]]
    for k, sol, sims, o, oc in sorted(rows, key=lambda r: r[0]):
        opt, der, _ = contestants[k]
        med = float(np.median(cpu[k]))
        table_rows.append([opt, der, getattr(sol, "nit", "") or sol.nfev, sims, f"{med:.2f}", f"{med / base:.1f}",
                           f"{o.cost:.3e}", f"{o.base_error:.2e}", f"{o.base_error_norm:.2e}", f"{o.single_error:.2e}",
                           f"{o.consistent}/6 -> {oc}{'/6' if isinstance(oc, int) else ''}"])
    headers = ["optimizer", "derivatives", "iterations (LM: residual evaluations)", "window simulations", "CPU s (median)",
               "x LM + sensitivities", "final cost", "max rel. error, base parameters",
               "rel. error, identifiable part", "max error / scale, single parameters",
               "consistent links (fit -> projected)"]
    table = format_table(headers, table_rows)
    print(table)
    # one derivative evaluation each, at the start, interleaved
    z0 = np.zeros(ident.rank)
    one = {"residuals (one run per window)": lambda: fit.residuals(z0),
           "Jacobian by forward sensitivities": lambda: fit.jacobian(z0),
           "gradient by the adjoint (eomc.gradient)": lambda: fit.cost_and_gradient(z0),
           "gradient by '3-point' differences": lambda: _central(fit, z0)}
    t_one = {k: [] for k in one}
    for _ in range(max(3, args.repeat)):
        for k, f in one.items():
            t0 = time.thread_time()
            f()
            t_one[k].append(time.thread_time() - t0)
    r0 = float(np.median(t_one["residuals (one run per window)"]))
    per = format_table(["one evaluation at the start", "CPU ms (median)", "x residuals"],
                       [[k, f"{np.median(v) * 1e3:.1f}", f"{np.median(v) / r0:.1f}"] for k, v in t_one.items()])
    print(per)
    g_adj = fit.cost_and_gradient(z0)[1]
    J = fit.jacobian(z0)
    g_sens = J.T @ fit.residuals(z0)
    g_fd = _central(fit, z0)
    agree = (f"gradient at the start: adjoint vs Jacobian'·residuals {np.max(np.abs(g_adj - g_sens)) / np.max(np.abs(g_sens)):.1e}, "
             f"vs central differences {np.max(np.abs(g_adj - g_fd)) / np.max(np.abs(g_fd)):.1e} (max abs. difference / max abs.)")
    print(agree)
    if not args.no_write:
        notes = [f"UR5 (example-robot-data), recursive formulation, UrdfModel(all_inertial_parameters=True, "
                 f"limits=False): {len(arm_.bodies)} links x 10 = {10 * len(arm_.bodies)} inertial parameters "
                 f"(m, m·c, inertia about the link frame; the model keeps {len(arm_.columns)} of its own, the "
                 "shoulder's inertia about x, y does no work)",
                 f"identifiable: {ident.rank} combinations (SVD of the regressor stacked over {ex.samples} random "
                 f"states, scaled by the prior; singular values {ident.singular[ident.rank - 1]:.1e} | "
                 f"{ident.singular[ident.rank]:.1e} at the cut); the trajectory's Jacobian w.r.t. all 60 has rank "
                 f"{rank}, condition {cond:.1e}; {10 * len(arm_.bodies) - ident.rank} unidentifiable directions stay "
                 "at the prior (the fit moves only the identifiable ones)",
                 f"experiment: {ex.T} s, RK4 dt = {ex.dt} s, computed-torque control with the prior model tracking "
                 f"{ex.harmonics} harmonics of {ex.f0} Hz per joint, torque held over {ex.hold * ex.dt * 1e3:.0f} ms "
                 f"samples ({data.R.shape[0]} windows, each simulated from its measured start); no noise",
                 "start = prior: every parameter off by up to 30 % of its scale (|value|, floored for zero "
                 "entries), each link consistent; 'projected': the unidentifiable part moved as little as "
                 "possible to make every link physically consistent (pseudo-inertia > 0), cost unchanged",
                 "base parameters: QR with column pivoting of the scaled regressor, beta = pi_1 + K pi_2; "
                 "error |beta - beta_true| / max(|beta_true|, scale)",
                 f"pinned to core {core}; thread CPU; LM + sensitivities and the capped adjoint runs: median of "
                 f"{args.repeat}, interleaved; the difference runs and the full adjoint run once",
                 agree]
        text = (environment_header("Identification of all 60 inertial parameters of UR5", args, notes)
                + "\n" + table + "\n\n" + per + "\n")
        write_results("identification_arm", text)


def _central(fit, z, h=1e-6):
    """d cost / dz by central differences (what L-BFGS-B's '3-point' does, for the per-call table)."""
    g = np.empty(z.size)
    for k in range(z.size):
        e = np.zeros(z.size)
        e[k] = h
        g[k] = (fit.cost(z + e) - fit.cost(z - e)) / (2 * h)
    return g


if __name__ == "__main__":
    main()
