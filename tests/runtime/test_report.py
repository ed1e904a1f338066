"""Work-precision report: reference vs closed forms, monotone errors, CSV/PNG/Markdown, CLI.

Oracles: the harmonic oscillator's closed form (q = cos 2t), the pendulum's
energy recomputed here from its formula, the stiff chain's matrix
exponential, and the report's own numbers re-read from its CSV for the
recommendation (cheapest by counted work among the rows meeting the target).
"""
import csv
import math
import re
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import expm

from helpers.stand_in import get_model

from eomc.runtime.reference import compute_reference, scaled_error, state_scale
from eomc.runtime.report import COLUMNS, work_precision
from eomc.runtime.simulate import simulate

W = 2.0                                     # oscillator: k = 4, m = 1
T = 10.0
TOLS = (1e-3, 1e-5, 1e-7, 1e-9)
METHODS = ("rk4", "dopri5", "dop853", "radau")


def osc_exact(t):
    return np.column_stack([np.cos(W * t), -W * np.sin(W * t)])


@pytest.fixture(scope="module")
def osc():
    return get_model("oscillator")


@pytest.fixture(scope="module")
def osc_report(osc):
    return work_precision(osc, [1.0, 0.0], (0.0, T), methods=METHODS, tolerances=TOLS, repeats=1,
                          progress=False, n_points=101)


def test_reference_agrees_with_closed_form_and_with_its_check(osc):
    t = np.linspace(0, T, 101)
    ref = compute_reference(osc, [1.0, 0.0], (0.0, T), t)
    exact = osc_exact(t)
    assert np.max(np.abs(ref.x - exact)) < 1e-11
    assert ref.method == "dop853" and ref.check_method == "scipy dop853"
    assert 0 < ref.agreement < 1e-11
    assert "checked against scipy dop853" in ref.describe()


def test_scaled_error_definition():
    x_ref = np.array([[1.0, 0.0], [0.0, 2.0], [-1.0, 0.0]])
    x = x_ref + np.array([[1e-3, 0.0], [0.0, 0.0], [0.0, 2e-3]])
    np.testing.assert_allclose(state_scale(x_ref), [1.0, 2.0])
    # worst time is row 0 or 2: sqrt((1e-3 ** 2 + 0) / 2) both
    assert scaled_error(x, x_ref) == pytest.approx(1e-3 / math.sqrt(2))
    # a state that stays at 0 is measured against 1e-3 of the largest state, not 0
    np.testing.assert_allclose(state_scale(np.array([[5.0, 0.0]])), [5.0, 5e-3])


def test_reported_error_is_the_error_against_the_closed_form(osc, osc_report):
    """The row's error equals scaled_error of the same run against cos(2t), to reference accuracy."""
    row = next(r for r in osc_report.rows if r["method"] == "dop853" and r["tolerance"] == 1e-5)
    t = np.linspace(0, T, 101)
    res = simulate(osc, [1.0, 0.0], (0, T), method="dop853", rtol=1e-5, atol=1e-5, t_eval=t)
    exact = osc_exact(t)
    assert row["error"] == pytest.approx(scaled_error(res.x, exact, state_scale(exact)), rel=1e-6)


@pytest.mark.parametrize("method", METHODS)
def test_errors_decrease_as_tolerance_tightens(osc_report, method):
    rows = [r for r in osc_report.rows if r["method"] == method]
    assert [r["tolerance"] for r in rows] == sorted(TOLS, reverse=True)
    errors = [r["error"] for r in rows]
    assert all(r["status"] == 0 for r in rows)
    assert all(b < a for a, b in zip(errors, errors[1:])), errors
    assert errors[-1] < 1e-5 < errors[0]


def test_rk4_step_matches_dopri5_step_count(osc_report):
    for tol in TOLS:
        rk4 = next(r for r in osc_report.rows if r["method"] == "rk4" and r["tolerance"] == tol)
        dp5 = next(r for r in osc_report.rows if r["method"] == "dopri5" and r["tolerance"] == tol)
        assert rk4["dt"] == pytest.approx(T / dp5["accepted"])
        assert abs(rk4["steps"] - dp5["accepted"]) <= 1
        assert rk4["rtol"] is None


def read_csv(path):
    with open(path, newline="") as fh:
        reader = csv.DictReader(fh)
        return reader.fieldnames, list(reader)


