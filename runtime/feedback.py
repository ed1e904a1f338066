"""Inputs that depend on the state, or on time through a Python function.

Why this module: a controller closes the loop r = r0 + K (x_ref - x) -- the
classic use of ``linearize`` (LQR, PD) -- and the C integrator evaluates that
at every stage without Python (``eomc_feedback`` in eomc_integrators.h).  A
Python callable ``r(t)`` or ``r(t, x)`` is the slow path: C calls back into
Python once per stage (a few microseconds each), which is exact where the old
sampling on a fixed grid silently missed a fast input.  This module checks
the gain and reference and builds the C struct, the callback included.  An
exception in the callable (KeyboardInterrupt included) is kept and returns
EOMC_ABORTED, on which the integrator stops at once; it is raised when the C
call returns.
"""
import inspect

import numpy as np

from .cdef import STATUS_ABORTED

__all__ = ["FeedbackBinding", "callable_arity", "applied_inputs", "cubic_slopes", "gain_schedule"]


def callable_arity(model, r):
    """1 for r(t), 2 for r(t, x); a clear error for anything else."""
    try:
        params = [p for p in inspect.signature(r).parameters.values()
                  if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD) and p.default is p.empty]
        varargs = any(p.kind == p.VAR_POSITIONAL for p in inspect.signature(r).parameters.values())
    except (TypeError, ValueError):       # builtins without a signature: assume r(t)
        return 1
    if len(params) in (1, 2):
        return len(params)
    if varargs and len(params) <= 2:
        return 2
    raise ValueError(f"{model.name}: an input callable must take (t) or (t, x); "
                     f"{getattr(r, '__name__', r)!r} takes {len(params)} arguments")


def cubic_slopes(model, t_grid, values, kind):
    """dr/dt at the grid times of scipy's not-a-knot CubicSpline (C then evaluates the
    piecewise cubic Hermite with them: the same spline); kind "linear" gives None."""
    if kind == "linear":
        return None
    if kind != "cubic":
        raise ValueError(f"{model.name}: r=(t_grid, values, kind) takes kind 'linear' or 'cubic'; "
                         f"got {kind!r}")
    from scipy.interpolate import CubicSpline
    t = np.asarray(t_grid, dtype=np.float64)
    v = np.asarray(values, dtype=np.float64).reshape(t.size, model.ninput)
    if t.size < 4:
        raise ValueError(f"{model.name}: a cubic input table needs at least 4 times; got {t.size}")
    return np.ascontiguousarray(CubicSpline(t, v, axis=0)(t, 1))


def applied_inputs(model, a):
    """r(t, x) exactly as the C integrator applies it for prepared arguments ``a`` (in Python)."""
    ni = model.ninput
    fun = a.get("r_fun")
    two = fun is not None and callable_arity(model, fun) == 2
    g = gain_schedule(model, a["K"], a.get("x_ref")) if a.get("K") is not None else None
    if a.get("r_slopes") is not None:
        from scipy.interpolate import CubicHermiteSpline
        spline = CubicHermiteSpline(a["r_t"], a["r_v"], a["r_slopes"], axis=0)

    def r(t, x):
        if fun is not None:
            base = np.asarray(fun(t, np.array(x)) if two else fun(t), dtype=float).ravel()
        elif a["n_r"] >= 2 and a.get("r_slopes") is not None:
            base = spline(min(max(t, a["r_t"][0]), a["r_t"][-1]))
        elif a["n_r"] >= 2:
            base = np.array([np.interp(t, a["r_t"], a["r_v"][:, k]) for k in range(ni)])
        elif a["n_r"] == 1:
            base = np.array(a["r_v"][:ni], dtype=float)
        else:
            base = np.zeros(ni)
        if g is None:
            return base
        K, ref = g.at(t)
        return base + K @ ((ref if ref is not None else 0.0) - np.asarray(x))
    return r


