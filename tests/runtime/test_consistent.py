"""model.consistent_state and simulate's check of a start off the constraints.

Oracles: the rolling disc's centre height -r cos(lean) (its configuration
constraint in closed form) and the four-bar's loop closure solved by scipy's
fsolve; the constraint residual along runs started either way.
"""
import warnings
from pathlib import Path

import numpy as np
import pytest
import sympy as sm
from scipy.optimize import fsolve

from helpers import zoo

import eomc
import eomc.mechanics as me
from eomc.runtime.consistent import ConstraintWarning
from eomc.runtime.errors import ModelError

FOUR_BAR = dict(l1=1.0, l2=2.0, l3=1.5, l4=2.0)


@pytest.fixture(scope="module")
def disc(tmp_path_factory):
    kane, _ = zoo.rolling_disc(me)
    r, m, g = sm.symbols("r m g")
    return eomc.compile(kane, "disc", parameters={r: 0.5, m: 1.0, g: 9.81},
                        cache_dir=tmp_path_factory.mktemp("cache"), progress=False)


@pytest.fixture(scope="module")
def fourbar(tmp_path_factory):
    kane, _ = zoo.four_bar(me)
    values = {**FOUR_BAR, "g": 9.81, "m1": 1.0, "m2": 1.0, "m3": 1.0, "I1": 0.1, "I2": 0.3,
              "I3": 0.2}
    params = {sm.Symbol(k): v for k, v in values.items()}
    return eomc.compile(kane, "fourbar", parameters=params,
                        cache_dir=tmp_path_factory.mktemp("cache"), progress=False)


def test_rolling_disc_completes_height_and_contact_speeds(disc):
    x0 = np.zeros(disc.nx)
    x0[[1, 3, 4]] = [0.3, 1.0, 2.0]                  # lean, contact x, y
    x0[6:9] = [0.5, 6.0, -0.2]                       # independent speeds (omega in B)
    x = disc.consistent_state(x0)
    np.testing.assert_array_equal(x[:5], x0[:5])     # independent coordinates kept
    np.testing.assert_array_equal(x[6:9], x0[6:9])   # independent speeds kept
    assert x[5] == pytest.approx(-0.5 * np.cos(0.3), abs=1e-14)
    assert np.max(np.abs(disc.constraints(0.0, x))) < 1e-12
    with pytest.warns(ConstraintWarning, match=r"off the constraints \(configuration residual "
                                               r"0\.478, velocity residual"):
        bad = disc.simulate(x0, (0, 2), rtol=1e-9, atol=1e-9, consistent=False)     # run as given
    good = disc.simulate(x0, (0, 2), rtol=1e-9, atol=1e-9, consistent=True)
    np.testing.assert_array_equal(good.x[0], x)
    with pytest.warns(ConstraintWarning, match=r"x0 was off the constraints \(configuration residual "
                                               r"0\.478.*completed it on them"):
        default = disc.simulate(x0, (0, 2), rtol=1e-9, atol=1e-9)    # completed like consistent=True
    np.testing.assert_array_equal(default.x[0], x)
    assert good.constraint_residual.max() < 1e-6 < bad.constraint_residual.max()
    with warnings.catch_warnings():
        warnings.simplefilter("error")               # a consistent start: no warning
        disc.simulate(x, (0, 0.5), rtol=1e-9, atol=1e-9)


def test_four_bar_closes_the_loop_like_fsolve(fourbar):
    l1, l2, l3, l4 = FOUR_BAR.values()
    q1 = 0.9

    def loop(q23):
        q2, q3 = q23
        return [l1 * np.cos(q1) + l2 * np.cos(q2) + l3 * np.cos(q3) - l4,
                l1 * np.sin(q1) + l2 * np.sin(q2) + l3 * np.sin(q3)]
    guess = [0.1, -1.5]
    ref = fsolve(loop, guess, xtol=1e-14)
    x = fourbar.consistent_state([q1, *guess, 0.7, 0.0, 0.0])
    np.testing.assert_allclose(x[1:3], ref, atol=1e-12)
    assert x[0] == q1 and x[3] == 0.7
    assert np.max(np.abs(fourbar.constraints(0.0, x))) < 1e-12
    # holding another coordinate: q3 given, q1 and q2 solved for
    y = fourbar.consistent_state(x + [0.05, 0.05, 0.0, 0, 0, 0], fixed=["q3", "u1"])
    assert y[2] == x[2] and np.max(np.abs(fourbar.constraints(0.0, y))) < 1e-12
    res = fourbar.simulate(x, (0, 3), rtol=1e-10, atol=1e-10)
    assert res.constraint_residual.max() < 1e-6


def test_unreachable_and_singular_starts_are_clear_errors(fourbar):
    with pytest.raises(ModelError, match="Newton's method did not reach the configuration "
                                         "constraints.*solving for q2, q3"):
        fourbar.consistent_state([0.9, 0.1, -1.5, 0, 0, 0], p={"l4": 100.0})
    with pytest.raises(ModelError, match="2 configuration constraint.*only 1 free"):
        fourbar.consistent_state([0.9, 0.1, -1.5, 0, 0, 0], fixed=["q1", "q2"])
    with pytest.raises(ValueError, match="unknown fixed state"):
        fourbar.consistent_state([0.9, 0.1, -1.5, 0, 0, 0], fixed=["qq"])


