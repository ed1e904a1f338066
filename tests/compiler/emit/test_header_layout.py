"""The generated NAME.h documents the order of x, p (with defaults), r and the outputs.

A C user reads the header, not NAME.json: the indices there must be the ones
the functions use, i.e. the metadata's order (the `parameters` dict's order,
not alphabetical).
"""
import sympy as sm
from sympy.physics.vector import dynamicsymbols

from eomc.compiler.emit import generate_c
from eomc.compiler.mechanics.formed import FormedSystem


def _cart():
    x, v = dynamicsymbols("x v")
    F = dynamicsymbols("F")
    m, k, c = sm.symbols("m k c")
    formed = FormedSystem(method="kane", coordinates=(x,), speeds=(v,), n_dependent_coordinates=0,
                          n_dependent_speeds=0, kinematics=sm.Matrix([v]),
                          dynamics_matrix=sm.Matrix([[m]]), dynamics_rhs=sm.Matrix([F - k * x - c * v]),
                          multipliers=(), holonomic_constraints=sm.zeros(0, 1),
                          velocity_constraints=sm.zeros(0, 1), inputs=(F,), parameters=(c, k, m))
    return generate_c(formed, "cart", parameters={m: 2.5, k: 4.0, c: 0.1},
                      outputs={"energy": m * v**2 / 2 + k * x**2 / 2, "spring": -k * x})


def test_header_lists_every_vector_in_the_functions_order():
    gm = _cart()
    header = gm.header.split("*/")[0]
    lines = [line.strip(" *") for line in header.splitlines()]
    assert "x[0] x" in lines and "x[1] v" in lines
    p_lines = [line for line in lines if line.startswith("p[")]
    assert p_lines == [f"p[{i}] {n} = {d!r}" for i, (n, d) in
                       enumerate(zip(gm.metadata["param_names"], gm.metadata["param_defaults"]))]
    assert p_lines == ["p[0] m = 2.5", "p[1] k = 4.0", "p[2] c = 0.1"]
    assert "r[0] F" in lines
    assert ["out[0] energy", "out[1] spring"] == [line for line in lines if line.startswith("out[")]


def test_header_says_none_for_empty_vectors():
    x, v = dynamicsymbols("x v")
    formed = FormedSystem(method="kane", coordinates=(x,), speeds=(v,), n_dependent_coordinates=0,
                          n_dependent_speeds=0, kinematics=sm.Matrix([v]),
                          dynamics_matrix=sm.Matrix([[1]]), dynamics_rhs=sm.Matrix([-x]),
                          multipliers=(), holonomic_constraints=sm.zeros(0, 1),
                          velocity_constraints=sm.zeros(0, 1), inputs=(), parameters=())
    header = generate_c(formed, "osc").header
    assert "r: inputs (ninput = 0): none" in header
    assert "p: parameters (nparam = 0), with the model's defaults: none" in header
