"""Identify a cart-pole's masses, friction and a sensor bias from noisy, sparse measurements.

The plant is examples/cart_pole_system.py (cart on a spring and a viscous
damper -- its friction -- with a pole on a pin).  A "true" parameter set
drives a simulation under a known excitation force F(t); the measurements are
the cart position and the pole angle at 25 instants over 6 s, with Gaussian
noise, and the angle sensor reads with a constant bias.  Unknown: m_cart,
m_pole, the damping c and the bias b.

The fit is scipy.optimize.least_squares on the weighted residuals; the
Jacobian of the simulated measurements with respect to (m_cart, m_pole, c)
comes from ``simulate(..., sensitivities=[...])`` (dx(t)/dp integrated with the
state in C) and the bias column is constant.  The same fit with finite
differences of whole simulations (least_squares' own '2-point' and '3-point')
is the comparison.  Covariance of the estimate: (JᵀJ)⁻¹ at the optimum (residuals are
divided by the noise's sigma), 95 % intervals ±1.96 standard deviations.

Run: ``python examples/identify_cartpole.py`` (prints the estimates, their
intervals and both fits' cost); benchmarks/bench_identification.py times the two.
The file is also a model file (the plant, taken from cart_pole_system.py), so
``eomc build examples/identify_cartpole.py`` builds what is identified here.
"""
import runpy
import time
from pathlib import Path

import numpy as np

import eomc

HERE = Path(__file__).resolve().parent
# the plant: this file is a model file too (eomc.compile / eomc build / eomc simulate take it)
_PLANT = runpy.run_path(str(HERE / "cart_pole_system.py"))
system, inputs, parameters = _PLANT["system"], _PLANT["inputs"], _PLANT["parameters"]
initial_state, outputs = _PLANT["initial_state"], _PLANT["outputs"]
UNKNOWN = ("m_cart", "m_pole", "c")            # model parameters to identify (+ the sensor bias)
TRUE = {"m_cart": 1.3, "m_pole": 0.45, "c": 0.8, "bias": 0.02}
GUESS = {"m_cart": 1.0, "m_pole": 0.3, "c": 0.3, "bias": 0.0}
SIGMA = np.array([1e-3, 2e-3])                 # noise of the cart-position and pole-angle sensors
T_MEAS = np.linspace(0.25, 6.0, 24)            # sparse measurement instants
TOL = 1e-10


def build():
    """The cart-pole with rhs, jac_x, jac_p and jvp: sensitivities integrate S' = J S + P from
    jvp's directional derivatives (jac_x alone would do, forming J at every stage)."""
    return eomc.compile(str(HERE / "cart_pole_system.py"), functions=["rhs", "jac_x", "jac_p", "jvp", "outputs"],
                        progress=False)


def excitation():
    """A known force on the cart: a chirp-like table, linear in between (evaluated in C)."""
    t = np.linspace(0.0, 6.0, 121)
    F = 2.0 * np.sin(1.5 * t + 0.4 * t ** 2)
    return t, np.column_stack([F, np.zeros_like(F)])        # inputs (F, T): no pole torque


class Problem:
    """Residuals and Jacobian of the fit; counts the simulations it runs."""

    def __init__(self, model, x0, seed=0):
        self.model, self.x0, self.r = model, np.asarray(x0, dtype=float), excitation()
        self.cols = [model.param_names.index(n) for n in UNKNOWN]
        self.t_eval = np.concatenate([[0.0], T_MEAS])
        self.rows = [model.state_names.index("q_cart"), model.state_names.index("q_pole")]
        self.simulations = 0
        rng = np.random.default_rng(seed)
        clean = self.measure(self.theta(TRUE))
        self.y = clean + rng.normal(0.0, 1.0, clean.shape) * SIGMA

    def theta(self, values):
        return np.array([values[n] for n in UNKNOWN] + [values["bias"]])

    def params(self, theta):
        p = self.model.param_defaults.copy()
        p[self.cols] = theta[:len(UNKNOWN)]
        return p

    def _run(self, theta, sensitivities=False):
        self.simulations += 1
        return self.model.simulate(self.x0, (0.0, 6.0), p=self.params(theta), r=self.r, t_eval=self.t_eval,
                                   rtol=TOL, atol=TOL, events=False,
                                   sensitivities=list(UNKNOWN) if sensitivities else False)

    def measure(self, theta, res=None):
        res = self._run(theta) if res is None else res
        y = res.x[1:, self.rows].copy()
        y[:, 1] += theta[-1]                                  # the angle sensor's bias
        return y

    def residuals(self, theta):
        return ((self.measure(theta) - self.y) / SIGMA).ravel()

    def jacobian(self, theta):
        """d residuals / d theta from one simulation with sensitivities."""
        res = self._run(theta, sensitivities=True)
        S = res.dx_dp[1:][:, self.rows, :]                    # (n_meas, 2 sensors, 3 parameters)
        J = np.zeros((S.shape[0], 2, len(UNKNOWN) + 1))
        J[:, :, :len(UNKNOWN)] = S
        J[:, 1, -1] = 1.0                                     # the bias shifts the angle reading
        return (J / SIGMA[None, :, None]).reshape(-1, len(UNKNOWN) + 1)


def fit(problem, jac="sensitivities"):
    """least_squares from GUESS with ``jac`` = "sensitivities" or scipy's finite differences
    ("2-point", "3-point"); returns (solution, covariance, CPU seconds, simulations)."""
    from scipy.optimize import least_squares
    problem.simulations = 0
    t0 = time.process_time()
    sol = least_squares(problem.residuals, problem.theta(GUESS), method="lm", x_scale="jac",
                        jac=problem.jacobian if jac == "sensitivities" else jac)
    seconds = time.process_time() - t0
    J = problem.jacobian(sol.x)          # the covariance from the exact Jacobian in both cases
    cov = np.linalg.inv(J.T @ J) * (2 * sol.cost / max(1, J.shape[0] - J.shape[1]))
    return sol, cov, seconds, problem.simulations


def report(problem, sol, cov):
    """Rows of (name, true, estimate, ±95 % half-width, inside)."""
    rows = []
    for k, name in enumerate(UNKNOWN + ("bias",)):
        half = 1.96 * np.sqrt(cov[k, k])
        rows.append((name, TRUE[name], sol.x[k], half, abs(sol.x[k] - TRUE[name]) <= half))
    return rows


def main():
    model = build()
    problem = Problem(model, [0.0, 0.2, 0.0, 0.0])
    for jac in ("sensitivities", "2-point", "3-point"):
        sol, cov, seconds, sims = fit(problem, jac)
        print(f"\n{jac}: {sol.nfev} residual evaluations, {sol.njev or 0} Jacobians, "
              f"{sims} simulations, {seconds:.3f} s CPU, cost {sol.cost:.4g}, status {sol.status}")
        print(f"{'':8s} {'true':>8s} {'estimate':>10s} {'± 95 %':>9s}  inside")
        for name, true, est, half, inside in report(problem, sol, cov):
            print(f"{name:8s} {true:8.4f} {est:10.5f} {half:9.5f}  {inside}")


if __name__ == "__main__":
    main()
