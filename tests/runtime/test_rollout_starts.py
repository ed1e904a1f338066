"""eomc.rollout starts each row as simulate starts x0: on the model's constraints.

Session 52 (a rollout sweep over the 31 gymnasium and dm_control MJCF files): on dm_control's
manipulator, quadruped and stacker, rows with random joint speeds were run off the velocity
constraints as given -- status 0, no warning, up to 0.24 away from simulate of the same start,
which completes it.  Oracle: simulate itself (row i equals simulate of x0s[i], bit for bit) and
the four-bar's loop closure in closed form (a parallelogram: q2 = pi - q1, q3 = q1, u2 = -u1,
u3 = u1).
"""
import warnings
from pathlib import Path

import numpy as np
import pytest

import eomc
from eomc.runtime.batch import simulate_many
from eomc.runtime.consistent import ConstraintWarning
from eomc.runtime.errors import ModelError

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
DT, STEPS = 0.005, 40


@pytest.fixture(scope="module")
def fourbar():
    return eomc.compile(str(EXAMPLES / "four_bar_system.py"), progress=False)


def _starts(model):
    """Six rows: 0, 2, 4 off the loop (q2, q3 and the dependent speeds left as the first row's),
    1, 3, 5 on it (the parallelogram's closed form)."""
    X0 = np.tile(model.initial_state, (6, 1))
    q1 = np.array([-1.0, -0.95, -0.9, -1.1, -1.05, -0.85])
    u1 = np.array([0.5, -0.3, 1.0, 0.0, 0.2, -0.7])
    X0[:, 0], X0[:, 3] = q1, u1
    on = [1, 3, 5]
    X0[on, 1], X0[on, 2] = np.pi - q1[on], q1[on]
    X0[on, 4], X0[on, 5] = -u1[on], u1[on]
    return X0


def _constraint_max(model, x, p=None):
    return float(np.max(np.abs(model.constraints(0.0, x, p))))


def test_rows_off_the_constraints_are_completed_as_simulate_completes_them(fourbar):
    X0 = _starts(fourbar)
    assert min(_constraint_max(fourbar, X0[i]) for i in (0, 2, 4)) > 1e-3
    with pytest.warns(ConstraintWarning, match=r"3 of 6 rows of x0s \(rows 0, 2, 4\); row 0: four_bar_system: "
                                               r"x0 was off the constraints .*completed it on them"):
        res = eomc.rollout(fourbar, X0, steps=STEPS, dt=DT, method="rk4", record="steps")
    for i in range(6):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConstraintWarning)
            one = fourbar.simulate(X0[i], (0, STEPS * DT), method="rk4", dt=DT)
        np.testing.assert_array_equal(res.x[i], one.x)        # every step, bit for bit
        assert _constraint_max(fourbar, res.x[i, 0]) < 1e-10
    np.testing.assert_array_equal(res.x[1::2, 0], X0[1::2])   # rows on the loop start as given
    np.testing.assert_array_equal(res.x[::2, 0, 0], X0[::2, 0])   # the independent q1, u1 kept
    np.testing.assert_array_equal(res.x[::2, 0, 3], X0[::2, 3])
    # the adaptive methods' rows too (their own C path: final states)
    with pytest.warns(ConstraintWarning, match="3 of 6 rows"):
        ada = eomc.rollout(fourbar, X0, t_final=0.2)
    for i in (0, 1):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConstraintWarning)
            np.testing.assert_array_equal(ada.x[i], fourbar.simulate(X0[i], (0, 0.2)).x_final)


def test_consistent_false_runs_as_given_with_the_warning_and_true_completes_every_row(fourbar):
    X0 = _starts(fourbar)
    with pytest.warns(ConstraintWarning, match=r"3 of 6 rows of x0s.*x0 is off the constraints"):
        given = eomc.rollout(fourbar, X0, steps=STEPS, dt=DT, method="rk4", record="steps", consistent=False)
    np.testing.assert_array_equal(given.x[:, 0], X0)
    assert _constraint_max(fourbar, given.x[0, -1]) > 1e-3      # it followed the wrong motion
    with warnings.catch_warnings():
        warnings.simplefilter("error")                         # every row made consistent: no warning
        every = eomc.rollout(fourbar, X0, steps=STEPS, dt=DT, method="rk4", record="steps", consistent=True)
    for i in range(6):
        np.testing.assert_array_equal(every.x[i, 0], fourbar.consistent_state(X0[i]))
    with warnings.catch_warnings():
        warnings.simplefilter("error")                         # rows on the constraints: no warning
        eomc.rollout(fourbar, X0[1::2], steps=2, dt=DT, method="rk4")


def test_each_row_is_completed_with_its_own_parameters_and_a_hopeless_row_is_named(fourbar):
    """Per-row p: the rows are checked one by one (the loop's lengths are parameters)."""
    X0 = _starts(fourbar)[:3]
    names = list(fourbar.param_names)
    P = np.tile(fourbar.param_defaults, (3, 1))
    P[1, names.index("l1")] *= 1.05                           # row 1, on the default loop, is off this one
    with pytest.warns(ConstraintWarning, match="3 of 3 rows"):
        res = eomc.rollout(fourbar, X0, steps=2, dt=DT, method="rk4", p=P, record="steps")
    for i in range(3):
        assert _constraint_max(fourbar, res.x[i, 0], P[i]) < 1e-10
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConstraintWarning)
            np.testing.assert_array_equal(res.x[i], fourbar.simulate(X0[i], (0, 2 * DT), p=P[i], method="rk4",
                                                                     dt=DT).x)
    P[2, names.index("l4")] = 100.0                           # the loop cannot close
    with pytest.raises(ModelError, match=r"x0s row 2 of 3: four_bar_system: x0 is off the constraints .*cannot "
                                         r"be completed"):
        eomc.rollout(fourbar, X0, steps=2, dt=DT, method="rk4", p=P)


def test_simulate_many_and_sweep_complete_like_simulate(fourbar):
    """One rule everywhere: simulate_many's and sweep's cases are simulate of their starts."""
    X0 = _starts(fourbar)[:3]
    with pytest.warns(ConstraintWarning, match=r"2 of 3 cases: .*completed it on them"):
        batch = simulate_many(fourbar, X0, (0, 0.05), progress=False, n_points=3)
    swept = eomc.sweep(fourbar, {"x0": X0}, (0, 0.05), n_points=3, progress=False)
    for i in range(3):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConstraintWarning)
            one = fourbar.simulate(X0[i], (0, 0.05), n_points=3)
        np.testing.assert_array_equal(batch.x[i], one.x)
        np.testing.assert_array_equal(swept.x[i], one.x)


def test_the_warning_points_at_the_callers_line(fourbar):
    """The rows' ConstraintWarning names the user's line, from eomc.rollout and from an eomc.Rollout
    call alike (it named runtime/rollout.py until session 53)."""
    X0 = _starts(fourbar)
    for run in (lambda: eomc.rollout(fourbar, X0, dt=DT, steps=STEPS, threads=1),
                lambda: eomc.Rollout(fourbar, dt=DT, threads=1)(X0, steps=STEPS)):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            run()
        assert [w.category for w in caught] == [ConstraintWarning]
        assert caught[0].filename == __file__
