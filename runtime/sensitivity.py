"""Forward sensitivities of a simulation: dx(t)/dx0 and dx(t)/dp, in C.

Why: fitting a trajectory to measurements (identification, shooting methods,
optimal control) needs the derivative of the simulated states with respect
to the initial state and the parameters.  Finite differences of whole
simulations cost 2 runs per column and lose half the digits; the variational
equations S' = jac_x S + jac_p (S = dx/dtheta) give them to the integrator's
tolerance in one run.  The integration itself is eomc_sensitivity.c.  By
default S does not steer the steps (the run takes the plain run's steps):
explicit methods carry the augmented state [x; S] through their stages with
the error test on x; Radau (with jvp) is staggered direct -- after each
accepted step S's collocation equations are solved with that step's Newton
matrix and LU (CVODES's staggered method).  ``error_control=True`` makes the
step control watch S as well (the simultaneous approach; more steps).

``simulate(..., sensitivities=...)`` (runtime/simulate.py) checks the request
here (:func:`check_request`), prepares its arguments as always and makes the
C call here (:func:`run`).  Which
columns: ``True`` (every initial state and every parameter), ``"x0"`` or
``"p"`` (all of one kind), or a list of state and parameter names.
"""

import numpy as np

from eomc.runtime.errors import ModelError

from .header_cdef import header_cdef
from .integrators_api import METHOD_IDS
from .native import extension_library

__all__ = ["columns", "check_request", "run", "attach", "SENS_CDEF"]

SENS_CDEF = header_cdef("eomc_sensitivity.h")
MAX_COLUMNS = 4096          # EOMC_SENS_MAXCOL in eomc_sensitivity.c


def _sens_ffi(base):
    """(ffi, lib): the sensitivity API in an FFI that includes the model's base FFI (shared types)."""
    return extension_library(base, SENS_CDEF)


def columns(model, sensitivities):
    """(state indices, parameter indices) of the sensitivity columns asked for.

    A name that is a parameter folded into the code (fold_parameters) has no
    column: the error names it and says how to rebuild.
    """
    if sensitivities is True:
        return list(range(model.nx)), list(range(model.nparam))
    if isinstance(sensitivities, str) and sensitivities in ("x0", "p"):
        return ((list(range(model.nx)), []) if sensitivities == "x0"
                else ([], list(range(model.nparam))))
    if isinstance(sensitivities, str) or not hasattr(sensitivities, "__iter__"):
        raise ValueError(f"{model.name}: sensitivities must be True, 'x0', 'p' or a list of state "
                         f"and parameter names; got {sensitivities!r}")
    xs, ps = [], []
    folded = (model.metadata.get("folded_parameters") or {})
    for name in sensitivities:
        name = str(name)
        if name in model.state_names:
            xs.append(model.state_names.index(name))
        elif name in model.param_names:
            ps.append(model.param_names.index(name))
        elif name in folded:
            raise ModelError(f"{model.name}: parameter {name!r} was folded into the code "
                             f"(fold_parameters) and has no sensitivity column; rebuild without "
                             f"--fold-parameters to get d x / d {name}")
        else:
            raise ValueError(f"{model.name}: {name!r} in sensitivities is neither a state "
                             f"({', '.join(model.state_names)}) nor a parameter "
                             f"({', '.join(model.param_names) or 'none'})")
    if len(set(xs)) != len(xs) or len(set(ps)) != len(ps):
        raise ValueError(f"{model.name}: sensitivities names a state or parameter twice")
    if not xs and not ps:
        raise ValueError(f"{model.name}: sensitivities names no state and no parameter")
    if len(xs) + len(ps) > MAX_COLUMNS:
        raise ValueError(f"{model.name}: {len(xs) + len(ps)} sensitivity columns; at most {MAX_COLUMNS}")
    return xs, ps


