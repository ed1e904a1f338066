"""C integrators against closed forms: orders, tolerances, dense output, inputs, stiffness.

Oracles are independent of the integrators: the harmonic oscillator's closed
form, the matrix exponential of the (linear) stiff chain, scipy's DOP853 at
rtol=1e-12, and conservation of energy.
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import expm

from helpers.stand_in import get_model

from eomc.runtime.simulate import scipy_fun, simulate

W = 2.0  # oscillator: k = 4, m = 1 -> omega = 2


def osc_error(method, h, t1=2.0):
    """Max error vs cos(2t) at constant step h (loose tolerance: every step accepted)."""
    m = get_model("oscillator")
    kw = dict(dt=h) if method == "rk4" else dict(first_step=h, max_step=h, rtol=1e3, atol=1e3,
                                                 stiff_check=False)
    res = simulate(m, [1.0, 0.0], (0.0, t1), method=method, t_eval=[t1], **kw)
    return abs(res.x[-1, 0] - np.cos(W * t1))


@pytest.mark.parametrize("method,order", [("rk4", 4), ("dopri5", 5), ("dop853", 8)])
def test_fixed_step_order_of_convergence(method, order):
    hs = [0.2, 0.1, 0.05] if method != "dop853" else [0.4, 0.2, 0.1]
    errs = [osc_error(method, h) for h in hs]
    slopes = np.diff(np.log(errs)) / np.diff(np.log(hs))
    assert all(order - 0.6 < s < order + 1.2 for s in slopes), (errs, slopes)


@pytest.mark.parametrize("method,order", [("dopri5", 5), ("dop853", 8), ("radau", 5)])
def test_adaptive_error_against_work(method, order):
    """Error ~ nsteps**-order across tolerances (radau has no fixed-step mode)."""
    m = get_model("oscillator")
    errs, steps = [], []
    for tol in (1e-5, 1e-7, 1e-9):
        res = simulate(m, [1.0, 0.0], (0.0, 10.0), method=method, rtol=tol, atol=tol, t_eval=[10.0])
        errs.append(abs(res.x[-1, 0] - np.cos(W * 10.0)))
        steps.append(res.stats["accepted"])
    slope = -np.polyfit(np.log(steps), np.log(errs), 1)[0]
    assert order - 1.5 < slope < order + 2.0, (errs, steps, slope)


@pytest.mark.parametrize("method", ["dopri5", "dop853", "radau"])
@pytest.mark.parametrize("tol", [1e-6, 1e-9])
def test_reaches_requested_tolerance_with_dense_output(method, tol):
    m = get_model("oscillator")
    t = np.linspace(0, 10, 2001)      # most points fall between steps: dense output
    res = simulate(m, [1.0, 0.0], (0, 10), method=method, rtol=tol, atol=tol, t_eval=t)
    assert res.stats["accepted"] < 2000
    err = np.max(np.abs(res["q"] - np.cos(W * t)))
    assert err < 10 * tol, err
    assert np.max(np.abs(res["u"] + W * np.sin(W * t))) < 20 * tol


def test_dense_output_order_dop853():
    """Interpolating inside fixed steps: the 7th-order interpolant's error falls ~ h^8."""
    m = get_model("oscillator")
    errs = []
    for h in (0.4, 0.2):
        t = np.arange(0, 4.0, h) + 0.37 * h
        res = simulate(m, [1.0, 0.0], (0, 4.0), method="dop853", first_step=h, max_step=h,
                       rtol=1e3, atol=1e3, t_eval=t, stiff_check=False)
        errs.append(np.max(np.abs(res["q"] - np.cos(W * t))))
    assert 6.0 < np.log2(errs[0] / errs[1]) < 9.5, errs


def test_forced_oscillator_with_inputs_on_a_grid():
    """q'' + 4 q = A cos(Ot), q(0)=u(0)=0: q = A/(4-O^2) (cos Ot - cos 2t)."""
    m = get_model("oscillator")
    amp, om = 0.7, 1.3
    exact = lambda t: amp / (4 - om**2) * (np.cos(om * t) - np.cos(2 * t))  # noqa: E731
    grid = np.linspace(0, 10, 20001)
    t = np.linspace(0, 10, 101)
    res = simulate(m, [0, 0], (0, 10), r=(grid, amp * np.cos(om * grid)), rtol=1e-10,
                   atol=1e-12, t_eval=t)
    assert np.max(np.abs(res["q"] - exact(t))) < 1e-7
    res2 = simulate(m, [0, 0], (0, 10), r=lambda s: [amp * np.cos(om * s)], rtol=1e-10,
                    atol=1e-12, t_eval=t)
    assert np.max(np.abs(res2["q"] - exact(t))) < 1e-5     # 1001-point sampling of r
    const = simulate(m, [0, 0], (0, 10), r=[0.8], rtol=1e-10, atol=1e-12, t_eval=t)
    assert np.max(np.abs(const["q"] - 0.2 * (1 - np.cos(2 * t)))) < 1e-8


@pytest.mark.parametrize("method", ["rk4", "dopri5", "dop853", "radau"])
def test_stats_are_consistent(method):
    m = get_model("pendulum")
    kw = dict(dt=0.01) if method == "rk4" else {}
    s = simulate(m, [1.0, 0.0], (0, 5), method=method, rtol=1e-8, atol=1e-8, **kw).stats
    assert s["status"] == 0 and s["t"] == 5.0
    assert s["steps"] == s["accepted"] + s["rejected"] and s["accepted"] > 10
    if method == "rk4":
        assert s["nfev"] == 4 * s["steps"] + 1
    elif method == "dop853":
        assert s["nfev"] >= 12 * s["steps"]
    elif method == "radau":
        assert s["njev"] >= 1 and s["nlu"] >= 2 and s["nfev"] >= 3 * s["steps"]
    if method != "radau":
        assert s["njev"] == 0 and s["nlu"] == 0