class GainSchedule:
    """Checked feedback gains and references: constant, or on a time grid (t_grid not None).

    K: (ninput, nx), or with ``rows`` per trajectory (rows, ninput, nx); on a grid
    (k, ninput, nx) or (rows, k, ninput, nx).  ref: None, (nx,) or (rows, nx) constant, or on
    the grid (k, nx) or (rows, k, nx) (ref_on_grid).  K_stride / ref_stride: doubles from one
    trajectory's block to the next (0: one for all)."""

    def __init__(self, t_grid, K, ref, ref_on_grid, K_stride, ref_stride):
        self.t_grid, self.K, self.ref, self.ref_on_grid = t_grid, K, ref, ref_on_grid
        self.K_stride, self.ref_stride = K_stride, ref_stride

    @property
    def n_grid(self):
        return 0 if self.t_grid is None else self.t_grid.size

    def at(self, t, row=0):
        """(K, x_ref) at time t for trajectory ``row``, by the C code's rule and arithmetic
        (eomc_integrators.c grid_rows_at): held at the grid's ends, linear between."""
        K = self.K[row] if self.K_stride else self.K
        ref = None if self.ref is None else (self.ref[row] if self.ref_stride else self.ref)
        if self.t_grid is None:
            return K, ref
        tg, hi = self.t_grid, self.t_grid.size - 1

        def pick(V):
            if t <= tg[0]:
                return V[0]
            if t >= tg[hi]:
                return V[hi]
            lo = int(np.searchsorted(tg, t, side="right")) - 1
            w = (t - tg[lo]) / (tg[lo + 1] - tg[lo])
            return (1.0 - w) * V[lo] + w * V[lo + 1]
        return pick(K), (None if ref is None else pick(ref) if self.ref_on_grid else ref)


def _reals(value, what):
    a = np.asarray(value)
    if a.dtype.kind not in "fiub":
        raise ValueError(f"{what} must hold real numbers; got dtype {a.dtype}")
    return np.asarray(a, dtype=np.float64)


def gain_schedule(model, K, x_ref, rows=None):
    """The feedback K (x_ref - x) of ``simulate(K=, x_ref=)`` (rows None) or ``rollout`` (rows =
    its number of trajectories), checked: a GainSchedule.

    K: (ninput, nx) constant, or (t_grid, values) with values (k, ninput, nx) -- the gains at
    the grid times, linear between them and held at the ends (what an iLQR/DDP solver hands
    over: K_k along its nominal trajectory) -- and with rows also (rows, ninput, nx) or
    (rows, k, ninput, nx), one per trajectory.  x_ref: None (zeros), a dict of state names
    (simulate), (nx,), with rows (rows, nx); with gains on a grid also (k, nx) or, with rows,
    (rows, k, nx): the references at the grid times."""
    ni, nx = model.ninput, model.nx
    where = f"{model.name}: the feedback gain K"
    cols = f"rows: {', '.join(model.input_names)}; columns: {', '.join(model.state_names)}"
    if isinstance(K, tuple):
        if len(K) != 2:
            raise ValueError(f"{where} as a tuple is a gain schedule (t_grid, values); got {len(K)} items")
        t_grid = np.ascontiguousarray(_reals(K[0], f"{where}: t_grid"))
        V = _reals(K[1], f"{where}: values")
        if t_grid.ndim != 1 or t_grid.size < 2:
            raise ValueError(f"{where}: t_grid must be 1-d with at least 2 times; got shape {t_grid.shape}")
        if not np.all(np.isfinite(t_grid)) or np.any(np.diff(t_grid) <= 0):
            raise ValueError(f"{where}: t_grid must be finite and strictly increasing")
        k = t_grid.size
        shapes = [(k, ni, nx)] + ([(rows, k, ni, nx)] if rows is not None else [])
        said = f"(k, ninput, nx) = {shapes[0]}" + (f" or {shapes[1]} (one schedule per row)" if rows else "")
    else:
        t_grid, k = None, 0
        V = np.asarray(K, dtype=np.float64)
        if V.shape == (nx,) and ni == 1:
            V = V[None, :]
        shapes = [(ni, nx)] + ([(rows, ni, nx)] if rows is not None else [])
        said = f"(ninput, nx) = {shapes[0]}" + (f" or {shapes[1]} (one per row)" if rows else "")
    if V.shape not in shapes:
        raise ValueError(f"{where} must have shape {said} [{cols}]"
                         f"{f' (t_grid has {k} times)' if k else ''}; got shape {V.shape}")
    if not np.all(np.isfinite(V)):
        raise ValueError(f"{where} holds non-finite values")
    V = np.ascontiguousarray(V, dtype=np.float64)
    K_stride = V[0].size if V.ndim == (4 if k else 3) else 0
    ref_on_grid, ref_stride = False, 0
    if x_ref is None:
        ref = None
    elif isinstance(x_ref, dict):
        if rows is not None:
            raise ValueError(f"{model.name}: x_ref must be an array here (a dict names one state)")
        from .names import index_of
        ref = np.zeros(nx)
        for key, v in x_ref.items():
            ref[index_of(key, model.state_names, "x_ref name", model.name)] = float(v)
    else:
        ref = np.asarray(x_ref, dtype=np.float64)
        shapes = [(nx,)] + ([(rows, nx)] if rows is not None and not k else [])
        if k:
            shapes += [(k, nx)] + ([(rows, k, nx)] if rows is not None else [])
        if ref.shape not in shapes:
            raise ValueError(f"{model.name}: x_ref must have shape {' or '.join(map(str, shapes))} "
                             f"[{', '.join(model.state_names)}]; got shape {ref.shape}")
        ref_on_grid = ref.ndim >= 2 and bool(k)
        ref_stride = ref[0].size if ref.ndim == (3 if ref_on_grid else 2) else 0
    if ref is not None and not np.all(np.isfinite(ref)):
        raise ValueError(f"{model.name}: x_ref holds non-finite values")
    return GainSchedule(t_grid, V, None if ref is None else np.ascontiguousarray(ref), ref_on_grid,
                        K_stride, ref_stride)


