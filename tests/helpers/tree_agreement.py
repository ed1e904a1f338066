"""Compare two compiled models of one system (Kane's and the recursive formulation) at random states.

``agree`` returns the largest relative difference of rhs, mass_matrix,
inverse_dynamics and jac_x (when compiled) over ``nstates`` random states whose
mass matrix is well conditioned (a near-singular M would measure conditioning,
not the formulations).

Each state's difference is counted in units of max(1, cond(M)/COND_FLOOR): both
formulations solve with M (Kane's LDLᵀ, the recursion's articulated pivots), so each
carries rounding of about eps·cond(M), and jac_x, which differentiates through the solve,
more.  Below cond(M) = COND_FLOOR the caller's bound applies as it is.  Why (measured on
test_random_trees' third derandomized example, a 313 ball joint near gimbal lock, 400
states with cond(M) < 1e8, main's code at a5a5d6e): recursive vs Kane jac_x differed by up
to 5.9e-14 at cond < 1e2, 8.4e-13 at 1e2-1e3, 7.1e-12 at 1e3-1e4 and 2.9e-8 above; 13 of
400 states over 1e-12.  The example passed at 1e-12 only because its three states drew
3.4e-13; any change in the order of the recursion's roundings (issue 31's operation
count) drew 1.9e-12 at cond 3.2e3, with the same distribution over the 400 states.
"""
import numpy as np

__all__ = ["agree", "relative", "COND_FLOOR"]

COND_FLOOR = 1e2


def relative(a, b):
    return np.max(np.abs(a - b) / np.maximum(1.0, np.abs(b)))


def _params(model, values):
    return np.array([values[k] for k in model.metadata["param_names"]])


def agree(kane, rec, seed, nstates=4):
    """Largest relative difference over the compiled functions at random states (in [-1, 1]:
    a free joint's middle Euler angle stays away from its singularity at ±π/2)."""
    assert rec.metadata["formulation"] == "recursive"
    assert kane.metadata["formulation"] == "kane"
    has_jac = "jac_x" in rec.functions
    rng = np.random.default_rng(seed)
    names = sorted(set(kane.metadata["param_names"]) | set(rec.metadata["param_names"]))
    nq, nu, nr = kane.nq, kane.nu, kane.ninput
    worst = 0.0
    checked = 0
    for _ in range(50):
        vals = {k: rng.uniform(0.5, 1.5) for k in names}
        pk, pr = _params(kane, vals), _params(rec, vals)
        x = rng.uniform(-1.0, 1.0, nq + nu)
        r = rng.uniform(-1.0, 1.0, nr)
        M = kane.mass_matrix(0.0, x, p=pk, r=r)
        cond = np.linalg.cond(M)
        if cond > 1e8:
            continue      # near-singular M: differences would measure conditioning
        worst = max(worst, relative(rec.mass_matrix(0.0, x, p=pr, r=r), M))
        unit = max(1.0, cond / COND_FLOOR)        # the solves' rounding grows with cond(M)
        worst = max(worst, relative(rec.rhs(0.0, x, p=pr, r=r), kane.rhs(0.0, x, p=pk, r=r)) / unit)
        ud = rng.uniform(-1.0, 1.0, nu)
        worst = max(worst, relative(rec.inverse_dynamics(0.0, x, ud, p=pr, r=r),
                                    kane.inverse_dynamics(0.0, x, ud, p=pk, r=r)))
        if has_jac:
            worst = max(worst, relative(rec.jacobian(0.0, x, p=pr, r=r), kane.jacobian(0.0, x, p=pk, r=r)) / unit)
        checked += 1
        if checked == nstates:
            break
    assert checked == nstates
    return worst
