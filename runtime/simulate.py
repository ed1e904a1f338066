"""simulate(model, x0, t_span, ...): one trajectory with the whole loop in C.

Why this module exists: it turns friendly Python arguments (dicts by state
name, callables for inputs, method names) into the flat arrays the C
integrator (runtime/c/eomc_integrators.c) needs, checks every one of them
*before* any C runs (issue 4 §8: wrong shapes, non-finite states, reversed
spans, tolerances <= 0, unknown methods are ValueErrors), makes one foreign
call (cffi releases the GIL for it) and wraps the arrays in a
SimulationResult.  It uses only the runtime Model attributes listed in the
pipeline interface (ffi, lib, c_model, nx, names, param_defaults, ...).
"""
import functools
import numbers
import warnings

import numpy as np

from eomc.runtime.errors import ModelError, SimulationError

from .diagnose import SINGULAR_STATUS, singular_direction
from .integrators_api import FIXED_STEP, METHOD_ALIASES, METHOD_IDS, STATUS_NAMES
from .law_parameters import check_law_parameters
from .events import DEFAULT_MAX_EVENTS, EventsBinding, check_max_events, resolve_events
from .feedback import FeedbackBinding, applied_inputs, check_callable, cubic_slopes
from .names import index_of
from .progress import follow_integration
from .result import SimulationResult
from .start import start_or_default

__all__ = ["simulate", "prepare", "run_prepared", "scipy_fun", "resolve_method", "METHODS",
           "DEFAULT_POINTS", "check_keywords", "DEFAULT_METHOD", "auto_method"]

METHODS = tuple(METHOD_IDS) + ("auto",)
# The default: DOP853 while the problem is not stiff, Radau from the start for a model with
# ground contacts (stiff and only piecewise smooth), and Radau from where DOP853 detects
# stiffness otherwise (as LSODA switches) -- so no default run stops with "looks stiff".
DEFAULT_METHOD = "auto"
DEFAULT_POINTS = 1001      # output rows when neither t_eval nor dt is given
# Hairer's stabilized (PI) step control for DOPRI5/DOP853.  On the n-link cart at
# rtol = atol = 1e-8 it rejects ~4x fewer steps than the classical control
# (pi_beta=0, scipy's) and needs ~6% fewer rhs calls for a smaller error.
PI_BETA = 0.04
STIFF_ADVICE = "use method='radau'"
# Output rows are allocated (NaN-filled) before the C call; beyond this many bytes the
# request is almost surely a mistake (rk4 with a tiny dt, a huge n_points): refuse it.
MAX_OUTPUT_BYTES = 2 ** 31
C_LONG_MAX = 2 ** 63 - 1   # opt.max_steps is a C long


@functools.lru_cache(maxsize=64)
def _parameter_names(function):
    """A function's parameter names, computed once (inspect.signature took ~0.1 ms of every
    simulate call: a fifth of a short contact run's time)."""
    import inspect
    return tuple(inspect.signature(function).parameters)


def check_keywords(kw, function, skip=0):
    """Refuse keyword arguments ``function`` does not take, as a ValueError naming them.

    Why: ``model.simulate(..., rtoll=1e-8)`` would otherwise end in Python's TypeError from
    deep inside eomc; the message lists the keywords that exist (the first ``skip``
    positional parameters, e.g. model, x0, t_span, are not offered).
    """
    names = _parameter_names(function)[skip:]
    unknown = [k for k in kw if k not in names]
    if unknown:
        raise ValueError(f"{function.__name__}() got unknown keyword argument(s) "
                         f"{', '.join(map(repr, unknown))}; valid keywords: {', '.join(names)}")


def resolve_method(method):
    """Canonical method name; ValueError naming the nearest ones and listing the valid ones
    otherwise (the command line checks --method with it before building a model file)."""
    key = str(method).lower().replace("-", "").replace("_", "")
    key = METHOD_ALIASES.get(key, key)
    if key not in METHOD_IDS and key != "auto":
        import difflib
        names = ["auto"] + list(METHOD_IDS) + list(METHOD_ALIASES)
        near = difflib.get_close_matches(key, names, n=2, cutoff=0.6)
        raise ValueError(f"unknown integration method {method!r}"
                         + (f" (did you mean {' or '.join(near)}?)" if near else "")
                         + f"; valid methods: {', '.join(names)}")
    return key


def _positive(value, what, allow_none=False):
    if value is None and allow_none:
        return None
    if not isinstance(value, numbers.Real) or isinstance(value, bool) or not np.isfinite(value) \
            or value <= 0:
        raise ValueError(f"{what} must be a finite number > 0; got {value!r}")
    return float(value)


def _span(t_span):
    try:
        t0, t1 = (float(v) for v in t_span)
    except (TypeError, ValueError):
        raise ValueError(f"t_span must be (t0, t_final) with two numbers; got {t_span!r}") from None
    if not (np.isfinite(t0) and np.isfinite(t1)):
        raise ValueError(f"t_span must be finite; got ({t0}, {t1})")
    if t1 == t0:
        raise ValueError(f"t_span ({t0}, {t1}) is empty: t_final must be greater than t0")
    if t1 < t0:
        raise ValueError(f"t_span ({t0}, {t1}) is reversed: integration runs forward, "
                         f"t_final must be greater than t0")
    ulp = float(np.spacing(max(abs(t0), abs(t1))))
    if t1 - t0 < 1e3 * ulp:
        raise ValueError(f"t_span ({t0:.17g}, {t1:.17g}) is too short for its size: near "
                         f"t={max(abs(t0), abs(t1)):.3g} doubles are {ulp:.3g} apart, so the span holds "
                         f"only {(t1 - t0) / ulp:.0f} of them and every step would underflow relative "
                         f"to t; shift the time origin (start near t=0)")
    return t0, t1


