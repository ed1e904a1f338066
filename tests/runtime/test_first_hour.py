"""What a new user met in the first hour (session 23), in the runtime: `eomc check` on a model
that starts with contacts at depth 0, the check's cond(M) line, the report's failure notes and
the progress of an "auto" run after it switched to Radau."""
import io
import re
from types import SimpleNamespace

import numpy as np

from helpers import model_files
from helpers.stand_in import get_model

from eomc.runtime import progress, stability
from eomc.runtime.report_output import _run_notes
from eomc.runtime.simulate import simulate

# Two contacts whose force grows like depth**1.5 from depth 0, pressed by x in opposite
# directions: at x = 0 both are at their onset (dm_control's walker.xml at qpos0, four capsule ends
# at depth 0).  jac_x there is 0 (the slope of depth**1.5 at 0), but the differences at step h
# are ~k sqrt(h) on one side or the other: 1e3 at h = 1e-8 for k = 1e7.
_ONSET = '''
import sympy as sm
from eomc.mechanics import *

x, y, u, v = dynamicsymbols("x y u v")
m, k = sm.symbols("m k")
N = ReferenceFrame("N")
O = Point("O"); O.set_vel(N, 0)
P = O.locatenew("P", x * N.x + y * N.y); P.set_vel(N, u * N.x + v * N.y)
kane = KanesMethod(N, q_ind=[x, y], u_ind=[u, v], kd_eqs=[x.diff() - u, y.diff() - v])
def push(d):
    return sm.Piecewise((k * d**sm.Rational(3, 2), d > 0), (0, True))
kane.kanes_equations([Particle("ball", P, m)], [(P, -push(x) * N.x - push(-x) * N.y)])
system = kane
name = "onset"
parameters = {m: 1.0, k: 1e7}
'''


def test_the_jacobian_check_at_a_contacts_onset(tmp_path):
    """`eomc check` on dm_control's walker.xml (no flags) failed 'jacobian: rel. difference
    1.48e+01' with a right jac_x: its feet start at depth 0, where the contact force's slope is 0
    but finite differences approach it only like sqrt(h).  The check extrapolates them to h -> 0
    and passes, naming the column; a jac_x off by 5 % of its scale still fails."""
    import eomc
    onset = eomc.compile(model_files.write(tmp_path, _ONSET, "onset"), cache_dir=tmp_path / "cache",
                         progress=False)
    x0 = np.zeros(4)
    J = np.array(onset.jacobian(0.0, x0, onset.param_defaults))
    assert np.all(J[2:, 0] == 0.0)                                # the slope at the onset: 0
    f0 = np.array(onset.rhs(0.0, x0, onset.param_defaults))
    ahead = (np.array(onset.rhs(0.0, x0 + [1e-8, 0, 0, 0], onset.param_defaults)) - f0) / 1e-8
    assert abs(ahead[2]) > 500                                    # ... that the differences miss
    jac = stability._jacobian_vs_fd(onset, x0, onset.param_defaults)
    assert jac.passed, jac.measured
    assert "1 column (x) at a law's onset" in jac.measured, jac.measured
    wrong = onset.jacobian

    class Off:      # d u'/d x off by 0.05 (scale 1): a wrong jac_x at the onset
        def __getattr__(self, name):
            return getattr(onset, name)

        def jacobian(self, t, x, p):
            J = np.array(wrong(t, x, p))
            J[2, 0] -= 0.05
            return J
    bad = stability._jacobian_vs_fd(Off(), x0, onset.param_defaults)
    assert not bad.passed and bad.measured.startswith("rel. difference 5.00e-02"), bad.measured


def test_the_conditioning_line_names_the_coordinates_not_the_speeds():
    """cond(M) depends on the coordinates only: the line names them (theta, phi), not the speeds
    (the humanoid's check printed 70 values, half of them speeds)."""
    sp = get_model("sphere")
    checks = {c.name: c for c in stability.check_model(sp, [0.5, 0.0, 0.0, 1e-3], 1.0, methods=("dop853",))}
    cond = checks["mass matrix conditioning"].measured
    assert "theta=" in cond and "phi=" in cond, cond
    assert "theta_dot" not in cond and "phi_dot" not in cond, cond


