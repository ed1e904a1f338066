"""Issue 4 §6: stiff, near-singular, extreme-scale, long-horizon and fast-spin cases.

Each test states its expectation in its docstring.  (a), the stiff chain over
stiffness ratios 1e3..1e8, lives in test_integrators.py; here it runs through
check_model, the function behind ``eomc check``.
"""
from pathlib import Path

import numpy as np
import pytest

from helpers.spoiled_method import spoil_dop853
from helpers.stand_in import get_model

import eomc.cli.common as cli_common
from eomc.cli import main
from eomc.errors import SimulationError
from eomc.runtime.simulate import simulate
from eomc.runtime import stability
from eomc.runtime.stability import EXIT_INCONCLUSIVE, check_model, format_checks, outcome


def by_name(checks):
    return {c.name: c for c in checks}


def test_a_check_model_on_stiff_chain_recommends_radau():
    """Explicit methods stop with 'stiff ... use method=radau' -- not "ok" (issue 29: a method
    that stopped did not do the job), but on a model the stiffness check calls stiff that is
    expected: "[stiff]", not a failure (first hour s21: talos_reduced's check exited 1 on it);
    radau and the default auto (which switches to radau where DOP853 finds the problem stiff)
    meet the tolerance."""
    listed = check_model(get_model("chain"), [1, 1, 0, 0], 10.0, p=[1.0, 1e8, 0.1, 2e4], rtol=1e-6,
                         atol=1e-8)
    checks = by_name(listed)
    assert checks["stiffness at x0"].measured.endswith(": stiff")
    for method in ("dopri5", "dop853"):
        assert not checks[f"{method} accuracy"].passed and checks[f"{method} accuracy"].stiff
        assert "stiff" in checks[f"{method} accuracy"].measured
        assert "method='radau'" in checks[f"{method} accuracy"].measured
        assert "state " not in checks[f"{method} accuracy"].measured     # no state dump for the expected
    assert outcome(listed) == "passed"
    text = format_checks(listed)
    assert "[stiff] dopri5 accuracy: dopri5 stopped at t=" in text and "FAIL" not in text
    assert "2 stiff (dopri5 and dop853 stopped as explicit methods do on a stiff model: expected, not " \
           "failures)" in text
    for method in ("auto", "radau"):
        assert checks[f"{method} accuracy"].passed, checks[f"{method} accuracy"].measured
        assert "x tolerance" in checks[f"{method} accuracy"].measured
    assert all(c.passed for name, c in checks.items() if name not in ("dopri5 accuracy", "dop853 accuracy"))
    assert float(checks["stiffness at x0"].measured.split("= ")[1].split(",")[0]) > 1e4


def test_a_stopped_method_still_fails_unless_explicit_on_a_stiff_model(monkeypatch):
    """The other side of "[stiff]": an implicit or default method that stops fails its check
    on a stiff model; an explicit method that runs out of steps fails even there (only its
    stiffness detector's stop is expected); and an explicit method that stops on a model the
    stiffness check does not call stiff fails."""
    run = stability._run
    steps = {"dopri5": 20, "radau": 20, "auto": 20}

    def few_steps(model, x0, p, t_final, t_eval, method, rtol, atol, max_steps):    # the checked runs only
        return run(model, x0, p, t_final, t_eval, method, rtol, atol,
                   steps.get(method, max_steps) if rtol == checked else max_steps)
    monkeypatch.setattr(stability, "_run", few_steps)
    checked = 1e-6
    stiff = check_model(get_model("chain"), [1, 1, 0, 0], 10.0, p=[1.0, 1e8, 0.1, 2e4], rtol=checked,
                        atol=1e-8, methods=("auto", "radau", "dopri5", "dop853"))
    stopped = by_name(stiff)
    for method in ("auto", "radau", "dopri5"):
        assert not stopped[f"{method} accuracy"].passed and not stopped[f"{method} accuracy"].stiff
        assert f"[FAIL] {method} accuracy" in format_checks(stiff)
    assert "maximum number of steps" in stopped["dopri5 accuracy"].measured
    assert stopped["dop853 accuracy"].stiff and "looks stiff" in stopped["dop853 accuracy"].measured
    assert outcome(stiff) == "failed"
    monkeypatch.undo()
    # the same stop as stiff, from an explicit method on a model the stiffness check at x0 does
    # not call stiff (it became stiff later, e.g. at a limit): not foreseen, so a failure
    looks_stiff = simulate(get_model("chain"), [1, 1, 0, 0], (0, 1.0), p=[1.0, 1e8, 0.1, 2e4],
                           method="dopri5", raise_on_failure=False)
    assert looks_stiff.status == stability.STIFF_STOP
    unforeseen = stability._stopped("dopri5", looks_stiff, stiff=False)
    assert not unforeseen.passed and not unforeseen.stiff and outcome([unforeseen]) == "failed"
    assert stability._stopped("dopri5", looks_stiff, stiff=True).stiff