def test_pendulum_agrees_with_scipy_dop853_and_keeps_energy():
    m = get_model("pendulum")
    fun, _ = scipy_fun(m)
    t = np.linspace(0, 10, 201)
    ref = solve_ivp(fun, (0, 10), [2.5, 0.0], method="DOP853", rtol=1e-12, atol=1e-12, t_eval=t)
    for method in ("dop853", "dopri5", "radau"):
        res = simulate(m, {"q1": 2.5}, (0, 10), method=method, rtol=1e-10, atol=1e-10, t_eval=t)
        assert np.max(np.abs(res.x - ref.y.T)) < 1e-7, method
        assert np.ptp(res["energy"]) < 1e-7 * 9.81


def test_kepler_orbit_returns_after_one_period():
    """Eccentric orbit (e = 0.6, a = 1): after 2*pi the state is back; energy, L kept."""
    m = get_model("kepler")
    e = 0.6
    x0 = [1 - e, 0.0, 0.0, np.sqrt((1 + e) / (1 - e))]
    res = simulate(m, x0, (0, 2 * np.pi), method="dop853", rtol=1e-11, atol=1e-12)
    assert np.max(np.abs(res.x[-1] - x0)) < 1e-8
    assert np.ptp(res["energy"]) < 1e-9 and np.ptp(res["angular_momentum"]) < 1e-9


def chain_case(kappa):
    p = np.array([1.0, kappa, 0.1, 2 * np.sqrt(kappa)])      # overdamped stiff link
    m = get_model("chain")
    return m, p, m.jacobian(0.0, np.zeros(4), p)


@pytest.mark.parametrize("kappa", [1e3, 1e4, 1e6, 1e8])
def test_stiff_chain_implicit_reaches_tolerance(kappa):
    m, p, A = chain_case(kappa)
    x0 = np.array([1.0, 1.0, 0.0, 0.0])
    t = np.linspace(0, 10, 11)
    res = simulate(m, x0, (0, 10), p=p, method="radau", rtol=1e-6, atol=1e-6, t_eval=t,
                   max_steps=5000)
    exact = np.array([expm(A * s) @ x0 for s in t])
    assert np.max(np.abs(res.x - exact)) < 1e-5
    assert res.stats["steps"] < 1000


@pytest.mark.parametrize("kappa", [1e3, 1e4, 1e6, 1e8])
@pytest.mark.parametrize("method", ["dopri5", "dop853"])
def test_stiff_chain_explicit_succeeds_or_says_stiff(kappa, method):
    m, p, A = chain_case(kappa)
    x0 = np.array([1.0, 1.0, 0.0, 0.0])
    t = np.linspace(0, 10, 11)
    res = simulate(m, x0, (0, 10), p=p, method=method, rtol=1e-6, atol=1e-6, t_eval=t,
                   max_steps=20000, raise_on_failure=False)
    assert np.all(np.isfinite(res.x)) and np.all(np.isfinite(res.x_final))
    if res.status == 0:
        exact = np.array([expm(A * s) @ x0 for s in t])
        assert np.max(np.abs(res.x - exact)) < 1e-4     # DOP853 ~ scipy's DOP853 here
    else:
        assert res.status in (6, 7), res.message
        assert "method='radau'" in res.message and "t=" in res.message
    if kappa >= 1e6:
        assert res.status == 7, res.message


@pytest.mark.parametrize("method, scipy_method", [("dop853", "DOP853"), ("dopri5", "RK45")])
def test_classical_step_control_follows_scipy_step_for_step(method, scipy_method):
    """pi_beta=0: same method, same controller as scipy, so the same steps and the same answer."""
    m = get_model("pendulum")
    fun, _ = scipy_fun(m)
    ref = solve_ivp(fun, (0, 10), [2.5, 0.0], method=scipy_method, rtol=1e-8, atol=1e-8)
    res = simulate(m, [2.5, 0.0], (0, 10), method=method, rtol=1e-8, atol=1e-8, t_eval=[0, 10],
                   pi_beta=0.0)
    assert abs(res.stats["nfev"] - ref.nfev) <= 3        # the first step's extra evaluations
    assert np.max(np.abs(res.x[-1] - ref.y[:, -1])) < 1e-12


@pytest.mark.parametrize("method", ["dop853", "dopri5"])
def test_pi_step_control_rejects_fewer_steps_at_the_same_accuracy(method):
    """The default (Hairer's stabilized control, beta = 0.04) smooths the step sequence."""
    m = get_model("pendulum")
    fun, _ = scipy_fun(m)
    exact = solve_ivp(fun, (0, 10), [2.5, 0.0], method="DOP853", rtol=1e-13, atol=1e-13).y[:, -1]
    runs = {beta: simulate(m, [2.5, 0.0], (0, 10), method=method, rtol=1e-8, atol=1e-8,
                           t_eval=[0, 10], pi_beta=beta) for beta in (0.0, 0.04)}
    assert runs[0.04].stats["rejected"] < runs[0.0].stats["rejected"]
    errors = {beta: np.max(np.abs(r.x[-1] - exact)) for beta, r in runs.items()}
    assert errors[0.04] < 2 * errors[0.0]
    with pytest.raises(ValueError, match="pi_beta"):
        simulate(m, [2.5, 0.0], (0, 1), pi_beta=0.5)
