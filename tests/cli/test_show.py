"""`eomc show`: the derived equations, printed readably."""

import re

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


def test_entries_too_large_to_read_are_summarized_unless_full(tmp_path, capsys, monkeypatch):
    """UR5's Kane form pretty-printed to 14 MB (lines up to 335 kB) in 23 s CPU (first hour
    s26): an entry over ENTRY_CHARS is now given as its operation count and size, one line
    says so and names --full, which prints everything as before.  The cart, small, prints as
    it did (the first test); here the limit is lowered to reach its mass matrix."""
    import eomc.cli.show as show
    model = model_files.write(tmp_path, model_files.CART, "cart")
    assert main(["show", str(model), "--ascii", "-q"]) == 0
    whole = capsys.readouterr().out
    monkeypatch.setattr(show, "ENTRY_CHARS", 8)
    assert main(["show", str(model), "--ascii", "-q"]) == 0
    out = capsys.readouterr().out
    assert "(too large to read whole" in out and "--full prints everything" in out, out
    assert "entries over 8 characters are given as operation count and size;" in out, out
    assert "mass matrix  (A in A u' = b)\n  [0, 0] = M + m\n" in out, out          # 5 characters
    assert re.search(r"\n  \[0, 1\]: \d+ operations, \d+ characters\n", out), out
    assert main(["show", str(model), "--ascii", "-q", "--full"]) == 0
    assert capsys.readouterr().out == whole
    monkeypatch.setattr(show, "ENTRY_CHARS", 400)
    monkeypatch.setattr(show, "TOTAL_CHARS", 10)          # every block entry by entry
    assert main(["show", str(model), "--ascii", "-q"]) == 0
    out = capsys.readouterr().out
    assert "kinematics  q' =\n  [0] = v\n  [1] = w\n" in out and "the rest one per line" in out, out
