"""Compare two compiled models of one system (Kane's and the recursive formulation) at random states.

``agree`` returns the largest relative difference of rhs, mass_matrix,
inverse_dynamics and jac_x (when compiled) over ``nstates`` random states whose
mass matrix is well conditioned (a near-singular M would measure conditioning,
not the formulations).
"""
import numpy as np

__all__ = ["agree", "relative"]


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
        if np.linalg.cond(M) > 1e8:
            continue      # near-singular M: differences would measure conditioning
        worst = max(worst, relative(rec.mass_matrix(0.0, x, p=pr, r=r), M))
        worst = max(worst, relative(rec.rhs(0.0, x, p=pr, r=r), kane.rhs(0.0, x, p=pk, r=r)))
        ud = rng.uniform(-1.0, 1.0, nu)
        worst = max(worst, relative(rec.inverse_dynamics(0.0, x, ud, p=pr, r=r),
                                    kane.inverse_dynamics(0.0, x, ud, p=pk, r=r)))
        if has_jac:
            worst = max(worst, relative(rec.jacobian(0.0, x, p=pr, r=r), kane.jacobian(0.0, x, p=pk, r=r)))
        checked += 1
        if checked == nstates:
            break
    assert checked == nstates
    return worst
