"""eomc.Rollout (runtime/rollout_session.py): a rollout planned once, run call after call.

Oracle: ``eomc.rollout`` with the same options and arguments -- a Rollout call runs the same plan
(runtime/rollout._Plan) and the same C, so its rows, statuses, steps, unsolved counts, messages
and warnings must be the same bits, call after call, with other starts, inputs and spans between
them (a plan or a buffer kept across calls that leaks one call's rows into the next is a bug).
"""
import warnings

import numpy as np
import pytest

from helpers.mjcf_builds import gym_model
from helpers.stand_in import get_model

import eomc
from eomc.errors import SimulationError
from eomc.runtime.rollout import rollout
from eomc.runtime.rollout_session import PLANS_KEPT, Rollout


def _same(got, want):
    assert got.method == want.method
    np.testing.assert_array_equal(got.x, want.x)
    np.testing.assert_array_equal(got.t, want.t)
    for field in ("status", "steps", "unsolved"):
        np.testing.assert_array_equal(getattr(got, field), getattr(want, field))
    assert got.messages == want.messages


def _starts(n, seed):
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(-3.0, 3.0, n), rng.uniform(-2.0, 2.0, n)])


@pytest.mark.parametrize("options", [dict(dt=0.01, method="rk4"), dict(dt=0.01, method="rk4", record="steps"),
                                     dict(method="dop853", rtol=1e-9, atol=1e-11), dict(dt=0.02)])
def test_calls_equal_rollout_call_after_call(options):
    m = get_model("pendulum")
    ro = Rollout(m, threads=2, **options)
    span = "steps" if "dt" in options else "t_final"
    for k, (n, length) in enumerate([(7, 30), (7, 30), (3, 55), (7, 30)]):
        X0 = _starts(n, seed=k)
        kw = {span: length if span == "steps" else length / 20}
        _same(ro(X0, **kw), rollout(m, X0, threads=2, **options, **kw))
    assert ro.method == ("dop853" if "method" in options and options["method"] == "dop853" else "rk4")


def test_method_none_without_dt_stays_auto():
    """Without dt, method=None is "auto", which picks per row (DOP853, stiff rows on with Radau):
    kept as "auto", not as the method its first rows ran, so later calls equal rollout's."""
    m = get_model("pendulum")
    ro = Rollout(m)
    for seed in range(2):
        X0 = _starts(4, seed)
        _same(ro(X0, t_final=0.5), rollout(m, X0, t_final=0.5))
    assert ro.method == "auto"


def test_inputs_per_call_and_per_row_parameters():
    """Inputs change every call (an RL agent's actions); p with one row per trajectory."""
    m = get_model("oscillator")
    n = 6
    P = np.column_stack([np.linspace(1.0, 9.0, n), np.full(n, 1.0), np.linspace(0.0, 0.4, n)])
    ro = Rollout(m, dt=0.01, method="rk4", p=P)
    rng = np.random.default_rng(3)
    for _ in range(3):
        X0 = rng.normal(size=(n, m.nx))
        R = rng.normal(size=(n, m.ninput))
        _same(ro(X0, steps=20, r=R), rollout(m, X0, dt=0.01, method="rk4", p=P, steps=20, r=R))
        grid = (np.array([0.0, 0.1, 0.2]), rng.normal(size=(n, 3, m.ninput)))
        _same(ro(X0, steps=20, r=grid), rollout(m, X0, dt=0.01, method="rk4", p=P, steps=20, r=grid))
    with pytest.raises(ValueError, match=r"p must have shape .*\(4, 3\)"):
        ro(np.zeros((4, m.nx)), steps=5)      # the parameters' rows fix the row count


def test_set_params_takes_effect_on_the_next_call():
    """Domain randomisation: new parameters each episode; every call then equals rollout with them,
    and the caller's array changing afterwards changes nothing."""
    m = get_model("oscillator")
    X0 = np.random.default_rng(4).normal(size=(5, m.nx))
    ro = Rollout(m, dt=0.01, method="rk4")
    _same(ro(X0, steps=30), rollout(m, X0, dt=0.01, method="rk4", steps=30))
    for k in (2.0, 9.0):
        P = np.column_stack([np.full(5, k), np.linspace(0.5, 1.5, 5), np.full(5, 0.1)])
        ro.set_params(P)
        want = rollout(m, X0, dt=0.01, method="rk4", steps=30, p=P.copy())
        P[:] = 1.0
        _same(ro(X0, steps=30), want)
    with pytest.raises(ValueError, match="has a non-finite k"):
        ro.set_params([np.nan, 1.0, 0.0])


