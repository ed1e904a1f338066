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


def test_an_euler_angle_of_a_quaternion_joint_says_how_to_get_it():
    """MJCF free and ball joints became quaternions by default (session 30): a script's dict x0
    naming the old body-XYZ angle is told the quaternion's names and orientation="euler"; a name
    that is no angle of a quaternion joint gets no such sentence."""
    names = ["q_root_x", "q_root_qw", "q_root_qx", "q_root_qy", "q_root_qz", "q_hip"]
    with pytest.raises(ValueError, match=r"unknown state 'q_root_ry' \(q_root_ry: a body-XYZ angle; MJCF free and "
                                         r"ball joints are quaternions by default, q_root_qw, q_root_qx, q_root_qy, "
                                         r"q_root_qz .*orientation=\"euler\""):
        index_of("q_root_ry", names, "state", "ant")
    with pytest.raises(ValueError) as info:
        index_of("q_hip_rx", names, "state", "ant")
    assert "body-XYZ" not in str(info.value)