def input_value(model, fun, arity, t, x):
    """fun(t) or fun(t, x) as ninput floats; a ValueError naming t and what came back otherwise.

    An exception raised by the user's function becomes a ValueError saying where it happened,
    with the original as its cause."""
    args = "t" if arity == 1 else "t, x"
    expected = f"r({args}) must return {model.ninput} value(s) [{', '.join(model.input_names)}]"
    try:
        value = fun(t) if arity == 1 else fun(t, x)
    except Exception as exc:
        raise ValueError(f"{model.name}: r({args}) raised {type(exc).__name__} at t={t:.9g}: "
                         f"{exc}") from exc
    try:
        v = np.ascontiguousarray(value, dtype=np.float64).ravel() if value is not None else None
    except (TypeError, ValueError, OverflowError):
        v = None
    if v is None:
        raise ValueError(f"{model.name}: {expected}; at t={t:.9g} it returned "
                         f"{type(value).__name__} {value!r}")
    if v.size != model.ninput:
        raise ValueError(f"{model.name}: {expected}; at t={t:.9g} it returned {v.size}")
    return v


def check_callable(model, r, t0, x0):
    """Call r once at the start, so a wrong return shape is an error before any C runs."""
    arity = callable_arity(model, r)
    input_value(model, r, arity, t0, np.array(x0, dtype=np.float64))
    return arity


class FeedbackBinding:
    """The C ``eomc_feedback`` struct for one run (gain, reference, callback)."""

    def __init__(self, model, K=None, x_ref=None, fun=None, slopes=None):
        ffi = model.ffi
        self.error = None
        fb = self.struct = ffi.new("eomc_feedback *")
        self._keep = []
        if slopes is not None:
            self.slopes = np.ascontiguousarray(slopes, dtype=np.float64)
            fb.r_slopes = ffi.from_buffer("double[]", self.slopes)
            self._keep.append(fb.r_slopes)
        if K is not None:
            g = gain_schedule(model, K, x_ref)
            self.K, self.x_ref = g.K, g.ref
            fb.K = ffi.from_buffer("double[]", self.K)
            self._keep.append(fb.K)
            if self.x_ref is not None:
                fb.x_ref = ffi.from_buffer("double[]", self.x_ref)
                self._keep.append(fb.x_ref)
            if g.t_grid is not None:
                self.k_tgrid = g.t_grid
                fb.n_kgrid, fb.ref_on_grid = g.n_grid, int(g.ref_on_grid)
                fb.k_tgrid = ffi.from_buffer("double[]", self.k_tgrid)
                self._keep.append(fb.k_tgrid)
        elif x_ref is not None:
            raise ValueError(f"{model.name}: x_ref= is the reference of the feedback K (x_ref - x); "
                             f"pass K= too")
        if fun is not None:
            arity = callable_arity(model, fun)
            nx, ni = model.nx, model.ninput

            def call(user, t, x, r):
                try:
                    x_now = (None if arity == 1 else
                             np.frombuffer(ffi.buffer(x, 8 * nx), dtype=np.float64).copy())
                    ffi.memmove(r, input_value(model, fun, arity, t, x_now), 8 * ni)
                    return 0
                except BaseException as exc:   # noqa: BLE001 - re-raised after the C call
                    if self.error is None:
                        self.error = exc
                    # EOMC_ABORTED, not a non-finite value: C stops the run at once -- no retry
                    # of the stage, no further call of fun (report r3, N5)
                    return STATUS_ABORTED
            self._callback = ffi.callback("eomc_input_fn", call)
            fb.fn = self._callback

    def raise_error(self):
        """Re-raise an exception the callable raised inside the C call."""
        if self.error is not None:
            raise self.error