def test_csv_rows_and_columns(osc_report, tmp_path):
    names, rows = read_csv(osc_report.to_csv(tmp_path / "r.csv"))
    assert tuple(names) == COLUMNS
    assert len(rows) == len(METHODS) * len(TOLS)
    assert {(r["method"], float(r["tolerance"])) for r in rows} == \
        {(m, t) for m in METHODS for t in TOLS}
    for r in rows:
        assert r["status"] == "0" and float(r["error"]) > 0 and float(r["wall_time_s"]) > 0
        assert 0 < float(r["cpu_time_s"]) < 10 * float(r["wall_time_s"]) + 1e-3   # thread CPU time, measured
        assert int(r["nfev"]) > 0 and float(r["energy_drift"]) >= 0
        assert r["constraint_residual"] == ""            # the oscillator has no constraints
        assert (r["dt"] != "") == (r["method"] == "rk4")


@pytest.mark.parametrize("target", [1e-4, 1e-6, 1e-8])
def test_recommendation_is_cheapest_run_meeting_target(osc_report, tmp_path, target):
    _, rows = read_csv(osc_report.to_csv(tmp_path / "r.csv"))
    meeting = [r for r in rows if float(r["error"]) <= target]
    cheapest = min(meeting, key=lambda r: (float(r["cost"]), float(r["error"])))
    best = osc_report.recommend(target)
    assert best["error"] <= target
    assert (best["method"], best["tolerance"]) == (cheapest["method"], float(cheapest["tolerance"]))
    text = osc_report.summary_markdown(target)
    assert f'method="{best["method"]}"' in text and f"target {target:.0e}" in text


def test_no_run_meets_an_impossible_target(osc_report):
    assert osc_report.recommend(1e-15) is None
    assert "No run met the target" in osc_report.summary_markdown(1e-15)


def test_png_is_written(osc_report, tmp_path):
    path = osc_report.plot(tmp_path / "wp.png")
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000


def test_summary_mentions_reference_energy_and_table(osc_report):
    text = osc_report.summary_markdown()
    assert text.startswith("# Work-precision report: oscillator")
    assert "reference: dop853 at rtol=atol=1e-12" in text and "agreement" in text   # 1000x the finest, 1e-9
    assert "Energy: the reference conserves it" in text
    assert "Stiffness: no symptoms" in text
    assert text.count("\n| ") == 1 + len(METHODS) * len(TOLS)     # header + rows
    assert "Warning" not in text


def pendulum_energy(x, g=9.81, L=1.0):
    """The pendulum's energy per unit mass, written here (not read from its C outputs)."""
    return 0.5 * L * L * x[:, 1] ** 2 - g * L * np.cos(x[:, 0])


def test_energy_drift_on_pendulum():
    m = get_model("pendulum")
    rep = work_precision(m, [1.0, 0.0], (0.0, 10.0), methods=("dopri5", "dop853"),
                         tolerances=(1e-4, 1e-10), repeats=1, progress=False, n_points=101)
    t = np.linspace(0, 10, 101)
    for row in rep.rows:
        res = simulate(m, [1.0, 0.0], (0, 10), method=row["method"], rtol=row["tolerance"],
                       atol=row["tolerance"], t_eval=t)
        e = pendulum_energy(res.x)
        assert row["energy_drift"] == pytest.approx(np.max(np.abs(e - e[0])) / abs(e[0]), rel=1e-6)
    drift = {(r["method"], r["tolerance"]): r["energy_drift"] for r in rep.rows}
    for method in ("dopri5", "dop853"):
        assert drift[(method, 1e-10)] < 1e-8
        assert drift[(method, 1e-10)] < drift[(method, 1e-4)] / 100
    assert rep.reference_energy_drift() < 1e-11


def test_loose_reference_is_flagged_not_trusted(osc):
    rep = work_precision(osc, [1.0, 0.0], (0.0, T), methods=("dop853",), tolerances=(1e-6, 1e-9),
                         repeats=1, progress=False, reference_tol=1e-7)
    assert rep.reference.agreement > 1e-10
    assert "**Warning:** the two references agree only to" in rep.summary_markdown()


def test_constraints_and_unrunnable_method_on_ring():
    m = get_model("ring")                       # no jac_x: radau cannot run
    rep = work_precision(m, [1.0, 0.0, 0.0, 0.5], (0.0, 3.0), methods=("dop853", "radau"),
                         tolerances=(1e-4, 1e-9), repeats=1, progress=False)
    assert "radau" in rep.skipped and all(r["method"] == "dop853" for r in rep.rows)
    res = {r["tolerance"]: r["constraint_residual"] for r in rep.rows}
    assert res[1e-9] < 1e-7 < res[1e-4]
    text = rep.summary_markdown()
    assert "radau not run" in text and "jac_x" in text and "Constraints: reference residual" in text


