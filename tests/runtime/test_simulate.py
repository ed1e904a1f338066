"""simulate(): argument checking before C runs, failures, named results, projection, CSV."""

import numpy as np
import pytest

from helpers.stand_in import get_model

from eomc.errors import SimulationError
from eomc.runtime.consistent import ConstraintWarning
from eomc.runtime.simulate import scipy_fun, simulate


@pytest.fixture(scope="module")
def pend():
    return get_model("pendulum")


@pytest.mark.parametrize("kw,match", [
    (dict(x0=[1.0, 0.0, 0.0]), r"shape \(2,\)"),
    (dict(x0=[[1.0, 0.0]]), r"shape \(2,\)"),
    (dict(x0=[np.nan, 0.0]), "not finite for q1"),
    (dict(x0=[np.inf, 0.0]), "not finite"),
    (dict(x0={"q9": 1.0}), "unknown x0"),
    (dict(t_span=(1.0, 0.0)), "reversed"),
    (dict(t_span=(1.0, 1.0)), "empty"),
    (dict(t_span=(0.0,)), "t_span"),
    (dict(t_span=(0.0, np.inf)), "finite"),
    (dict(rtol=0.0), "rtol"),
    (dict(atol=-1e-9), "atol"),
    (dict(method="euler"), "valid methods: auto, rk4, dopri5, dop853, radau, implicitfast"),
    (dict(method="bfd"), r"unknown integration method 'bfd' \(did you mean bdf\?\); valid methods: auto"),
    (dict(method="rk4"), "dt"),
    (dict(t_eval=[0.5, 0.2]), "increasing"),
    (dict(t_eval=[0.0, 3.0]), "inside t_span"),
    (dict(p=[1.0]), r"shape \(2,\)"),
    (dict(p={"g": np.nan}), "not finite"),
    (dict(r=[1.0]), "no inputs"),
    (dict(max_steps=0), "max_steps"),
])
def test_bad_input_is_a_value_error_before_c_runs(pend, kw, match):
    args = dict(x0=[1.0, 0.0], t_span=(0.0, 1.0))
    args.update(kw)
    with pytest.raises(ValueError, match=match):
        simulate(pend, args.pop("x0"), args.pop("t_span"), **args)


def test_bad_input_grid_shapes():
    m = get_model("oscillator")
    with pytest.raises(ValueError, match="t_grid"):
        simulate(m, [0, 0], (0, 1), r=(np.linspace(0, 1, 5), np.zeros((4, 1))))
    with pytest.raises(ValueError, match="strictly increasing"):
        simulate(m, [0, 0], (0, 1), r=(np.array([0, 0.5, 0.5, 1.0]), np.zeros(4)))
    with pytest.raises(ValueError, match=r"r\(t\) must return 1 value"):
        simulate(m, [0, 0], (0, 1), r=lambda t: [t, t])


def test_named_columns_outputs_and_aliases(pend):
    res = simulate(pend, {"q1": 0.3}, (0, 2), method="RK45", rtol=1e-9, atol=1e-9, n_points=51)
    assert res.method == "dopri5" and res.success and res.t.shape == (51,)
    assert res.x.shape == (51, 2)
    np.testing.assert_array_equal(res["q1"], res.x[:, 0])
    e0 = -9.81 * np.cos(0.3)
    assert np.max(np.abs(res["energy"] - e0)) < 1e-7
    assert res.constraint_residual is None
    with pytest.raises(KeyError, match="neither a state nor an output"):
        res["nope"]


def test_to_csv_round_trip(pend, tmp_path):
    res = simulate(pend, [0.3, 0.0], (0, 1), n_points=11)
    path = res.to_csv(tmp_path / "traj.csv")
    data = np.genfromtxt(path, delimiter=",", names=True)
    assert data.dtype.names == ("t", "q1", "u1", "energy")
    np.testing.assert_array_equal(data["u1"], res["u1"])


def test_blowup_raises_simulation_error_with_time_and_state():
    m = get_model("blowup")                       # x' = x^2, x(0) = 1 -> infinite at t = 1
    with pytest.raises(SimulationError, match=r"t=(0\.99|1\.0).*state x=") as info:
        simulate(m, [1.0], (0, 2))
    assert "non-finite" in str(info.value) or "step size became too small" in str(info.value)
    res = simulate(m, [1.0], (0, 2), method="radau", raise_on_failure=False)
    assert res.status in (3, 5) and 0.99 < res.t_final < 1.001
    assert np.all(res.t <= res.t_final) and np.all(np.isfinite(res.x))


