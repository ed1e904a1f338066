"""method="auto", the default (runtime/simulate.py; issue 29): DOP853 while the problem is not
stiff, BDF (Radau at rtol < 1e-7) from the start on a model with ground contacts, Radau from
where DOP853 finds the problem stiff -- the run goes on and agrees with Radau throughout."""
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from helpers.stand_in import get_model

from eomc.runtime.simulate import DEFAULT_METHOD, simulate
from eomc.runtime.switching import PhysicsWarning

sys.path.insert(0, str(Path(__file__).parents[1] / "compiler" / "contact"))
import bounce_grid as bg  # noqa: E402

CHAIN = dict(x0=[1, 1, 0, 0], p=[1.0, 1e8, 0.1, 2e4])    # stiffness ratio 1e8 (test_stability)


def test_auto_is_the_default():
    assert DEFAULT_METHOD == "auto"
    res = simulate(get_model("pendulum"), [0.5, 0.0], (0, 2), rtol=1e-9, atol=1e-12)
    assert res.status == 0 and res.method == "dop853"         # not stiff: the explicit method


def test_auto_switches_to_radau_where_dop853_finds_the_problem_stiff():
    chain = get_model("chain")
    t = np.linspace(0, 10, 201)
    explicit = simulate(chain, CHAIN["x0"], (0, 10), p=CHAIN["p"], method="dop853", rtol=1e-6, atol=1e-8,
                        t_eval=t, raise_on_failure=False)
    assert explicit.status == 7                                # looks stiff: stops
    auto = simulate(chain, CHAIN["x0"], (0, 10), p=CHAIN["p"], rtol=1e-6, atol=1e-8, t_eval=t)
    radau = simulate(chain, CHAIN["x0"], (0, 10), p=CHAIN["p"], method="radau", rtol=1e-10, atol=1e-12,
                     t_eval=t)
    assert auto.status == 0 and auto.t.shape == (201,) and np.all(np.isfinite(auto.x))
    assert auto.method.startswith("dop853, then radau from t=")
    assert auto.stats["switched_at"] == pytest.approx(explicit.stats["t"])
    assert auto.stats["steps"] < explicit.stats["steps"] + 2000
    assert np.max(np.abs(auto.x - radau.x)) < 1e-4


@pytest.fixture(scope="module")
def ball(tmp_path_factory):
    return bg.build(tmp_path_factory.mktemp("cache"))


@pytest.mark.parametrize("rtol,method", [(1e-6, "bdf"), (1e-3, "bdf"), (1e-8, "radau")])
def test_auto_takes_an_implicit_method_from_the_start_with_contacts(ball, rtol, method):
    """BDF at rtol >= 1e-7, Radau tighter (runtime/simulate.BDF_FINEST; how they compare per
    tolerance: benchmarks/results/contact_wp.md)."""
    p = np.array(ball.param_defaults)
    p[ball.param_names.index("k_ball")] = 1e9
    with warnings.catch_warnings():
        warnings.simplefilter("error", PhysicsWarning)
        res = ball.simulate(np.r_[0, 0, 0.5, np.zeros(9)], (0, 3), p=p, rtol=rtol, atol=rtol * 1e-3)
    assert res.status == 0 and res.method == method
    # the bounce height to the tolerance (BDF at rtol 1e-3: 0.5053, energy +1 %; the verdict's
    # limit is 100 rtol)
    assert res["z"].max() == pytest.approx(0.5, rel=max(2e-3, 20 * rtol))


def test_check_and_report_list_what_auto_picks_on_contacts(ball):
    """`eomc check` on a contact model runs auto and what auto takes at the tolerance (bdf and
    radau at rtol >= 1e-7, radau below), and `eomc report` lists bdf and radau by default; on
    the ball all meet the tolerance."""
    from eomc.runtime.report import DEFAULT_METHODS
    from eomc.runtime.stability import check_model, default_methods
    assert default_methods(ball) == default_methods(ball, 1e-6) == ("auto", "bdf", "radau")
    assert default_methods(ball, 1e-8) == ("auto", "radau")      # auto is radau there
    assert {"bdf", "radau"} <= set(DEFAULT_METHODS)
    checks = {c.name: c for c in check_model(ball, np.r_[0, 0, 0.5, np.zeros(9)], 1.0, rtol=1e-6,
                                             atol=1e-9)}
    for method in ("auto", "bdf", "radau"):
        assert checks[f"{method} accuracy"].passed, checks[f"{method} accuracy"].measured



def test_check_runs_auto_once_where_it_is_one_listed_method(ball, monkeypatch):
    """On a contact model below rtol 1e-7 auto is radau with radau's settings: the two runs are
    equal bit for bit, so `eomc check` runs it once and reports it under both names (G1's
    no-flag check ran Radau twice over 10 s of 232 contact points)."""
    from eomc.runtime import stability
    x0, kw = np.r_[0, 0, 0.5, np.zeros(9)], dict(rtol=1e-8, atol=1e-10, t_eval=np.linspace(0, 0.5, 11))
    auto, radau = ball.simulate(x0, (0, 0.5), **kw), ball.simulate(x0, (0, 0.5), method="radau", **kw)
    assert auto.method == "radau"
    np.testing.assert_array_equal(auto.x, radau.x)
    ran = []
    real, real_refs = stability._run, stability.run_references
    monkeypatch.setattr(stability, "_run", lambda *a: ran.append(a[5]) or real(*a))
    # the two references run at once (runtime/check_references.py, s31), not through _run
    monkeypatch.setattr(stability, "run_references", lambda *a, **k: ran.extend([a[5]] * 2) or real_refs(*a, **k))
    checks = {c.name: c for c in stability.check_model(ball, x0, 0.5, rtol=1e-8, atol=1e-10)}
    # the same run's numbers under both names, auto's saying whose they are (first hour s27: two
    # equal lines and nothing saying why)
    assert checks["auto accuracy"].passed and checks["auto accuracy"].measured == (
        checks["radau accuracy"].measured + " (auto runs radau here: the radau run, judged once)")
    assert ran == ["radau", "radau", "auto"]       # the two references, then one run for both names