def test_b_near_singular_mass_matrix_is_reported_with_time_and_state():
    """Spherical pendulum swinging (almost) through the pole: cond(M) ~ 1/sin^2(theta) rises;
    the check names the time and state; passing exactly through it is a SimulationError."""
    sp = get_model("sphere")
    checks = by_name(check_model(sp, [0.5, 0.0, 0.0, 1e-3], 1.0, methods=("dop853",)))
    cond = checks["mass matrix conditioning"]
    assert "max cond(M) = " in cond.measured and "theta=" in cond.measured
    t_worst = float(cond.measured.split("at t=")[1].split()[0])
    res = simulate(sp, [0.5, 0.0, 0.0, 1e-3], (0, 1.0), rtol=1e-10, atol=1e-12, n_points=2001)
    assert abs(t_worst - res.t[np.argmin(np.abs(res["theta"]))]) < 0.01
    assert float(cond.measured.split("= ")[1].split()[0]) > 1e5
    assert np.all(np.isfinite(res.x))                                    # no silent NaN
    with pytest.raises(SimulationError, match=r"stopped at t=0: the mass matrix is singular; state theta=0"):
        simulate(sp, [0.0, 0.0, 1.0, 0.0], (0, 1.0))


@pytest.mark.parametrize("scale", [1e-6, 1.0, 1e6])
@pytest.mark.parametrize("amp", [1e-6, 1e6])
def test_c_extreme_scales_keep_relative_error_within_tolerance(scale, amp):
    """Oscillator with m and k from 1e-6 to 1e6 (omega = sqrt(k/m) from 1e-6..1e6 too) and
    amplitudes 1e-6..1e6: over 5 periods the relative error stays ~ rtol."""
    m = get_model("oscillator")
    mass, k = scale, scale * scale            # omega = sqrt(scale)
    omega = np.sqrt(k / mass)
    t1 = 5 * 2 * np.pi / omega
    t = np.linspace(0, t1, 101)
    for method in ("dop853", "radau"):
        res = simulate(m, [amp, 0.0], (0, t1), p=[k, mass, 0.0], method=method, rtol=1e-9,
                       atol=1e-12 * amp * max(1.0, omega), t_eval=t)
        rel = np.max(np.abs(res["q"] - amp * np.cos(omega * t))) / amp
        assert rel < 1e-7, (method, rel)


