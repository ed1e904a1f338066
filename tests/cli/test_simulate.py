"""eomc simulate: CSV, plot, overrides, one-line errors (model loading stubbed by a stand-in)."""

import numpy as np
import pytest

from helpers.stand_in import get_model

import eomc.cli.common as cli_common
from eomc.cli import main


@pytest.fixture
def pendulum(monkeypatch):
    model = get_model("pendulum")
    model.initial_state = np.array([0.5, 0.0])
    monkeypatch.setattr(cli_common, "load_model", lambda spec, quiet=True, **_: model)
    return model


def test_simulate_writes_csv_from_initial_state(pendulum, tmp_path, capsys):
    out = tmp_path / "traj.csv"
    assert main(["simulate", "pend", "--t-final", "2", "-o", str(out), "--points", "21",
                 "--rtol", "1e-10", "--atol", "1e-10"]) == 0
    data = np.genfromtxt(out, delimiter=",", names=True)
    assert data["t"][-1] == 2.0 and data["q1"][0] == 0.5 and len(data) == 21
    assert np.ptp(data["energy"]) < 1e-8
    text = capsys.readouterr().out
    assert "dop853" in text and "energy" in text and "wrote" in text


def test_simulate_overrides_and_rk4(pendulum, tmp_path):
    out = tmp_path / "t.csv"
    assert main(["simulate", "pend", "--t-final", "1", "-o", str(out), "--method", "rk4",
                 "--dt", "0.1", "--x0", "q1=0.1,u1=0.2", "--param", "g=1.0"]) == 0
    data = np.genfromtxt(out, delimiter=",", names=True)
    assert len(data) == 11 and data["q1"][0] == 0.1 and data["u1"][0] == 0.2
    assert abs(data["energy"][0] - (0.02 - np.cos(0.1))) < 1e-12


@pytest.mark.parametrize("argv,match", [
    (["--method", "euler"], "valid methods"),
    (["--x0", "zz=1"], "unknown state zz"),
    (["--x0", "q1"], "NAME=VALUE"),
    (["--rtol", "0"], "rtol"),
])
def test_simulate_bad_arguments_one_line(pendulum, capsys, argv, match):
    assert main(["simulate", "pend", "--t-final", "1", *argv]) == 2
    err = capsys.readouterr().err
    assert match in err and "Traceback" not in err and err.count("\n") == 1


@pytest.mark.parametrize("argv,message", [
    (["--x0", "u11=1"], "pendulum: unknown state u11 in --x0 (did you mean u1?); states: q1, u1"),
    (["--param", "LL=2"], "pendulum: unknown parameter LL in --param (did you mean L?); parameters: g, L"),
])
def test_a_built_models_unknown_names_get_the_nearest_ones(pendulum, capsys, argv, message):
    """A built model's --x0/--param are checked as a model file's are before its build (read_checks):
    the nearest names, then at most 12 of them.  Before: no hint, and every name (UR5's 62
    parameters on one line)."""
    assert main(["simulate", "pend", "--t-final", "1", *argv]) == 2
    assert capsys.readouterr().err == f"eomc simulate: error: {message}\n"


def test_simulate_failure_is_one_line(monkeypatch, capsys):
    monkeypatch.setattr(cli_common, "load_model", lambda spec, quiet=True, **_: get_model("singular"))
    assert main(["simulate", "s", "--t-final", "1"]) == 1
    err = capsys.readouterr().err
    assert "the mass matrix is singular" in err and "stopped at t=0.5:" in err


