"""Values that used to slip past validation (reliability report F5) are model errors at file:line.

Each case appends one mistake to a valid pendulum (or edits its load) and
expects a ModelFileError naming the file, the line and the symbol or
expression, raised while deriving -- before any C is generated.
"""
import subprocess
import sys
import warnings

import pytest

from helpers import model_files
import eomc
from eomc import mechanics as em
from eomc.cli import main
from eomc.compiler.model import model_spec
from eomc.compiler.model.validate import non_real_constants
from eomc.errors import EomcWarning, ModelError, ModelFileError

HEAD = model_files.PENDULUM
HEAD_LINES = HEAD.count("\n")
SYSTEM_LINE = HEAD.splitlines().index("system = kane") + 1
LOAD = "[(P, -m * g * N.y)]"


def _error(tmp_path, text, name="m"):
    path = model_files.write(tmp_path, text, name)
    with pytest.raises(ModelFileError) as info:
        model_spec(path)
    return path, info.value


@pytest.mark.parametrize("default, message", [
    ("float('nan')", "the default of parameter `m` must be a finite real number, not nan"),
    ("float('inf')", "the default of parameter `m` must be a finite real number, not inf"),
    ("-float('inf')", "the default of parameter `m` must be a finite real number, not -inf"),
    ("10**400", "the default of parameter `m` must be a finite real number; an integer of about 400 digits is too large"),
    ("10**5000", "an integer of about 5000 digits is too large for a double"),
    ("sm.oo", "the default of parameter `m` must be a finite real number, not oo"),
    ("1 + 2j", "the default of parameter `m` must be a real number, not complex (1+2j)"),
    ("sm.I", "the default of parameter `m` must be a real number, not the expression I"),
    ("sm.zoo", "the default of parameter `m` must be a real number, not the expression zoo"),
])
def test_non_finite_or_complex_parameter_defaults(tmp_path, default, message):
    path, error = _error(tmp_path, HEAD + f"\nparameters = {{m: {default}, l: 1.0, g: 9.81}}\n")
    assert str(error).startswith(f"{path}:{HEAD_LINES + 2}: "), str(error)
    assert message in str(error)


@pytest.mark.parametrize("value", ["float('inf')", "float('nan')", "10**400"])
def test_non_finite_initial_state(tmp_path, value):
    path, error = _error(tmp_path, HEAD + f"\ninitial_state = {{q: {value}}}\n")
    assert str(error).startswith(f"{path}:{HEAD_LINES + 2}: initial_state[q] must be a finite real number")


@pytest.mark.parametrize("expr, word", [
    ("sm.zoo * q", "zoo (complex infinity"),
    ("sm.I * q", "I (the imaginary unit"),
    ("sm.nan * q", "nan (not a number"),
    ("sm.oo * q", "oo (infinity)"),
    ("q / 0", "zoo (complex infinity"),
])
def test_non_real_constants_in_outputs(tmp_path, expr, word):
    path, error = _error(tmp_path, HEAD + f"\noutputs = {{'e': {expr}}}\n")
    assert str(error).startswith(f"{path}:{HEAD_LINES + 2}: output `e` contains {word}"), str(error)


@pytest.mark.parametrize("extra, where, word", [
    ("q / 0 * N.x", "forcing row 1", "zoo"),
    ("sm.I * q * N.x", "forcing row 1", "I (the imaginary unit"),
    ("sm.oo * q * N.x", "forcing row 1", "-oo (infinity)"),
])
def test_non_real_constants_in_the_equations(tmp_path, extra, where, word):
    text = HEAD.replace(LOAD, f"[(P, -m * g * N.y + {extra})]")
    path, error = _error(tmp_path, text)
    assert str(error).startswith(f"{path}:{SYSTEM_LINE}: the {where} contains {word}"), str(error)


def test_imaginary_mass_reaches_the_mass_matrix(tmp_path):
    text = HEAD.replace('bob = Particle("bob", P, m)', 'bob = Particle("bob", P, m * sm.I)')
    path, error = _error(tmp_path, text)
    assert f"{path}:{SYSTEM_LINE}: the mass matrix row 1 contains I" in str(error)


def test_derivative_of_an_undeclared_dynamic_symbol(tmp_path):
    # used to build a model with two independent inputs, w and w'
    text = HEAD.replace(LOAD, "[(P, -m * g * N.y + dynamicsymbols('w').diff() * N.x)]")
    path, error = _error(tmp_path, text)
    assert str(error).startswith(f"{path}:{SYSTEM_LINE}: the equations of motion use w' "
                                 f"(the time derivative of w), but w is not a coordinate or speed")