@pytest.mark.parametrize("method,kw", [("dop853", {}), ("rk4", {"dt": 0.01})])
def test_model_status_propagates_with_time(method, kw):
    m = get_model("singular")                     # reports a singular mass matrix after t = 0.5
    with pytest.raises(SimulationError, match="the mass matrix is singular"):
        simulate(m, [0.0], (0, 1), method=method, **kw)
    res = simulate(m, [0.0], (0, 1), method=method, raise_on_failure=False, **kw)
    assert res.status == 1 and res.t_final <= 0.5 + 1e-12
    assert res.t[-1] <= 0.5


def test_max_steps_is_reported():
    with pytest.raises(SimulationError, match="maximum number of steps"):
        simulate(get_model("pendulum"), [1.0, 0.0], (0, 100), max_steps=10)


def test_projection_keeps_the_ring_constraint():
    m = get_model("ring")
    x0 = [1.0, 0.0, 0.0, 0.0]
    free = simulate(m, x0, (0, 20), rtol=1e-5, atol=1e-8)
    proj = simulate(m, x0, (0, 20), rtol=1e-5, atol=1e-8, project=True)
    assert free.constraint_residual.shape == free.t.shape
    assert free.constraint_residual[-1] > 1e-6            # drifts without projection
    assert proj.stats["nproj"] == proj.stats["accepted"] + 1
    assert proj.stats["max_residual"] < 1e-12
    assert proj.constraint_residual[-1] < 1e-12          # t_final is a step end: projected
    r = np.hypot(proj["x"], proj["y"])
    assert np.max(np.abs(r - 1.0)) < 1e-3                  # dense output between projections
    assert np.max(proj.constraint_residual) < np.max(free.constraint_residual)


def test_scipy_fun_returns_fresh_arrays(pend):
    fun, jac = scipy_fun(pend)
    a, b = fun(0.0, np.array([0.1, 0.0])), fun(0.0, np.array([0.2, 0.0]))
    assert a is not b and a[1] != b[1]
    np.testing.assert_allclose(jac(0.0, np.array([0.0, 0.0])), [[0, 1], [-9.81, 0]])


def test_plot_writes_png(pend, tmp_path):
    pytest.importorskip("matplotlib")
    res = simulate(pend, [0.3, 0.0], (0, 1), n_points=11)
    assert res.plot(tmp_path / "t.png").stat().st_size > 1000
    import matplotlib
    matplotlib.use("Agg")
    fig = res.plot()                      # coordinates, speeds and outputs on panels of their own
    # the conserved energy is drawn as its change from the start (plotting._nearly_constant)
    energy = f"energy (start {res['energy'][0]:.10g})"
    assert [ax.get_ylabel() for ax in fig.axes] == ["coordinates", "speeds", "outputs: change from the start"]
    assert [line.get_label() for line in fig.axes[0].lines] == ["q1"]
    assert [line.get_label() for line in fig.axes[2].lines] == [energy]
    # names pick the curves; a coordinate and an output still get panels of their own (the
    # plots' rule: an energy of -19 J must not flatten a coordinate of +-0.3 rad)
    picked = res.plot(names=["q1", "energy"])
    assert [ax.get_ylabel() for ax in picked.axes] == ["coordinates", "outputs: change from the start"]
    assert [[line.get_label() for line in ax.lines] for ax in picked.axes] == [["q1"], [energy]]


def test_baumgarte_stabilization_pulls_residuals_back():
    """Started 1e-3 off the circle: without help the residual stays; with baumgarte=a it
    decays like exp(-a t) (a = 5, t = 4: e^-20 ~ 2e-9 of the start)."""
    m = get_model("ring")
    x0 = [1.001, 0.0, 0.0, 0.0]
    with pytest.warns(ConstraintWarning, match="configuration residual 0.002"):
        free = simulate(m, x0, (0, 4), rtol=1e-10, atol=1e-12, consistent=False)    # as given
    stab = simulate(m, x0, (0, 4), rtol=1e-10, atol=1e-12, baumgarte=5.0)   # no warning: it decays
    assert free.constraint_residual[-1] > 1e-3
    assert stab.constraint_residual[-1] < 1e-7
    i = np.searchsorted(stab.t, 1.0)
    ratio = stab.constraint_residual[i] / stab.constraint_residual[0]
    assert 0.3 * np.exp(-5.0) < ratio < 3 * np.exp(-5.0)
    with pytest.raises(ValueError, match="need the model's constraints"):
        simulate(get_model("pendulum"), [1.0, 0.0], (0, 1), baumgarte=1.0)
    with pytest.raises(ValueError, match="baumgarte"):
        simulate(m, x0, (0, 1), baumgarte=-1.0)