def test_stiff_chain_symptoms_and_radau_recommended():
    kappa = 1e6
    m = get_model("chain")
    p = np.array([1.0, kappa, 0.1, 2 * np.sqrt(kappa)])
    x0 = np.array([1.0, 1.0, 0.0, 0.0])
    rep = work_precision(m, x0, (0.0, 2.0), p=p, methods=("dopri5", "radau"),
                         tolerances=(1e-4, 1e-7), repeats=1, progress=False, n_points=21,
                         reference_tol=1e-12)   # tied to 1e-7 it is 1e-10: 5.4e-9 from expm
    exact = np.array([expm(m.jacobian(0, np.zeros(4), p) * s) @ x0 for s in rep.reference.t])
    assert scaled_error(rep.reference.x, exact) < 1e-9
    failed = [r for r in rep.rows if r["method"] == "dopri5" and r["status"] != 0]
    assert failed and all(r["status"] == 7 for r in failed)
    text = rep.summary_markdown(1e-5)
    assert "Stiffness symptoms" in text and "stiff" in text
    assert rep.recommend(1e-5)["method"] == "radau"


def test_bad_arguments_raise_before_running(osc):
    with pytest.raises(ValueError, match="unknown integration method"):
        work_precision(osc, [1.0, 0.0], (0, 1), methods=("euler",), progress=False)
    with pytest.raises(ValueError, match="tolerances > 0"):
        work_precision(osc, [1.0, 0.0], (0, 1), tolerances=(1e-3, 0.0), progress=False)
    with pytest.raises(ValueError, match="reversed"):
        work_precision(osc, [1.0, 0.0], (1, 0), progress=False)


# ---- eomc report (the CLI) on a compiled model file and on its built directory ----

def test_cli_report_on_model_file_and_built_directory(tmp_path, monkeypatch, capsys):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from helpers.model_files import PENDULUM, write
    from eomc.cli import main
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    model_file = write(tmp_path, PENDULUM, "pend")
    args = ["--t-final", "2", "--methods", "dop853,radau", "--tolerances", "1e-4", "1e-8",
            "--repeats", "1", "--target", "1e-6", "-q"]
    assert main(["report", str(model_file), *args, "-o", str(tmp_path / "a")]) == 0
    out = capsys.readouterr().out
    assert "Recommendation" in out and "dop853" in out
    names, rows = read_csv(tmp_path / "a" / "report.csv")
    assert len(rows) == 4 and tuple(names) == COLUMNS
    md = (tmp_path / "a" / "report.md").read_text()
    assert md.startswith("# Work-precision report: pend") and "Warning" not in md
    assert (tmp_path / "a" / "report.png").stat().st_size > 10_000
    built = next(p.parent for p in (tmp_path / "cache").rglob("pend.json"))
    assert main(["report", str(built), *args, "-o", str(tmp_path / "b")]) == 0
    _, rows_b = read_csv(tmp_path / "b" / "report.csv")
    assert [r["error"] for r in rows_b] == [r["error"] for r in rows]     # same model, same numbers


def test_cli_report_errors_are_one_line(tmp_path, capsys):
    from eomc.cli import main
    assert main(["report", str(tmp_path / "missing.py")]) == 2  # a usage error
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "no such model file" in err


def test_stability_limited_step_counts_are_called_stiff():
    """dop853 on the overdamped chain: its step count stays flat over 4 decades of tolerance."""
    kappa = 1e4
    m = get_model("chain")
    p = np.array([1.0, kappa, 0.1, 2 * np.sqrt(kappa)])
    rep = work_precision(m, [1.0, 1.0, 0.0, 0.0], (0.0, 10.0), p=p, methods=("dop853",),
                         tolerances=(1e-3, 1e-7), repeats=1, progress=False, n_points=21)
    steps = [r["accepted"] for r in rep.rows]
    assert all(r["status"] == 0 for r in rep.rows) and steps[1] < 1.5 * steps[0]
    assert "step limited by stability, not accuracy" in rep.summary_markdown()


def test_reference_check_follows_a_time_varying_input(osc):
    """r(t) sampled on a grid: scipy's check interpolates it as the C side does, so they agree."""
    t = np.linspace(0, 5, 51)
    ref = compute_reference(osc, [1.0, 0.0], (0.0, 5.0), t, r=lambda s: [np.sin(3 * s)])
    assert ref.check_method == "scipy dop853" and ref.agreement < 1e-8
    free = compute_reference(osc, [1.0, 0.0], (0.0, 5.0), t)
    assert scaled_error(free.x, ref.x) > 1e-2          # the input really acted


def test_importing_the_report_pulls_in_neither_sympy_nor_matplotlib():
    import subprocess
    code = ("import sys, eomc.runtime.report; "
            "print('sympy' in sys.modules, 'matplotlib' in sys.modules, 'eomc.compiler' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False", "False"]