def test_the_reports_failures_are_one_line_per_method_and_reason():
    """gymnasium's hopper report listed 'rk4 at 1e-04 failed: not run: DOPRI5 failed ...' once
    per tolerance (seven lines); now one line names the tolerances, and the notes after it
    (the count of stopped runs) are kept."""
    why = "not run: DOPRI5 failed at this tolerance, so there is no step count to match"
    rows = [dict(method="rk4", status=1, message=why, tolerance=tol, dt=None) for tol in (1e-4, 1e-5, 1e-6)]
    rows.append(dict(method="radau", status=2, message="m: radau stopped at t=1: too many steps",
                     tolerance=1e-4, dt=None))
    report = SimpleNamespace(skipped={}, rows=rows, model_name="m", ok_rows=lambda: [])
    notes = _run_notes(report)
    assert notes[0] == f"rk4 at 1e-04, 1e-05, 1e-06 failed: {why}", notes
    assert notes[1] == "radau at 1e-04 failed: radau stopped at t=1: too many steps", notes
    assert notes[2].startswith("FAILED, stopped: 4 of 4 runs (radau, rk4)"), notes
    assert len(notes) == 3


LINE = re.compile(r"^run: t = (\S+) of \[(\S+), (\S+)\] \((\d+) %\), (\d+) steps, \d+ s$")


def test_progress_after_auto_switches_to_radau_shows_the_whole_span(monkeypatch):
    """method="auto" runs DOP853, then Radau from where DOP853 found the problem stiff: the
    progress lines of the Radau part read 't = ... of [t_switch, 10]' with the step count from 0
    (first hour s22, centauro: 'of [0.00122364, 10]'); now every line is over the whole span
    [0, T] and the steps go on from DOP853's."""
    monkeypatch.setattr(progress, "LINE_SECONDS", 0.0)
    monkeypatch.setattr(progress, "POLL_S", 0.0005)
    stream = io.StringIO()
    t_final = 2000.0
    with progress.integration("run", stream, enabled=True):
        res = simulate(get_model("chain"), [1, 1, 0, 0], (0, t_final), p=[1.0, 1e8, 0.1, 2e4],
                       method="auto", rtol=1e-10, atol=1e-12, n_points=3, max_steps=10**8)
    switched = res.stats["switched_at"]
    assert res.status == 0 and 0 < switched < 0.1 * t_final, res.stats     # auto switched early
    lines = [LINE.match(line) for line in stream.getvalue().splitlines()]
    assert lines and all(lines), stream.getvalue()
    assert {(m.group(2), m.group(3)) for m in lines} == {("0", f"{t_final:g}")}, stream.getvalue()
    steps = [int(m.group(5)) for m in lines]
    assert steps == sorted(steps) and steps[-1] == res.stats["steps"], (steps, res.stats)
    assert float(lines[-1].group(1)) == t_final and int(lines[-1].group(4)) == 100
    assert any(switched < float(m.group(1)) < t_final for m in lines), stream.getvalue()   # Radau's


def test_the_report_says_which_reference_it_ran(capsys):
    """`eomc report` printed the reference it was asked for (auto at rtol 1e-13) while report.md
    recorded the one it ran (radau at rtol 1e-12 on a contact model): stderr now says both, the
    second line as report.md does.  Asked for Radau at 1e-13, it runs at 1e-12 (its finest)."""
    from eomc.runtime.report import work_precision

    osc = get_model("oscillator")
    rep = work_precision(osc, [1.0, 0.0], (0.0, 1.0), methods=("dop853",), tolerances=(1e-5,),
                         repeats=1, n_points=11, reference_tol=1e-13, reference_method="radau",
                         reference_check="none")
    err = capsys.readouterr().err
    assert "computing the reference (radau at rtol=1e-12, atol=1e-13 (its finest rtol; 1e-13 asked)" in err, err
    assert rep.reference.tol == 1e-12
    assert f"eomc report: {rep.reference.describe()}\n" in err, err
    assert "eomc report: reference: radau at rtol=1e-12, atol=1e-13" in err, err


def test_the_reports_announcement_says_what_auto_will_run():
    """`eomc report` announced "auto at rtol 1e-13" and then ran Radau at 1e-12 (first hour
    s26): the announcement now names DOP853 at the asked tolerance and Radau at its finest."""
    from eomc.runtime.reference import plan

    assert plan("auto", 1e-13, 1e-14) == ("dop853 at rtol=1e-13, atol=1e-14, or radau at "
                                         "rtol=1e-12, atol=1e-14 if DOP853 finds the motion stiff")
    assert plan("dop853", 1e-10) == "dop853 at rtol=atol=1e-10"
    assert plan("radau", 1e-9, 1e-10) == "radau at rtol=1e-09, atol=1e-10"


