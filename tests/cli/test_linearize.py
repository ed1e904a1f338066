"""eomc linearize: A, B, eigenvalues; --reduced over the independent states of a constrained model."""
import textwrap

import numpy as np

from eomc.cli import main

CPEND = textwrap.dedent('''\
    import sympy as sm
    from eomc.mechanics import *
    x, y = dynamicsymbols("x y")
    m, g, l = sm.symbols("m g l")
    system = LagrangesMethod(m / 2 * (x.diff()**2 + y.diff()**2) - m * g * y, [x, y],
                             hol_coneqs=[x**2 + y**2 - l**2])
    system.form_lagranges_equations()
    parameters = {m: 2.0, g: 9.81, l: 1.5}
    initial_state = {y: -1.4}
    ''')


def _eigenvalues(text):
    line = next(s for s in text.splitlines() if s.startswith("eigenvalues: "))
    return np.array([complex(v.replace(" ", "")) for v in line[len("eigenvalues: "):].split(",")])


def test_linearize_full_and_reduced(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    path = tmp_path / "cpend.py"
    path.write_text(CPEND)
    assert main(["linearize", str(path), "--reduced", "--consistent"]) == 0
    out = capsys.readouterr().out
    assert "y=-1.5" in out                        # --consistent completed y from y = -1.4
    eig = _eigenvalues(out)
    assert len(eig) == 2
    np.testing.assert_allclose(sorted(eig.imag), [-np.sqrt(9.81 / 1.5), np.sqrt(9.81 / 1.5)],
                               rtol=1e-6)
    assert main(["linearize", str(path), "--x0", "y=-1.5"]) == 0
    assert len(_eigenvalues(capsys.readouterr().out)) == 4    # the full A: every state
    assert main(["linearize", str(path), "--x0", "y=-1.4", "--reduced"]) == 1
    assert "off the constraints" in capsys.readouterr().err


def test_the_tables_columns_line_up_under_long_row_names():
    """hopper's rows q_thigh_joint, u_thigh_joint ... were printed three places right of the
    others (a 10-wide column of names, first hour s27), and -0 entries as -0."""
    from eomc.cli.linearize import _matrix
    rows = ["q_x", "q_thigh_joint", "u_x", "u_thigh_joint"]
    text = _matrix("A", np.array([[0.0, 1.0], [-0.0, 2.5], [3.0, -0.0], [1e-17, 4.0]]), rows, ["F", "ctrl_actuator0"])
    lines = text.splitlines()[1:]
    assert len({len(line) for line in lines}) == 1, text        # every row as wide as the header
    assert lines[2].split() == ["q_thigh_joint", "0", "2.5"] and "-0 " not in text + " ", text


def test_eigenvalues_within_round_off_of_zero_print_as_zero():
    """A1 --floating-base --ground (first hour s28) printed its free base's zero eigenvalues as
    LAPACK returns them from their 2x2 Jordan blocks, -2.27e-09+8.6e-10j and the like, some with
    a positive real part that reads as an unstable mode.  Parts below sqrt(eps |A|) print as 0
    with a note counting them; a slow but real mode (1e-3) and exact zeros are printed as they are."""
    from eomc.cli.linearize import eigenvalue_text

    jordan = np.array([[0.0, 1.0, 0.0], [1e-17, 0.0, 0.0], [0.0, 0.0, -1e-3]])
    assert np.max(np.abs(np.linalg.eigvals(jordan).real)) > 1e-9           # what LAPACK gives
    text = eigenvalue_text(jordan)
    assert text.splitlines()[0] == "eigenvalues: -0.001, 0, 0", text
    assert "2 of them had a real or imaginary part within round-off of 0, below 1.5e-08" in text, text
    assert len(_eigenvalues(text)) == 3
    spin = np.array([[0.0, 2.0], [-2.0, 0.0]]) + 1e-18          # a centre: its real parts round-off
    assert eigenvalue_text(spin).splitlines()[0] == "eigenvalues: 0-2j, 0+2j"
    assert eigenvalue_text(np.zeros((2, 2))) == "eigenvalues: 0, 0"



def test_zeros_in_larger_jordan_blocks_print_as_zero_and_real_modes_stay():
    """A1 --floating-base --ground at its lifted start (first hour s29): A is nilpotent with
    Jordan blocks of size 4 (a base tilt turns gravity into a linear acceleration, q_rx -> v_y ->
    q_y), whose zeros LAPACK returns as +-2.4e-7j, above sqrt(eps |A|) = 4.7e-8: they printed as
    modes.  The same chain here, with a Jacobian entry at round-off (1e-15 of |A| ~ 10), puts
    LAPACK's values at 3e-4; the ranks of A, A^2, ... say 0 is 4-fold in a block of size 4, so
    those four print as 0 with a note saying why; a damped oscillator beside them is kept."""
    from eomc.cli.linearize import _zero_blocks, eigenvalue_text

    A = np.zeros((6, 6))
    A[0, 2] = A[1, 3] = 1.0     # q = (y, rx), v = (v_y, v_rx)
    A[2, 1] = 9.81              # tilt -> linear acceleration
    A[3, 0] = 1e-15             # round-off in a Jacobian entry
    A[4, 5], A[5, 4], A[5, 5] = 1.0, -4.0, -0.1
    assert np.sort(np.abs(np.linalg.eigvals(A)))[3] > 1e-4           # what LAPACK gives
    assert _zero_blocks(A) == (4, 4)
    text = eigenvalue_text(A, columns=100)
    assert text.splitlines()[0] == "eigenvalues: -0.05-1.99937j, -0.05+1.99937j, 0, 0, 0, 0", text
    note = " ".join(text.split())
    assert "A's zero eigenvalue is 4-fold, in Jordan blocks of up to size 4" in note, note
    assert _zero_blocks(np.diag([1e-9, -1e-3, 2.0])) == (0, 1)         # slow modes are not zeros
    assert _zero_blocks(np.array([[0.0, 1.0], [0.0, 0.0]])) == (2, 2)

def test_a_wide_matrix_is_printed_in_blocks_of_columns_that_fit():
    """A1 --floating-base --ground's A has 36 columns: one line per row was ~700 characters
    (first hour s28).  A table wider than the terminal (100 characters when not one) is printed
    in blocks of columns, every row named again in each; every entry is there once; a table that
    fits is one block as before.  The eigenvalues and the operating point wrap between items."""
    from eomc.cli.linearize import _matrix, eigenvalue_text
    rng = np.random.default_rng(2)
    names = [f"q_FL_calf_joint_{k}" for k in range(36)]
    M = rng.normal(size=(36, 36))
    text = _matrix("A", M, names, names, columns=100)
    lines = text.splitlines()
    assert max(len(line) for line in lines) <= 100, max(len(line) for line in lines)
    got, at = np.full_like(M, np.nan), 0
    for block in [i for i, line in enumerate(lines) if line.startswith("A (columns ")]:
        lo, hi = map(int, lines[block].split()[2].split("-"))
        assert lo == at + 1
        for i in range(36):
            row = lines[block + 2 + i].split()
            assert row[0] == names[i]
            got[i, lo - 1:hi] = [float(v) for v in row[1:]]
        at = hi
    assert at == 36 and lines[-1].startswith(names[-1])
    np.testing.assert_allclose(got, M, rtol=1e-5, atol=1e-6)              # printed to 6 digits
    small = _matrix("A", M[:3, :3], names[:3], names[:3], columns=100)
    assert small.splitlines()[0] == "A:" and len(small.splitlines()) == 5
    eig = eigenvalue_text(M, columns=100)
    assert max(len(line) for line in eig.splitlines()) <= 100 and eig.startswith("eigenvalues: ")
    values = eig.replace("\n  ", " ")[len("eigenvalues: "):].split(",")
    assert len(values) == 36


def test_a_slow_real_mode_below_the_round_off_band_prints_as_computed():
    """A real eigenvalue of -1e-9 (a slow decay, |A| ~ 2) lies below sqrt(eps |A|) = 2.1e-8 and
    printed as 0, hiding the mode (session 30's papercut); the ranks of A, A^2, ... say A has no zero
    eigenvalue, so it prints as computed, with a note saying it is within the band where a zero
    eigenvalue's round-off in a Jordan block lies.  A lightly damped centre keeps its real part
    likewise; round-off below n eps |A| (1e-18 on a centre) and the Jordan zeros still print as 0."""
    from eomc.cli.linearize import eigenvalue_text

    text = eigenvalue_text(np.diag([-1e-9, -1e-3, 2.0]), columns=200)
    assert text.splitlines()[0] == "eigenvalues: -0.001, -1e-09, 2", text
    note = " ".join(text.split())
    assert "-1e-09 is below 2.1e-08 = sqrt(eps |A|)" in note and "no zero eigenvalue" in note, note
    damped = eigenvalue_text(np.array([[-1e-9, 2.0], [-2.0, -1e-9]]), columns=200)
    assert damped.splitlines()[0] == "eigenvalues: -1e-09-2j, -1e-09+2j", damped
    assert eigenvalue_text(np.array([[0.0, 2.0], [-2.0, 0.0]]) + 1e-18).splitlines()[0] == "eigenvalues: 0-2j, 0+2j"
