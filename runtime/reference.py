"""Reference solutions for error measurements, computed twice and compared.

Why this module exists: a work-precision report is only as trustworthy as
the solution its errors are measured against.  The reference is integrated
far tighter than any run in the grid (our C DOP853 at rtol = atol = 1e-13 by
default) and then *checked* by a second, independent integration -- scipy's
own DOP853 (``scipy.integrate.solve_ivp``) on the model's compiled rhs, a
different implementation of a different error control -- or, on request, our
Radau IIA.  The agreement of the two is reported; a report whose finest
tolerance asks for more than the references agree on says so instead of
trusting the reference silently.

The error measure used everywhere (see :func:`scaled_error`) is defined here
so that the reference check and the grid measure the same thing.
"""
import time
from dataclasses import dataclass

import numpy as np

from .simulate import finish, prepare, run_prepared, scipy_fun

__all__ = ["Reference", "compute_reference", "scaled_error", "state_scale", "SCALE_FLOOR",
           "CHECK_METHODS"]

SCALE_FLOOR = 1e-3      # states that stay below 1e-3 x the largest state are scaled by that
CHECK_METHODS = ("scipy", "radau", "dop853-half", "none")


def state_scale(x_ref):
    """Per-state scale S_j = max_i |x_ref[i, j]|, floored at SCALE_FLOOR * max_k S_k.

    A state that stays (nearly) zero would otherwise turn round-off into huge
    relative errors; it is measured relative to the trajectory's overall size.
    """
    s = np.max(np.abs(x_ref), axis=0)
    top = float(np.max(s)) if s.size else 0.0
    if top == 0.0:
        return np.ones_like(s)
    return np.maximum(s, SCALE_FLOOR * top)


def scaled_error(x, x_ref, scale=None):
    """max_i sqrt(mean_j ((x[i,j] - x_ref[i,j]) / S_j)**2) over the output times i.

    S_j = :func:`state_scale` of the reference: each state's largest magnitude
    along the trajectory.  So an error of 1e-6 means "at the worst output
    time, the RMS over states of the error, relative to each state's size,
    is one part in a million".  Rows missing from ``x`` (a failed run) make
    the error infinite.
    """
    x, x_ref = np.asarray(x, float), np.asarray(x_ref, float)
    if x.shape != x_ref.shape:
        return float("inf")
    scale = state_scale(x_ref) if scale is None else scale
    e = np.sqrt(np.mean(((x - x_ref) / scale) ** 2, axis=1))
    return float(np.max(e)) if e.size else 0.0


@dataclass
class Reference:
    """The reference trajectory and how far a second computation agrees with it."""
    t: np.ndarray
    x: np.ndarray
    scale: np.ndarray
    method: str
    tol: float
    wall_time: float
    stats: dict
    outputs: dict
    constraint_residual: np.ndarray
    check_method: str
    check_tol: float
    agreement: float          # scaled_error(check, reference); nan if unchecked

    def describe(self):
        """One sentence: how the reference was obtained and checked."""
        text = (f"reference: {self.method} at rtol=atol={self.tol:.0e} "
                f"({self.stats.get('accepted', '?')} steps, {self.wall_time:.3g} s)")
        if self.check_method == "none":
            return text + "; not checked"
        return (text + f"; checked against {self.check_method} at rtol=atol={self.check_tol:.0e}: "
                       f"agreement {self.agreement:.2e} (scaled error)")


def _c_run(model, x0, t_span, p, r, t_eval, method, tol, project):
    a = prepare(model, x0, t_span, p=p, r=r, method=method, rtol=tol, atol=tol, t_eval=t_eval,
                max_steps=10 ** 7, project=project, stiff_check=False)
    start = time.perf_counter()
    x_out, stats, x_last = run_prepared(model, a)
    elapsed = time.perf_counter() - start
    return finish(model, a, x_out, stats, x_last), elapsed, a


def _input_function(a, ninput):
    """r(t) as the C side sees it: none, constant, or linear interpolation on a grid."""
    if a["n_r"] == 0:
        return lambda t: None
    if a["n_r"] == 1:
        return lambda t: a["r_v"][:ninput]
    r_t, r_v = a["r_t"], a["r_v"]
    return lambda t: np.array([np.interp(t, r_t, r_v[:, k]) for k in range(ninput)])


def _scipy_check(model, a, t_eval, tol):
    """solve_ivp DOP853 on model.rhs: an independent implementation of the same order."""
    from scipy.integrate import solve_ivp
    p, r_of_t = a["p"][:-1], _input_function(a, model.ninput)
    if a["n_r"] <= 1:
        fun, _ = scipy_fun(model, p, r_of_t(0.0))
    else:
        def fun(t, x):
            return np.array(model.rhs(t, x, p, r_of_t(t)), dtype=float, copy=True)
    sol = solve_ivp(fun, (a["t0"], a["t1"]), a["x0"], method="DOP853", rtol=tol, atol=tol,
                    t_eval=t_eval)
    if not sol.success:
        raise RuntimeError(f"scipy DOP853 reference check failed: {sol.message}")
    return sol.y.T


def compute_reference(model, x0, t_span, t_eval, p=None, r=None, tol=1e-13, check="scipy",
                      project=False):
    """Integrate the reference (C DOP853 at ``tol``) and check it a second way.

    check: "scipy" (solve_ivp DOP853 at the same tol on model.rhs; needs
    model.rhs), "radau" (our Radau IIA at max(tol, 1e-12); needs jac_x),
    "dop853-half" (our DOP853 at tol/2: the same code, a weaker check) or
    "none".  Raises SimulationError if the reference itself cannot be computed.
    """
    if check not in CHECK_METHODS:
        raise ValueError(f"unknown reference check {check!r}; valid: {', '.join(CHECK_METHODS)}")
    res, elapsed, a = _c_run(model, x0, t_span, p, r, t_eval, "dop853", tol, project)
    scale = state_scale(res.x)
    check_tol, agreement = float("nan"), float("nan")
    if check == "scipy":
        check_tol = tol
        agreement = scaled_error(_scipy_check(model, a, a["t_eval"], tol), res.x, scale)
    elif check in ("radau", "dop853-half"):
        method, check_tol = ("radau", max(tol, 1e-12)) if check == "radau" else ("dop853", tol / 2)
        other, _, _ = _c_run(model, x0, t_span, p, r, t_eval, method, check_tol, project)
        agreement = scaled_error(other.x, res.x, scale)
    return Reference(t=res.t, x=res.x, scale=scale, method="dop853", tol=tol, wall_time=elapsed,
                     stats=res.stats, outputs=res.outputs,
                     constraint_residual=res.constraint_residual, check_method=check,
                     check_tol=check_tol, agreement=agreement)