def test_simulate_takes_rollouts_split_and_refuses_it_elsewhere(tmp_path):
    """rollout(split=0) (implicitfast unchecked, one model call per step as MuJoCo's) had no
    simulate to be checked against: simulate takes split= now, its row equal to rollout's bit
    for bit; with a method other than implicitfast, or a negative split, it is refused."""
    import warnings

    import pytest

    import eomc
    from .test_rollout import thrown_ball

    m, x0 = thrown_ball(tmp_path, "fh5_split")
    kw = dict(method="implicitfast", dt=0.005)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ro = eomc.rollout(m, x0[:3], t_final=0.3, split=0.0, raise_on_failure=False, threads=1, **kw)
        for i in range(3):
            off = m.simulate(x0[i], (0.0, 0.3), split=0, raise_on_failure=False, **kw)
            assert np.array_equal(off.x[-1], ro.x[i]), i
            assert off.stats["nfev"] == round(0.3 / 0.005) + 1         # one call per step, and one at t = 0
        on = [m.simulate(x0[i], (0.0, 0.3), raise_on_failure=False, **kw) for i in range(3)]
    assert sum(r.stats["nfev"] for r in on) > 3 * (round(0.3 / 0.005) + 1)   # the default test splits landings
    with pytest.raises(ValueError, match="split= is implicitfast's residual test"):
        m.simulate(x0[0], (0.0, 0.1), method="radau", split=0)
    with pytest.raises(ValueError, match="split must be a number >= 0"):
        m.simulate(x0[0], (0.0, 0.1), split=-1, **kw)


def test_an_mjcf_limits_overshoot_is_not_blamed_on_a_too_soft_stiffness():
    """gymnasium's walker2d and inverted_pendulum (no flags) warned that their limits' default
    stiffness was "too soft for the loads they met"; it is the file's solref, and MuJoCo's mj_step
    takes the same limits as far or further (walker2d's knees 0.085-0.091 rad against eomc's
    0.041): the note says so.  A URDF joint's default (eomc's own rule) is still called too soft."""
    from eomc.runtime.switching import Limit, _overshoot_notes

    names = ["lo_a", "limit_k_a", "hi_b", "limit_k_b"]
    defaults = np.array([-1.0, 100.0, 2.0, 50.0])
    sw = SimpleNamespace(limits=[Limit("a", 0, 0, -1.0, -1, "lower"), Limit("b", 1, 2, 1.0, -1, "upper")])
    over, e = np.array([0.05, 0.06]), np.full(2, 3e-4)
    for laws, past in (({"a": {}, "b": {}}, [0, 1]), ({"a": {}}, [0])):
        mjcf = SimpleNamespace(param_names=names, param_defaults=defaults, metadata={"limit_laws": laws})
        text = " ".join(_overshoot_notes(mjcf, defaults, sw, past, over, e))
        assert "too soft" not in text, text
        assert "the default: from the joint's MuJoCo solref" in text or "the default (from the joint's MuJoCo solref" in text
        assert "as soft as MuJoCo's own under the file's solref" in text and "--param limit_k_" in text, text
    urdf = SimpleNamespace(param_names=names, param_defaults=defaults, metadata={})
    for past in ([0, 1], [0]):
        text = " ".join(_overshoot_notes(urdf, defaults, sw, past, over, e))
        assert "too soft for the load" in text and "MuJoCo" not in text, text


def test_a_contact_that_starts_deep_is_put_down_to_the_start(tmp_path):
    """gymnasium's humanoidstandup.xml starts its arms 0.035 m into the floor (MuJoCo's mj_forward
    at qpos0 says so too) and the run only lifts them out; the warning read "penetrated 0.037 m
    ... the contact is too soft for the load (raise k_...)".  A contact the run presses no
    deeper than it started is put down to the start; one pressed deeper is still blamed on its
    stiffness."""
    import sys
    import warnings
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parents[1] / "compiler" / "contact"))
    import bounce_grid as bg

    ball = bg.build(tmp_path)
    x0 = np.zeros(12)
    x0[2] = 0.03                    # radius 0.1: 0.07 m deep, more than half the radius
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        ball.simulate(x0, (0, 0.5), raise_on_failure=False)
    text = " ".join(str(w.message) for w in seen)
    assert "contact ball (0.07 m, more than 0.5 of its radius 0.1 m) started that deep" in text, text
    assert "penetrated" not in text and "raise k_ball" not in text, text
    p = np.array(ball.param_defaults)
    p[ball.param_names.index("k_ball")] = 1e3
    x0[2] = 0.5
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        ball.simulate(x0, (0, 3), p=p, method="dop853", raise_on_failure=False)
    text = " ".join(str(w.message) for w in seen)
    assert "contact ball penetrated 0.1" in text and "raise k_ball" in text and "started that deep" not in text, text


