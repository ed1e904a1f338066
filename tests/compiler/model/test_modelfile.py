"""Model files: what is read from them, and mistakes reported at the user's file:line."""
import textwrap

import pytest
import sympy as sm

from helpers import model_files
from eomc.compiler.model import assignment_lines, model_spec
from eomc.errors import ModelError, ModelFileError

# A valid pendulum, then one mistake appended (lines after HEAD_LINES).
HEAD = model_files.PENDULUM
HEAD_LINES = HEAD.count("\n")


def _file(tmp_path, text, name="m"):
    return model_files.write(tmp_path, text, name)


def _error(tmp_path, text):
    path = _file(tmp_path, text)
    with pytest.raises(ModelFileError) as info:
        model_spec(path)
    return path, info.value


def test_reads_every_variable(tmp_path):
    spec = model_spec(_file(tmp_path, HEAD, "my-pendulum"))
    names = {str(s): v for s, v in spec.parameters.items()}
    assert spec.name == "pend"  # the file's `name`
    assert names == {"m": 2.0, "l": 0.5, "g": 9.81}
    assert spec.initial_state == [0.3, 0.0]
    assert list(spec.outputs) == ["energy"]
    assert spec.formed.nq == 1 and spec.path.name == "my-pendulum.py"


def test_name_defaults_to_sanitized_stem(tmp_path):
    spec = model_spec(_file(tmp_path, HEAD.replace('name = "pend"\n', ""), "2-link"))
    assert spec.name == "model_2_link"


def test_missing_system(tmp_path):
    path, error = _error(tmp_path, "x = 1\n")
    assert str(error).startswith(f"{path}: does not define `system`")


# SymPy's documentation scripts end with their formed method under another name (KM, LM).
_SYMPY_DOCS_KANE = textwrap.dedent("""\
    from sympy import symbols
    from sympy.physics.mechanics import *
    q, u = dynamicsymbols('q u')
    qd = dynamicsymbols('q', 1)
    m, c, k = symbols('m c k')
    N = ReferenceFrame('N')
    P = Point('P')
    P.set_vel(N, u * N.x)
    KM = KanesMethod(N, q_ind=[q], u_ind=[u], kd_eqs=[qd - u])
    fr, frstar = KM.kanes_equations([Particle('pa', P, m)], [(P, (-k * q - c * u) * N.x)])
    parameters = {m: 1.0, c: 0.1, k: 4.0}
    """)


def test_the_files_only_method_is_its_system_with_a_warning(tmp_path):
    from eomc.errors import EomcWarning
    path = _file(tmp_path, _SYMPY_DOCS_KANE, "kane_docs")
    with pytest.warns(EomcWarning, match=r"kane_docs.py:9: no `system` variable: compiling KM, the file's "
                                         r"one KanesMethod \(write `system = KM` to say so\)"):
        spec = model_spec(path)
    assert spec.formed.nq == 1 and {str(s) for s in spec.parameters} == {"m", "c", "k"}


def test_several_methods_without_system_are_named(tmp_path):
    text = _SYMPY_DOCS_KANE + "KM2 = KanesMethod(N, q_ind=[q], u_ind=[u], kd_eqs=[qd - u])\n"
    path, error = _error(tmp_path, text)
    assert str(error).startswith(f"{path}: does not define `system`")
    assert "it defines KM (KanesMethod, line 9), KM2 (KanesMethod, line 12)" in str(error)


def test_exception_in_user_code_points_at_its_line(tmp_path):
    path, error = _error(tmp_path, "import math\n\nvalue = math.sqrt(-1)\nsystem = None\n")
    assert str(error) == f"{path}:3: ValueError: math domain error"
    assert error.lineno == 3 and error.filename == str(path)


def test_exception_deep_in_library_points_at_the_users_call(tmp_path):
    text = "from eomc.mechanics import *\nN = ReferenceFrame('N')\n\nA = N.orientnew('A', 'Axis', [1, 2, 3])\n"
    path, error = _error(tmp_path, text)
    assert error.lineno == 4 and str(error).startswith(f"{path}:4: ")


def test_syntax_error_has_line(tmp_path):
    path, error = _error(tmp_path, "system = (\n\nx = 1 +\n")
    assert error.filename == str(path) and error.lineno is not None


def test_system_of_wrong_type(tmp_path):
    path, error = _error(tmp_path, "x = 1\nsystem = 42\n")
    assert str(error).startswith(f"{path}:2: `system` is a int; expected a System")


