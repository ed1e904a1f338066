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


def test_inspect_reads_a_built_directory_or_its_json_as_built(tmp_path, capsys):
    """A built directory (or its NAME.json) is inspected from NAME.json: the same sizes, counts and
    sparsity as the model file's report.  Before: "cannot read model file (Is a directory)", and the
    JSON was run as Python ("ur5_robot.json:293: NameError: name 'null' is not defined")."""
    model = model_files.write(tmp_path, model_files.CART, "cart")
    assert main(["build", str(model), "-o", str(tmp_path / "out"), "-q"]) == 0
    capsys.readouterr()
    assert main(["inspect", str(model), "-q"]) == 0
    from_file = capsys.readouterr().out
    report = from_file.split("\n\nformulation: ")[0]
    for target in (tmp_path / "out", tmp_path / "out" / "cart.json"):
        assert main(["inspect", str(target)]) == 0
        out = capsys.readouterr().out
        assert out.split("\n\nformulation: ")[0] == report
        assert "formulation: " in out and "(as built)" in out


def test_inspect_of_a_built_model_refuses_build_options_and_empty_directories(tmp_path, capsys):
    model = model_files.write(tmp_path, model_files.CART, "cart")
    assert main(["build", str(model), "-o", str(tmp_path / "out"), "-q"]) == 0
    capsys.readouterr()
    assert main(["inspect", str(tmp_path / "out"), "--outputs", "rhs", "--formulation", "kane"]) == 2
    err = capsys.readouterr().err
    assert "--formulation, --outputs shape a build: a built model is inspected as it was built" in err, err
    (tmp_path / "empty").mkdir()
    assert main(["inspect", str(tmp_path / "empty")]) == 2
    err = capsys.readouterr().err
    assert "a directory with no built model in it" in err and err.count("\n") == 1, err
    (tmp_path / "other.json").write_text("[1]")
    assert main(["inspect", str(tmp_path / "other.json")]) == 2
    assert "not the NAME.json of a built model" in capsys.readouterr().err
