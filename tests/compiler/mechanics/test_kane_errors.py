"""Bad input to KanesMethod raises ModelError naming the culprit (never a SymPy traceback)."""
import pytest
import sympy as sm

from eomc.errors import ModelError
from eomc.mechanics import (KanesMethod, Particle, Point, ReferenceFrame, RigidBody,
                            dynamicsymbols, inertia)


@pytest.fixture
def cart():
    N = ReferenceFrame("N")
    q, u = dynamicsymbols("q u")
    P = Point("P")
    P.set_vel(N, u * N.x)
    return N, q, u, P, Particle("Pa", P, sm.Symbol("m"))


def test_kinematic_equation_count(cart):
    N, q, u, P, pa = cart
    q2, u2 = dynamicsymbols("q2 u2")
    with pytest.raises(ModelError, match=r"1 kinematic differential equation.*2 coordinate.*q2"):
        KanesMethod(N, [q, q2], [u, u2], [q.diff() - u])


def test_dependent_speeds_without_velocity_constraints(cart):
    N, q, u, P, pa = cart
    u2 = dynamicsymbols("u2")
    with pytest.raises(ModelError, match="dependent speeds \\(u2\\).*without velocity_constraints"):
        KanesMethod(N, [q], [u], [q.diff() - u], u_dependent=[u2])


def test_dependent_speed_count_mismatch(cart):
    N, q, u, P, pa = cart
    u2, u3 = dynamicsymbols("u2 u3")
    with pytest.raises(ModelError, match=r"2 dependent speed\(s\) \(u2, u3\) but 1 velocity"):
        KanesMethod(N, [q], [u], [q.diff() - u], u_dependent=[u2, u3],
                    velocity_constraints=[u2 - u])


def test_configuration_constraint_count_mismatch(cart):
    N, q, u, P, pa = cart
    q2 = dynamicsymbols("q2")
    with pytest.raises(ModelError, match=r"1 dependent coordinate\(s\) \(q2\) but 0 configuration"):
        KanesMethod(N, [q], [u], [q.diff() - u, q2.diff() - u], q_dependent=[q2])


def test_coordinate_not_a_function_of_time(cart):
    N, q, u, P, pa = cart
    x = sm.Symbol("x")
    with pytest.raises(ModelError, match=r"coordinate #1 \(x\) is not a function of time"):
        KanesMethod(N, [x], [u], [sm.Symbol("xd") - u])
    with pytest.raises(ModelError, match=r"speed #1 \(w\(s\)\) is not a function of time"):
        KanesMethod(N, [q], [sm.Function("w")(sm.Symbol("s"))], [q.diff()])


def test_load_on_point_without_velocity(cart):
    N, q, u, P, pa = cart
    Q = Point("Floating")
    km = KanesMethod(N, [q], [u], [q.diff() - u])
    with pytest.raises(ModelError, match="load #2 on point Floating.*velocity of point Floating"):
        km.kanes_equations([pa], [(P, N.x), (Q, N.y)])


def test_body_whose_point_has_no_velocity(cart):
    N, q, u, P, pa = cart
    lost = Particle("Lost", Point("Nowhere"), 1)
    km = KanesMethod(N, [q], [u], [q.diff() - u])
    with pytest.raises(ModelError, match=r"body #2 \(Lost\).*point Nowhere"):
        km.kanes_equations([pa, lost], [(P, N.x)])


@pytest.mark.parametrize("loads, pattern", [
    ("force", "expects lists of bodies and of loads, got 'force'"),
    ([(1, 2, 3)], r"load #1 .* is not a \(Point, Vector\)"),
    ([("P", sm.Symbol("f"))], r"load #1 .*first item must be a Point or a ReferenceFrame"),
])
def test_loads_in_wrong_shapes(cart, loads, pattern):
    N, q, u, P, pa = cart
    km = KanesMethod(N, [q], [u], [q.diff() - u])
    with pytest.raises(ModelError, match=pattern):
        km.kanes_equations([pa], loads)


def test_load_vector_not_a_vector(cart):
    N, q, u, P, pa = cart
    km = KanesMethod(N, [q], [u], [q.diff() - u])
    with pytest.raises(ModelError, match=r"load #2 .*second item must be a Vector"):
        km.kanes_equations([pa], [(P, N.x), (P, sm.Symbol("f"))])


def test_bodies_in_wrong_shapes(cart):
    N, q, u, P, pa = cart
    km = KanesMethod(N, [q], [u], [q.diff() - u])
    with pytest.raises(ModelError, match=r"body #2 \('not a body'\) is not a Particle or RigidBody"):
        km.kanes_equations([pa, "not a body"], [(P, N.x)])
    with pytest.raises(ModelError, match="mixes bodies and loads"):
        km.kanes_equations([pa, (P, N.x)], [(P, N.x)])
    with pytest.raises(ModelError, match="no bodies"):
        km.kanes_equations(None, [(P, N.x)])


def test_kinematic_equation_without_qdot(cart):
    N, q, u, P, pa = cart
    q2, u2 = dynamicsymbols("q2 u2")
    with pytest.raises(ModelError, match=r"kinematic differential equation #2 \(q\(t\) - u2\(t\)\)"
                                         r".*cannot be solved for q'"):
        KanesMethod(N, [q, q2], [u, u2], [q.diff() - u, q - u2])


def test_kinematic_equations_singular(cart):
    N, q, u, P, pa = cart
    q2, u2 = dynamicsymbols("q2 u2")
    kd = [q.diff() + q2.diff() - u, 2 * q.diff() + 2 * q2.diff() - u2]
    with pytest.raises(ModelError, match="cannot be solved for q'.*singular.*#1"):
        KanesMethod(N, [q, q2], [u, u2], kd)


def test_kinematic_equation_nonlinear(cart):
    N, q, u, P, pa = cart
    with pytest.raises(ModelError, match=r"kinematic differential equation #1 .* not linear in"):
        KanesMethod(N, [q], [u], [q.diff() ** 2 - u])


def test_inertial_frame_required(cart):
    N, q, u, P, pa = cart
    with pytest.raises(ModelError, match="inertial ReferenceFrame"):
        KanesMethod("N", [q], [u], [q.diff() - u])


def test_equations_needed_before_results(cart):
    N, q, u, P, pa = cart
    km = KanesMethod(N, [q], [u], [q.diff() - u])
    with pytest.raises(ModelError, match="call kanes_equations"):
        km.mass_matrix
    with pytest.raises(ModelError, match="call kanes_equations"):
        km.formed()


def test_rigid_body_frame_without_angular_velocity():
    N = ReferenceFrame("N")
    B = ReferenceFrame("Loose")
    q, u = dynamicsymbols("q u")
    G = Point("G")
    G.set_vel(N, u * N.x)
    body = RigidBody("Rb", G, B, 1, (inertia(B, 1, 1, 1), G))
    km = KanesMethod(N, [q], [u], [q.diff() - u])
    with pytest.raises(ModelError, match=r"body #1 \(Rb\).*angular velocity of frame Loose"):
        km.kanes_equations([body], [(G, N.x)])


def test_load_vector_in_an_unoriented_frame(cart):
    N, q, u, P, pa = cart
    Stray = ReferenceFrame("Stray")
    km = KanesMethod(N, [q], [u], [q.diff() - u])
    with pytest.raises(ModelError, match="load on point P: frame Stray is not oriented"):
        km.kanes_equations([pa], [(P, Stray.x)])