@pytest.mark.parametrize("mistake, message", [
    ("parameters = [1.0, 2.0]", "`parameters` must be a dict symbol -> default value, not list"),
    ("parameters = {m: 'heavy'}", "the default of parameter `m` must be a real number, not str 'heavy'"),
    ("parameters = {m: True}", "must be a real number"),
    ("parameters = {sm.Symbol('mass'): 1.0}", "unknown parameter `mass`: it does not appear in the equations of motion or outputs (parameters: g, l, m)"),
    ("parameters = {'m': 1.0, 'k': 3.0}", "unknown parameter `k`"),
    ("inputs = q", "`inputs` must be a list of dynamic symbols"),
    ("inputs = [dynamicsymbols('T')]", "unknown input(s) T"),
    ("initial_state = {'zz': 1.0}", "`zz` in initial_state is not a coordinate or speed (states: q, u)"),
    ("initial_state = [0.1]", "`initial_state` must be a dict"),
    ("outputs = {'e': dynamicsymbols('z') ** 2}", "output `e` uses z, which is not a coordinate, speed or input"),
    ("outputs = {'bad name': q}", "output name 'bad name' must be an identifier"),
    ("outputs = {'v': N.x}", "output `v`"),
    ("name = '3d'", "model name '3d' must be a C identifier"),
])
def test_bad_variables_point_at_their_assignment(tmp_path, mistake, message):
    path, error = _error(tmp_path, HEAD + "\n" + mistake + "\n")
    assert error.lineno == HEAD_LINES + 2, str(error)
    assert str(error).startswith(f"{path}:{HEAD_LINES + 2}: ")
    assert message in str(error)


def test_missing_inputs_are_named(tmp_path):
    text = model_files.CART.replace("inputs = [F]", "inputs = []")
    path, error = _error(tmp_path, text)
    assert "use input(s) F that `inputs` does not list" in str(error)


def test_keyword_overrides_are_checked_as_arguments(tmp_path):
    with pytest.raises(ModelError, match="unknown parameter `nope`") as info:
        model_spec(_file(tmp_path, HEAD), parameters={"nope": 1.0})
    assert not isinstance(info.value, ModelFileError)


def test_sympy_formed_system_is_converted(tmp_path):
    text = HEAD.replace("from eomc.mechanics import *", "from sympy.physics.mechanics import *")
    spec = model_spec(_file(tmp_path, text))
    assert spec.formed.nq == 1
    assert type(spec.system).__module__.startswith("sympy.physics")
    assert sm.Symbol("g") in spec.formed.parameters


def test_helper_module_beside_the_file_is_importable(tmp_path):
    (tmp_path / "helper_mod_xyz.py").write_text("VALUE = 3.0\n")
    text = HEAD + "\nfrom helper_mod_xyz import VALUE\nparameters = {m: VALUE, g: 9.81, l: 1.0}\n"
    spec = model_spec(_file(tmp_path, text))
    assert {str(k): v for k, v in spec.parameters.items()} == {"m": 3.0, "g": 9.81, "l": 1.0}


def test_partial_parameters_name_the_missing_ones(tmp_path):
    text = HEAD + "\nparameters = {m: 2.0}\n"
    with pytest.raises(ModelFileError, match=r"m\.py:\d+: no default value for g, l"):
        model_spec(_file(tmp_path, text))


def test_assignment_lines_cover_all_forms():
    source = textwrap.dedent("""\
        a = 1
        b: int = 2
        c, (d, e) = 1, (2, 3)
        a += 1
        def f():
            z = 1
        """)
    assert assignment_lines(source) == {"a": 4, "b": 2, "c": 3, "d": 3, "e": 3}


def test_parameters_override_merges_with_the_files_defaults(tmp_path):
    text = HEAD + "\nparameters = {m: 2.0, g: 9.81, l: 0.5}\n"
    spec = model_spec(_file(tmp_path, text), parameters={"m": 3.0})
    assert {str(k): v for k, v in spec.parameters.items()} == {"m": 3.0, "g": 9.81, "l": 0.5}


def test_a_built_model_or_a_directory_is_not_read_as_a_model_file(tmp_path):
    """`eomc show out/`, `eomc build out/NAME.json`, eomc.compile("out/"): said as what they are.
    Before: "cannot read model file (Is a directory)", and NAME.json was executed as Python and
    failed at its first null ("NameError: name 'null' is not defined")."""
    built = tmp_path / "out"
    built.mkdir()
    (built / "pend.json").write_text('{"name": "pend", "initial_state": null}')
    (built / "libpend.so").write_bytes(b"")
    with pytest.raises(ModelFileError, match=r"out: a built model directory \(pend.json\): a built model is "
                                             r"loaded \(eomc.load, or eomc simulate"):
        model_spec(built)
    with pytest.raises(ModelFileError, match=r"pend.json: a built model's metadata \(NAME.json\), not a model "
                                             r"file: .* give the model file it was built from"):
        model_spec(built / "pend.json")
    with pytest.raises(ModelFileError, match=r"empty: a directory, not a model file \(.py, .urdf or MuJoCo's "
                                             r".xml\)$"):
        (tmp_path / "empty").mkdir()
        model_spec(tmp_path / "empty")
