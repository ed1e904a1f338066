"""Inputs evaluated at every stage: a Python callable r(t) / r(t, x), and feedback K (x_ref - x) in C.

Oracles: scipy's solve_ivp on the closed-form cart-pendulum (tests/helpers/model_files.py)
with the same input function, and an LQR designed from the model's own linearize.
"""
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import solve_continuous_are

from helpers import model_files

import eomc


@pytest.fixture(scope="module")
def cart(tmp_path_factory):
    d, cache = tmp_path_factory.mktemp("models"), tmp_path_factory.mktemp("cache")
    return eomc.compile(str(model_files.write(d, model_files.CART, "cart")), cache_dir=cache,
                        progress=False)


def test_fast_callable_input_over_long_span_matches_solve_ivp(cart):
    """A 5 Hz force over 100 s: sampling it on 1001 points (10 per second) was wrong; now exact."""
    force = lambda t: [2.0 * np.sin(2 * np.pi * 5 * t)]    # noqa: E731
    x0 = cart.initial_state
    ref = solve_ivp(lambda t, x: model_files.cart_rhs(x, F=force(t)[0]), (0, 100), x0,
                    method="DOP853", rtol=1e-11, atol=1e-11)
    res = cart.simulate(x0, (0, 100), r=force, rtol=1e-11, atol=1e-11, n_points=11)
    assert np.max(np.abs(res.x_final - ref.y[:, -1])) < 1e-6
    assert np.max(np.abs(res.x[-1] - ref.y[:, -1])) < 1e-6


def _lqr(cart):
    up = np.array([0.0, np.pi, 0.0, 0.0])
    A, B = cart.linearize(0.0, up)
    P = solve_continuous_are(A, B, np.diag([1.0, 10.0, 1.0, 1.0]), np.eye(1))
    return B.T @ P, up


def test_lqr_feedback_in_c_matches_closed_form_and_python_callable(cart):
    K, up = _lqr(cart)
    x0 = up + [0.0, 0.2, 0.0, 0.0]
    t = np.linspace(0, 8, 81)
    ref = solve_ivp(lambda s, x: model_files.cart_rhs(x, F=(K @ (up - x))[0]), (0, 8), x0,
                    method="DOP853", rtol=1e-12, atol=1e-12, t_eval=t)
    res = cart.simulate(x0, (0, 8), K=K, x_ref=up, rtol=1e-11, atol=1e-11, t_eval=t)
    assert np.max(np.abs(res.x - ref.y.T)) < 1e-8
    assert abs(res.x[-1, 1] - np.pi) < 0.01             # from 0.2 rad off: held upright
    by_python = cart.simulate(x0, (0, 8), r=lambda s, x: K @ (up - x), rtol=1e-11, atol=1e-11,
                              t_eval=t)
    assert np.max(np.abs(by_python.x - res.x)) < 1e-9
    # Radau's Jacobian includes -jac_r K: it converges to the same trajectory
    stiff = cart.simulate(x0, (0, 8), K=K, x_ref=up, method="radau", rtol=1e-10, atol=1e-12,
                          t_eval=t)
    assert np.max(np.abs(stiff.x - ref.y.T)) < 1e-6


def test_feedback_adds_to_constant_input(cart):
    K, up = _lqr(cart)
    x0 = up + [0.0, 0.1, 0.0, 0.0]
    res = cart.simulate(x0, (0, 2), r=[0.3], K=K, x_ref=up, rtol=1e-11, atol=1e-11, n_points=3)
    ref = solve_ivp(lambda s, x: model_files.cart_rhs(x, F=0.3 + (K @ (up - x))[0]), (0, 2), x0,
                    method="DOP853", rtol=1e-12, atol=1e-12)
    assert np.max(np.abs(res.x_final - ref.y[:, -1])) < 1e-8


def test_bad_feedback_and_callables_are_clear_errors(cart):
    K, up = _lqr(cart)
    with pytest.raises(ValueError, match=r"gain K must have shape \(ninput, nx\) = \(1, 4\).*got shape \(4, 1\)"):
        cart.simulate(up, (0, 1), K=K.T)
    with pytest.raises(ValueError, match=r"x_ref must have shape \(4,\)"):
        cart.simulate(up, (0, 1), K=K, x_ref=[0, 1])
    with pytest.raises(ValueError, match="pass K= too"):
        cart.simulate(up, (0, 1), x_ref=up)
    with pytest.raises(ValueError, match=r"must take \(t\) or \(t, x\)"):
        cart.simulate(up, (0, 1), r=lambda a, b, c: 0.0)
    with pytest.raises(ValueError, match=r"r\(t, x\) must return 1 value"):
        cart.simulate(up, (0, 1), r=lambda t, x: [0.0, 1.0])

    def fails_later(t):
        if t > 0.5:
            raise RuntimeError("controller broke")
        return [0.0]
    with pytest.raises(ValueError, match=r"r\(t\) raised RuntimeError at t=0\.[5-9]\d*: controller broke") as info:
        cart.simulate(up, (0, 1), r=fails_later)
    assert isinstance(info.value.__cause__, RuntimeError)


def test_cartpole_lqr_example(tmp_path):
    """examples/cartpole_lqr.py: LQR from linearize holds it upright; uncontrolled, it falls."""
    from pathlib import Path
    example = Path(__file__).resolve().parents[2] / "examples" / "cartpole_lqr.py"
    model = eomc.compile(str(example), cache_dir=tmp_path, progress=False)
    K, up = _lqr(model)
    res = model.simulate(model.initial_state, (0, 10), K=K, x_ref=up, rtol=1e-9, atol=1e-9)
    assert res.event_stop is None and abs(res.x_final[1] - np.pi) < 1e-3
    free = model.simulate(model.initial_state, (0, 10), rtol=1e-9, atol=1e-9)
    assert free.event_stop == "fallen" and np.cos(free.x_final[1]) == pytest.approx(0, abs=1e-12)


def test_cubic_input_table_is_the_spline(cart):
    """r=(t, values, "cubic"): scipy's not-a-knot CubicSpline evaluated in C (Hermite form)."""
    from scipy.interpolate import CubicSpline
    grid = np.linspace(0, 3, 31)                       # 10 points per second of sin(3 t)
    spline = CubicSpline(grid, np.sin(3 * grid))
    x0 = cart.initial_state
    ref = solve_ivp(lambda s, x: model_files.cart_rhs(x, F=float(spline(s))), (0, 3), x0,
                    method="DOP853", rtol=1e-12, atol=1e-12)
    cubic = cart.simulate(x0, (0, 3), r=(grid, np.sin(3 * grid), "cubic"), rtol=1e-11, atol=1e-11,
                          n_points=7)
    linear = cart.simulate(x0, (0, 3), r=(grid, np.sin(3 * grid)), rtol=1e-11, atol=1e-11,
                           n_points=7)
    assert np.max(np.abs(cubic.x_final - ref.y[:, -1])) < 1e-8
    assert np.max(np.abs(linear.x_final - ref.y[:, -1])) > 1e-5      # linear is another input
    with pytest.raises(ValueError, match="kind 'linear' or 'cubic'"):
        cart.simulate(x0, (0, 3), r=(grid, np.sin(3 * grid), "quadratic"))