# ---- issue 24 (N14): inputs and feedback that are not real numbers name the argument ---------------
def test_complex_or_text_feedback_and_tables_name_the_argument():
    from helpers.stand_in import get_model
    m = get_model("oscillator")
    K = np.ones((1, 2))
    cases = [
        (dict(K=K + 5j), r"the feedback gain K must hold real numbers; got complex numbers"),
        (dict(K=K, x_ref=np.zeros(2) + 1j), r"x_ref must hold real numbers; got complex numbers"),
        (dict(K=[["a", "b"]]), r"the feedback gain K must hold real numbers; got dtype <U1"),
        (dict(r=(np.array([0.0, 1.0]), np.array(["a", "b"]))), r"r=\(t_grid, values\): values must hold real"),
        (dict(r=(np.array([0.0, 1.0]), np.zeros(2), "cubic", 4)), r"r as a tuple is an input table .* got a "
                                                                  r"tuple of 4 items"),
        (dict(r=np.array([1 + 2j])), r"r \(inputs\) must be real numbers"),
    ]
    for kw, match in cases:
        kw = {"r": np.zeros(1), **kw}
        with pytest.raises(ValueError, match=match):
            simulate(m, [1.0, 0.0], (0, 1), **kw)


def test_one_input_takes_a_number():
    """First hour #7: r=0.5 for a one-input model was 'must have shape (1,)'."""
    from helpers.stand_in import get_model
    m = get_model("oscillator")
    np.testing.assert_array_equal(simulate(m, [1.0, 0.0], (0, 1), r=0.5).x,
                                  simulate(m, [1.0, 0.0], (0, 1), r=[0.5]).x)
    with pytest.raises(ValueError, match="r \\(inputs\\) must be real numbers"):
        simulate(m, [1.0, 0.0], (0, 1), r="0.5")


def test_a_bound_call_keeps_its_model_alive():
    """bind_call's call keeps the model it was bound to: a caller that kept only the call (a
    timing harness) saw the model collected and then wrong runs (gymnasium's ant from qpos0: 777
    model calls instead of 121) or a segfault."""
    import gc
    import weakref

    from eomc.runtime.simulate import bind_call, prepare
    m = get_model("pendulum")
    call, _, x_last, stats = bind_call(m, prepare(m, [1.0, 0.0], (0.0, 1.0), method="rk4", dt=0.01, t_eval=[1.0]))
    alive = weakref.ref(m)
    del m
    gc.collect()
    assert alive() is not None
    assert call() == 0 and stats.status == 0 and np.all(np.isfinite(x_last))


def test_no_x0_and_no_initial_state_starts_from_rest_with_a_warning():
    """model.simulate(None, ...) on a model without initial_state raised while `eomc simulate`
    started from rest with a note (first hour s26): Python now does as the command line, the
    note a warning, and the run equals one from x0 = 0."""
    from eomc.errors import EomcWarning

    osc = get_model("oscillator")
    assert osc.initial_state is None
    with pytest.warns(EomcWarning, match="no initial_state and no x0 was given: starting from rest"):
        res = simulate(osc, None, (0.0, 1.0), n_points=5)
    ref = simulate(osc, np.zeros(osc.nx), (0.0, 1.0), n_points=5)
    assert res.status == 0 and np.array_equal(res.x, ref.x)


@pytest.fixture(scope="module")
def ball(tmp_path_factory):
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).parents[1] / "compiler" / "contact"))
    import bounce_grid
    return bounce_grid.build(tmp_path_factory.mktemp("cache"))


def test_the_default_step_budget_grows_with_the_span_on_the_ground(ball, monkeypatch):
    """Sweep s27: Talos --floating-base --ground ran out of the fixed 100000 steps at t = 1.67 of
    2 (~61,000 BDF steps a simulated second, half of them its grippers' limit springs): a run with
    ground contacts gets 100000 steps per simulated second; without contacts the budget stays
    100000; the message says how many were allowed and why."""
    import eomc.runtime.simulate as sim
    assert sim.default_max_steps(ball, (0.0, 0.5)) == 100000
    assert sim.default_max_steps(ball, (1.0, 3.5)) == 250000
    assert sim.default_max_steps(get_model("chain"), (0.0, 30.0)) == 100000
    monkeypatch.setattr(sim, "MAX_STEPS", 10)
    monkeypatch.setattr(sim, "CONTACT_STEPS_PER_S", 20)
    x0 = np.zeros(ball.nx)
    x0[2] = 0.5
    res = ball.simulate(x0, (0, 3), raise_on_failure=False)
    assert res.status == 6 and res.stats["steps"] == 60, res.message
    assert "raise max_steps (60 now: the default for a run with ground contacts, 20 per simulated second)" \
        in res.message, res.message
    res = ball.simulate(x0, (0, 3), max_steps=30, raise_on_failure=False)
    assert res.status == 6 and "raise max_steps (30 now);" in res.message + ";", res.message
