"""Consistent initial states of constrained models, numerically, from the compiled constraints.

Why this module: a model with configuration constraints f_h(q, t) = 0 and
velocity constraints f_v(q, u, t) = 0 must start on them; a user naturally
gives only the independent coordinates and speeds.  Started off the
constraints, an integration silently runs on a wrong manifold for its whole
length.  ``consistent_state`` completes the dependent coordinates by Newton's
method on f_h (the compiled ``constraints_jac`` gives the Jacobian) and then
the dependent speeds from f_v (linear in u for mechanical constraints: one
Newton step solves it, a second confirms).  ``start_residual`` is the check
simulate runs on every start.

Which states are solved for: by default the last nhol coordinates and the
last nvel speeds, the dependent ones in eomc's state order (Kane's q_dependent
and u_dependent come last; for Lagrange's method the last coordinates).
``fixed=`` names the states to hold instead; every other coordinate (speed)
is free, and with more free states than constraints the correction is the
minimum-norm one.
"""
import numbers

import numpy as np

from eomc.runtime.errors import EomcWarning, ModelError

from .names import index_of

__all__ = ["consistent_state", "start_residual", "ConstraintWarning"]


class ConstraintWarning(EomcWarning):
    """An initial state violates the model's constraints.

    An EomcWarning, so the ``eomc`` command prints it as one line (no source line);
    ``cli_text()`` is the same advice with the command line's flags.
    """

    @classmethod
    def off(cls, model_name, hol, vel, limit):
        w = cls(cls._text(model_name, hol, vel, limit, "consistent=True (or x0=model.consistent_state(x0))",
                          "project=True"))
        w.model_name, w.hol, w.vel, w.limit = model_name, hol, vel, limit
        return w

    @staticmethod
    def _text(model_name, hol, vel, limit, consistent, project):
        return (f"{model_name}: x0 is off the constraints (configuration residual {hol:.3g}, "
                f"velocity residual {vel:.3g}; tolerance {limit:.3g}): the run would follow "
                f"the wrong motion. Pass {consistent} to complete the dependent coordinates and "
                f"speeds (keeping the independent ones), or {project} (which moves the start onto "
                f"the constraints, the coordinates you gave included)")

    def cli_text(self):
        """The advice with the flags of ``eomc simulate``."""
        if not hasattr(self, "hol"):
            return str(self)
        return self._text(self.model_name, self.hol, self.vel, self.limit, "--consistent",
                          "--project").replace(
            "(which moves the start onto the constraints, the coordinates you gave included)",
            "(which completes the start the same way, holding the states given with --x0, and then "
            "keeps the run on the constraints)")


def start_residual(model, t, x, p=None, r=None):
    """(max |holonomic residual|, max |velocity residual|) at (t, x); (0, 0) without constraints."""
    if model.nhol + model.nvel == 0 or model.c_model.constraints == model.ffi.NULL:
        return 0.0, 0.0
    g = np.abs(model.constraints(t, x, p, r))
    return (float(g[:model.nhol].max()) if model.nhol else 0.0,
            float(g[model.nhol:].max()) if model.nvel else 0.0)


def _free(model, fixed):
    nq, nx = model.nq, model.nx
    nqu = nq + model.nu     # extra first-order states follow; the constraints never involve them
    if fixed is None:
        held = set(range(nq - model.nhol)) | set(range(nq, nqu - model.nvel)) | set(range(nqu, nx))
    else:
        if isinstance(fixed, (str, int)):
            fixed = [fixed]
        held = set()
        for item in fixed:
            held.add(item if isinstance(item, int) and 0 <= item < nx
                     else index_of(item, model.state_names, "fixed state", model.name))
    free_q = [i for i in range(nq) if i not in held]
    free_u = [i for i in range(nq, nqu) if i not in held]
    return free_q, free_u


def _step(J, g, names, what, model):
    """Newton (square J) or minimum-norm Gauss-Newton correction solving J dz = -g."""
    if J.shape[1] < J.shape[0]:
        raise ModelError(f"{model.name}: {J.shape[0]} {what} constraint(s) but only {J.shape[1]} free "
                         f"state(s) ({', '.join(names) or 'none'}) to satisfy them; fix fewer states")
    sv = np.linalg.svd(J, compute_uv=False)
    if sv.size and (sv[-1] <= 1e-12 * max(sv[0], 1.0) or not np.all(np.isfinite(sv))):
        raise ModelError(f"{model.name}: the {what} constraints' Jacobian with respect to "
                         f"{', '.join(names)} is singular here (those states cannot be solved for at "
                         f"this configuration); choose other states with fixed= or start elsewhere")
    if J.shape[0] == J.shape[1]:
        return np.linalg.solve(J, -g)
    return -J.T @ np.linalg.solve(J @ J.T, g)


