"""Why the mass matrix is singular, in the user's terms: which speeds meet no inertia.

A "singular mass matrix" status alone leaves the user to guess which body or joint
lacks inertia.  A mass matrix that is singular to rounding (a URDF link whose inertia is
1e-20, a head on two neck joints) is not refused by the LDLᵀ but makes the problem so
stiff that the step size collapses: that failure gets the same diagnosis.  When it happens (not on the hot path), the model's own
``mass_matrix`` at the failing state is decomposed: the eigenvector of its smallest
eigenvalue is the motion nothing resists, and its large components name the
speeds (for URDF and joint models the speed names carry the joint names).
"""
import numpy as np

from .cdef import STATUS_SINGULAR_MASS_MATRIX as SINGULAR_STATUS

__all__ = ["SINGULAR_STATUS", "singular_direction"]


def singular_direction(model, t, x, p=None, r=None, semidefinite=False):
    """'; nothing resists motion along u2 (1), u3 (-0.24) ...' (the null direction of M, its
    largest components first) or '' when it cannot tell.

    ``semidefinite``: say it only when M is positive semidefinite to rounding, i.e. when M
    is a plain mass matrix that is singular.  For a guess at a cause that is not M's own
    status (a collapsed step, the start of a build): a constrained system's mass_matrix is
    not symmetric positive (four-bar: eigenvalue -1.36) and is not evidence there."""
    if "mass_matrix" not in getattr(model, "functions", ()):
        return ""
    if isinstance(p, np.ndarray) and p.ndim == 1:
        p = p[:model.nparam]          # the integrators' parameter block may carry more after p
    try:
        M = np.asarray(model.mass_matrix(t, x, p=p, r=r), dtype=float)
        if not np.all(np.isfinite(M)):
            return ""
        w, V = np.linalg.eigh((M + M.T) / 2)
    except Exception:      # a diagnosis must never hide the original error
        return ""
    if w[-1] <= 0:
        return "; M is zero there: no speed meets any mass or inertia"
    if w[0] > 1e-10 * w[-1] or (semidefinite and w[0] < -1e-10 * w[-1]):
        return ""
    v = V[:, 0] / np.max(np.abs(V[:, 0]))
    v = v if v[np.argmax(np.abs(v))] > 0 else -v
    speeds = model.state_names[model.nq:model.nq + model.nu]
    parts = [f"{speeds[k]} ({v[k]:.2g})" for k in np.argsort(-np.abs(v)) if abs(v[k]) > 0.05][:4]
    return f"; nothing resists motion along {', '.join(parts)} (M's smallest eigenvalue " \
           f"{w[0]:.3g}, largest {w[-1]:.3g}): a body with no (or next to no) mass or inertia about those " \
           f"joints, or joint axes lined up (gimbal lock)"