@pytest.mark.parametrize("method,periods", [("dop853", 10000), ("dopri5", 10000), ("radau", 300)])
def test_d_long_horizon_energy_drift_grows_linearly(method, periods):
    """Non-symplectic RK methods drift in energy ~ linearly in time: 10x the horizon gives
    ~10x the drift, and the drift stays small (< 1e-5 relative) at rtol = 1e-10."""
    pen = get_model("pendulum")
    period = 2 * np.pi / np.sqrt(9.81)          # small-amplitude period; a scale only
    drifts = []
    for n in (periods // 10, periods):
        res = simulate(pen, [1.0, 0.0], (0, n * period), method=method, rtol=1e-10, atol=1e-10,
                       max_steps=10**7, n_points=11)
        e = res["energy"]
        drifts.append(abs(e[-1] - e[0]) / abs(e[0]))
    assert drifts[1] < 1e-5
    assert 4 < drifts[1] / drifts[0] < 25, drifts


def test_d_kepler_orbit_long_horizon():
    """100 eccentric orbits (e = 0.6): energy and angular momentum drift stay < 1e-7 with
    DOP853 at rtol=1e-11, and the orbit closes (the position error grows with the phase)."""
    kp = get_model("kepler")
    e = 0.6
    x0 = np.array([1 - e, 0.0, 0.0, np.sqrt((1 + e) / (1 - e))])
    res = simulate(kp, x0, (0, 100 * 2 * np.pi), method="dop853", rtol=1e-11, atol=1e-13,
                   t_eval=2 * np.pi * np.arange(0, 101), max_steps=10**6)
    energy, ang = res["energy"], res["angular_momentum"]
    assert np.max(np.abs(energy - energy[0])) / abs(energy[0]) < 1e-7
    assert np.max(np.abs(ang - ang[0])) / abs(ang[0]) < 1e-7
    err = np.linalg.norm(res.x[:, :2] - x0[:2], axis=1)
    assert err[-1] < 1e-4 and err[-1] > err[1]


@pytest.mark.parametrize("spin", [10.0, 1e3, 1e5])
def test_e_fast_spin_conserves_energy_and_momentum(spin):
    """Torque-free body spinning about its major axis with a small wobble, at 10..1e5 rad/s
    over 200 revolutions: energy and |L|^2 conserved to ~1e-12 relative by DOP853."""
    top = get_model("top")
    x0 = [1e-3 * spin, 1e-3 * spin, spin]
    res = simulate(top, x0, (0, 200 * 2 * np.pi / spin), method="dop853", rtol=1e-10,
                   atol=1e-12 * spin, max_steps=10**6)
    for name in ("energy", "L2"):
        v = res[name]
        assert np.ptp(v) / v[0] < 1e-12, name
    assert abs(res["w3"][-1] / spin - 1) < 1e-5     # the spin axis is stable (major axis)


def test_eomc_check_cli(monkeypatch, capsys):
    monkeypatch.setattr(cli_common, "load_model", lambda spec, quiet=True, **_: get_model("pendulum"))
    assert main(["check", "pend", "--x0", "q1=1.0", "--t-final", "5"]) == 0
    out = capsys.readouterr().out
    assert "dop853 accuracy" in out and "checks passed" in out and "FAIL" not in out
    monkeypatch.setattr(cli_common, "load_model", lambda spec, quiet=True, **_: get_model("sphere"))
    assert main(["check", "s", "--x0", "theta=0.0,theta_dot=1.0"]) == 1   # singular at x0
    assert "FAIL" in capsys.readouterr().out
    # explicit methods stopping on a model the stiffness check calls stiff: "[stiff]", exit 0
    # (first hour s21: `eomc check talos_reduced.urdf` exited 1, "11 of 13 checks passed")
    monkeypatch.setattr(cli_common, "load_model", lambda spec, quiet=True, **_: get_model("chain"))
    assert main(["check", "c", "--x0", "q1=1,q2=1", "--param", "k2=1e8,c2=2e4", "--rtol", "1e-6",
                 "--atol", "1e-8"]) == 0
    out = capsys.readouterr().out
    assert "[stiff] dop853 accuracy" in out and "FAIL" not in out and ": stiff\n" in out


@pytest.fixture(scope="module")
def double_pendulum(tmp_path_factory):
    import eomc
    example = Path(__file__).resolve().parents[2] / "examples" / "double_pendulum.py"
    return eomc.compile(str(example), cache_dir=tmp_path_factory.mktemp("dp"), progress=False)


def test_chaotic_motion_is_judged_by_convergence(double_pendulum):
    """The double pendulum amplifies local errors past 1000x the tolerance within 5 s; the
    accuracy check then asks for convergence instead, and says so."""
    model = double_pendulum
    checks = {c.name: c for c in check_model(model, t_final=5.0, methods=("dopri5",))}
    acc = checks["dopri5 accuracy"]
    amplified = float(acc.measured.split(" x tolerance")[0])
    assert amplified > 1000                      # the plain criterion alone would fail
    assert acc.passed and "converging" in acc.measured and "NOT" not in acc.measured


def test_check_runs_both_implicit_methods_and_fails_a_method_that_stopped_or_missed():
    """Issue 29 item 6: `eomc check` lists bdf beside radau (auto picks either), and calls a
    method that stopped, or that missed its tolerance by orders of magnitude, a failed check."""
    from eomc.runtime.stability import default_methods
    m = get_model("pendulum")
    assert default_methods(m) == ("auto", "dopri5", "dop853", "bdf", "radau")
    checks = by_name(check_model(m, [1.0, 0.0], 5.0))
    assert checks["bdf accuracy"].passed and checks["radau accuracy"].passed
    # DOPRI5 needs ~190 steps here: with 100 it stops, and a run that stopped is no pass
    stopped = by_name(check_model(m, [1.0, 0.0], 5.0, methods=("dopri5",), max_steps=100))
    assert not stopped["dopri5 accuracy"].passed
    assert "maximum number of steps" in stopped["dopri5 accuracy"].measured
    # rtol 0.1 with atol 1e-14 over 20 s: DOPRI5 ends 3.6e6 x its (pointwise) tolerance away
    missed = by_name(check_model(m, [1.0, 0.0], 20.0, rtol=1e-1, atol=1e-14, methods=("dopri5",)))
    assert not missed["dopri5 accuracy"].passed
    assert "missed by orders of magnitude" in missed["dopri5 accuracy"].measured
    assert "FAIL" in format_checks(list(missed.values()))


def test_a_reference_that_cannot_be_computed_makes_the_check_inconclusive(monkeypatch, capsys):
    """Issue 29: a check whose reference stops (too stiff or too long at its tolerance: Go2
    resting on 124 contact points stopped the old 1e-12 reference at 2e6 steps) is neither
    passed nor failed: it says why and what to change, and `eomc check` exits 3 -- not 1,
    which says a method is wrong."""
    m = get_model("pendulum")
    checks = by_name(check_model(m, [1.0, 0.0], 5.0, methods=("dopri5",), max_steps=2))
    ref = checks["reference"]
    assert ref.inconclusive and not ref.passed
    assert "maximum number of steps" in ref.measured
    assert "--t-final" in ref.measured and "--rtol" in ref.measured and "--max-steps" in ref.measured
    assert "dopri5 accuracy" not in checks          # nothing is judged against no reference
    assert outcome(list(checks.values())) == "inconclusive"
    monkeypatch.setattr(cli_common, "load_model", lambda spec, quiet=True, **_: m)
    assert main(["check", "pend", "--x0", "q1=1.0", "--t-final", "5", "--max-steps", "2"]) == EXIT_INCONCLUSIVE == 3
    out = capsys.readouterr().out
    assert "[INCONCLUSIVE] reference" in out and "exit status 3" in out and "FAIL" not in out
    # a method that stops is still a failure (exit 1), reference or not
    assert main(["check", "pend", "--x0", "q1=1.0", "--t-final", "5", "--max-steps", "30",
                 "--methods", "dopri5"]) == 1


CHAOTIC = [2.5, 2.5, 0.0, 0.0]      # the double pendulum from here: chaotic


def test_conditioning_is_told_apart_from_a_wrong_method(double_pendulum, monkeypatch):
    """Issue 29 item 2: from (2.5, 2.5) rad the double pendulum is chaotic; the two references
    (DOP853 at rtol 1e-10 and 1e-11) agree to < 100 x tolerance until t ~ 3.7 s and then
    differ by ~6e6 x.  DOP853 at 1e-8 is judged where they agree (and passes), and the line says
    up to when and why (the references stop there since s31: runtime/check_references.py; their
    ~8e7 x later was reported as the problem's conditioning, not failed).  A method that is wrong by
    1e-4 from t = 1 s on still fails; and references that part before a method can be judged
    leave the check inconclusive, naming the span that can be checked."""
    checks = by_name(check_model(double_pendulum, CHAOTIC, 10.0, methods=("dop853",)))
    ref, acc = checks["reference"], checks["dop853 accuracy"]
    assert ref.passed and "the problem's conditioning" in ref.measured
    horizon = float(ref.measured.split("until t=")[1].split(",")[0])
    assert 2.0 < horizon < 6.0
    assert acc.passed and "conditioning, not the method" in acc.measured
    assert f"judged up to t={horizon:.4g}, where the references part" in acc.measured
    assert "so both stopped there and nothing after it is judged" in ref.measured
    # a wrong method: its result off by 1e-4 in q1 from t = 1 s (inside the agreeing window)
    spoil_dop853(monkeypatch, 1e-4)
    bad = by_name(check_model(double_pendulum, CHAOTIC, 10.0, methods=("dop853",)))["dop853 accuracy"]
    assert not bad.passed and not bad.inconclusive and "missed by orders of magnitude" in bad.measured
    assert outcome([bad]) == "failed"
    monkeypatch.undo()
    # 400 s: the references part at ~6 s, 3 output times in: nothing can be judged
    early = check_model(double_pendulum, CHAOTIC, 400.0, methods=("dop853",))
    assert outcome(early) == "inconclusive"
    unsure = [c for c in early if c.inconclusive][0]
    assert "--t-final" in unsure.measured and "dop853 accuracy" not in by_name(early)


_DRAG = '''\
import sympy as sm
from eomc.mechanics import *

x, v = dynamicsymbols("x v")
m, c = sm.symbols("m c")
N = ReferenceFrame("N")
O = Point("O"); O.set_vel(N, 0)
P = O.locatenew("P", x * N.x); P.set_vel(N, v * N.x)
kane = KanesMethod(N, q_ind=[x], u_ind=[v], kd_eqs=[x.diff() - v])
kane.kanes_equations([Particle("ball", P, m)], [(P, -c * sm.Abs(v) * v * N.x)])
system = kane
name = "drag"
parameters = {m: 1.0, c: 300.0}
'''


def test_the_jacobian_check_at_a_jump_of_a_laws_curvature(tmp_path):
    """A quadratic drag c|v|v at rest: its derivative there is 0 (jac_x is right), but every
    difference at step h is off by c h (first hour s22: dm_control's swimmer.xml at rest, density
    3000, failed `eomc check` with 'rel. difference 3.00e-04').  The miss shrinks with the step,
    so the check passes at a smaller one; a wrong jac_x still fails."""
    from helpers import model_files
    import eomc
    drag = eomc.compile(model_files.write(tmp_path, _DRAG, "drag"), cache_dir=tmp_path / "cache", progress=False)
    jac = by_name(check_model(drag, [0.0, 0.0], 1.0, methods=("radau",)))["jacobian"]
    assert jac.passed and float(jac.measured.split()[-1]) < 1e-5, jac.measured
    wrong = drag.jacobian

    class Off:      # jac_x off by 1e-3 in d v'/d v: missed at every step
        def __getattr__(self, name):
            return getattr(drag, name)

        def jacobian(self, t, x, p):
            J = np.array(wrong(t, x, p))
            J[1, 1] += 1e-3
            return J
    bad = stability._jacobian_vs_fd(Off(), np.zeros(2), drag.param_defaults)
    assert not bad.passed and "1.00e-03" in bad.measured, bad.measured


def test_a_terminal_event_that_ends_the_runs_is_said(tmp_path):
    """examples/cartpole_lqr.py without its controller falls at t = 0.55, where its terminal event
    "fallen" ends every run: `eomc check` said t_final=10 and "10 of 10 checks passed" with
    nothing of it (first hour s28).  The reference check says where the runs end and why."""
    import eomc
    model = eomc.compile(str(Path(__file__).resolve().parents[2] / "examples" / "cartpole_lqr.py"),
                         cache_dir=tmp_path / "cache", progress=False)
    checks = by_name(check_model(model, t_final=2.0, methods=("dop853",)))
    said = checks["reference"].measured
    assert "; every run ends at t=0.5508, where the terminal event fallen fired: the checks cover [0, 0.5508]" \
        in said, said
    assert checks["reference"].passed and checks["dop853 accuracy"].passed