def test_damped_model_energy_is_physics_not_error(osc):
    rep = work_precision(osc, [1.0, 0.0], (0.0, 5.0), p=[4.0, 1.0, 0.5], methods=("dop853",),
                         tolerances=(1e-8,), repeats=1, progress=False, n_points=51)
    assert rep.reference_energy_drift() > 0.5          # c = 0.5 dissipates most of it by t = 5
    assert "not conserved by the model itself" in rep.summary_markdown()


def test_precomputed_reference_is_reused(osc, osc_report):
    rep = work_precision(osc, [1.0, 0.0], (0.0, T), methods=("dop853",), tolerances=(1e-5,),
                         repeats=1, progress=False, n_points=101, reference=osc_report.reference)
    assert rep.reference is osc_report.reference
    old = next(r for r in osc_report.rows if r["method"] == "dop853" and r["tolerance"] == 1e-5)
    assert rep.rows[0]["error"] == old["error"]
    with pytest.raises(ValueError, match="reference has shape"):
        work_precision(osc, [1.0, 0.0], (0.0, T), methods=("dop853",), tolerances=(1e-5,),
                       progress=False, n_points=11, reference=osc_report.reference)


def test_the_reference_is_tied_to_the_finest_tolerance(osc):
    """As `eomc check` ties its references to the checked tolerance (issue 29): 1000x tighter
    than the finest tolerance of the grid (1e-13 at the default 1e-10, never below), not a fixed
    1e-13 whatever the grid -- a contact model reported at 1e-2..1e-6 gets a 1e-9 reference, not
    one whose atol stops at rest; it still resolves the finest run (agreement < 0.1 x its
    tolerance, what the report asks of it)."""
    rep = work_precision(osc, [1.0, 0.0], (0.0, T), methods=("dop853",), tolerances=(1e-4, 1e-7),
                         repeats=1, progress=False, n_points=101)
    ref = rep.reference
    assert (ref.tol, ref.atol) == pytest.approx((1e-10, 1e-10), rel=1e-12)
    assert (ref.check_tol, ref.check_atol) == pytest.approx((1e-9, 1e-9), rel=1e-12)
    assert "dop853 at rtol=atol=1e-10" in ref.describe()
    assert 0 < ref.agreement < 1e-8 and np.max(ref.agreement_t) == ref.agreement
    assert np.max(np.abs(ref.x - osc_exact(ref.t))) < 1e-7
    assert rep.window == 101 and "Errors are measured on" not in rep.summary_markdown()


def test_errors_are_measured_where_the_references_agree(osc, osc_report):
    """Where the reference's two computations part (a chaotic or collapsing motion), later
    errors measure the problem's conditioning: the report measures errors before it and says
    so; if they part within MIN_WINDOW output times nothing is judged, and `eomc report`
    exits 3 (inconclusive), as `eomc check` does."""
    import copy
    ref = copy.copy(osc_report.reference)
    ref.agreement_t = np.where(np.arange(101) < 40, 1e-12, 1e-3)     # they part at t = 4
    kw = dict(methods=("dop853",), tolerances=(1e-5,), repeats=1, progress=False, n_points=101,
              reference=ref)
    rep = work_precision(osc, [1.0, 0.0], (0.0, T), **kw)
    t = np.linspace(0, T, 101)
    res = simulate(osc, [1.0, 0.0], (0, T), method="dop853", rtol=1e-5, atol=1e-5, t_eval=t)
    assert rep.window == 40 and rep.inconclusive is None
    assert rep.rows[0]["error"] == scaled_error(res.x[:40], ref.x[:40], ref.scale)
    assert rep.rows[0]["error"] < scaled_error(res.x, ref.x, ref.scale)    # the error grows after t=4
    assert "Errors are measured on t in [0, 4]" in rep.summary_markdown()
    ref.agreement_t = np.where(np.arange(101) < 3, 1e-12, 1e-3)
    early = work_precision(osc, [1.0, 0.0], (0.0, T), **kw)
    assert early.inconclusive and "--t-final 0.3" in early.inconclusive
    assert np.isnan(early.rows[0]["error"]) and early.recommend() is None
    assert early.recommendation_text().startswith("**Inconclusive:**")


def test_cli_report_whose_reference_fails_is_inconclusive(monkeypatch, capsys):
    import eomc.cli.common as cli_common
    from eomc.cli import main
    monkeypatch.setattr(cli_common, "load_model", lambda *a, **k: get_model("blowup"))
    assert main(["report", "blowup", "--x0", "x=1", "--t-final", "2", "--methods", "dop853",
                 "--tolerances", "1e-6", "-q"]) == 3
    err = capsys.readouterr().err
    assert "inconclusive (exit status 3)" in err and "--t-final" in err
    assert re.search(r"reached t = (0\.99\d*|1) of 2\).*stopped at t=", err)     # where, and why


