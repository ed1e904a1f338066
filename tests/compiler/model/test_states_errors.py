"""Bad `states` in a model file: one line, file:line of the offending entry, naming the state."""
import re

import pytest

import eomc
from eomc.errors import ModelFileError
from helpers.state_models import PENDULUM_Z

FIRST = PENDULUM_Z.count("\n") + 1      # the line `states = {` starts on

CASES = [
    ("states = {\n    z: (e - z) / tau,\n    w: None,\n}", FIRST + 2,
     "state `w` has no derivative"),
    ("states = [z]", FIRST, "`states` lists 1 state(s) without derivatives"),
    ("states = {\n    z: (e - z) / tau + sm.Symbol('c'),\n}", FIRST + 1,
     "the derivative of state `z` uses c, which `parameters` does not declare"),
    ("states = {\n    z: (e - z) / tau,\n    w: z + dynamicsymbols('v'),\n}", FIRST + 2,
     "the derivative of state `w` uses v, which is not a coordinate, speed, state or input"),
    ("states = {\n    z: (e - z) / tau,\n    q: 1,\n}", FIRST + 2,
     "state `q` has the name of a coordinate of the system"),
    ("states = {z: (e - z) / tau, dynamicsymbols('u'): 0}", FIRST,
     "state `u` has the name of a speed of the system"),
    ("states = {z: u.diff()}", FIRST, "the derivative of state `z` uses u' (an acceleration)"),
    ("states = {z: w.diff()}", FIRST, "the derivative of state `z` uses w'"),
    ("states = {w: -w}", FIRST, "the equations of motion use z, which is neither a state nor listed in "
                                "`inputs`: if it is a state, give its derivative in `states = {z: ...}`"),
    ("states = {z: sm.zoo}", FIRST, "the derivative of state `z` contains zoo"),
]


@pytest.mark.parametrize("text, line, message", CASES)
def test_bad_states_name_the_state_at_its_line(tmp_path, text, line, message):
    path = tmp_path / "bad.py"
    path.write_text(PENDULUM_Z + text + "\n")
    with pytest.raises(ModelFileError) as info:
        eomc.compile(path, cache_dir=tmp_path / "cache")
    text = str(info.value)
    assert text.startswith(f"{path}:{line}: "), text
    assert message in text
    assert "\n" not in text and "Traceback" not in text


def test_states_argument_errors_are_model_errors(tmp_path):
    from eomc.errors import ModelError
    ns = {}
    exec(PENDULUM_Z, ns)
    with pytest.raises(ModelError, match=re.escape("state `z` has no derivative")):
        eomc.compile(ns["system"], parameters=ns["parameters"], inputs=ns["inputs"],
                     states={ns["z"]: None}, cache_dir=tmp_path)


def test_show_prints_the_extra_states(tmp_path):
    from eomc.cli.show import format_equations
    from eomc.compiler.model import model_spec
    path = tmp_path / "good.py"
    path.write_text(PENDULUM_Z + "states = {z: (e - z) / tau}\n")
    text = format_equations(model_spec(str(path)), ascii_only=True)
    assert "states z:      z" in text and "extra states  z' =" in text
    assert "inputs:        e" in text and "tau=0.1" in text
