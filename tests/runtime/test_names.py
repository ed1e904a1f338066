"""Dict keys name a model's entries by string or by the SymPy objects the model was written with."""
import pytest
import sympy as sm
from sympy.physics.mechanics import dynamicsymbols

from eomc.runtime.names import index_of, model_name


def test_sympy_objects_map_to_the_model_names():
    q1 = dynamicsymbols("q1")
    assert model_name(q1) == "q1"
    assert model_name(q1.diff()) == "q1'"
    assert model_name(q1.diff(sm.Symbol("t"), 2)) == "q1''"
    assert model_name(sm.Symbol("m")) == "m"
    assert model_name("u0") == "u0"


def test_index_of_finds_names_and_lists_the_valid_ones():
    names = ["q1", "q1'"]
    assert index_of(dynamicsymbols("q1").diff(), names, "state", "pend") == 1
    assert index_of("q1", names, "state", "pend") == 0
    with pytest.raises(ValueError, match=r"pend: unknown state 'q2'; valid names: q1, q1'"):
        index_of(dynamicsymbols("q2"), names, "state", "pend")
