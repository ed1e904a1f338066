"""Hypothesis-generated open chains, compiled: the C functions vs SymPy's own equations.

Each random chain (tests/helpers/random_chains.py) is derived by eomc.mechanics,
lowered to C and compiled; the oracle is sympy.physics.mechanics' KanesMethod
of the same chain, evaluated with lambdify and numpy.linalg.solve.  Half the
examples force jac_x's tangent-loop form (used above TANGENT_MIN_STATES), so
both Jacobian forms meet random mechanisms.
"""
import numpy as np
import pytest
import sympy.physics.mechanics as sme
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from helpers import emit_support as es
import eomc.mechanics as em
from eomc.compiler.emit import generate_c, symbolic
from eomc.errors import ModelError
from helpers.random_chains import build, chain

FUNCTIONS = ["rhs", "jac_x", "jac_r", "mass_matrix", "inverse_dynamics"]


def _fd(c, fn_args, nx, x, r, wrt, h=1e-6):
    """Central differences of rhs with respect to x or r."""
    base = x if wrt == "x" else r
    J = np.empty((nx, base.size))
    for k in range(base.size):
        e = np.zeros(base.size)
        e[k] = h
        lo, hi = ((x - e, r), (x + e, r)) if wrt == "x" else ((x, r - e), (x, r + e))
        J[:, k] = (c.call("rhs", nx, fn_args[0], hi[0], fn_args[1], hi[1])[1]
                   - c.call("rhs", nx, fn_args[0], lo[0], fn_args[1], lo[1])[1]) / (2 * h)
    return J


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(spec=chain, looped=st.booleans(), seed=st.integers(0, 2**32 - 1))
def test_compiled_random_chain_matches_sympy(tmp_path_factory, spec, looped, seed):
    ours, theirs = build(em, spec), build(sme, spec)
    M = ours.mass_matrix
    if any(all(M[i, j] == 0 for i in range(M.rows)) for j in range(M.cols)):
        # a link turning about the line its mass sits on: no inertia, no solvable equations;
        # refused when the equations are read, before any C (issue 8, bad input)
        with pytest.raises(ModelError, match="has no inertia"):
            ours.formed()
        return
    formed = ours.formed()
    ref = es.kane_formed(theirs, formed.inputs)
    saved = symbolic.TANGENT_MIN_STATES
    symbolic.TANGENT_MIN_STATES = 0 if looped else saved
    try:
        gm = generate_c(formed, "chain", functions=FUNCTIONS)
    finally:
        symbolic.TANGENT_MIN_STATES = saved
    assert looped or "dx[" not in gm.c_source    # (a constant residual has no tangent to loop)
    c = es.Compiled(gm, tmp_path_factory.mktemp("chain"))
    orc = es.Oracle(ref, list(ref.parameters), ref.inputs)
    ours_p = [s.name for s in formed.parameters]
    rng = np.random.default_rng(seed)
    nx, nu = formed.nq + formed.nu, formed.nu
    for _ in range(2):
        tv = rng.uniform(-1, 1)
        x = rng.normal(size=nx)
        p_ref = rng.uniform(0.5, 2.0, size=len(ref.parameters))
        by_name = dict(zip((s.name for s in ref.parameters), p_ref))
        p = np.array([by_name[name] for name in ours_p])
        r = rng.normal(size=len(formed.inputs))
        M_ref = np.array(orc.A(tv, x, p_ref, r), float)
        status, xdot = c.call("rhs", nx, tv, x, p, r)
        if np.linalg.cond(M_ref) > 1e8:
            # a configuration where this chain's mass matrix is (nearly) singular, e.g. a
            # particle link swung onto the next joint's axis: agreement to 1e-11 means
            # nothing there (the C code reports an exactly singular pivot as status 1)
            continue
        assert status == 0
        expect = orc.rhs(tv, x, p_ref, r)
        assert es.rel_err(xdot, expect) <= 1e-11
        status, M = c.call("mass_matrix", (nu, nu), tv, x, p, r)
        assert status == 0
        assert es.rel_err(M, M_ref) <= 1e-12
        status, tau = c.call("inverse_dynamics", nu, tv, x, p, r, extra=xdot[formed.nq:])
        assert status == 0 and np.max(np.abs(tau)) <= 1e-9 * max(1.0, np.max(np.abs(M)))
        status, J = c.call("jac_x", (nx, nx), tv, x, p, r)
        assert status == 0
        assert es.rel_err(J, _fd(c, (tv, p), nx, x, r, "x")) <= 1e-6
        if r.size:
            status, B = c.call("jac_r", (nx, r.size), tv, x, p, r)
            assert status == 0
            assert es.rel_err(B, _fd(c, (tv, p), nx, x, r, "r")) <= 1e-6