def test_a_failing_reference_is_a_simulation_error():
    from eomc.errors import SimulationError
    with pytest.raises(SimulationError, match=r"reference solution failed.*t=(0\.99|1\b)"):
        work_precision(get_model("blowup"), [1.0], (0.0, 2.0), methods=("dop853",),
                       tolerances=(1e-6,), progress=False)
    with pytest.raises(ValueError, match="n_points"):
        work_precision(get_model("oscillator"), [1.0, 0.0], (0.0, 1.0), n_points=1, progress=False)


def test_recommendation_is_deterministic_under_timing_noise(osc, monkeypatch):
    """Three runs with wall and CPU times scrambled by up to 10x (a busy machine) recommend the same run."""
    import eomc.runtime.report as report_module
    timed = report_module._timed
    picks, texts = [], []
    for seed in (1, 2, 3):
        rng = np.random.default_rng(seed)

        def noisy(model, a, repeats, rng=rng):
            res, (median, low), cpu = timed(model, a, repeats)
            factor = 10.0 ** rng.uniform(0, 1)
            return res, (median * factor, low * factor), cpu * factor
        monkeypatch.setattr(report_module, "_timed", noisy)
        rep = work_precision(osc, [1.0, 0.0], (0.0, T), methods=METHODS, tolerances=TOLS,
                             repeats=1, progress=False, n_points=51)
        best = rep.recommend(1e-6)
        picks.append((best["method"], best["tolerance"], best["cost"]))
        texts.append(rep.recommendation_text(1e-6).split(" -- ")[0])
    assert picks[0] == picks[1] == picks[2]
    assert texts[0] == texts[1] == texts[2]
    assert "ranked by counted work, not by wall time" in rep.summary_markdown(1e-6)


def test_cost_weighs_jacobians_and_lu_by_operation_counts():
    from eomc.runtime.report import cost_weights, run_cost

    class Stub:
        nx = 4
        metadata = {"op_counts": {"rhs": {"adds": 60, "muls": 40}, "jac_x": {"adds": 300, "muls": 200}}}
    (w_jac, w_lu), counted = cost_weights(Stub())
    assert counted and w_jac == 5.0 and w_lu == pytest.approx(5 / 3 * 64 / 100)
    row = dict(status=0, nfev=100, njev=2, nlu=3)
    assert run_cost(row, (w_jac, w_lu)) == pytest.approx(100 + 10 + 3 * w_lu)
    assert run_cost(dict(row, status=6), (w_jac, w_lu)) is None


def test_png_point_labels_stay_inside_the_axes(osc_report, tmp_path, monkeypatch):
    """report.png clipped the rightmost point's tolerance label at the axes' edge (first hour
    s26): every label now lies inside the axes."""
    import matplotlib.pyplot as plt
    closed = []
    monkeypatch.setattr(plt, "close", lambda fig=None: closed.append(fig))
    osc_report.plot(tmp_path / "wp.png")
    (fig,) = closed
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    (ax,) = fig.axes
    box = ax.get_window_extent(renderer)
    labels = [t for t in ax.texts]
    assert labels
    for t in labels:
        e = t.get_window_extent(renderer)
        assert box.x0 <= e.x0 and e.x1 <= box.x1 and box.y0 <= e.y0 and e.y1 <= box.y1, (t.get_text(), e, box)
    plt.close(fig)


def test_an_auto_check_that_scipy_cannot_finish_is_made_our_other_way(osc, monkeypatch):
    """scipy's DOP853 has no stiffness test: 10x looser than our reference it can blow up where
    ours passed (gymnasium's half_cheetah, its feet landing: a non-finite state at t = 0.26, and
    `eomc report` stopped there, first hour s27).  The "auto" check then runs our Radau and says
    why; a check asked for by name still fails."""
    from eomc.errors import SimulationError
    import eomc.runtime.reference as reference

    def blows_up(model, *args, **kwargs):
        raise SimulationError(f"{model.name}.rhs: a non-finite value appeared at t=0.264856, state x=1e+93")
    monkeypatch.setattr(reference, "_scipy_check", blows_up)
    t = np.linspace(0, 2.0, 21)
    ref = compute_reference(osc, [1.0, 0.0], (0.0, 2.0), t)
    assert ref.method == "dop853"
    assert ref.check_method == ("radau (scipy dop853 failed: oscillator.rhs: a non-finite value appeared "
                                "at t=0.264856)")
    assert 0 < ref.agreement < 1e-9
    assert np.max(np.abs(ref.x - osc_exact(t))) < 1e-11
    with pytest.raises(SimulationError, match="non-finite"):
        compute_reference(osc, [1.0, 0.0], (0.0, 2.0), t, check="scipy")