def _check_model(model, ps):
    need_p = bool(ps) and "jvp" not in model.functions     # jvp has the parameter directions too
    missing = [f for f, need in (("jac_x", True), ("jac_p", need_p)) if need and f not in model.functions]
    # (jac_x stays required: Radau's Newton matrix is built from it)
    if missing:
        have = ",".join(f for f in model.functions if f not in missing)
        raise ModelError(f"{model.name}: sensitivities need {' and '.join(missing)}, which this model "
                         f"was built without; rebuild with functions including "
                         f"{', '.join(repr(f) for f in missing)} (eomc build --outputs "
                         f"{have},{','.join(missing)})")
    if model.backend != "cffi":
        raise ModelError(f"{model.name}: sensitivities run through the cffi backend; load the model "
                         f"with the default backend")


def check_request(model, sensitivities, events, r, K, x_ref, project, baumgarte):
    """(state indices, parameter indices) after refusing what has no sensitivities here."""
    xs, ps = columns(model, sensitivities)
    _check_model(model, ps)
    if events not in (None, False) or (events is None and "events" in model.functions):
        raise ValueError(f"{model.name}: events are not supported with sensitivities (the jump of "
                         f"dx/dtheta at an event time is not computed); pass events=False")
    if callable(r):
        raise ValueError(f"{model.name}: sensitivities need inputs that do not depend on the state; "
                         f"give r as constants or a (t_grid, values) table, not a callable")
    if isinstance(r, tuple) and len(r) == 3:
        raise ValueError(f"{model.name}: sensitivities take a linear input table, not a cubic one")
    if K is not None or x_ref is not None:
        raise ValueError(f"{model.name}: sensitivities with state feedback K are not supported")
    if project or baumgarte:
        raise ValueError(f"{model.name}: sensitivities are computed without constraint "
                         f"projection or stabilization (project/baumgarte)")
    return xs, ps


def use_jvp(model, jvp=None):
    """Whether S' = J S + P comes from the model's directional derivatives (its ``jvp``,
    when it was built: A and b factored once per stage, then per column a tangent and a
    solve) rather than from jac_x, jac_p and an nx x nx x k product.  On the n = 8 cart
    the directions are faster at every k up to nx + nparam (bench_sensitivity), so
    ``PREFER_JVP`` is on; ``jvp`` overrides it for one run."""
    if "jvp" not in model.functions:
        if jvp:
            raise ModelError(f"{model.name}: jvp=True needs the model built with 'jvp' "
                             f"(eomc build --outputs ...,jvp)")
        return False
    return PREFER_JVP if jvp is None else bool(jvp)


PREFER_JVP = True

# The model's jvp_more (built on request with jvp) carries Radau's second staggered iteration
# in the first iteration's middle-stage call (eomc_sens_jvp_more): same results, one primal
# fewer a step.  Off only to measure the difference (benchmarks/bench_sensitivity.py).
USE_JVP_MORE = True

# Radau's staggered solves skip the LU's top rows' zero entries when J's top rows are [0 I]
# (eomc_sens_full_solves): the same S to the bit, faster.  Off only to measure or check that.
TRIM_SOLVES = True