def test_derivative_of_an_input_in_outputs(tmp_path):
    text = model_files.CART + "\noutputs = {'dF': F.diff()}\n"
    path, error = _error(tmp_path, text)
    assert "output `dF` uses F' (the time derivative of F)" in str(error)


def test_coordinate_rates_in_outputs_stay_allowed(tmp_path):
    spec = model_spec(model_files.write(tmp_path, HEAD + "\noutputs = {'qd': q.diff()}\n", "m"))
    assert list(spec.outputs) == ["qd"]


def test_not_utf8_names_the_file_and_exits_1(tmp_path, capsys):
    path = tmp_path / "binary.py"
    path.write_bytes(b"# model\nx = '\xff\xfe'\n")
    with pytest.raises(ModelFileError, match=r"binary\.py: not a model file: it is not UTF-8 text "
                                             r"\(byte 0xff at position 13, line 2\)"):
        model_spec(path)
    assert main(["show", str(path)]) == 1
    assert f"eomc show: error: {path}: not a model file" in capsys.readouterr().err


def test_a_declared_latin1_file_is_read(tmp_path):
    path = model_files.write(tmp_path, "# -*- coding: latin-1 -*-\n" + HEAD, "latin")
    path.write_bytes(path.read_bytes() + "\n# caf\u00e9\n".encode("latin-1"))
    assert model_spec(path).name == "pend"


def test_bad_model_is_refused_before_any_c_is_written(tmp_path, capsys):
    path = model_files.write(tmp_path, HEAD + "\nparameters = {m: float('nan'), l: 1.0, g: 9.81}\n", "nanp")
    cache, out = tmp_path / "cache", tmp_path / "out"
    assert main(["build", str(path), "-o", str(out), "--cache-dir", str(cache), "-q"]) == 1
    assert f"{path}:{HEAD_LINES + 2}: the default of parameter `m`" in capsys.readouterr().err
    assert not out.exists()
    assert not list(cache.rglob("*.c"))


def test_python_api_errors_have_no_file(tmp_path):
    import sympy as sm
    namespace = {}
    exec(HEAD, namespace)
    with pytest.raises(ModelError, match="the default of parameter `m` must be a finite real number"):
        model_spec(namespace["kane"], parameters={namespace["m"]: float("nan"), "l": 1.0, "g": 9.81})
    assert non_real_constants([sm.Symbol("x") + 1, sm.pi]) == []


def test_no_parameters_warns_once_naming_each(tmp_path):
    path = model_files.write(tmp_path, HEAD.replace("parameters = {m: 2.0, l: 0.5, g: 9.81}\n", ""), "nop")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("default")
        model_spec(path)
        model_spec(path)
    mine = [w for w in caught if issubclass(w.category, EomcWarning)]
    assert len(mine) == 1
    assert "no `parameters` dict: every parameter defaults to 1.0 (g, l, m)" in str(mine[0].message)
    assert mine[0].filename == __file__  # points at the caller, not inside eomc


def test_given_parameters_do_not_warn(tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("error", EomcWarning)
        model_spec(model_files.write(tmp_path, HEAD, "m"))


def test_cli_prints_the_warning_as_one_line(tmp_path, capsys):
    path = model_files.write(tmp_path, HEAD.replace("parameters = {m: 2.0, l: 0.5, g: 9.81}\n", ""), "nop2")
    run = subprocess.run([sys.executable, "-m", "eomc", "show", str(path)], capture_output=True,
                         text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert run.stderr.startswith(f"eomc show: warning: {path}: no `parameters` dict")
    assert "EomcWarning" not in run.stderr and run.stderr.count("\n") == 1


def test_empty_system_is_refused_naming_the_missing_states(tmp_path, monkeypatch):
    """A System with no joints or bodies used to build a 0-state model whose simulate() then
    failed with "bad argument (the model failed at t=nan ...)"; it is refused before any C."""
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    ground = em.RigidBody("ground")
    system = em.System.from_newtonian(ground)
    with pytest.raises(ModelError, match="no coordinates, speeds or states.*nothing to integrate"):
        eomc.compile(system, progress=False)
    assert not (tmp_path / "cache").exists() or not any((tmp_path / "cache").rglob("*.so"))