# ---- issue 24: one rule for the states a start leaves out; arguments checked ----------------------
from pathlib import Path  # noqa: E402

from eomc.runtime.batch import simulate_many  # noqa: E402

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.fixture(scope="module")
def fourbar_file():
    """examples/four_bar_system.py: an initial_state far from 0 (q2 = pi + 1)."""
    return eomc.compile(str(EXAMPLES / "four_bar_system.py"), progress=False)


def test_a_dict_start_is_completed_from_initial_state_everywhere(fourbar_file):
    """N14 / first hour #7: simulate(dict, consistent=True) started Newton from 0 (singular there)
    while consistent_state(dict) started from initial_state; both now use initial_state."""
    fb = fourbar_file
    start = {"q1": -0.9, "u1": 1.0}
    want = fb.consistent_state(start)
    res = fb.simulate(start, (0, 0.2), consistent=True)
    np.testing.assert_array_equal(res.x[0], want)
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        plain = fb.simulate({"u1": 0.0}, (0, 0.1), n_points=2)     # initial_state is consistent
    assert not [w for w in seen if issubclass(w.category, ConstraintWarning)]
    np.testing.assert_array_equal(plain.x[0], fb.initial_state)
    np.testing.assert_array_equal(fb.simulate(None, (0, 0.1), n_points=2).x[0], fb.initial_state)
    np.testing.assert_array_equal(fb.consistent_state(None), fb.consistent_state(fb.initial_state))


def test_consistent_state_checks_tol_and_max_iter(fourbar_file):
    for kw, what in ((dict(tol=-1), "tol"), (dict(tol=float("nan")), "tol"), (dict(max_iter=-1), "max_iter"),
                     (dict(max_iter=2.5), "max_iter")):
        with pytest.raises(ValueError, match=f"consistent_state {what} must be"):
            fourbar_file.consistent_state({"q1": -0.9}, **kw)


def test_simulate_many_completes_every_start(fourbar_file):
    fb = fourbar_file
    X0 = np.tile(fb.initial_state, (3, 1))
    X0[:, 0] = [-1.0, -0.95, -0.9]
    batch = simulate_many(fb, X0, (0, 0.2), consistent=True, progress=False, n_points=3)
    for i in range(3):
        np.testing.assert_array_equal(batch.x[i, 0], fb.consistent_state(X0[i]))
    with pytest.warns(ConstraintWarning, match=r"2 of 3 cases: .*x0 is off the constraints"):
        simulate_many(fb, X0, (0, 0.01), progress=False, n_points=2, raise_on_failure=False, consistent=False)


# ---- issue 34: simulate() completes an inconsistent start by default, as `eomc simulate` does ---------
import importlib.util  # noqa: E402

_spec = importlib.util.spec_from_file_location("bench_loops", Path(__file__).resolve().parents[2]
                                               / "benchmarks" / "bench_loops.py")
bench_loops = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bench_loops)


@pytest.fixture(scope="module")
def slider_crank(tmp_path_factory):
    system, params, x0 = bench_loops.slider_crank(me)
    model = eomc.compile(system, "slider_crank", parameters=params, cache_dir=tmp_path_factory.mktemp("cache"),
                         progress=False)
    return model, {str(k)[:-3] if str(k).endswith("(t)") else str(k): float(v) for k, v in x0.items()}


def test_the_slider_crank_start_is_completed_by_default(slider_crank):
    """The first-hour case: the crank's angle and speed given, the rod's and slider's speeds
    left at 0 (off the velocity constraints).  By default the dependent speeds are solved for,
    the given and independent states held, with one ConstraintWarning saying how far off;
    consistent=False runs from the start as given (the warning of old) and leaves the
    constraints; a start that cannot be completed is refused with the ways out."""
    model, x0 = slider_crank
    start = {**x0, "u1": 3.0}
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        res = model.simulate(start, (0, 1), rtol=1e-9, atol=1e-9)
    notes = [str(w.message) for w in seen if issubclass(w.category, ConstraintWarning)]
    assert len(notes) == 1 and "\n" not in notes[0], notes
    assert "x0 was off the constraints (configuration residual " in notes[0], notes
    assert "velocity residual 3.63); completed it on them" in notes[0], notes
    assert "u2 0 -> " in notes[0] and "u3 0 -> " in notes[0] and "consistent=False" in notes[0], notes
    want = model.consistent_state(start)
    np.testing.assert_array_equal(res.x[0], want)
    assert res.x[0][model.state_names.index("u1")] == 3.0          # what was given is held
    assert res.constraint_residual.max() < 1e-6
    with pytest.warns(ConstraintWarning, match="x0 is off the constraints"):
        raw = model.simulate(start, (0, 1), rtol=1e-9, atol=1e-9, consistent=False, raise_on_failure=False)
    assert raw.constraint_residual.max() > 1e-2                     # as given: off the constraints
    with pytest.raises(ModelError, match="cannot be completed on them.*consistent=False"):
        model.simulate({"q1": 0.7}, (0, 1), p={"l": 0.1})   # a rod shorter than the crank cannot reach