def test_a_report_from_an_equilibrium_recommends_nothing():
    """`eomc report swimmer.xml` (gymnasium, no flags: from rest at x = 0, an equilibrium) measured
    every error as 0 and recommended `method="rk4", dt=1.25`: it is inconclusive now, saying why;
    a start that moves still gets its recommendation."""
    from eomc.runtime.report import work_precision

    osc = get_model("oscillator")
    kw = dict(methods=("rk4", "dop853"), tolerances=(1e-4, 1e-6), repeats=1, n_points=11, progress=False)
    rep = work_precision(osc, [0.0, 0.0], (0.0, 1.0), **kw)
    assert rep.inconclusive and rep.inconclusive.startswith("nothing moved: the start is an equilibrium")
    assert rep.recommendation_text(1e-6).startswith("**Inconclusive:** nothing moved")
    moving = work_precision(osc, [1.0, 0.0], (0.0, 1.0), **kw)
    assert moving.inconclusive is None and "**Recommendation**" in moving.recommendation_text(1e-4)


def test_a_rollout_without_dt_runs_simulates_default_method():
    """`eomc.rollout(model, X0, t_final=1)` refused (rollout's default method was rk4, which needs
    dt; session 24 made it say so) where `simulate(model, x0, (0, 1))` runs "auto": without dt= or
    steps= the default is now simulate's, row for row bit for bit; with dt= it is still rk4, and
    steps= without dt= names both ways out."""
    import pytest

    import eomc

    osc = get_model("oscillator")
    X0 = np.array([[1.0, 0.0], [0.5, -0.2]])
    res = eomc.rollout(osc, X0, t_final=1.0)
    for row, x0 in zip(res.x, X0):
        assert np.array_equal(row, simulate(osc, x0, (0.0, 1.0)).x[-1])
    stepped = eomc.rollout(osc, X0, t_final=1.0, dt=0.01)
    assert np.array_equal(stepped.x, eomc.rollout(osc, X0, t_final=1.0, dt=0.01, method="rk4").x)
    with pytest.raises(ValueError, match=r"method 'rk4' is fixed-step: give dt= .* or an "
                                         r"adaptive method with t_final= \(method='auto', the default without dt="):
        eomc.rollout(osc, X0, steps=10)
    with pytest.raises(ValueError, match="dt must be a finite step > 0; got 0.0"):
        eomc.rollout(osc, X0, t_final=1.0, dt=0.0)


def test_the_hint_after_nothing_moved_names_a_state_that_starts_a_motion(tmp_path, capsys):
    """SymPy's n_link_pendulum_on_cart starts at an equilibrium whose first coordinate is the
    cart's position: "give --x0 ... e.g. --x0 q0=0.1" led to the same still run.  The hint names
    the first coordinate whose change starts a motion (q1, a link), else a speed (gymnasium's
    swimmer, which no force pulls anywhere)."""
    import eomc
    from eomc.cli import main
    from eomc.runtime.diagnose import leaving_state

    path = tmp_path / "cart3.py"
    path.write_text("from sympy.physics.mechanics.models import n_link_pendulum_on_cart\n"
                    "system = n_link_pendulum_on_cart(2, cart_force=False)\n")
    model = eomc.compile(str(path), cache_dir=tmp_path / "cache", progress=False)
    assert model.state_names[0] == "q0"
    assert leaving_state(model, np.zeros(model.nx)) == "q1"
    assert leaving_state(model, np.zeros(model.nx), p={"g": 0.0}) == model.state_names[model.nq]  # nothing pulls
    assert main(["simulate", str(path), "--t-final", "0.5", "-q"]) == 0
    assert "e.g. --x0 q1=0.1" in capsys.readouterr().out