def _number(v, key, model):
    if isinstance(v, bool) or not isinstance(v, numbers.Real):
        raise ValueError(f"{model.name}: x0 {key} must be a real number; got {v!r}")
    return float(v)


def consistent_state(model, x0, t=0.0, p=None, r=None, fixed=None, tol=1e-12, max_iter=50):
    """A state on the model's constraints, keeping the states in ``fixed`` (default: the
    independent ones) and solving for the others; ModelError when Newton fails.

    x0: array (nx,) or {name: value} (missing names: the model's initial_state, else 0 -- the
    rule simulate() follows too) or None (the initial_state) -- the dependent entries are the
    starting guess.  tol: on the max-abs residual (a number > 0); max_iter: Newton's
    iterations (an integer >= 1).
    """
    if isinstance(tol, bool) or not isinstance(tol, numbers.Real) or not np.isfinite(tol) or tol <= 0:
        raise ValueError(f"{model.name}: consistent_state tol must be a finite number > 0; got {tol!r}")
    if isinstance(max_iter, bool) or not isinstance(max_iter, numbers.Integral) or max_iter < 1:
        raise ValueError(f"{model.name}: consistent_state max_iter must be an integer >= 1; "
                         f"got {max_iter!r}")
    if x0 is None:
        from .start import start_or_default
        x0 = start_or_default(model, None)
    if isinstance(x0, dict):
        base = model.initial_state if model.initial_state is not None else np.zeros(model.nx)
        x = np.array(base, dtype=np.float64)
        for key, v in x0.items():
            x[index_of(key, model.state_names, "state", model.name)] = _number(v, key, model)
    else:
        a = np.asarray(x0)
        if a.dtype.kind not in "fiub":
            raise ValueError(f"{model.name}: x0 must hold real numbers; got dtype {a.dtype}")
        x = np.array(a, dtype=np.float64).reshape(-1)
        if x.shape != (model.nx,):
            raise ValueError(f"{model.name}: x0 must have shape ({model.nx},); got {np.shape(x0)}")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{model.name}: x0 is not finite")
    if model.nhol + model.nvel == 0:
        return x
    free_q, free_u = _free(model, fixed)
    names = model.state_names
    nh = model.nhol
    g = model.constraints(t, x, p, r)
    for _ in range(max_iter if nh else 0):
        if np.max(np.abs(g[:nh])) <= tol:
            break
        J = model.constraints_jacobian(t, x, p, r)[:nh][:, free_q]
        x[free_q] += _step(J, g[:nh], [names[i] for i in free_q], "configuration", model)
        g = model.constraints(t, x, p, r)
    if nh and not np.max(np.abs(g[:nh])) <= tol:
        raise ModelError(f"{model.name}: Newton's method did not reach the configuration constraints "
                         f"from this start (residual {np.max(np.abs(g[:nh])):.3g} after {max_iter} "
                         f"iterations, solving for {', '.join(names[i] for i in free_q)}); give a "
                         f"closer guess for those coordinates")
    for _ in range(3 if model.nvel else 0):
        gv = g[nh:]
        if np.max(np.abs(gv)) <= tol:
            break
        J = model.constraints_jacobian(t, x, p, r)[nh:][:, free_u]
        x[free_u] += _step(J, gv, [names[i] for i in free_u], "velocity", model)
        g = model.constraints(t, x, p, r)
    if model.nvel and not np.max(np.abs(g[nh:])) <= max(tol, 1e-10):
        raise ModelError(f"{model.name}: the velocity constraints could not be solved for "
                         f"{', '.join(names[i] for i in free_u)} (residual {np.max(np.abs(g[nh:])):.3g})")
    return x


def complete_start(model, x, t=0.0, p=None, r=None, given=()):
    """A start off the constraints completed on them, for simulate() and the command line
    alike: first holding the states the user gave and the independent ones, then the given
    ones only, then the independent ones only (a start naming every state leaves nothing
    free under the first two). Returns (state, names held); the last attempt's ModelError
    when none works, for the caller to word in its own terms (x0 or --x0)."""
    nq, nqu = model.nq, model.nq + model.nu       # extra first-order states are never solved for
    names = [str(n) for n in model.state_names]
    independent = names[:nq - model.nhol] + names[nq:nqu - model.nvel] + names[nqu:]
    tries = [None] if not given else [sorted(set(given) | set(independent)), sorted(set(given)), None]
    error = None
    for fixed in tries:
        try:
            return consistent_state(model, x, t, p, r, fixed=fixed), (independent if fixed is None else fixed)
        except ModelError as exc:
            error = exc
    raise error