def test_feedback_gains_run_through_the_same_plan():
    m = get_model("oscillator")
    K = np.array([[4.0, 1.5]])
    ro = Rollout(m, dt=0.01, method="rk4", K=K, x_ref=np.zeros(m.nx))
    for seed in range(2):
        X0 = np.random.default_rng(seed).normal(size=(5, m.nx))
        _same(ro(X0, steps=40), rollout(m, X0, dt=0.01, method="rk4", K=K, x_ref=np.zeros(m.nx), steps=40))


def test_method_none_is_chosen_on_the_first_call_and_kept(tmp_path):
    """method=None with dt: RK4, or implicitfast where RK4 diverges at dt (a stiff spring): chosen
    on the first call's rows, then every call runs that method (the rows' results then do not
    depend on which rows came first in the object's life)."""
    from tests.runtime.test_rollout import _spring
    m = _spring(tmp_path, "rs_spring")
    X0 = np.column_stack([np.linspace(-1.0, 1.0, 6), np.zeros(6)])
    stiff = [1e6, 0.5, 1.0]                       # |dt lambda| = 10 at dt = 0.01
    ro = Rollout(m, dt=0.01, p=stiff, threads=1)
    assert ro.method is None
    got = ro(X0, steps=100)
    assert ro.method == got.method == "implicitfast" and got.ok.all()
    _same(got, rollout(m, X0, dt=0.01, p=stiff, steps=100, threads=1))
    assert ro(X0[:2], steps=3).method == "implicitfast"
    ro.set_params([4.0, 0.5, 1.0])          # soft again: chosen anew on the next call
    assert ro.method is None and ro(X0, steps=10).method == "rk4"
    soft = Rollout(m, dt=0.01, threads=1)
    assert soft(X0, steps=10).method == "rk4" and soft.method == "rk4"
    _same(soft(X0[:3], steps=7), rollout(m, X0[:3], dt=0.01, steps=7, threads=1))


def test_arguments_are_checked_where_given():
    m = get_model("pendulum")
    with pytest.raises(ValueError, match="dt must be a finite step > 0"):
        Rollout(m, dt=-1.0, method="rk4")
    with pytest.raises(ValueError, match="is fixed-step: give dt="):
        Rollout(m, method="rk4")
    with pytest.raises(ValueError, match="is adaptive: give t_final="):
        Rollout(m, dt=0.01, method="dop853")
    with pytest.raises(ValueError, match="record must be"):
        Rollout(m, dt=0.01, record="all")
    with pytest.raises(ValueError, match="p must have shape"):
        Rollout(m, dt=0.01, p=[1.0, 2.0, 3.0, 4.0, 5.0])
    ro = Rollout(m, dt=0.01)
    with pytest.raises(ValueError, match=r"x0s must have shape \(n, 2\)"):
        ro(np.zeros((3, 3)), steps=2)
    with pytest.raises(ValueError, match="x0s row 1 has a non-finite"):
        ro(np.array([[0.1, 0.0], [np.nan, 0.0]]), steps=2)
    with pytest.raises(ValueError, match="steps must be a whole number"):
        ro(np.zeros((2, 2)), steps=0)
    with pytest.raises(ValueError, match="exactly one of t_final= or steps="):
        ro(np.zeros((2, 2)))


def test_plans_kept_are_bounded():
    m = get_model("pendulum")
    ro = Rollout(m, dt=0.01, method="rk4")
    X0 = _starts(3, 0)
    for steps in range(1, 2 * PLANS_KEPT):
        ro(X0, steps=steps)
    assert len(ro._plans) == PLANS_KEPT
    _same(ro(X0, steps=1), rollout(m, X0, dt=0.01, method="rk4", steps=1))     # dropped, made again


def test_failed_rows_raise_or_are_kept_as_rollout_does():
    m = get_model("singular")
    P = np.array([[2.0], [0.5], [3.0]])
    X0 = np.zeros((3, m.nx))
    with pytest.raises(SimulationError, match="row 1 of 3 failed.*singular"):
        Rollout(m, dt=0.01, method="rk4", p=P)(X0, steps=100)
    ro = Rollout(m, dt=0.01, method="rk4", p=P, raise_on_failure=False)
    for _ in range(2):
        kept = ro(X0, steps=100)
        _same(kept, rollout(m, X0, dt=0.01, method="rk4", p=P, steps=100, raise_on_failure=False))
        assert kept.status.tolist()[0] == 0 and kept.status[1] != 0 and kept.status[2] == 0


