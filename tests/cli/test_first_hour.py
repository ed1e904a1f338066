"""The first hour's traps (first-hour report, reliability report F8's CLI cases).

- ``eomc simulate -o`` onto a missing folder or a folder fails before simulating
- ``-q`` is accepted by every subcommand
- ``--x0`` help says what happens to the states not named
- ``eomc show`` lists parameters in p[] order with defaults, and says "lambda" only with multipliers
"""
import numpy as np
import pytest

from helpers import model_files
from helpers.stand_in import get_model

import eomc.cli.common as cli_common
import eomc.runtime.simulate as simulate_module
from eomc.cli import SUBCOMMANDS, main


@pytest.fixture
def pendulum(monkeypatch):
    model = get_model("pendulum")
    model.initial_state = np.array([0.5, 0.0])
    monkeypatch.setattr(cli_common, "load_model", lambda spec, quiet=True: model)
    return model


@pytest.fixture
def no_simulation(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("simulated before checking the output path")
    monkeypatch.setattr(simulate_module, "simulate", refuse)


@pytest.mark.parametrize("target, message", [
    ("missing/dir/t.csv", "the directory {tmp}/missing/dir does not exist"),
    (".", "is a directory; give a file name"),
])
def test_bad_output_path_fails_before_simulating(pendulum, no_simulation, tmp_path, capsys, target, message):
    path = tmp_path / target
    assert main(["simulate", "pend", "--t-final", "1", "-o", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("eomc simulate: error: -o ")
    assert message.format(tmp=tmp_path) in err
    assert "Traceback" not in err


def test_bad_plot_path_fails_before_simulating(pendulum, no_simulation, tmp_path, capsys):
    assert main(["simulate", "pend", "--t-final", "1", "--plot", str(tmp_path / "no" / "p.png")]) == 2
    assert "eomc simulate: error: --plot " in capsys.readouterr().err


def test_good_output_path_still_writes(pendulum, tmp_path):
    out = tmp_path / "t.csv"
    assert main(["simulate", "pend", "--t-final", "1", "-o", str(out), "-q"]) == 0
    assert out.read_text().startswith("t,q1,u1")


@pytest.mark.parametrize("command", sorted(set(SUBCOMMANDS)))
def test_every_subcommand_accepts_quiet(command, capsys):
    with pytest.raises(SystemExit) as info:
        main([command, "--help"])
    assert info.value.code == 0
    assert "-q, --quiet" in capsys.readouterr().out


def test_x0_help_says_others_keep_the_initial_state(capsys):
    with pytest.raises(SystemExit):
        main(["simulate", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "states not named keep the model's initial_state" in text
    assert "others 0" not in text


def test_rk4_without_dt_names_the_cli_flag(pendulum, capsys):
    assert main(["simulate", "pend", "--t-final", "1", "--method", "rk4"]) == 2
    assert "--dt on the command line" in capsys.readouterr().err


def test_show_lists_parameters_in_p_order_and_no_lambda_without_multipliers(tmp_path, capsys):
    text = model_files.PENDULUM.replace("parameters = {m: 2.0, l: 0.5, g: 9.81}",
                                        "parameters = {m: 2.0, l: 0.5, g: 9.81}  # not alphabetical")
    path = model_files.write(tmp_path, text, "pend")
    assert main(["show", str(path), "-q"]) == 0
    out = capsys.readouterr().out
    assert "parameters:    m=2, l=0.5, g=9.81" in out
    assert "lambda" not in out and "mass matrix  (A in A u' = b)" in out


def test_show_says_lambda_with_multipliers(tmp_path, capsys):
    text = ("import sympy as sm\nfrom eomc.mechanics import *\n"
            "x, y = dynamicsymbols('x y')\nm, g, l = sm.symbols('m g l')\n"
            "L = m * (x.diff()**2 + y.diff()**2) / 2 - m * g * y\n"
            "lm = LagrangesMethod(L, [x, y], hol_coneqs=[x**2 + y**2 - l**2])\nlm.form_lagranges_equations()\n"
            "system = lm\nparameters = {m: 1.0, g: 9.81, l: 1.0}\n")
    path = model_files.write(tmp_path, text, "cartesian")
    assert main(["show", str(path), "-q"]) == 0
    assert "mass matrix  (A in A [u'; lambda] = b)" in capsys.readouterr().out


def test_report_output_onto_a_file_fails_before_running(pendulum, tmp_path, capsys):
    target = tmp_path / "taken"
    target.write_text("keep me")
    assert main(["report", "pend", "-o", str(target), "-q"]) == 2
    assert f"eomc report: error: -o {target} is a file" in capsys.readouterr().err
    assert target.read_text() == "keep me"
