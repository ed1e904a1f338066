"""`eomc inspect`: sizes, per-function operation counts and the mass matrix's sparsity."""

from helpers import model_files
from eomc.cli import main
from eomc.cli.inspect import format_report


def test_inspect_prints_sizes_counts_and_sparsity(tmp_path, capsys):
    model = model_files.write(tmp_path, model_files.CART, "cart")
    assert main(["inspect", str(model)]) == 0
    out = capsys.readouterr().out
    assert "sizes: nq=2, nu=2, nx=4, nparam=4, ninput=1" in out
    assert "states: x, th, v, w" in out and "inputs: F" in out
    rows = {line.split()[0]: line.split()[1:] for line in out.splitlines()
            if line and line.split()[0] in ("rhs", "mass_matrix", "jac_x")}
    assert set(rows) == {"rhs", "mass_matrix", "jac_x"}
    adds, muls, divs, calls, total = map(int, rows["rhs"])
    assert total == adds + muls + divs + calls and muls > 0
    assert "mass matrix sparsity" in out


def test_inspect_respects_outputs_selection(tmp_path, capsys):
    model = model_files.write(tmp_path, model_files.PENDULUM, "p")
    assert main(["inspect", str(model), "--outputs", "rhs"]) == 0
    names = [line.split()[0] for line in capsys.readouterr().out.splitlines() if line.strip()]
    assert "rhs" in names and "jac_x" not in names and "mass_matrix" not in names


def test_report_shows_structural_zeros():
    metadata = {"name": "m", "nq": 2, "nu": 2, "state_names": ["a", "b"], "param_names": [],
                "input_names": [], "output_names": [],
                "op_counts": {"rhs": {"adds": 1, "muls": 2, "divs": 3, "calls": 4}},
                "mass_matrix_sparsity": ["x.", ".x"]}
    text = format_report(metadata)
    assert "mass matrix sparsity (2 of 4 entries nonzero):\n  x .\n  . x" in text
    assert "rhs                      1       2       3       4       10" in text


def test_inspect_says_which_formulation_auto_took_and_why(tmp_path, capsys):
    """No --formulation: auto.  The cart (a formed KanesMethod, a tree of 2 speeds): both
    forms are compared, the cheaper rhs (by cost) is kept, and inspect prints both costs."""
    model = model_files.write(tmp_path, model_files.CART, "cart")
    assert main(["inspect", str(model)]) == 0
    out = capsys.readouterr().out
    lines = [line for line in out.splitlines() if line.startswith("formulation: ")]
    assert len(lines) == 1, out
    chosen = lines[0].split()[1]
    assert chosen in ("kane", "recursive") and "(asked for: auto)" in lines[0]
    assert "auto compared rhs costs (operations weighted: a call 36, " in out
    compared = next(line for line in out.splitlines() if "auto compared rhs costs" in line)
    costs = dict(part.split() for part in compared.split("): ", 1)[1].split(", "))
    assert chosen == min(costs, key=lambda f: int(costs[f]))
    # linearize has no code of its own: its row is marked as jac_x + jac_r
    assert "linearize*" in out and "runs jac_x and jac_r" in out


def test_report_marks_linearize_as_the_sum_of_the_jacobians():
    metadata = {"name": "m", "nq": 1, "nu": 1, "state_names": ["a", "b"], "param_names": [],
                "input_names": [], "output_names": [],
                "op_counts": {"jac_x": {"adds": 5, "muls": 5, "divs": 0, "calls": 0},
                              "linearize": {"adds": 5, "muls": 5, "divs": 0, "calls": 0}}}
    text = format_report(metadata)
    assert "linearize*" in text and "no code of its own" in text