def test_pickled_without_its_plans_and_equal_after(tmp_path):
    """A Rollout goes to a worker process with its model and options; its plans (C structs) are
    made again there.  A built model (it pickles by content) and a fresh process's view of it."""
    import pickle
    from tests.runtime.test_rollout import _spring
    m = _spring(tmp_path, "rs_pickled")
    X0 = np.column_stack([np.linspace(-1.0, 1.0, 4), np.zeros(4)])
    ro = Rollout(m, dt=0.01, p=[1e6, 0.5, 1.0], threads=1)
    want = ro(X0, steps=20)
    back = pickle.loads(pickle.dumps(ro))
    assert not back._plans and back.method is None      # chosen again on its first call
    _same(back(X0, steps=20), want)


def test_eomc_exports_it():
    assert eomc.Rollout is Rollout and "Rollout" in eomc.__all__


# --- gymnasium's hopper: contacts on implicitfast's fast path, the energy watch and verdict -----

@pytest.fixture(scope="module")
def hopper(tmp_path_factory):
    return gym_model("hopper.xml", "rs_hopper", tmp_path_factory.mktemp("rsh"),
                     ("rhs", "outputs", "energy", "jac_x", "implicit", "implicit_batch"))


def _hopper_starts(model, n, seed):
    X0 = np.tile(np.array(model.initial_state, dtype=float), (n, 1))
    X0[:, model.nq:] = np.random.default_rng(seed).uniform(-0.5, 0.5, (n, model.nu))
    return X0


def _warned(call):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = call()
    return result, [str(w.message) for w in caught]


@pytest.mark.parametrize("lanes", [False, True])
def test_hopper_fast_path_calls_equal_rollout(hopper, lanes):
    """The RL pattern: a few steps a call, new starts and actions each call; the fast path's C
    set-up (depth limits, energy watch) made once; verdicts and warnings as rollout's."""
    dt = 0.002
    ro = Rollout(hopper, dt=dt, lanes=lanes, threads=2, raise_on_failure=False)
    rng = np.random.default_rng(5)
    X0 = _hopper_starts(hopper, 11, seed=1)
    for call in range(4):
        R = rng.uniform(-1.0, 1.0, (11, hopper.ninput))
        steps = 4 if call % 2 else 60
        got, got_w = _warned(lambda: ro(X0, steps=steps, r=R))
        want, want_w = _warned(lambda: rollout(hopper, X0, dt=dt, steps=steps, r=R, lanes=lanes, threads=2,
                                               raise_on_failure=False))
        _same(got, want)
        assert got_w == want_w
        assert got.method == "implicitfast" and got.ok.all()
        X0 = got.x      # the next call goes on from where these rows are (an episode)
    z = list(hopper.state_names).index("q_rootz")
    assert X0[:, z].std() > 1e-3        # the rows went their own ways


def test_hopper_energy_verdict_each_call(hopper, monkeypatch):
    """A row whose energy rose fails with simulate's status 20 on every call that has it, and a
    call without such a row is clean: the verdict's state is not kept between calls."""
    import eomc.runtime.rollout as rollout_module
    from eomc.runtime import switching
    X0 = _hopper_starts(hopper, 4, seed=2)
    ro = Rollout(hopper, dt=0.002, raise_on_failure=False)
    clean = ro(X0, steps=30)
    assert clean.ok.all() and not clean.messages
    real = switching.energy_tolerance
    monkeypatch.setattr(rollout_module, "energy_tolerance", lambda rtol, atol: -1.0)     # every rise "too much"
    monkeypatch.setattr(switching, "energy_tolerance", lambda rtol, atol: -1.0)
    got, _ = _warned(lambda: ro(X0, steps=30))
    want, _ = _warned(lambda: rollout(hopper, X0, dt=0.002, steps=30, raise_on_failure=False))
    _same(got, want)
    assert (got.status == 20).any() and set(got.messages) == set(np.flatnonzero(got.status == 20))
    monkeypatch.setattr(rollout_module, "energy_tolerance", real)
    monkeypatch.setattr(switching, "energy_tolerance", real)
    _same(ro(X0, steps=30), clean)