def test_the_progress_lines_give_the_tables_cpu_time(osc, capsys):
    """Each row's progress line gives the figure its table row gives, named: it gave the wall time,
    unnamed, and under load it read as a second number for the same run (first hour s27: A1's
    bdf at 1e-3 printed 32.2 ms, and 16.1 in the table's CPU [ms] column)."""
    rep = work_precision(osc, [1.0, 0.0], (0.0, 2.0), methods=("dop853",), tolerances=(1e-4, 1e-8),
                         repeats=1, progress=True, n_points=21)
    lines = [line for line in capsys.readouterr().err.splitlines() if line.startswith("eomc report: dop853")]
    assert len(lines) == 2, lines
    for row, line in zip(rep.rows, lines):
        assert f"  {1e3 * row['cpu_time_s']:.3g} ms CPU  {row['steps']} steps" in line, (line, row)


def test_png_time_labels_do_not_run_into_each_other(osc_report, tmp_path, monkeypatch):
    """Over a decade and a half of CPU time (A1's report, 0.016 to 0.49 s: first hour s27) the
    x axis labelled 3x10^-2 and 4x10^-2 so wide they ran into each other: the labels inside the
    axes now stand apart."""
    import copy

    import matplotlib.pyplot as plt
    report = copy.deepcopy(osc_report)
    for method in report.methods:
        rows = [r for r in report.rows if r["method"] == method]
        for r, cpu in zip(rows, np.geomspace(0.0161, 0.486, len(rows))):
            r["cpu_time_s"] = cpu
    closed = []
    monkeypatch.setattr(plt, "close", lambda fig=None: closed.append(fig))
    report.plot(tmp_path / "wp.png")
    (fig,) = closed
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    (ax,) = fig.axes
    lo, hi = ax.get_xlim()
    ticks = [(t.get_position()[0], t.get_window_extent(renderer), t.get_text())
             for t in ax.xaxis.get_majorticklabels() + ax.xaxis.get_minorticklabels()
             if t.get_visible() and t.get_text()]
    shown = sorted(((e.x0, e.x1, text) for x, e, text in ticks if lo <= x <= hi))
    assert len(shown) >= 6, shown
    assert all(b[0] >= a[1] for a, b in zip(shown, shown[1:])), shown
    plt.close(fig)


def test_cli_report_says_no_initial_state_only_of_a_model_without_one(osc, monkeypatch, capsys, tmp_path):
    """`eomc report half_cheetah.xml` said the model "has no initial_state" of a model whose
    initial_state (MuJoCo's qpos0) is all zeros (first hour s27): the note is for a model without
    one, started from rest with no --x0."""
    import eomc.cli.common as cli_common
    from eomc.cli import main
    monkeypatch.setattr(cli_common, "load_model", lambda *a, **k: osc)
    argv = ["report", "osc", "--t-final", "1", "--methods", "dop853", "--tolerances", "1e-4",
            "--repeats", "1", "-o", str(tmp_path / "r")]
    note = f"{osc.name} has no initial_state and no --x0 was given"
    for initial, said in ((None, True), (np.zeros(osc.nx), False)):
        monkeypatch.setattr(osc, "initial_state", initial, raising=False)
        main(argv)
        err = capsys.readouterr().err
        assert (note in err) == said, err
    monkeypatch.setattr(osc, "initial_state", None, raising=False)
    main(argv + ["--x0", f"{osc.state_names[0]}=0"])
    assert note not in capsys.readouterr().err


# ---- a bounded report: the row budget, long runs timed once, the reference's check stopped ----