def _real(value, what):
    """float(value) for a real scalar; ValueError naming ``what`` for None, strings, complex, 10**400."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Real, np.ndarray)):
        raise ValueError(f"{what} must be a real number; got {type(value).__name__} {value!r}")
    try:
        return float(value)
    except (TypeError, ValueError, OverflowError):
        shown = (f"an integer of about {int(abs(value).bit_length() * 0.30103)} digits"
                 if isinstance(value, numbers.Integral) else repr(value))
        raise ValueError(f"{what} must be a real number that fits a double; got {shown}") from None


def state_defaults(model):
    """The values of states a dict x0 leaves out: the model's initial_state, else 0.

    One rule everywhere (simulate, simulate_many, sweep, consistent_state and the
    command line's --x0): a state not named starts where the model file starts it.
    """
    base = getattr(model, "initial_state", None)
    return np.zeros(model.nx) if base is None else np.array(base, dtype=np.float64)


def _real_array(value, what, dtype=np.float64):
    """np.asarray(value, float) with a ValueError naming ``what`` for strings, complex, ragged."""
    try:
        a = np.asarray(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{what} must be an array of real numbers; got {type(value).__name__} "
                         f"({exc})") from None
    if a.dtype.kind not in "fiub":
        kind = "complex numbers" if a.dtype.kind == "c" else f"dtype {a.dtype}"
        raise ValueError(f"{what} must hold real numbers; got {kind}")
    return np.asarray(a, dtype=dtype)


def _vector(model, value, size, names, defaults, what):
    """A float64 vector of `size` from an array or a {name: value} dict (missing -> defaults)."""
    if isinstance(value, dict):
        out = np.array(defaults, dtype=np.float64)
        for key, v in value.items():
            i = index_of(key, names, f"{what} name", model.name)
            out[i] = _real(v, f"{model.name}: {what} {names[i]}")
    else:
        a = np.asarray(value)
        if a.dtype.kind not in "fiu":
            raise ValueError(f"{model.name}: {what} must be real numbers; got dtype {a.dtype}")
        if a.shape != (size,):
            raise ValueError(f"{model.name}: {what} must have shape ({size},) "
                             f"[{', '.join(names)}]; got shape {a.shape}")
        out = np.array(a, dtype=np.float64)
    finite = np.isfinite(out)
    if not finite.all():
        bad = [n for n, ok in zip(names, finite) if not ok]
        raise ValueError(f"{model.name}: {what} is not finite for {', '.join(bad)}")
    return out


def _inputs(model, r, t0, t1):
    """(n_grid, t_grid, values) for the C side: constant, sampled grid, or callable."""
    ni = model.ninput
    if r is None:
        return 0, np.zeros(1), np.zeros(max(ni, 1))
    if ni == 0:
        raise ValueError(f"{model.name}: this model has no inputs, but r was given")
    if callable(r):
        # evaluated at every stage through a callback (feedback.py), never resampled
        return 0, np.zeros(1), np.zeros(max(ni, 1))
    if isinstance(r, tuple):
        if len(r) not in (2, 3):
            raise ValueError(f"{model.name}: r as a tuple is an input table (t_grid, values) or "
                             f"(t_grid, values, kind); got a tuple of {len(r)} items")
        return input_grid(model, r[0], r[1])
    if ni == 1 and isinstance(r, (numbers.Real, np.floating, np.integer)) and not isinstance(r, bool):
        r = [r]     # one input: a number is its value
    values = _vector(model, r, ni, model.input_names, np.zeros(ni), "r (inputs)")
    return 1, np.zeros(1), values


def input_grid(model, t_grid, values, rows=None):
    """(k, t_grid, values) of an input table r=(t_grid, values), checked once for every caller.

    ``simulate`` takes values of shape (k, ninput) (or (k,) for one input); ``rollout``
    passes ``rows`` = its number of trajectories and also takes (rows, k, ninput), one
    sequence per trajectory.  Every refusal names the argument, the shapes expected (with
    the input names) and what was given, so the two entry points speak alike."""
    what = f"{model.name}: r=(t_grid, values)"
    t_grid = np.ascontiguousarray(_real_array(t_grid, f"{what}: t_grid"))
    values = _real_array(values, f"{what}: values")
    ni = model.ninput
    if t_grid.ndim != 1 or t_grid.size < 2:
        raise ValueError(f"{what}: t_grid must be 1-d with at least 2 times; got shape {t_grid.shape}")
    k = t_grid.size
    if values.shape == (k,) and ni == 1:
        values = values[:, None]
    shapes = [(k, ni)] + ([(rows, k, ni)] if rows is not None else [])
    if values.shape not in shapes:
        names = ", ".join(model.input_names)
        if rows is None:
            expected = f"({k}, {ni}) (one row per t_grid time; inputs {names})"
        else:
            expected = (f"({k}, {ni}) (one sequence for every row) or ({rows}, {k}, {ni}) (one per row; "
                        f"inputs {names})")
        raise ValueError(f"{what}: values must have shape {expected}; got {values.shape} "
                         f"(t_grid has {k} times)")
    for name, a in (("t_grid", t_grid), ("values", values)):
        if not np.all(np.isfinite(a)):
            at = tuple(int(i) for i in np.argwhere(~np.isfinite(a))[0])
            raise ValueError(f"{what} holds non-finite values: {name}[{', '.join(map(str, at))}] = {a[at]}")
    steps = np.diff(t_grid)
    if np.any(steps <= 0):
        i = int(np.flatnonzero(steps <= 0)[0])
        raise ValueError(f"{what}: t_grid must be strictly increasing; t_grid[{i + 1}] = {t_grid[i + 1]:.17g} "
                         f"follows t_grid[{i}] = {t_grid[i]:.17g}")
    return k, t_grid, np.ascontiguousarray(values)


def _rk4_steps(t0, t1, dt):
    """RK4's step count for the span (a float: it may be astronomically large)."""
    return float(np.ceil((t1 - t0) / dt * (1 - 1e-12)))


def _n_points(n_points):
    if n_points is None:
        return DEFAULT_POINTS
    if isinstance(n_points, (bool, np.bool_)) or not isinstance(n_points, numbers.Integral) or n_points < 2:
        raise ValueError(f"n_points must be an integer >= 2 (the output rows, t0 and t_final "
                         f"included); got {n_points!r}")
    return int(n_points)


def _check_rows(rows, nx, why):
    """Refuse an output array too large to be meant (see MAX_OUTPUT_BYTES), before allocating it."""
    size = rows * max(nx, 1) * 8.0
    if size > MAX_OUTPUT_BYTES:
        raise ValueError(f"the output would hold {rows:.3g} rows ({size / 2 ** 30:.3g} GiB), more than "
                         f"eomc allocates ({MAX_OUTPUT_BYTES / 2 ** 30:g} GiB): {why}")


def _t_eval(t_eval, t0, t1, method, dt, n_points, nx=1):
    if t_eval is None:
        if method in FIXED_STEP:
            n = _rk4_steps(t0, t1, dt)
            _check_rows(n + 1, nx, f"{method} writes every step; pass t_eval= with the times you "
                                   "need or a larger dt")
            n = int(n)
            return np.append(t0 + dt * np.arange(n), t1)
        n = _n_points(n_points)
        _check_rows(n, nx, "pass a smaller n_points")
        return np.linspace(t0, t1, n)
    a = np.asarray(t_eval)
    if a.dtype.kind not in "fiu":
        raise ValueError(f"t_eval must hold real times; got dtype {a.dtype}")
    t = np.atleast_1d(np.asarray(a, dtype=np.float64))
    if t.ndim != 1 or t.size == 0:
        raise ValueError(f"t_eval must be a non-empty 1-d array of times; got shape {t.shape}")
    if not np.isfinite(t).all():      # (ndarray methods: no dispatch, a run's Python tail counts)
        raise ValueError("t_eval holds non-finite times")
    if t[0] < t0 or t[-1] > t1:
        raise ValueError(f"t_eval must lie inside t_span [{t0}, {t1}]; got [{t[0]}, {t[-1]}]")
    if t.size > 1 and (t[1:] <= t[:-1]).any():
        raise ValueError("t_eval must be strictly increasing")
    _check_rows(t.size, nx, "pass fewer t_eval times")
    return np.ascontiguousarray(t)


# method="auto" on a model with contacts: BDF at rtol >= this, Radau below.  Measured on
# Solo12 standing, gymnasium's hopper and ant dropped (benchmarks/results/contact_wp.md):
# BDF takes 1/2 to 1/3 of Radau's time from rtol 1e-2 to 1e-8 (rhs calls: one to two per step
# against Radau's three per Newton iteration), while Radau's order 5 pays off at the tightest
# tolerances: at eomc check's 1e-8 on G1 falling (34 contact spheres) BDF ended 3.6e5x its
# tolerance away from the reference, Radau 16x.
BDF_FINEST = 1e-7


def auto_method(model, rtol=1e-6):
    """(first method, may switch to radau) of method="auto" for this model at this rtol."""
    from .switching import find_switches
    implicit = model.c_model.jac_x != model.ffi.NULL
    if implicit and find_switches(model).contacts:
        return ("bdf" if rtol >= BDF_FINEST else "radau"), False
    return "dop853", implicit


MAX_STEPS = 100000              # max_steps' default ...
CONTACT_STEPS_PER_S = 100000    # ... and for a run with ground contacts, at least this many per simulated second


def default_max_steps(model, t_span):
    """max_steps when none is given: MAX_STEPS, and for a model with ground contacts at least
    CONTACT_STEPS_PER_S per simulated second of ``t_span``.

    Why per second: a robot on the ground takes many short steps for as long as it touches it
    (touch-downs, bodies resting on contacts and on joint limits), so a fixed budget ran out on
    long enough runs however sound: Talos --floating-base --ground (1576 contact points) takes
    ~61,000 BDF steps per simulated second as it collapses onto its knees and hands and stopped
    at t = 1.67 of 2 (sweep s27); G1 takes ~26,000.  About half of Talos's come from its grippers'
    limit springs (7 joints a hand, k ~ 3e5 on their own inertias of 9e-6 to 6e-4 kg m^2, sized
    by the floating-base load rule: with them off, 27,800 steps instead of 61,600 over the first
    second, the base's motion the same; runctl s28).  Without contacts a run that needs more than
    MAX_STEPS is rare and more often a sign of trouble, and the budget stays a fixed guard."""
    from .switching import find_switches
    t0, t1 = t_span
    if not find_switches(model).contacts:
        return MAX_STEPS
    return max(MAX_STEPS, int(np.ceil(CONTACT_STEPS_PER_S * abs(float(t1) - float(t0)))))


def prepare(model, x0, t_span, p=None, r=None, method=DEFAULT_METHOD, rtol=1e-6, atol=1e-9,
            t_eval=None, dt=None, max_steps=None, first_step=None, max_step=None,
            project=False, stiff_check=True, n_points=None, baumgarte=0.0, pi_beta=PI_BETA,
            events=None, max_events=DEFAULT_MAX_EVENTS, K=None, x_ref=None, switching=True):
    """Check every argument and return the dict run_prepared() passes to C.

    switching: end steps at the model's contact and limit switching points
    (runtime/switching.py); False only to measure what the bare integrator does
    (benchmarks).  The run's physics is judged either way."""
    method = resolve_method(method)
    auto = method == "auto"
    if auto:
        if dt is not None:
            raise ValueError(f"dt= (--dt) is only for the fixed-step methods {', '.join(map(repr, FIXED_STEP))}; "
                             f"the default method 'auto' is adaptive: pass one of them with it (method= in "
                             f"Python, --method on the command line)")
    t0, t1 = _span(t_span)
    rtol, atol = _positive(rtol, "rtol"), _positive(atol, "atol")
    if auto:
        method, may_switch = auto_method(model, rtol)
        stiff_check = stiff_check or may_switch
    if method in FIXED_STEP:
        if dt is None:
            # sweep s27: `eomc simulate hopper.xml --method implicitfast` was refused without a
            # word of the step its file is written for (MuJoCo's <option timestep>, the model's)
            step = getattr(model, "timestep", None)
            own = (f"; the model's file steps at {step:g} (MJCF <option timestep>): dt={step:g}, "
                   f"--dt {step:g}") if step else ""
            raise ValueError(f"method={method!r} is fixed-step: give the step size (dt= in Python, "
                             f"--dt on the command line){own}")
        first_step = _positive(dt, "dt")
    elif dt is not None:
        raise ValueError(f"dt= is only for the fixed-step methods {', '.join(map(repr, FIXED_STEP))}; "
                         f"{method!r} is adaptive (use first_step= or max_step=)")
    first_step = _positive(first_step, "first_step", allow_none=True)
    max_step = _positive(max_step, "max_step", allow_none=True)
    budget = max_steps is None
    if budget:
        max_steps = default_max_steps(model, (t0, t1))
    if not isinstance(max_steps, numbers.Integral) or isinstance(max_steps, (bool, np.bool_)) \
            or not 0 < max_steps <= C_LONG_MAX:
        raise ValueError(f"max_steps must be a positive integer up to 2**63 - 1; got {max_steps!r}")
    if method in FIXED_STEP and _rk4_steps(t0, t1, first_step) > max_steps:
        raise ValueError(f"{method} with dt={first_step:g} needs {_rk4_steps(t0, t1, first_step):.4g} steps "
                         f"over t_span ({t0:g}, {t1:g}), more than max_steps={max_steps}; raise "
                         f"max_steps or dt (or use an adaptive method)")
    if not isinstance(pi_beta, numbers.Real) or not 0.0 <= pi_beta <= 0.1:
        raise ValueError(f"pi_beta must be a number in [0, 0.1] (Hairer's advice); got {pi_beta!r}")
    if not isinstance(baumgarte, numbers.Real) or not np.isfinite(baumgarte) or baumgarte < 0:
        raise ValueError(f"baumgarte must be a finite rate >= 0 (1/time); got {baumgarte!r}")
    if (project or baumgarte) and (model.nhol + model.nvel == 0
                                   or model.c_model.constraints == model.ffi.NULL
                                   or model.c_model.constraints_jac == model.ffi.NULL):
        raise ValueError(f"{model.name}: project/baumgarte need the model's constraints and "
                         f"constraints_jac; this model has none")
    if model.c_model.rhs == model.ffi.NULL:
        raise model._missing("rhs")  # every method integrates rhs
    if ((method in ("radau", "bdf") or (method == "implicitfast" and "implicit" not in getattr(model, "functions", ())))
            and model.c_model.jac_x == model.ffi.NULL):
        raise ValueError(f"{model.name}: method {method!r} needs the Jacobian jac_x, which this model "
                         f"was built without; rebuild with functions including 'jac_x'")
    x0 = _vector(model, start_or_default(model, x0), model.nx, model.state_names, state_defaults(model),
                 "x0 (initial state)")
    quat = check_quaternions(model, x0, "x0 (initial state)")
    p = model.param_defaults if p is None else p
    p = _vector(model, p, model.nparam, model.param_names, model.param_defaults, "p (parameters)")
    check_law_parameters(model, p)      # the build's refusals, for values changed at run time
    n_r, r_t, r_v = _inputs(model, r, t0, t1)
    times = _t_eval(t_eval, t0, t1, method, first_step, n_points, model.nx)
    if times.size > 1 and (times[1:] <= times[:-1]).any():
        raise ValueError(f"the output times are not distinct near t={t1:.3g}: doubles there are "
                         f"{np.spacing(t1):.3g} apart; shift the time origin or use fewer points")
    extras = _extras(model, x0, t0, r, events, max_events, K, x_ref, method)
    from .switching import find_switches
    sw = find_switches(model)
    if sw:
        extras["switches"] = sw
        extras["switch_steps"] = bool(switching)
        extras.setdefault("max_events", max_events)
    if auto and may_switch and "r_fun" not in extras and ("K" not in extras
                                                            or model.c_model.jac_r != model.ffi.NULL):
        extras["auto_switch"] = True
    return dict(method=method, t0=t0, t1=t1, x0=x0, p=np.append(p, 0.0), n_r=n_r, r_t=r_t,
                r_v=r_v, t_eval=times, rtol=rtol, atol=atol, h0=first_step or 0.0,
                hmax=max_step or 0.0, max_steps=int(max_steps), max_steps_default=budget, project=bool(project),
                stiff_check=bool(stiff_check), baumgarte=float(baumgarte), pi_beta=float(pi_beta),
                auto=auto, **quat, **extras)


def check_quaternions(model, x, what, c_array=True):
    """{} for a model without quaternions, else {"quat": the C int array of their w indices}
    (eomc_options.quat: the integrators keep them unit; c_array=False: {}, the check alone), after
    checking that every quaternion of ``x`` (a state, or rows of states) has a length to normalise:
    a zero one is no orientation at all (its rhs would be NaN)."""
    starts = getattr(model, "quaternions", ())
    if not starts:
        return {}
    rows = np.atleast_2d(np.asarray(x, dtype=float))
    for i in starts:
        norms = np.linalg.norm(rows[:, i:i + 4], axis=1)
        ok = (norms > 1e-150) & (norms < np.inf)
        if ok.all():
            continue
        bad = np.flatnonzero(~ok)
        if bad.size:
            names = ", ".join(model.state_names[i:i + 4])
            row = f" (row {bad[0]})" if rows.shape[0] > 1 else ""
            raise ValueError(f"{model.name}: {what}{row}: the quaternion ({names}) is "
                             f"{'zero' if np.isfinite(norms[bad[0]]) else 'not finite'}: it is no "
                             f"orientation (upright is {model.state_names[i]}=1, the others 0)")
    return {"quat": model.ffi.new("int[]", [int(i) for i in starts])} if c_array else {}


def _extras(model, x0, t0, r, events, max_events, K, x_ref, method):
    """Checked events (events.py) and state feedback / input callable (feedback.py)."""
    out = {}
    resolved = resolve_events(model, events)
    if resolved is not None:
        out["events"] = resolved
        out["max_events"] = max_events
        if events is None:      # the model's own events (checked when first resolved)
            check_max_events(max_events, model.nx)
        else:
            EventsBinding(model, *resolved, max_events=max_events)   # checks now, before any C runs
    if callable(r):
        check_callable(model, r, t0, x0)
        out["r_fun"] = r
    slopes = cubic_slopes(model, *r) if isinstance(r, tuple) and len(r) == 3 else None
    if slopes is not None:
        out["r_slopes"] = slopes
    if K is not None or x_ref is not None:
        if model.ninput == 0:
            raise ValueError(f"{model.name}: this model has no inputs, so it takes no feedback K")
        if K is not None and not isinstance(K, tuple):
            K = _real_array(K, f"{model.name}: the feedback gain K")
        if x_ref is not None and not isinstance(x_ref, dict):
            x_ref = _real_array(x_ref, f"{model.name}: x_ref")
        FeedbackBinding(model, K, x_ref)                        # checks the shapes
        if method in ("radau", "bdf", "implicitfast") and model.c_model.jac_r == model.ffi.NULL:
            raise ValueError(f"{model.name}: method {method!r} with feedback K needs jac_r")
        out["K"], out["x_ref"] = K, x_ref
    return out


def _options(ffi, a, implicit=None):
    opt = ffi.new("eomc_options *")
    opt.method, opt.rtol, opt.atol = METHOD_IDS[a["method"]], a["rtol"], a["atol"]
    opt.h0, opt.hmax, opt.max_steps = a["h0"], a["hmax"], a["max_steps"]
    opt.project, opt.stiff_check = int(a["project"]), int(a["stiff_check"])
    opt.baumgarte, opt.pi_beta = a["baumgarte"], a["pi_beta"]
    if a.get("quat") is not None:       # kept alive by ``a`` and by bind_call's call
        opt.nquat, opt.quat = len(a["quat"]), a["quat"]
    if implicit is not None:
        opt.implicit = implicit
    if a.get("stop") is not None:       # an int* another thread may set to end the run (eomc check's
        opt.stop = a["stop"]            # references, runtime/check_references.py); kept alive by ``a``
    return opt


FREE_SPEEDS = ("vx", "vy", "vz", "wx", "wy", "wz")   # an eomc free joint's speeds (joint_kinds.KINDS)


def free_roots(model, parents):
    """The first speed of each free joint at the root of the tree (eomc_implicit.free): six speeds
    ``u_<joint>_vx`` ... ``u_<joint>_wz`` in a chain from a speed with no parent.  eomc's readers
    (MJCF, URDF, the multibody joints) give a free joint these speeds, body-frame, so their rows
    of the equations are the subtree's momentum balance p' + w x p = F that the fast path's
    fs_transport treats half implicitly; a model whose speeds are named otherwise keeps the
    explicit turning."""
    names = list(model.state_names)[model.nq:]
    out = []
    for s in range(len(names) - 5):
        stem = names[s][:-2]
        if (parents[s] == -1 and stem.startswith("u_") and stem.endswith("_")
                and all(names[s + j] == stem + c and (j == 0 or parents[s + j] == s + j - 1)
                        for j, c in enumerate(FREE_SPEEDS))):
            out.append(s)
    return out


def joint_starts(info, nu, free):
    """eomc_implicit.joint: per speed the first speed of its joint, from NAME.json's implicit "joints"
    (the speeds of each joint of several speeds, compiler/formulations/recursive.implicit_metadata),
    or None when every such joint is a root free joint in ``free`` (free_roots: its speeds' velocity
    before the joint is 0, and the C skips them) -- a contact's bias (fs_point_bias) then runs the
    one-speed code.  A model built before the json carried "joints" gets None too."""
    joints = [[int(s) for s in j] for j in info.get("joints", ())]
    if all(j[0] in free and len(j) == 6 for j in joints):
        return None
    out = list(range(nu))
    for j in joints:
        for s in j:
            out[s] = min(j)
    return out


def limit_entries(model):
    """[(state, speed, bound, sign)] of the model's joint limits (switching.find_switches) whose
    joint has one speed u_<joint>: eomc_implicit's limit arrays (the fast path locates a try's
    entry into them)."""
    from .switching import find_switches
    states = {n: i for i, n in enumerate(model.state_names)}
    out = []
    for lim in find_switches(model).limits:
        s = states.get(f"u_{lim.joint}", -1) - model.nq
        if 0 <= s < model.nu:
            out.append((lim.state, s, lim.param, lim.sign))
    return out


def implicit_terms(model):
    """The C ``eomc_implicit`` of ``model`` (its NAME_implicit and the structure NAME.json's
    "implicit" gives), or None when the model has none: then method="implicitfast" runs the
    linearly implicit Euler on the whole jac_x (runtime/c/eomc_fixedstep.c).  Built once per
    model; the struct and the arrays it points to live on the model."""
    cached = model.__dict__.get("_implicit_struct")
    if cached is not None:
        return cached[0]
    ffi, found = model.ffi, (None,)
    info = (getattr(model, "metadata", None) or {}).get("implicit")
    if (info and "implicit" in getattr(model, "functions", ()) and model.nz == 0
            and getattr(model, "backend", None) == "cffi"):
        try:
            fp = ffi.addressof(model.model_lib, f"{model.name}_implicit")
        except (AttributeError, KeyError, ffi.error):
            fp = None
        if fp is not None:
            contacts = info["contacts"]
            starts = np.cumsum([0] + [len(c["speeds"]) for c in contacts]).tolist()
            chain = [int(s) for c in contacts for s in c["speeds"]]
            parents = [int(x) for x in info["parents"]]
            tree = len(parents) == model.nu and all(-1 <= q < s for s, q in enumerate(parents))
            free = free_roots(model, parents)
            joint = joint_starts(info, model.nu, free)
            keep = (ffi.new("int[]", starts), ffi.new("int[]", chain or [0]),
                    ffi.new("int[]", parents) if tree else ffi.NULL, ffi.new("int[]", free or [0]))
            st = ffi.new("eomc_implicit *")
            st.terms = ffi.cast("eomc_mat_fn", fp)
            split = _const_apart(model)
            if split is not None:       # the constant outputs once per run (eomc_implicit.terms_const)
                st.terms, st.terms_const = ffi.cast("eomc_mat_fn", split[0]), split[1]
            if tree and model.metadata.get("tree_lu"):   # M's tree pattern factored in straight-line C
                st.tree_lu = ffi.addressof(model.model_lib, f"{model.name}_tree_lu")
                st.tree_solve = ffi.addressof(model.model_lib, f"{model.name}_tree_solve")
                st.tree_residual = ffi.addressof(model.model_lib, f"{model.name}_tree_residual")
            st.ncontact = len(contacts)
            st.chain_start, st.chain, st.parent = keep[:3]
            st.nfree, st.free = len(free), keep[3]
            st.work_len = model.integrators.eomc_fs_implicit_work_size(model.nq, model.nu, len(contacts))
            st.energy = int("energy" in info["layout"])     # its out[] ends with the energy (the watch's)
            if joint is not None:
                keep += (ffi.new("int[]", joint),)
                st.joint = keep[-1]
            limits = limit_entries(model)
            if limits:                  # where a try enters a limit (fs_onset_cell locates it)
                keep += tuple(ffi.new(kind, list(col)) for kind, col in
                              zip(("int[]", "int[]", "int[]", "double[]"), zip(*limits)))
                st.nlimit = len(limits)
                st.limit_state, st.limit_speed, st.limit_bound, st.limit_sign = keep[-4:]
            keep += _fixed_lists(model, st)
            found = (st, keep, fp)
    model._implicit_struct = found
    return found[0]


def _fixed_lists(model, st):
    """eomc_implicit.pattern: the fast path's fixed lists (M's tree pattern, the contacts' branch
    masks, M's and N's column lists) made once for the model by the C that would make them at every
    run's start (eomc_fs_pattern), set on ``st``; returns what must stay alive with it.  Why: a
    rollout of one step a call made them per row, ~4 us of the humanoid's ~19 us a row (session 53);
    a library without eomc_fs_pattern (an older build of the integrators): none, made per run."""
    make = getattr(model.integrators, "eomc_fs_pattern", None)
    if make is None:
        return ()
    ffi = model.ffi
    work = ffi.new("double[]", max(int(st.work_len), 1))
    n = int(make(st, model.nq, model.nu, work, ffi.NULL))
    lists = ffi.new("double[]", max(n, 1))
    make(st, model.nq, model.nu, work, lists)
    st.pattern, st.pattern_len = lists, n
    return (lists,)


def _const_apart(model):
    """(NAME_implicit_var, NAME_implicit_const) when the model has them (NAME.json's
    "const_outputs", compiler/tree/emit.implicit_constants), else None: NAME_implicit whole."""
    if not (model.metadata.get("const_outputs") or {}).get("implicit"):
        return None
    try:
        return (model.ffi.addressof(model.model_lib, f"{model.name}_implicit_var"),
                model.ffi.addressof(model.model_lib, f"{model.name}_implicit_const"))
    except (AttributeError, KeyError, model.ffi.error):
        return None


# implicitfast's fast path fails a run (EOMC_PENETRATED, status 10) whose contact goes deeper
# than its radius (the sphere's centre reaches the ground: the contact geometry no longer holds,
# whatever the law computes), or than POINT_DEPTH_FAIL for a point contact.  The warning at half
# the radius (switching.PENETRATION_FRACTION) stays the verdict of every method.
POINT_DEPTH_FAIL = 0.05     # m
PENETRATED_STATUS = 10      # EOMC_PENETRATED
# The fast path splits a step whose linearisation misses implicit Euler by more than this
# (eomc_implicit.split; runtime/c/eomc_fixedstep.c says how it was chosen).  0 turns the test
# off: one model call per step, MuJoCo's implicitfast (a["split"] = 0: what benchmarks
# measure as "unchecked").
IMPLICITFAST_SPLIT = 0.5
IMPLICITFAST_HARD_FACTOR = 20.0     # eomc_fixedstep.c HARD_FACTOR: split regardless above this x split


def depth_limits(model, p):
    """(ncontact,) the depth at which each contact of NAME_implicit fails the run, from the
    run's parameters (its radius r_<contact>); a body-body pair's point: none (inf: a pair has
    no radius to reach, and its depth is the rhs's verdict's, runtime/switching.py)."""
    # each contact's radius parameter index (-1: none, None: a pair), kept on the model: the
    # metadata's contacts are fixed, and a rollout reads them twice a call (the humanoid's 100)
    # (only an instance's own dict: a stand-in class's __dict__ is a read-only mappingproxy)
    cache = getattr(model, "__dict__", None)
    slots = cache.get("_depth_slots") if isinstance(cache, dict) else None
    if slots is None:
        index = {n: i for i, n in enumerate(model.param_names)}
        slots = tuple(None if c.get("pair") else index.get(f"r_{c.get('name')}", -1)
                      for c in model.metadata["implicit"]["contacts"])
        if isinstance(cache, dict):
            cache["_depth_slots"] = slots
    out = []
    for i in slots:
        if i is None:
            out.append(np.inf)
            continue
        r = float(p[i]) if i >= 0 else 0.0
        out.append(r if r > 0 else POINT_DEPTH_FAIL)
    return np.array(out, dtype=np.float64)


def implicit_for_run(model, p, split=IMPLICITFAST_SPLIT):
    """``implicit_terms(model)`` with the depth limits of parameters ``p`` and the residual
    test's ``split``: (struct, keep-alive), or (None, None) when the model has no fast path."""
    base = implicit_terms(model)
    if base is None:
        return None, None
    ffi = model.ffi
    lim = ffi.new("double[]", depth_limits(model, p).tolist() or [0.0])
    st = ffi.new("eomc_implicit *")
    st.terms, st.ncontact, st.chain_start, st.chain = base.terms, base.ncontact, base.chain_start, base.chain
    st.parent, st.work_len, st.depth_limit, st.split = base.parent, base.work_len, lim, float(split)
    st.nfree, st.free, st.terms_const, st.energy = base.nfree, base.free, base.terms_const, base.energy
    st.joint, st.tree_lu, st.tree_solve = base.joint, base.tree_lu, base.tree_solve
    st.tree_residual = base.tree_residual
    st.nlimit, st.limit_state, st.limit_speed = base.nlimit, base.limit_state, base.limit_speed
    st.limit_bound, st.limit_sign = base.limit_bound, base.limit_sign
    st.pattern, st.pattern_len = base.pattern, base.pattern_len
    return st, (st, lim, base)     # the caller keeps the second alive while C runs


def penetration_message(model, x_last, p):
    """The contacts of a run that failed EOMC_PENETRATED, deepest first, with their limits."""
    try:
        deep = deepest_contacts(model, x_last, p)
    except Exception:       # noqa: BLE001 -- the message must not hide the failure
        return ""
    if not deep:
        return ""
    return "; " + "; ".join(f"contact {n} went {d * 1e3:.2f} mm into the ground, deeper than its limit "
                            f"{lim * 1e3:.2f} mm (its radius: the sphere's centre reached the ground)"
                            for n, d, lim in deep[:4]) + (
        f" -- the contact is far too soft for the load (raise k_{deep[0][0]}) or the step too long for it "
        f"(lower dt)")


def deepest_contacts(model, x, p):
    """[(name, depth, limit)] of the contacts deeper than their limit at state x, deepest first."""
    from .generated_call import call_generated
    info = model.metadata["implicit"]
    layout = info["layout"]
    got = call_generated(model, "implicit", 0.0, x, p, np.zeros(model.ninput), layout["size"])
    if got is None or got[0] != 0:
        return []
    out = got[1]
    lims = depth_limits(model, p)
    found = [(c.get("name"), float(out[layout["contact"] + 25 * k]), float(lims[k]))
             for k, c in enumerate(info["contacts"])]
    return sorted([f for f in found if f[1] > f[2]], key=lambda f: -f[1])


def bind_call(model, a, out=None):
    """(call, x_out, x_last, stats): ``call()`` makes the integrator's C call for prepared args ``a``.

    All buffers are allocated here, once, so a caller timing ``call`` (the
    work-precision report) measures the integration in C and nothing else.  ``call`` keeps
    ``model`` alive: its C model and library must outlive the call (a caller that kept only
    the call saw its model collected, then wrong runs -- the ant's qpos0 run 777 calls
    instead of 121 -- or a segfault), and so are the C arrays ``opt`` points into that only
    ``a`` held (the quaternions' indices: with ``a`` collected, a quaternion build's bound
    calls ended at once with status 4, bad argument, or could normalise other coordinates).
    """
    ffi, lib = model.ffi, model.integrators
    buf = lambda arr: ffi.from_buffer("double[]", arr)  # noqa: E731
    n_eval = a["t_eval"].size
    x_out = np.full((n_eval, model.nx), np.nan) if out is None else out
    x_last = np.empty(model.nx)
    feedback = "r_fun" in a or "K" in a or "r_slopes" in a
    implicit = None
    if a["method"] == "implicitfast" and a.get("fast", True):
        implicit, a["_implicit_keep"] = implicit_for_run(model, a["p"], a.get("split", IMPLICITFAST_SPLIT))
    work = np.empty(lib.eomc_integrate_work_size(model.c_model, METHOD_IDS[a["method"]])
                    + (model.ninput * model.nx * (2 if isinstance(a.get("K"), tuple) else 1)
                       + (model.nx if isinstance(a.get("K"), tuple) else 0) if feedback else 0)
                    + (implicit.work_len if implicit is not None else 0))
    stats = ffi.new("eomc_stats *")
    opt = _options(ffi, a, implicit)
    if a["method"] == "implicitfast" and "switches" in a:   # the energy verdict's watch of every step
        watch_options(model, opt, a)
    head = (model.c_model, opt, a["t0"], a["t1"], buf(a["x0"]), buf(a["p"]), a["n_r"],
            buf(a["r_t"]), buf(a["r_v"]))
    tail = (n_eval, buf(a["t_eval"]), buf(x_out), buf(x_last), stats, buf(work), work.size)
    if not feedback and "events" not in a and "switches" not in a:
        keep = (a.get("_implicit_keep"), a.get("quat"))     # what opt points to: alive as long as the call
        return (lambda keep=keep, model=model: lib.eomc_integrate(*head, *tail)), x_out, x_last, stats
    fb = (FeedbackBinding(model, a.get("K"), a.get("x_ref"), a.get("r_fun"), a.get("r_slopes"))
          if feedback else None)
    source, chosen = a.get("events", (None, []))
    ev = (EventsBinding(model, source, chosen, max_events=a["max_events"], switches=a.get("switches"),
                        observe_only=not a.get("switch_steps", True))
          if "events" in a or "switches" in a else None)
    a["_bindings"] = (fb, ev)       # finish() reads the events and any callable's exception
    extras = (fb.struct if fb else ffi.NULL, ev.struct if ev else ffi.NULL)

    def call(bindings=(fb, ev, a.get("_implicit_keep"), a.get("quat")), model=model):   # keeps what its structs point to alive
        return lib.eomc_integrate_ex(*head, *extras, *tail)
    return call, x_out, x_last, stats


_STAT_FIELDS = ("steps", "accepted", "rejected", "nfev", "njev", "nlu", "nproj", "status", "n_out",
                "t", "t_fail", "h", "stiff_hlambda", "max_residual", "nswitch")


def run_prepared(model, a, out=None):
    """One C call: returns (x_out rows written, stats dict, x_last).  Releases the GIL.

    method="auto" (a["auto_switch"]): where DOP853 stops because the problem looks stiff,
    a second call continues with Radau from that state into the same output rows."""
    call, x_out, x_last, stats = bind_call(model, a, out)
    # a caller inside runtime.progress.integration() (eomc simulate) sees how far it got; the
    # Radau part of an "auto" run that switched goes on over the whole span and step count
    t0, t1, before = a.get("_progress", (a["t0"], a["t1"], None))
    try:
        follow_integration(lambda: (stats.t, stats.steps + (before or 0)), t0, t1, call, resume=before is not None)
    except BaseException as stop:
        if not isinstance(stop, Exception):     # Ctrl-C, SIGTERM: the C loop stopped, its rows go along
            stop.eomc_rows = (x_out, {f: getattr(stats, f) for f in _STAT_FIELDS}, x_last)
        raise
    got = {f: getattr(stats, f) for f in _STAT_FIELDS}
    if a.get("_watch") is not None:     # the C energy watch's numbers, for the verdict (finish)
        from .switching import watched_stats
        a["_watched"] = watched_stats(stats, a["_watch"][0])
    if a.get("auto_switch") and got["status"] == STIFF_STATUS and got["t"] < a["t1"]:
        return _continue_implicit(model, a, x_out, got, x_last)
    return x_out, got, x_last


STIFF_STATUS = 7    # EOMC_STIFF


def _continue_implicit(model, a, x_out, first, x_last):
    """The rest of an "auto" run with Radau, from where DOP853 found the problem stiff."""
    n1 = first["n_out"]
    fb, ev = a.get("_bindings", (None, None))
    b = dict(a)
    b.pop("_bindings", None)
    b.update(method="radau", t0=float(first["t"]), x0=np.array(x_last), auto_switch=False,
             t_eval=np.ascontiguousarray(a["t_eval"][n1:]), h0=0.0, _progress=(a["t0"], a["t1"], first["steps"]))
    if b["t_eval"].size and b["t_eval"][0] <= b["t0"]:
        b["t_eval"] = b["t_eval"][b["t_eval"] > b["t0"]]
    a["_first_bindings"] = (fb, ev)
    a["method_used"] = f"dop853, then radau from t={first['t']:.6g} (stiff)"
    try:
        rows, second, x_end = run_prepared(model, b, out=x_out[n1:n1 + b["t_eval"].size])
    except BaseException as stop:
        if hasattr(stop, "eomc_rows"):      # stopped in the Radau part: both parts' rows
            stop.eomc_rows = (x_out, _merged(first, stop.eomc_rows[1], n1), stop.eomc_rows[2])
            a["_bindings"] = b.get("_bindings", (None, None))
        raise
    a["_bindings"] = b.get("_bindings", (None, None))
    return x_out, _merged(first, second, n1), x_end


def _merged(first, second, n1):
    """The stats of an "auto" run that switched: the DOP853 part's and the Radau part's."""
    merged = dict(second)
    for f in ("steps", "accepted", "rejected", "nfev", "njev", "nlu", "nproj", "nswitch"):
        merged[f] = first[f] + second[f]
    merged["n_out"] = n1 + second["n_out"]
    merged["switched_at"] = first["t"]
    return merged


def evaluated_along(model, which):
    """Whether a run's result carries the model's outputs (which=0) or constraint residual
    (which=1): the model has them and its build has the C function (a build of chosen
    functions, ``eomc build --outputs rhs``, has neither)."""
    cols = model.noutput if which == 0 else model.nhol + model.nvel
    fn = model.c_model.outputs if which == 0 else model.c_model.constraints
    return cols > 0 and fn != model.ffi.NULL


def result_columns(model):
    """The column names of a run's CSV (SimulationResult.columns), known before the run:
    what ``eomc simulate --columns`` is checked against."""
    return ["t", *model.state_names, *(model.output_names if evaluated_along(model, 0) else ()),
            *(("constraint_residual",) if evaluated_along(model, 1) else ())]


def _along(model, a, which, t, x):
    """The model's outputs (which=0) or constraint residuals (which=1) at every row."""
    if not evaluated_along(model, which) or t.size == 0:
        return None
    cols = model.noutput if which == 0 else model.nhol + model.nvel
    ffi, lib = model.ffi, model.integrators
    buf = lambda arr: ffi.from_buffer("double[]", arr)  # noqa: E731
    out = np.full((t.size, cols), np.nan)
    work = np.empty(lib.eomc_integrate_work_size(model.c_model, METHOD_IDS["rk4"]))
    x = np.ascontiguousarray(x)
    status = lib.eomc_eval_along(model.c_model, which, t.size, buf(t), buf(x), buf(a["p"]),
                                 a["n_r"], buf(a["r_t"]), buf(a["r_v"]), buf(out), buf(work),
                                 work.size)
    if status:
        what = "outputs" if which == 0 else "constraints"
        names = model.output_names if which == 0 else [f"constraint {k}" for k in range(cols)]
        bad = ~np.isfinite(out)
        where = ""
        if bad.any():   # the rows before the failing one are written: name the row and the columns
            row = int(np.flatnonzero(bad.any(axis=1))[0])
            where = (f" at t={t[row]:.9g}: {', '.join(n for n, b in zip(names, bad[row]) if b)} "
                     f"{'is' if bad[row].sum() == 1 else 'are'} not finite there")
        raise SimulationError(f"{model.name}: evaluating {what} along the trajectory failed: "
                              f"{STATUS_NAMES.get(status, status)}{where}")
    return out


NONFINITE_STATUS = 3    # EOMC_NONFINITE


def _nonfinite_events(model, a, stats, x):
    """'; ... the event function(s)/output(s) X not finite ...' when a run stopped on a NaN in
    what it evaluates as events while the state stayed finite; '' when that is not the cause."""
    from .events import nonfinite_names
    t = stats["t"]
    try:
        source, events = a["events"]
        bad = nonfinite_names(model, source, events, t, x, a["p"], _input_at(model, a, t, x))
        where = "there"
        if not bad:     # finite at the last accepted step: look inside the step that failed
            bad, t_bad = _events_inside_step(model, a, stats, x)
            where = f"at t={t_bad:.9g}, inside the next step" if bad else ""
    except Exception:       # naming is a courtesy; the failure itself is already reported
        return ""
    if not bad:
        return ""
    what = "event function" if source == "events" else "output (outputs are evaluated as events)"
    if len(bad) > 1:
        what = what.replace("function", "functions").replace("output ", "outputs ", 1)
    return (f"; the state is finite, but the {what} {', '.join(bad)} "
            f"{'are' if len(bad) > 1 else 'is'} not finite {where}")


def _nonfinite_source(model, a, stats, x):
    """'; ...' naming what the model makes non-finite at the failed run's last state (runtime/
    nonfinite.py), or '' when nothing can be said there."""
    from .nonfinite import nonfinite_source
    t = float(stats["t"])
    try:
        r = _input_at(model, a, t, x)
    except Exception:       # noqa: BLE001 -- naming is a courtesy; the failure is already reported
        return ""
    step = None
    if a["method"] in ("rk4", "implicitfast") and not model.ninput:     # the same step, taken again
        h = float(a["h0"])

        def step():
            res = simulate(model, x, (t, t + h), p=a["p"][:model.nparam], method=a["method"], dt=h, events=False,
                           switching=False, raise_on_failure=False, t_eval=[t + h])
            return res.status, res.x_final
    return nonfinite_source(model, a["method"], t, x, a["p"], r, step)


def _input_at(model, a, t, x):
    return applied_inputs(model, a)(t, x) if model.ninput else np.zeros(0)


def _events_inside_step(model, a, stats, x):
    """(names, t): the event functions that are not finite along the failed step, found by running
    that stretch again without events (the step's trial states are gone); ([], nan) if none."""
    from .events import nonfinite_names
    t0 = stats["t"]
    t1 = min(a["t1"], t0 + 2.0 * max(stats["t_fail"] - t0, stats["h"], 1e-12))
    if not t1 > t0:
        return [], float("nan")
    times = np.linspace(t0, t1, 65)
    b = {k: v for k, v in a.items() if k not in ("events", "max_events", "_bindings")}
    b.update(t0=t0, t1=t1, x0=np.array(x, dtype=np.float64), t_eval=times, max_steps=10000)
    rows, st, _ = run_prepared(model, b)
    source, events = a["events"]
    for ti, xi in zip(times[:st["n_out"]], rows[:st["n_out"]]):
        if not np.all(np.isfinite(xi)):
            break
        bad = nonfinite_names(model, source, events, ti, xi, a["p"], _input_at(model, b, ti, xi))
        if bad:
            return bad, float(ti)
    return [], float("nan")


NEAR_SINGULAR_SUSPECTS = (3, 5, 6)    # non-finite, step too small, max steps


def failure_message(model, method, stats, x_last, p=None):
    """One line naming the reason, the time and the state of a failed integration."""
    status = stats["status"]
    reason = STATUS_NAMES.get(status, f"status {status}")
    state = ", ".join(f"{n}={v:.6g}" for n, v in zip(model.state_names, x_last))
    msg = f"{model.name}: {method} stopped at t={stats['t']:.9g}: {reason}"
    if f"{stats['t_fail']:.9g}" != f"{stats['t']:.9g}":
        msg += f" (the model failed at t={stats['t_fail']:.9g}, inside the next step)"
    if status == 7 and model.c_model.jac_x == model.ffi.NULL:
        msg += (f" (h*|lambda| ~ {stats['stiff_hlambda']:.3g}); an implicit method needs the Jacobian "
                f"jac_x, which this model was built without: rebuild it with jac_x (the default "
                f"functions include it), and the default method='auto' goes on with radau here")
    elif status == 7:
        msg += f" (h*|lambda| ~ {stats['stiff_hlambda']:.3g}); {STIFF_ADVICE}"
    elif status == 6 and ("radau" in method or "bdf" in method):
        # already implicit (auto on a contact model runs bdf): switching to radau is no remedy
        # (sweep s27: Talos --floating-base --ground, bdf out of steps at t = 1.67 of 2)
        msg += f" ({stats['steps']} steps); raise max_steps"
    elif status == 6:
        msg += f" ({stats['steps']} steps); raise max_steps or, if the problem is stiff, " \
               f"{STIFF_ADVICE}"
    elif status == 5:
        msg += f" (h={stats['h']:.3g}); the solution may blow up or be discontinuous here"
    # a step size that collapsed, a run that never ends or a non-finite value: M singular to
    # rounding is a common cause on real files (a link with inertia 1e-20), worth naming
    why = ""
    if status == SINGULAR_STATUS:
        why = singular_direction(model, stats["t_fail"], x_last, p)
    elif status in NEAR_SINGULAR_SUSPECTS:
        why = singular_direction(model, stats["t_fail"], x_last, p, semidefinite=True)
    if status == PENETRATED_STATUS and p is not None:
        why = penetration_message(model, x_last, p)
    return f"{msg}; state {state}{why}"


def simulate(model, x0, t_span, p=None, r=None, method=DEFAULT_METHOD, rtol=1e-6, atol=1e-9,
             t_eval=None, dt=None, max_steps=None, first_step=None, max_step=None,
             project=False, stiff_check=True, n_points=None, baumgarte=0.0,
             pi_beta=PI_BETA, raise_on_failure=True, events=None, max_events=DEFAULT_MAX_EVENTS,
             K=None, x_ref=None, consistent=None, sensitivities=False, switching=True,
             sensitivity_errors=False, split=None):
    """Integrate ``model`` from ``x0`` over ``t_span``; returns a SimulationResult.

    x0/p: arrays or {name: value} dicts (missing names -> the model's initial_state (0 without
    one) / the parameter defaults); x0=None starts at the model's initial_state (at rest,
    with a warning, without one).  r: constant
    array, (t_grid, values) interpolated linearly in C, (t_grid, values, "cubic") by a
    cubic spline (not-a-knot, scipy's CubicSpline) in C, or a callable (see below).
    method: "auto" (the default: DOP853 while the problem is not stiff, an implicit method
    from the start for a model with ground contacts -- BDF at rtol >= 1e-7, Radau tighter
    (BDF_FINEST) -- and Radau from wherever DOP853 detects stiffness -- the run continues,
    LSODA-like), rk4 (needs dt), dopri5/rk45, dop853,
    radau, bdf (needs jac_x: variable-order BDF/NDF like ode15s; at rtol 1e-2..1e-7 it takes
    0.29-0.60 of Radau's time on the ant, 0.39-0.68 on Solo12, docs/contact.md;
    runtime/c/eomc_bdf.c), implicitfast (needs dt
    and jac_x: fixed-step linearly implicit Euler for stiff contact at real-time steps,
    first order; runtime/c/eomc_fixedstep.c).  Output at
    t_eval (dense output) or, by default, on n_points (1001) equally spaced times
    (rk4, implicitfast: their step grid).  project=True projects onto the model's constraints
    after each step; baumgarte=a > 0 instead adds -a G^+ g to the rhs, so
    constraint residuals decay like exp(-a t) (Baumgarte-style).  pi_beta: Hairer's
    stabilized step control for dopri5/dop853 (0.04; 0 gives the classical control,
    step for step scipy's).  max_steps: the step budget; by default 100,000, and on a model with
    ground contacts 100,000 per simulated second (:func:`default_max_steps`).  A failed run raises SimulationError, or with
    raise_on_failure=False returns the rows computed so far with ``status``.  Ctrl-C stops the
    C loop within one model evaluation (so does SIGTERM where the program handles it, as the
    command line does: runtime/native.py); the KeyboardInterrupt carries the rows computed so
    far as ``partial_result``.

    Inputs and feedback: a callable r(t) or r(t, x) is called from C at every
    stage (exact, but a Python call per stage: ~µs each); K (ninput x nx) and
    x_ref add linear state feedback K (x_ref - x) to r, evaluated in C.  K=(t_grid, Ks)
    with Ks (k, ninput, nx) schedules the gains in time (an iLQR/DDP solver's K_k along its
    nominal trajectory; its u = u_k + K_k (x - x_k) is r=(t_grid, u), K=(t_grid, -K_k),
    x_ref=x_k), x_ref then (nx,) or (k, nx) on the same grid: linear between the grid
    times, held at its ends, in C (feedback.gain_schedule).
    Events (runtime/events.py): ``events=None`` uses the model's compiled
    events; else names of events or outputs, Event objects, or a dict name ->
    {"terminal": ..., "direction": ...}; False for none.  Crossings are located
    on the dense output; result.t_events / x_events hold them by name and
    result.event_stop names a terminal event that ended the run.

    Constrained models: a start off the constraints by more than max(1e-8, 10 atol) is
    completed on them by default (consistent=None), as `eomc simulate` does: the states a
    dict x0 names and the independent ones are held, the dependent coordinates and speeds
    solved for, and one ConstraintWarning says by how much the start was off and what moved;
    a start that cannot be completed is refused (run as given, one drove the slider-crank to
    u = 4e7).  consistent=True completes every start (model.consistent_state, keeping the
    independent ones); consistent=False runs from x0 as given, with a ConstraintWarning
    saying by how much it is off.  project=True (which projects the start) and
    baumgarte > 0 (which pulls it back) leave the start to themselves.

    sensitivities: True, "x0", "p" or a list of state/parameter names integrates the
    variational equations too (runtime/sensitivity.py; needs jac_x, and jac_p for
    parameters): result.dx_dx0 (n_t, nx, states) and result.dx_dp (n_t, nx, parameters).
    The sensitivities ride the plain run's steps (Radau with jvp: staggered, solved with
    each step's own Newton matrix); sensitivity_errors=True lets the step control watch
    them too (more steps, slower; the simultaneous approach).

    Contacts and joint limits (runtime/switching.py): Radau and the explicit methods end
    their steps at touch-down, lift-off and limit entry and restart there (switching=False
    turns that off, to measure the bare method); BDF passes over them, its error test
    sizing the steps (the laws are continuous there); a run that penetrates a contact or overshoots a
    limit beyond the stated bounds warns (PhysicsWarning, naming the contact or joint),
    and one that creates energy in a passive model with an ``energy`` output fails.

    split: implicitfast's residual test on a model with its fast path (contacts), as
    ``rollout(split=)``: a step whose linearisation misses implicit Euler by more than ``split``
    is split (None: IMPLICITFAST_SPLIT, 0.5); 0 turns the test off, one model call per step as
    MuJoCo's implicitfast -- unchecked, it can gain energy on a landing (the energy verdict
    says so).  Refused with any other method.
    """
    if split is not None:
        split = _checked_split(model, method, split)
    if sensitivities is not False and sensitivities is not None:
        return _simulate_sensitivities(model, x0, t_span, sensitivities, p=p, r=r, method=method,
                                       rtol=rtol, atol=atol, t_eval=t_eval, dt=dt, max_steps=max_steps,
                                       first_step=first_step, max_step=max_step, project=project,
                                       stiff_check=stiff_check, n_points=n_points, baumgarte=baumgarte,
                                       pi_beta=pi_beta, raise_on_failure=raise_on_failure,
                                       events=events, max_events=max_events, K=K, x_ref=x_ref,
                                       consistent=consistent, sensitivity_errors=sensitivity_errors)
    if consistent or (not project and not baumgarte and model.nhol + model.nvel):
        x0 = checked_start(model, x0, t_span, p, r, atol, consistent)
    a = prepare(model, x0, t_span, p=p, r=r, method=method, rtol=rtol, atol=atol, t_eval=t_eval,
                dt=dt, max_steps=max_steps, first_step=first_step, max_step=max_step,
                project=project, stiff_check=stiff_check, n_points=n_points,
                baumgarte=baumgarte, pi_beta=pi_beta, events=events, max_events=max_events,
                K=K, x_ref=x_ref, switching=switching)
    if split is not None:
        a["split"] = split
    if "switches" in a and a["switches"].limits:
        from .switching import warn_outside_limits
        warn_outside_limits(model, a["x0"], a["p"])
    from .switching import warn_unchecked
    warn_unchecked(model)
    try:
        x_out, stats, x_last = run_prepared(model, a)
    except BaseException as stop:
        _keep_rows(model, a, stop)
        raise
    result = finish(model, a, x_out, stats, x_last, raise_on_failure)
    if project and not consistent and model.nhol + model.nvel:
        _say_projected(model, a, result, atol)
    if result.status == 0 and (getattr(model, "metadata", None) or {}).get("gimbal_locks"):
        from .diagnose import gimbal_passed
        said = gimbal_passed(model, result.t, result.x)
        if said:
            import warnings
            from .switching import PhysicsWarning
            warnings.warn(PhysicsWarning(said), stacklevel=_user_level())
    return result


def _keep_rows(model, a, stop):
    """Ctrl-C (KeyboardInterrupt) or a SIGTERM handler's exception out of the C loop: the rows
    computed up to it, as a SimulationResult in ``stop.partial_result``: status 9 (EOMC_ABORTED),
    or 0 when the loop had finished as the signal came (`eomc simulate` writes them, marked as
    stopped, before it exits)."""
    rows = getattr(stop, "eomc_rows", None)
    if rows is None:
        return
    del stop.eomc_rows
    try:
        stop.partial_result = finish(model, a, *rows, raise_on_failure=False)
    except BaseException:       # noqa: BLE001 -- the rows cannot be wrapped: the stop goes on without them
        pass


def _checked_split(model, method, split):
    """simulate's split= as a float, or ValueError naming what is wrong with it."""
    if resolve_method(method) != "implicitfast":
        raise ValueError(f"{model.name}: split= is implicitfast's residual test (as rollout's); "
                         f"method {method!r} takes none")
    try:
        value = float(split)
    except (TypeError, ValueError):
        raise ValueError(f"{model.name}: split must be a number >= 0; got {split!r}") from None
    if not (np.isfinite(value) and value >= 0):
        raise ValueError(f"{model.name}: split must be a number >= 0 (0: no residual test); got {split!r}")
    return value


def _simulate_sensitivities(model, x0, t_span, sensitivities, p, r, method, rtol, atol, t_eval, dt,
                            max_steps, first_step, max_step, project, stiff_check, n_points,
                            baumgarte, pi_beta, raise_on_failure, events, max_events, K, x_ref,
                            consistent, sensitivity_errors=False):
    """simulate with the variational equations (runtime/sensitivity.py)."""
    from . import sensitivity
    xs, ps = sensitivity.check_request(model, sensitivities, events, r, K, x_ref, project, baumgarte)
    if consistent or model.nhol + model.nvel:
        x0 = checked_start(model, x0, t_span, p, r, atol, consistent)
    a = prepare(model, x0, t_span, p=p, r=r, method=method, rtol=rtol, atol=atol, t_eval=t_eval,
                dt=dt, max_steps=max_steps, first_step=first_step, max_step=max_step,
                stiff_check=stiff_check, n_points=n_points, pi_beta=pi_beta, events=False,
                max_events=max_events)
    x_out, stats, x_last, S = sensitivity.run(model, a, xs, ps, _STAT_FIELDS,
                                              error_control=sensitivity_errors)
    return sensitivity.attach(model, finish(model, a, x_out, stats, x_last, raise_on_failure), S, xs, ps)


def _say_projected(model, a, result, atol):
    """project=True moves a start off the constraints onto them, every state free to move
    (minimum norm), the coordinates the user gave included: say which moved, and by how much."""
    from .consistent import ConstraintWarning
    if not len(result.t) or result.t[0] != a["t0"]:
        return
    limit = max(1e-8, 10 * float(atol))
    moved = [f"{n} {old:.6g} -> {new:.6g}" for n, old, new in zip(model.state_names, a["x0"], result.x[0])
             if abs(new - old) > limit * max(1.0, abs(old))]
    if moved:
        warnings.warn(ConstraintWarning(
            f"{model.name}: x0 was off the constraints and project=True moved the start onto them: "
            f"{', '.join(moved)}; pass consistent=True instead to keep the independent coordinates "
            f"and speeds and solve for the others"), stacklevel=_user_level())


def checked_start(model, x0, t_span, p, r, atol, consistent):
    """x0 made consistent (consistent=True), completed when it is off the constraints
    (consistent=None, simulate's default: see :func:`_completed`) or checked against them
    (consistent=False: a warning).

    A dict x0 is completed from the model's initial_state first (state_defaults), the
    same start consistent_state() uses for a dict.
    """
    from .consistent import ConstraintWarning, consistent_state
    if model.nhol + model.nvel == 0 or model.c_model.constraints == model.ffi.NULL:
        return x0
    t0 = _span(t_span)[0]
    p_vec = _vector(model, model.param_defaults if p is None else p, model.nparam,
                    model.param_names, model.param_defaults, "p (parameters)")
    x = _vector(model, start_or_default(model, x0), model.nx, model.state_names, state_defaults(model),
                "x0 (initial state)")
    r_vec = r if (r is not None and not callable(r) and not isinstance(r, tuple)) else None
    if r_vec is not None and not isinstance(r_vec, dict) and np.ndim(r_vec) == 0:
        r_vec = [r_vec]     # one input given as a number
    if consistent:
        return consistent_state(model, x, t0, p_vec, r_vec)
    n_r, r_t, r_v = _inputs(model, r, t0, t0 + 1.0)    # residuals through C, as finish() computes them
    g = np.abs(_along(model, dict(p=np.append(p_vec, 0.0), n_r=n_r, r_t=r_t, r_v=r_v), 1,
                      np.array([t0]), x[None, :])[0])
    hol = float(g[:model.nhol].max()) if model.nhol else 0.0
    vel = float(g[model.nhol:].max()) if model.nvel else 0.0
    limit = max(1e-8, 10 * float(atol))
    if hol <= limit and vel <= limit:
        return x0
    if consistent is None:
        given = list(x0) if isinstance(x0, dict) else []
        return _completed(model, x, t0, p_vec, r_vec, given, hol, vel)
    warnings.warn(ConstraintWarning.off(model.name, hol, vel, limit), stacklevel=_user_level())
    return x0


def _completed(model, x, t0, p_vec, r_vec, given, hol, vel):
    """A start off the constraints, completed on them: the states a dict x0 named and the
    independent ones held (then the named ones only, then the independent ones only, when
    that leaves too few free), the others solved for; one ConstraintWarning says how far
    off it was and what moved.
    ModelError, with the ways out, when it cannot be completed."""
    from .consistent import ConstraintWarning, complete_start
    names = [str(n) for n in model.state_names]
    given = [names[index_of(k, model.state_names, "state", model.name)] for k in given]
    try:
        done, held = complete_start(model, x, t0, p_vec, r_vec, given)
    except ModelError as error:
        named = f"; the states x0 names ({', '.join(given)}) are held" if given else ""
        raise ModelError(f"{model.name}: x0 is off the constraints (configuration residual {hol:.3g}, "
                         f"velocity residual {vel:.3g}) and cannot be completed on them: {error}{named}; "
                         f"give a consistent x0 (the dependent coordinates and speeds too), or "
                         f"consistent=False to run from it as given") from None
    moved = [f"{n} {old:.6g} -> {new:.6g}" for n, old, new in zip(names, x, done) if new != old]
    warnings.warn(ConstraintWarning(
        f"{model.name}: x0 was off the constraints (configuration residual {hol:.3g}, velocity "
        f"residual {vel:.3g}); completed it on them: {', '.join(moved)} (held: "
        f"{', '.join(held)}; consistent=False runs from x0 "
        f"as given)"), stacklevel=_user_level())
    return done


_checked_start = checked_start


def _user_level():
    """warnings.warn's stacklevel for the first frame outside eomc (the user's call)."""
    import sys
    frame, level = sys._getframe(2), 2
    while frame is not None and frame.f_globals.get("__name__", "").startswith("eomc"):
        frame, level = frame.f_back, level + 1
    return level


def finish(model, a, x_out, stats, x_last, raise_on_failure=True):
    """Wrap C's arrays in a SimulationResult (or raise on failure)."""
    fb, ev = a.get("_bindings", (None, None))
    fb1, ev1 = a.get("_first_bindings", (None, None))     # method="auto" before it switched
    for binding in (fb1, fb):
        if binding is not None:
            binding.raise_error()
    method = a.get("method_used", a["method"])
    status, n = stats["status"], stats["n_out"]
    message = "ok" if status == 0 else failure_message(model, method, stats, x_last, a.get("p"))
    if status == NONFINITE_STATUS and ev is not None and np.all(np.isfinite(x_last)):
        message += _nonfinite_events(model, a, stats, x_last)
    if status == NONFINITE_STATUS and "not finite" not in message:
        message += _nonfinite_source(model, a, stats, x_last)
    if status == 6:     # out of steps: say how many were allowed, and whence
        rule = (f": the default for a run with ground contacts, {CONTACT_STEPS_PER_S} per simulated second"
                if a.get("max_steps_default") and a["max_steps"] > MAX_STEPS else "")
        message = message.replace("raise max_steps", f"raise max_steps ({a['max_steps']} now{rule})", 1)
    if status == 0:
        stats.pop("t_fail", None)  # where the model failed: only meaningful for a failed run
    if status and raise_on_failure:
        raise SimulationError(message)
    t, x = a["t_eval"][:n], x_out[:n]
    if fb is not None and t.size:
        a = _inputs_along(model, a, t, x)
    outputs = _along(model, a, 0, t, x)
    residual = _along(model, a, 1, t, x)
    result = SimulationResult(
        t=t, x=x, state_names=tuple(model.state_names),
        outputs={} if outputs is None else dict(zip(model.output_names, outputs.T)),
        constraint_residual=None if residual is None else np.max(np.abs(residual), axis=1),
        stats=stats, status=status, message=message, method=method, model_name=model.name,
        x_final=x_last, t_final=stats["t"], nq=model.nq)
    if a["method"] == "implicitfast" and status == 0 and stats["rejected"]:
        import warnings
        from .switching import PhysicsWarning
        if a.get("_implicit_keep") is not None:
            # the fast path (NAME_implicit): one linearised step; a step counts when its residual
            # test still fails at 1/64 of dt after Newton iterations on that cell (eomc_fixedstep.c,
            # fs_last_cell)
            split = a.get("split", IMPLICITFAST_SPLIT)
            what = (f"{stats['rejected']} step(s) of 1/64 dt still missed implicit Euler: after Newton "
                    f"iterations the step's Newton correction was more than "
                    f"{IMPLICITFAST_HARD_FACTOR * split:g} x the step's own change of the speeds")
        else:
            # the W-method (jac_x only): simplified Newton, then Newton with a fresh jac_x
            what = (f"Newton did not converge on {stats['rejected']} (sub-)step(s): their implicit "
                    f"Euler equation was not solved to tolerance even split into 64")
        warnings.warn(PhysicsWarning(
            f"{model.name}: implicitfast: {what} (a hard impact, or the solution blows up); a "
            f"smaller dt, or an adaptive method (the default 'auto'), checks the result"), stacklevel=3)
    if ev is not None and "switches" in a and status == 0:
        from .switching import verdict
        seen = ev.switch_maxima()
        if ev1 is not None:
            seen = np.maximum(seen, ev1.switch_maxima())
        watched = a.get("_watched")
        outputs = result.outputs
        if watched is not None and outputs and (not len(result.t) or result.t[0] != a["t0"]):
            outputs = with_start(model, a, outputs)      # the verdict reads the start's energy and depths
        bad, why = verdict(model, a, result, seen, a["switches"], watched=watched, outputs=outputs,
                           place=place_finder(model, a, result.t, result.x) if watched is not None else None)
        if bad:
            result.status = stats["status"] = bad
            result.message = f"{model.name}: {method}: {why}"
            if raise_on_failure:
                raise SimulationError(result.message)
    if ev is not None and "events" in a:
        result.t_events, result.x_events, result.event_stop, dropped = ev.results()
        if ev1 is not None:     # the events before "auto" switched to Radau come first
            t1_, x1_, _, dropped1 = ev1.results()
            for name in result.t_events:
                result.t_events[name] = np.concatenate([t1_[name], result.t_events[name]])
                result.x_events[name] = np.concatenate([x1_[name], result.x_events[name]])
            dropped += dropped1
        if dropped:
            warnings.warn(f"{model.name}: {dropped} event occurrence(s) beyond max_events="
                          f"{a['max_events']} were not stored", RuntimeWarning, stacklevel=3)
    return result


def final_outputs(model, a, t, x):
    """{output: value} at one state (a run's x_final), with the inputs applied there; NaN
    where the state is not finite or an output cannot be evaluated (a failed run)."""
    if model.noutput == 0:
        return {}
    T, X = np.array([float(t)]), np.asarray(x, dtype=np.float64).reshape(1, model.nx)
    try:
        if a.get("_bindings", (None, None))[0] is not None:
            a = _inputs_along(model, a, T, X)
        out = _along(model, a, 0, T, X)[0]
    except (SimulationError, ValueError, ArithmeticError):
        out = np.full(model.noutput, np.nan)
    return dict(zip(model.output_names, out))


def _inputs_along(model, a, t, x):
    """``a`` with the inputs actually applied at each output row (feedback, callable) as a grid."""
    r = applied_inputs(model, a)
    R = np.array([r(ti, xi) for ti, xi in zip(t, x)]).reshape(t.size, model.ninput)
    if t.size == 1:
        return {**a, "n_r": 1, "r_t": np.zeros(1), "r_v": np.ascontiguousarray(R[0])}
    return {**a, "n_r": t.size, "r_t": np.ascontiguousarray(t), "r_v": np.ascontiguousarray(R)}


def scipy_fun(model, p=None, r=None):
    """(fun, jac) closures for scipy.integrate.solve_ivp over the model's C functions.

    Each call returns a fresh array: solve_ivp keeps references to what fun
    returns, so a reused buffer would silently corrupt its solution.
    """
    def fun(t, x):
        return np.array(model.rhs(t, x, p, r), dtype=np.float64, copy=True)

    def jac(t, x):
        return np.array(model.jacobian(t, x, p, r), dtype=np.float64, copy=True)
    return fun, jac


def with_start(model, a, outputs):
    """outputs (along a run's recorded rows) with the start's row first (t_eval that leaves the
    start out), or unchanged when the start's outputs are not finite."""
    try:
        first = _along(model, a, 0, np.array([float(a["t0"])]), np.asarray(a["x0"], dtype=float)[None, :])
    except SimulationError:
        return outputs
    if first is None:
        return outputs
    return {n: np.concatenate([[first[0][j]], np.asarray(outputs[n], dtype=float)])
            for j, n in enumerate(model.output_names) if n in outputs}


def place_finder(model, a, t=None, x=None):
    """energy_verdict's ``place`` for a fixed-step run with prepared args ``a`` (x0, p, inputs,
    dt = a["h0"]): the states at both ends of the step that ends at t_jump, from the recorded rows
    (t, x) when they hold both, else from the run made again with those two output times only (its
    steps do not depend on the output times: the same states), then switching.place_words.  One run
    at most per verdict that warns (rollout: the row its warning quotes)."""
    def place(t_jump):
        h, t0 = float(a["h0"]), float(a["t0"])
        k = int(round((t_jump - t0) / h))
        if k < 1:
            return ""
        ta = t0 + (k - 1) * h
        X = None
        if t is not None and x is not None:
            ia, ib = np.flatnonzero(np.asarray(t) == ta), np.flatnonzero(np.asarray(t) == t_jump)
            if ia.size and ib.size:
                X = np.stack([np.asarray(x)[ia[0]], np.asarray(x)[ib[0]]])
        if X is None:
            b = {key: v for key, v in a.items() if key not in ("switches", "events", "_bindings", "_watch")}
            b["t_eval"] = np.array([ta, t_jump])
            # to one step past t_jump: the same grid t0 + k h and the same whole steps up to it
            b["t1"] = min(float(a["t1"]), t0 + (k + 1) * h)
            rows, stats, _ = run_prepared(model, b)
            if stats["status"] != 0 or stats["n_out"] < 2:
                return ""
            X = np.array(rows[:2])
        try:
            out = _along(model, a, 0, np.array([ta, t_jump]), X)
        except SimulationError:     # an output not finite there: the limits are still named
            out = None
        names = list(model.output_names)
        oa = {} if out is None else dict(zip(names, out[0]))
        ob = {} if out is None else dict(zip(names, out[1]))
        from .switching import find_switches, place_words
        return place_words(model, np.asarray(a["p"], dtype=float), find_switches(model), t_jump, X[0], X[1], oa, ob)
    return place


def watch_options(model, opt, a):
    """Turn the C energy watch on in eomc_options ``opt`` for a fixed-step implicitfast run with
    prepared args ``a`` that the energy verdict judges (a model with switching points and an
    ``energy`` output, its outputs function, no feedback): watch_output, watch_fn (NAME_energy where
    built), and the limit springs the output leaves out (switching.watch_springs).  Returns the spring
    count (kept with the structs in a["_watch"]), or None when not watched."""
    from .switching import find_switches, watch_springs
    names = list(model.output_names)
    if (a.get("method") != "implicitfast" or "energy" not in names or not find_switches(model)
            or model.c_model.outputs == model.ffi.NULL or "r_fun" in a or "K" in a or "r_slopes" in a):
        return None
    opt.watch_output = names.index("energy") + 1
    opt.watch_fn = energy_fn(model, model.ffi)
    n, springs, keep = watch_springs(model, model.ffi, a["p"])
    opt.nspring, opt.spring = n, springs
    a["_watch"] = (n, keep)
    return n


def energy_fn(model, ffi):
    """NAME_energy (the energy output alone, compiler/emit/generate.energy_program) as the
    eomc_rhs_fn ``ffi`` declares, for eomc_options.watch_fn; NULL for a model built without it
    (before session 16, or an energy that reads u'): the watch then calls the whole outputs."""
    if "energy" not in model.metadata.get("functions", ()) or model.model_lib is None:
        return ffi.NULL
    fp = model.ffi.addressof(model.model_lib, f"{model.name}_energy")
    return ffi.cast("eomc_rhs_fn", int(model.ffi.cast("uintptr_t", fp)))
