"""`eomc show`: the derived equations, printed readably."""

from helpers import model_files
from eomc.cli import main


def test_show_prints_coordinates_kinematics_mass_matrix_and_forcing(tmp_path, capsys):
    model = model_files.write(tmp_path, model_files.CART, "cart")
    assert main(["show", str(model), "--ascii"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("model cart (kane): nq=2, nu=2")
    assert "coordinates q: x, th" in out and "speeds u:      v, w" in out
    assert "inputs:        F" in out and "parameters:    M=1.5, m=0.5, l=0.8, g=9.81" in out  # p[] order
    for section in ("kinematics  q' =", "mass matrix", "forcing  b ="):
        assert section in out
    assert "(t)" not in out  # dynamic symbols print as plain names
    assert "M + m" in out  # the cart's mass-matrix entry


def test_show_prints_outputs(tmp_path, capsys):
    model = model_files.write(tmp_path, model_files.PENDULUM, "p")
    assert main(["show", str(model)]) == 0
    out = capsys.readouterr().out
    assert "\noutputs\nenergy =" in out


def test_show_reports_model_file_errors_with_line(tmp_path, capsys):
    bad = model_files.write(tmp_path, "import math\nmath.log(0)\n", "bad")
    assert main(["show", str(bad)]) == 1
    assert f"{bad}:2: ValueError: math domain error" in capsys.readouterr().err


def test_a_long_pretty_print_is_not_silent_in_a_log(tmp_path, capsys, monkeypatch):
    """The printing is its own stage: UR5's Kane form derives in 1 s and pretty-prints 14 MB in
    23 s CPU, which a log (stderr not a terminal) met with silence; now its stage line comes."""
    import time
    import eomc.cli.show as show
    from eomc.compiler.driver import Progress
    monkeypatch.setattr(Progress, "LOG_AFTER", 0.1)
    formatted = show.format_equations
    monkeypatch.setattr(show, "format_equations", lambda *a, **k: (time.sleep(0.4), formatted(*a, **k))[1])
    model = model_files.write(tmp_path, model_files.CART, "cart")
    assert main(["show", str(model), "--ascii"]) == 0
    captured = capsys.readouterr()
    assert captured.out.startswith("model cart (kane): nq=2, nu=2")
    assert "eomc: pretty-print ... (still running after 0.1 s)" in captured.err, captured.err