def test_a_run_past_its_budget_is_cut_and_the_report_still_ends(osc, monkeypatch, tmp_path, capsys):
    """The row budget (s34, reportg1: G1's report with no flags ran 41 min): a run whose budget
    is spent is stopped, kept as a cut row saying where, never recommended, its method's tighter
    tolerances not run; the other methods' rows and the outputs are as without it.  The budget
    is forced spent for dop853's runs (its flag set as the run starts: the C loop stops at its
    first model evaluation), so which rows are cut does not depend on the machine's speed."""
    import eomc.cli.common as cli_common
    import eomc.runtime.report as report_module
    from eomc.cli import main
    enter = report_module._Budget.__enter__

    def spent(self):
        enter(self)
        if self.method == "dop853":
            self.cut, self.flag[0] = True, 1
        return self
    monkeypatch.setattr(report_module._Budget, "__enter__", spent)
    monkeypatch.setattr(cli_common, "load_model", lambda *a, **k: osc)
    out = tmp_path / "cut"
    assert main(["report", "oscillator", "--x0", "q=1", "--t-final", "5", "--methods", "dop853,radau",
                 "--tolerances", "1e-4", "1e-6", "1e-8", "--repeats", "1", "--row-budget", "7",
                 "-o", str(out)]) == 0
    captured = capsys.readouterr()
    names, rows = read_csv(out / "report.csv")
    assert tuple(names) == COLUMNS and len(rows) == 6
    dop = [r for r in rows if r["method"] == "dop853"]
    assert dop[0]["status"] == "9" and dop[0]["message"].startswith("cut: stopped after 7 s of ")
    assert re.search(r"at t = 0 of 5, \d+ steps$", dop[0]["message"]), dop[0]["message"]
    for r in dop[1:]:
        assert r["status"] == "-1" and "not run: dop853 at tol=1e-04 was cut at the row budget" in r["message"]
    radau = [r for r in rows if r["method"] == "radau"]
    assert all(r["status"] == "0" and float(r["error"]) > 0 for r in radau)
    md = (out / "report.md").read_text()
    assert "CUT at the row budget (7 s of" in md and "dop853 at 1e-06, 1e-08 was not run" in md
    assert 'method="radau"' in md.split("\n\n")[2]           # the recommendation: a run that finished
    assert "FAILED" not in md and "cut t=0" in captured.out and "not run" in captured.out
    assert "--row-budget 7" in md
    assert (out / "report.png").stat().st_size > 10_000
    assert re.search(r"eomc report: dop853 +tol=1e-04 +cut: stopped after 7 s", captured.err)


def test_the_budget_stops_a_long_run_by_its_cpu_time(osc):
    """The watcher itself: a run of ~1e6 DOP853 steps (seconds) under a 0.05 s budget is stopped
    part of the way, its rows up to there kept; with no budget the same call runs to the end."""
    import eomc.runtime.report as report_module
    t1 = 1e5
    common = dict(x0=[1.0, 0.0], t_span=(0.0, t1), p=None, r=None, t_eval=np.array([0.0, t1]),
                  project=False)
    ref = compute_reference(osc, [1.0, 0.0], (0.0, 1.0), np.array([0.0, 1.0]), check="none")
    row, res = report_module._one(osc, "dop853", 1e-12, None, common, 1, ref, budget=0.05)
    assert report_module.is_cut(row) and row["status"] == 9 and 0 < row["cut_at"] < t1
    assert res.t.size == 1 and np.isnan(row["error"]) and np.isnan(row["cpu_time_s"])
    assert f"at t = {row['cut_at']:.4g} of {t1:g}" in row["message"]
    short = dict(common, t_span=(0.0, 10.0), t_eval=np.array([0.0, 10.0]))
    done, _ = report_module._one(osc, "dop853", 1e-12, None, short, 1, ref, budget=None)
    assert done["status"] == 0 and not report_module.is_cut(done)


def test_a_long_run_is_timed_by_its_one_call(osc, monkeypatch):
    """A run whose first call took ONCE_S of CPU time is not called again for timing samples
    (5 calls a row before); a short one is (repeats samples)."""
    import eomc.runtime.report as report_module
    import eomc.runtime.simulate as simulate_module
    calls = []
    bind = simulate_module.bind_call

    def counting(model, a, out=None):
        call, *rest = bind(model, a, out)

        def counted():
            calls.append(1)
            return call()
        return (counted, *rest)
    monkeypatch.setattr(report_module, "bind_call", counting)
    monkeypatch.setattr(simulate_module, "bind_call", counting)
    rep = work_precision(osc, [1.0, 0.0], (0.0, 2.0), methods=("dop853",), tolerances=(1e-6,),
                         repeats=3, progress=False, n_points=11, row_budget=None)
    short = len(calls)
    assert rep.rows[0]["samples"] == 3 and short >= 1 + 1 + 3
    monkeypatch.setattr(report_module, "ONCE_S", 0.0)
    calls.clear()
    rep = work_precision(osc, [1.0, 0.0], (0.0, 2.0), methods=("dop853",), tolerances=(1e-6,),
                         repeats=3, progress=False, n_points=11, row_budget=None,
                         reference=rep.reference)
    assert rep.rows[0]["samples"] == 1 and len(calls) == 1 and rep.rows[0]["status"] == 0
    assert rep.rows[0]["cpu_time_s"] > 0


