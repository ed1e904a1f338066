"""Bad input to LagrangesMethod: ModelError naming the problem, never a SymPy traceback."""
import pytest
import sympy as sm

from eomc.errors import ModelError
from eomc.mechanics import (LagrangesMethod, Point, ReferenceFrame,
                            dynamicsymbols)

q1, q2 = dynamicsymbols("q1 q2")
q1d, q2d = dynamicsymbols("q1 q2", 1)
L = q1d**2 + q2d**2


def test_coordinate_not_a_function_of_time():
    x = sm.Symbol("x")
    with pytest.raises(ModelError, match="coordinate x is not a function of time"):
        LagrangesMethod(L, [q1, x])


def test_coordinate_given_twice():
    with pytest.raises(ModelError, match="q1.* twice"):
        LagrangesMethod(L, [q1, q1])


def test_coordinates_not_a_list():
    with pytest.raises(ModelError, match="list"):
        LagrangesMethod(L, q1)


def test_lagrangian_not_an_expression():
    N = ReferenceFrame("N")
    with pytest.raises(ModelError, match="Lagrangian must be a scalar"):
        LagrangesMethod(q1d * N.x, [q1])
    with pytest.raises(ModelError, match="Lagrangian must be a scalar"):
        LagrangesMethod([L, L], [q1, q2])


def test_lagrangian_with_third_derivative():
    lm = LagrangesMethod(L + q1.diff(dynamicsymbols._t, 2) ** 2, [q1, q2])
    with pytest.raises(ModelError, match="Lagrangian contains .*order 2"):
        lm.form_lagranges_equations()


def test_forcelist_without_frame():
    P = Point("P")
    with pytest.raises(ModelError, match="frame="):
        LagrangesMethod(L, [q1, q2], forcelist=[(P, 0)])


def test_frame_not_a_frame():
    with pytest.raises(ModelError, match="frame must be a ReferenceFrame"):
        LagrangesMethod(L, [q1, q2], forcelist=[], frame="N")


def _construct_with(loads):
    N = ReferenceFrame("N")
    return LagrangesMethod(L, [q1, q2], forcelist=loads(N), frame=N)


def test_bad_load_shape_names_the_item():
    P = Point("P")
    with pytest.raises(ModelError, match="forcelist item 1"):
        _construct_with(lambda N: [(P, N.x), (P, N.x, N.y)])


def test_bad_load_location():
    with pytest.raises(ModelError, match="item 0: the load's location q1"):
        _construct_with(lambda N: [(q1, N.x)])


def test_load_not_a_vector():
    P = Point("P")
    with pytest.raises(ModelError, match="load on P is 7"):
        _construct_with(lambda N: [(P, 7)])


def test_point_without_velocity():
    Q = Point("Q")
    lm = _construct_with(lambda N: [(Q, N.x)])
    with pytest.raises(ModelError, match="velocity of point Q in frame N is undefined"):
        lm.form_lagranges_equations()


def test_matrices_need_the_equations():
    lm = LagrangesMethod(L, [q1, q2])
    for attr in ("mass_matrix", "forcing", "mass_matrix_full", "forcing_full"):
        with pytest.raises(ModelError, match="form_lagranges_equations"):
            getattr(lm, attr)
    with pytest.raises(ModelError, match="form_lagranges_equations"):
        lm.formed()


def test_no_multipliers_to_solve():
    lm = LagrangesMethod(L, [q1, q2])
    lm.form_lagranges_equations()
    with pytest.raises(ModelError, match="no lagrange multipliers"):
        lm.solve_multipliers()


def test_constraint_not_an_expression():
    N = ReferenceFrame("N")
    with pytest.raises(ModelError, match="hol_coneqs"):
        LagrangesMethod(L, [q1, q2], hol_coneqs=[N.x])


def test_model_error_is_a_value_error():
    with pytest.raises(ValueError):
        LagrangesMethod(L, [q1, sm.Symbol("y")])


def test_holonomic_constraint_with_velocities():
    with pytest.raises(ModelError, match="holonomic constraint .* order 1"):
        LagrangesMethod(L, [q1, q2], hol_coneqs=[q1d - q2])