def run(model, a, xs, ps, stat_fields, jvp=None, error_control=False):
    """One C call for prepared arguments ``a`` (runtime/simulate.prepare, events off).

    Returns (x rows, stats dict, x_last, S) with S (n_eval, nx, k): the columns for
    ``xs`` then ``ps``.  ``jvp``: see :func:`use_jvp`.  ``error_control``: the step
    control watches S too (else the steps are the plain run's).  The stats gain
    ``njvp`` / ``sens_iterations`` / ``sens_slow`` / ``sens_trimmed`` (Radau's staggered
    iteration: jvp calls, iterations, steps whose iteration had not converged, factorizations
    whose S solves skipped the LU's structural zeros (:data:`TRIM_SOLVES`); 0 elsewhere).
    """
    ffi, lib = _sens_ffi(model.ffi)
    nx, k = model.nx, len(xs) + len(ps)
    ctx = ffi.new("char[]", int(lib.eomc_sens_size()))
    s = ffi.cast("eomc_sens *", ctx)
    scratch = np.empty(lib.eomc_sens_scratch_size(model.c_model, len(xs) + len(ps)))
    xcols = np.array(xs + [0], dtype=np.intc)
    pcols = np.array(ps + [0], dtype=np.intc)
    jvp_fn = getattr(model.model_lib, f"{model.name}_jvp") if use_jvp(model, jvp) else ffi.NULL
    jac_p = (getattr(model.model_lib, f"{model.name}_jac_p") if ps and "jac_p" in model.functions
             else ffi.NULL)
    buf = lambda arr: ffi.from_buffer("double[]", arr)  # noqa: E731
    status = lib.eomc_sens_init(s, model.c_model, jac_p, jvp_fn, buf(a["p"]), len(xs),
                                ffi.from_buffer("int[]", xcols), len(ps),
                                ffi.from_buffer("int[]", pcols), buf(scratch))
    if status:
        raise ModelError(f"{model.name}: could not set up the sensitivities (status {status})")
    lib.eomc_sens_error_control(s, int(bool(error_control)))
    if jvp_fn != ffi.NULL and USE_JVP_MORE and "jvp_more" in model.functions:   # else the old path
        lib.eomc_sens_jvp_more(s, getattr(model.model_lib, f"{model.name}_jvp_more"))
    lib.eomc_sens_full_solves(s, int(not TRIM_SOLVES))
    N = int(lib.eomc_sens_nstates(s))
    X0 = np.empty(N)
    lib.eomc_sens_start(s, buf(a["x0"]), buf(X0))
    method = METHOD_IDS[a["method"]]
    work = np.empty(lib.eomc_sens_work_size(s, method))
    n_eval = a["t_eval"].size
    X_out = np.full((n_eval, N), np.nan)
    X_last = np.empty(N)
    stats = ffi.new("eomc_stats *")
    opt = ffi.new("eomc_options *")
    opt.method, opt.rtol, opt.atol = method, a["rtol"], a["atol"]
    opt.h0, opt.hmax, opt.max_steps = a["h0"], a["hmax"], a["max_steps"]
    opt.project, opt.stiff_check = 0, int(a["stiff_check"])
    opt.baumgarte, opt.pi_beta = 0.0, a["pi_beta"]
    arm = getattr(model.integrators, "eomc_interrupt_arm", None)
    if arm is not None:              # Ctrl-C stops the run within one evaluation (runtime/native.py)
        from .native import _ARM_LOCK
        with _ARM_LOCK:
            arm()
    lib.eomc_sens_integrate(s, opt, a["t0"], a["t1"], buf(X0), a["n_r"], buf(a["r_t"]), buf(a["r_v"]),
                            n_eval, buf(a["t_eval"]), buf(X_out), buf(X_last), stats, buf(work),
                            work.size)
    st = {f: getattr(stats, f) for f in stat_fields}
    counts = ffi.new("long[3]")              # C long: 32 bits on Windows, so not an int64 buffer
    lib.eomc_sens_counts(s, counts)
    st.update(njvp=int(counts[0]), sens_iterations=int(counts[1]), sens_slow=int(counts[2]),
              sens_trimmed=int(lib.eomc_sens_trimmed(s)))
    S = X_out[:, nx:].reshape(n_eval, k, nx).transpose(0, 2, 1)
    return np.ascontiguousarray(X_out[:, :nx]), st, X_last[:nx].copy(), S


def attach(model, res, S, xs, ps):
    """Put the rows of S that the result kept on it as dx_dx0 / dx_dp with their names."""
    n = len(res.t)
    res.dx_dx0 = np.ascontiguousarray(S[:n, :, :len(xs)])
    res.dx_dp = np.ascontiguousarray(S[:n, :, len(xs):])
    res.sensitivity_states = tuple(model.state_names[i] for i in xs)
    res.sensitivity_params = tuple(model.param_names[i] for i in ps)
    return res