def test_rows_on_threads_are_the_rows_on_one(osc):
    """Methods on threads of their own give the same rows (counts, errors) as one after the
    other, in the same order; rk4 still takes DOPRI5's step count."""
    kw = dict(methods=("rk4", "dopri5", "dop853", "radau"), tolerances=(1e-4, 1e-7), repeats=1,
              progress=False, n_points=51)
    one = work_precision(osc, [1.0, 0.0], (0.0, 5.0), threads=1, **kw)
    four = work_precision(osc, [1.0, 0.0], (0.0, 5.0), threads=4, reference=one.reference, **kw)
    assert one.threads == 1 and four.threads == 4
    keys = ("method", "tolerance", "dt", "status", "error", "steps", "nfev", "njev", "nlu")
    assert [[r[k] for k in keys] for r in one.rows] == [[r[k] for k in keys] for r in four.rows]
    with pytest.raises(ValueError, match="threads must be >= 1"):
        work_precision(osc, [1.0, 0.0], (0.0, 5.0), threads=0, **kw)
    with pytest.raises(ValueError, match="row_budget must be >= 0"):
        work_precision(osc, [1.0, 0.0], (0.0, 5.0), row_budget=-1, **kw)


def test_the_reference_check_stops_where_the_two_part(osc):
    """A check by our own code is stopped at the first output time where it differs from the
    reference by more than the level errors are measured to: where they part and everything
    before it is what the check run to the end gives (the same rows), nothing after is judged."""
    t1 = 2e4
    t = np.linspace(0.0, t1, 401)
    full = compute_reference(osc, [1.0, 0.0], (0.0, t1), t, tol=1e-10, check="dop853-half")
    level = float(full.agreement_t[200])
    h = full.horizon(level)
    assert 10 < h < t.size - 1 and full.check_stopped_at is None
    cut = compute_reference(osc, [1.0, 0.0], (0.0, t1), t, tol=1e-10, check="dop853-half",
                            stop_level=level)
    assert cut.horizon(level) == h
    np.testing.assert_array_equal(cut.agreement_t[:h + 1], full.agreement_t[:h + 1])
    np.testing.assert_array_equal(cut.x, full.x)
    if cut.check_stopped_at is not None:      # stopped by a poll (every 50 ms): the run was long enough
        assert t[h] <= cut.check_stopped_at < t1 and np.isnan(cut.agreement_t[-1])
        assert "its check stopped at t=" in cut.describe()


def test_a_method_whose_runs_used_its_sweep_budget_stops_there(osc, monkeypatch):
    """A method's runs having used SWEEP_BUDGETS row budgets together, its tighter tolerances are
    not run (each within budget, they would still add up): the rows and the notes say so.  The
    factor is made tiny so that the first run's own CPU time uses it up."""
    import eomc.runtime.report as report_module
    monkeypatch.setattr(report_module, "SWEEP_BUDGETS", 1e-12)
    rep = work_precision(osc, [1.0, 0.0], (0.0, 2.0), methods=("dop853", "radau"),
                         tolerances=(1e-4, 1e-6, 1e-8), repeats=1, progress=False, n_points=11,
                         row_budget=100.0)
    for method in ("dop853", "radau"):
        rows = [r for r in rep.rows if r["method"] == method]
        assert rows[0]["status"] == 0
        for r in rows[1:]:
            assert r["status"] == -1 and re.search(
                rf"not run: {method}'s runs at looser tolerances took \d+ s of CPU time together", r["message"])
    md = rep.summary_markdown()
    assert "dop853 at 1e-06, 1e-08 not run: its runs at looser tolerances used" in md and "FAILED" not in md
    assert rep.recommend(1e-3) is not None


def test_a_check_started_with_the_reference_gives_the_same_reference(osc):
    """``parallel``: our Radau check starts on a thread of its own with the reference (the two
    take the longer of their times, not the sum); the rows and the agreement are those of the
    check run after it.  A check that ends up another way (scipy, under 20 000 reference steps)
    is dropped, its thread ended."""
    import threading
    t = np.linspace(0.0, 20.0, 201)
    kw = dict(tol=1e-11, check="radau")
    one = compute_reference(osc, [1.0, 0.0], (0.0, 20.0), t, **kw)
    two = compute_reference(osc, [1.0, 0.0], (0.0, 20.0), t, parallel=True, **kw)
    np.testing.assert_array_equal(one.x, two.x)
    np.testing.assert_array_equal(one.agreement_t, two.agreement_t)
    assert one.check_method == two.check_method == "radau" and one.agreement == two.agreement > 0
    level = float(one.agreement_t[100])
    h = one.horizon(level)
    stopped = compute_reference(osc, [1.0, 0.0], (0.0, 20.0), t, parallel=True, stop_level=level, **kw)
    assert stopped.horizon(level) == h
    np.testing.assert_array_equal(stopped.agreement_t[:h + 1], one.agreement_t[:h + 1])
    auto = compute_reference(osc, [1.0, 0.0], (0.0, 20.0), t, tol=1e-11, parallel=True)
    assert auto.check_method == "scipy dop853"
    assert not [th for th in threading.enumerate() if th.name == "eomc-reference-check"]