def test_check_takes_the_looser_reference_as_the_reference_methods_convergence_run(ball, monkeypatch):
    """A run 1000-1e5 x its tolerance off is judged by convergence: the same method at 100x
    tighter tolerances must be 10x closer.  For the reference's own method (radau on contacts)
    the looser reference is that run (100x tighter rtol), so check integrates nothing more --
    G1's no-flag check ran Radau at rtol 1e-10 twice more (23 s CPU each) for it."""
    from eomc.runtime import stability
    x0 = np.r_[0, 0, 0.5, np.zeros(9)]
    ran, real, real_refs = [], stability._run, stability.run_references

    def refs(model, x0, p, t_final, t_eval, method, tols, *rest):
        ran.extend((method, *tol) for tol in tols)      # at once, not through _run (s31)
        return real_refs(model, x0, p, t_final, t_eval, method, tols, *rest)
    monkeypatch.setattr(stability, "run_references", refs)

    def off(*a):                 # the checked runs (rtol 1e-8) ~2000 x their tolerance off at the end
        ran.append((a[5], a[6], a[7]))
        res = real(*a)
        if a[6] == 1e-8:
            res.x[-1, 2] += 2000 * (1e-10 + 1e-8 * abs(res.x[-1, 2]))
        return res
    monkeypatch.setattr(stability, "_run", off)
    checks = {c.name: c for c in stability.check_model(ball, x0, 0.5, rtol=1e-8, atol=1e-10)}
    for name in ("auto accuracy", "radau accuracy"):
        assert checks[name].passed and "converging" in checks[name].measured, checks[name].measured
        assert "100x tighter rtol (the looser reference, atol=1e-10)" in checks[name].measured
        assert float(checks[name].measured.split(" x tolerance")[0]) > stability.GLOBAL_FACTOR
    assert [m for m, *_ in ran] == ["radau", "radau", "auto"]       # the references, one checked run
    assert np.array([t for _, *t in ran]) == pytest.approx(np.array([[1e-10, 1e-10], [1e-11, 1e-11],
                                                                      [1e-8, 1e-10]]), rel=1e-12)
    # a method that is not the reference's still gets its own run at 100x tighter tolerances
    ran.clear()
    bdf = {c.name: c for c in stability.check_model(ball, x0, 0.5, rtol=1e-8, atol=1e-10, methods=("bdf",))}
    assert ran[-1][0] == "bdf" and ran[-1][1:] == pytest.approx((1e-10, 1e-12), rel=1e-12)
    assert "100x tighter tolerances" in bdf["bdf accuracy"].measured


def test_bdf_cut_at_predicted_touch_down_is_bit_stable_and_agrees_with_tight_radau(ball):
    """BDF shortens a step whose predicted end lies past touch-down (eomc_bdf.c PRED_OVER) so
    that it ends just past it: the ball at k = 1e9, c = 0 (three bounces in 1.5 s) at rtol 1e-4
    touches down when Radau at 1e-10 says (to 5 rtol of the elapsed time), keeps its bounce height, and two runs
    (and the model's own events against the same events named) give the same bits."""
    p = np.array(ball.param_defaults)
    p[ball.param_names.index("k_ball")] = 1e9
    x0 = np.r_[0, 0, 0.5, np.zeros(9)]
    t = np.linspace(0, 1.5, 301)
    run = lambda **kw: ball.simulate(x0, (0, 1.5), p=p, t_eval=t, **kw)  # noqa: E731
    a, b = run(method="bdf", rtol=1e-4, atol=1e-7), run(method="bdf", rtol=1e-4, atol=1e-7)
    named = run(method="bdf", rtol=1e-4, atol=1e-7, events=["contact_ball"])
    ref = run(method="radau", rtol=1e-10, atol=1e-13)
    assert a.status == 0 and np.array_equal(a.x, b.x) and np.array_equal(a.x, named.x)
    assert np.array_equal(a.t_events["contact_ball"], named.t_events["contact_ball"])
    assert np.array_equal(a.t_events["contact_ball"], b.t_events["contact_ball"])
    ta, tr = a.t_events["contact_ball"], ref.t_events["contact_ball"]
    assert ta.size == tr.size >= 5           # touch-down and lift-off, at least three bounces
    # a global error of a few rtol per unit time: measured 1.9e-6, 6.8e-5, 2.1e-4 s at the
    # touch-downs at 0.29, 0.86, 1.43 s (the restitution's small error shifts later bounces)
    assert np.all(np.abs(ta - tr) <= 5 * 1e-4 * tr)
    after = t > tr[1]                       # the first rebound's apex (c = 0: back to 0.5 m)
    assert ref["z"][after].max() == pytest.approx(0.5, abs=1e-3)
    assert a["z"][after].max() == pytest.approx(ref["z"][after].max(), rel=20 * 1e-4)
