"""Linearization over the independent states of a constrained model.

Why this module: ``model.linearize`` differentiates the rhs with respect to
every state, dependent ones included, so for a model with constraints its A
has spurious directions off the constraint manifold (the non-minimal
pendulum's A has 4 eigenvalues, the physical system 2).  Perturbations that
stay on the constraints satisfy G dx = 0 (G = constraints_jacobian: the
configuration rows in q, the velocity rows in q and u).  Splitting the states
into independent (kept) and dependent ones, dx_D = -G_D^-1 G_I dx_I, so
dx = T dx_I with T = [I; -G_D^-1 G_I] (rows in model order), and

    dx_I' = S A T dx_I + S B dr,

S selecting the independent rows.  Valid at equilibria and along steady
motions alike (A, B, G are evaluated at the given state, which must be on
the constraints).  Independent states default to those consistent_state
keeps (all but the last nhol coordinates and the last nvel speeds).

Quaternion coordinates (MJCF free and ball joints) are first replaced by
their 3-angle tangent chart (eomc.runtime.tangent: their length is no
motion), so A, B, states and basis are the chart's, with or without
constraints.
"""
import numpy as np

from eomc.runtime.errors import ModelError

from .consistent import _free, start_residual
from .tangent import ReducedLinearization, tangent_chart

__all__ = ["ReducedLinearization", "linearize_reduced"]



def linearize_reduced(model, t, x, p=None, r=None, fixed=None, tol=1e-8):
    """(A, B, states, basis) over the independent states at (t, x); see the module docstring.

    fixed: the independent states by name (default: the model's independent ones).
    tol: x must satisfy the constraints to this (else a ModelError saying by how much).
    """
    chart = tangent_chart(model, x)
    x = chart.x                             # its quaternions made unit (the same orientations)
    A, B = model.linearize(t, x, p, r)
    A, B, C = chart.S @ A @ chart.T, chart.S @ B, chart.T
    names = chart.states
    k = model.nhol + model.nvel
    if k == 0:
        return ReducedLinearization(A, B, tuple(names), C)
    hol, vel = start_residual(model, t, x, p, r)
    if max(hol, vel) > tol:
        raise ModelError(f"{model.name}: the operating point is off the constraints (configuration "
                         f"residual {hol:.3g}, velocity residual {vel:.3g}); complete it with "
                         f"model.consistent_state first")
    free_q, free_u = _free(model, fixed)
    quat = [model.state_names[i] for i in free_q + free_u if chart.columns[i] < 0]
    if quat:
        raise ModelError(f"{model.name}: the constraints cannot be solved for a quaternion coordinate "
                         f"({', '.join(quat)}); pick other independent states with fixed=")
    dep = [chart.columns[i] for i in free_q + free_u]   # the states solved for (dependent), chart columns
    ind = [i for i in range(len(names)) if i not in dep]
    if len(dep) != k:
        raise ModelError(f"{model.name}: {k} constraint(s) need exactly {k} dependent states; "
                         f"fixing {', '.join(names[i] for i in ind)} leaves {len(dep)}")
    G = model.constraints_jacobian(t, x, p, r) @ C
    GD, GI = G[:, dep], G[:, ind]
    if np.linalg.matrix_rank(GD) < k:
        raise ModelError(f"{model.name}: the constraints cannot be solved for "
                         f"{', '.join(names[i] for i in dep)} at this state (their Jacobian is "
                         f"singular); pick other independent states with fixed=")
    T = np.zeros((len(names), len(ind)))
    T[ind, np.arange(len(ind))] = 1.0
    T[dep, :] = -np.linalg.solve(GD, GI)
    return ReducedLinearization(A[ind] @ T, B[ind], tuple(names[i] for i in ind), C @ T)
