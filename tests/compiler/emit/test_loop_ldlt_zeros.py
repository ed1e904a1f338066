"""The loop LDLT (n > 16, nearly dense) reads every lower entry of F: structural zeros must be stored.

Found on Solo12 with a floating base (18x18, branches make zeros): the
dynamics helper stored only the nonzeros, the loop factor read the rest from
uninitialized stack memory, and rhs failed at random with a 'singular' mass
matrix.  Here: a 17x17 symmetric M with a few structural zeros.
"""
import re

import sympy as sm
from sympy.physics.vector import dynamicsymbols

from eomc.compiler.emit import generate_c
from eomc.compiler.mechanics.formed import FormedSystem

N = 17
ZEROS = {(1, 0), (5, 2), (16, 3)}


def test_structural_zeros_are_stored_for_the_loop_factor():
    q = dynamicsymbols(f"q0:{N}")
    u = dynamicsymbols(f"u0:{N}")
    M = sm.zeros(N, N)
    params = []
    for i in range(N):
        for j in range(i + 1):
            if (i, j) in ZEROS:
                continue
            s = sm.Symbol(f"m_{i}_{j}")
            params.append(s)
            M[i, j] = M[j, i] = s * sm.cos(q[i]) if i != j else s + sm.cos(q[i]) ** 2
    formed = FormedSystem(method="kane", coordinates=tuple(q), speeds=tuple(u), n_dependent_coordinates=0,
                          n_dependent_speeds=0, kinematics=sm.Matrix(u), dynamics_matrix=M,
                          dynamics_rhs=sm.Matrix([sm.sin(x) for x in q]), multipliers=(),
                          holonomic_constraints=sm.zeros(0, 1), velocity_constraints=sm.zeros(0, 1),
                          inputs=(), parameters=tuple(sorted(params, key=str)))
    gm = generate_c(formed, "loopzeros", functions=["rhs"])
    assert "loopzeros_ldlt_factor" in gm.c_source and "for (k = 0; k < j; k++)" in gm.c_source  # the loop one
    stored = set(int(m) for m in re.findall(r"^\s*F\[(\d+)\] = ", gm.c_source, flags=re.M))
    for i, j in ZEROS:
        assert i * N + j in stored, f"M[{i}][{j}] (structural zero) is never stored"