def test_simulate_of_a_built_directory_imports_nothing_heavy(tmp_path):
    """`eomc simulate DIR` starts fast (issue 10: <= 0.3 s): no SymPy, SciPy, matplotlib, Jinja2 or
    eomc.compiler on that path (benchmarks/bench_startup.py measures the time itself)."""
    import subprocess
    import sys
    from helpers import model_files
    model = model_files.write(tmp_path, model_files.PENDULUM, "p")
    env_cache = ["--cache-dir", str(tmp_path / "c")]
    assert main(["build", str(model), "-o", str(tmp_path / "built"), *env_cache, "-q"]) == 0
    code = ("import sys; from eomc.cli import main; "
            "rc = main(['simulate', sys.argv[1], '--t-final', '1', '-o', sys.argv[2]]); "
            "heavy = ('sympy', 'scipy', 'matplotlib', 'jinja2', 'eomc.compiler'); "
            "print(rc, sorted(m for m in sys.modules if m.startswith(heavy)))")
    run = subprocess.run([sys.executable, "-c", code, str(tmp_path / "built"), str(tmp_path / "t.csv")],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    assert run.stdout.splitlines()[-1] == "0 []"
    assert (tmp_path / "t.csv").read_text().startswith("t,")


def test_a_failed_run_keeps_its_rows_marked_incomplete(pendulum, tmp_path, capsys):
    """Issue 29: a run that stops still writes what it computed, marked as such (the CSV's last
    line is a '# incomplete: ...' comment numpy.loadtxt skips), and the command fails."""
    out = tmp_path / "traj.csv"
    assert main(["simulate", "pend", "--t-final", "20", "-o", str(out), "--max-steps", "30",
                 "--rtol", "1e-10", "--atol", "1e-10"]) != 0
    err = capsys.readouterr().err
    assert "maximum number of steps" in err and "rows computed up to t=" in err and "incomplete" in err
    lines = out.read_text().splitlines()
    assert lines[-1].startswith("# incomplete: ") and "maximum number of steps" in lines[-1]
    data = np.loadtxt(out, delimiter=",", skiprows=1, ndmin=2)
    assert 1 < len(data) < 1001 and data[0, 1] == 0.5 and np.all(np.isfinite(data))


@pytest.mark.parametrize("method, stiff", [("dop853", True), ("bdf", False)])
def test_out_of_steps_advice_names_the_flags(pendulum, method, stiff, capsys):
    """Sweep s27: Talos --floating-base --ground (auto: bdf) ran out of steps at t = 1.67 of 2 and the
    command said "raise max_steps or, if the problem is stiff, use method='radau'": the Python
    keywords, and radau as a remedy for a run that was already implicit.  The flags now, and the
    stiff remedy only after an explicit method."""
    assert main(["simulate", "pend", "--t-final", "20", "--max-steps", "30", "--method", method,
                 "--rtol", "1e-10", "--atol", "1e-10"]) != 0
    err = capsys.readouterr().err
    assert "raise --max-steps (30 now)" in err and "max_steps" not in err, err
    assert ("use --method radau" in err) == stiff and "method='radau'" not in err, err


def test_columns_choose_the_csvs_columns_and_a_bad_pattern_names_them(tmp_path, capsys, monkeypatch):
    """G1 on the ground wrote 4272 columns (840 contacts x 5 outputs), 27 MB, with no choice
    (first hour s26): --columns keeps t and the columns its names or glob patterns match; a
    pattern that matches nothing fails before the run, naming the columns there are."""
    from helpers import model_files
    model = model_files.write(tmp_path, model_files.PENDULUM, "p")
    out = tmp_path / "t.csv"
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "c"))
    cache = []
    assert main(["simulate", str(model), "--t-final", "0.5", "-q", "-o", str(out), *cache,
                 "--columns", "en*"]) == 0
    assert out.read_text().splitlines()[0] == "t,energy"
    assert main(["simulate", str(model), "--t-final", "0.5", "-q", "-o", str(out), *cache,
                 "--columns", "q, energy"]) == 0
    assert out.read_text().splitlines()[0] == "t,q,energy"
    capsys.readouterr()
    assert main(["simulate", str(model), "--t-final", "0.5", "-q", "-o", str(tmp_path / "u.csv"), *cache,
                 "--columns", "energi"]) == 2
    err = capsys.readouterr().err
    assert "--columns: energi matches no column (did you mean energy?); columns: t, q, u, energy" in err, err
    assert not (tmp_path / "u.csv").exists()


ROD = '''\
import sympy as sm
from eomc.mechanics import *

x1, x2, u1, u2 = dynamicsymbols("x1 x2 u1 u2")
m, L, k = sm.symbols("m L k")
N = ReferenceFrame("N")
O = Point("O")
O.set_vel(N, 0)
P1 = O.locatenew("P1", x1 * N.x)
P1.set_vel(N, u1 * N.x)
P2 = O.locatenew("P2", x2 * N.x)
P2.set_vel(N, u2 * N.x)
kane = KanesMethod(N, q_ind=[x1], u_ind=[u1], kd_eqs=[x1.diff() - u1, x2.diff() - u2],
                   q_dependent=[x2], configuration_constraints=[x2 - x1 - L],
                   u_dependent=[u2], velocity_constraints=[u2 - u1])
kane.kanes_equations([Particle("a", P1, m), Particle("b", P2, m)], [(P1, -k * x1 * N.x)])
system = kane
name = "rod"
parameters = {m: 1.0, L: 1.0, k: 4.0}
initial_state = {x1: 0.5, x2: 1.5}
outputs = {"energy": m * u1**2 / 2 + m * u2**2 / 2 + k * x1**2 / 2}
'''


def test_columns_are_checked_against_the_columns_the_run_writes(tmp_path, capsys, monkeypatch):
    """--columns was checked against a constraint_residual column (and the outputs) whenever the
    model had constraints (outputs), but a build of chosen functions (eomc build --outputs rhs)
    writes neither: the pattern passed the check, the run ran, and only writing the CSV failed.
    Now the check reads the columns the run writes (runtime.simulate.result_columns)."""
    from helpers import model_files
    model = model_files.write(tmp_path, ROD, "rod")
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "c"))
    out = tmp_path / "t.csv"
    assert main(["simulate", str(model), "--t-final", "0.5", "-q", "-o", str(out),
                 "--columns", "constr*,energy"]) == 0
    assert out.read_text().splitlines()[0] == "t,energy,constraint_residual"
    built = tmp_path / "built"
    assert main(["build", str(model), "--outputs", "rhs", "-o", str(built), "-q"]) == 0
    capsys.readouterr()
    for pattern in ("constraint_residual", "energy"):
        assert main(["simulate", str(built), "--t-final", "0.5", "-q", "-o", str(tmp_path / "u.csv"),
                     "--columns", pattern]) == 2
        captured = capsys.readouterr()
        assert captured.out == "", captured.out         # refused before the run
        assert captured.err == (f"eomc simulate: error: rod: --columns: {pattern} matches no column; columns: "
                                f"t, x1, x2, u1, u2 (names or glob patterns such as 'q_*')\n"), captured.err
        assert not (tmp_path / "u.csv").exists()
    assert main(["simulate", str(built), "--t-final", "0.5", "-q", "-o", str(out), "--columns", "x*"]) == 0
    assert out.read_text().splitlines()[0] == "t,x1,x2"
    assert "no outputs (the build left out rod_outputs (energy): add outputs to eomc build --outputs)" \
        in capsys.readouterr().out
