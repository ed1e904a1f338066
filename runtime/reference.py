"""Reference solutions for error measurements, computed twice and compared.

Why this module exists: a work-precision report is only as trustworthy as
the solution its errors are measured against.  The reference is integrated
far tighter than any run in the grid (our C DOP853; Radau IIA, not below rtol 1e-12, when
DOP853 finds the problem stiff; the report ties its rtol and atol to the grid's finest
tolerance, :func:`tied_tolerances`) and then
*checked* by a second integration: by default scipy's own DOP853 or Radau
(``scipy.integrate.solve_ivp``) on the model's compiled rhs -- independent
code -- run 10 times looser than the reference.

Why looser: scipy's DOP853 is Hairer's algorithm, and with the classical step
control (ours with pi_beta=0; the default PI control differs only a little)
at the *same* tolerance it takes the same steps and repeats the same
truncation errors (the two agree to ~1e-13 even at tol = 1e-7, which would
certify nothing).  At 10 x tol the steps and the truncation errors
differ, and the agreement estimates the reference's error from above.  The
agreement is reported; a report whose finest tolerance asks for more than the
references agree on says so instead of trusting the reference silently.

The error measure used everywhere (see :func:`scaled_error`) is defined here
so that the reference check and the grid measure the same thing.
"""
import time
from dataclasses import dataclass

import numpy as np

from eomc.runtime.errors import SimulationError

from .check_references import BackgroundRun
from .progress import follow_integration, stage
from .simulate import _STAT_FIELDS, finish, prepare, run_prepared, scipy_fun

__all__ = ["Reference", "compute_reference", "scaled_error", "state_scale", "SCALE_FLOOR",
           "CHECK_METHODS", "REFERENCE_METHODS", "tied_tolerances", "MIN_WINDOW"]

SCALE_FLOOR = 1e-3      # states that stay below 1e-3 x the largest state are scaled by that
CHECK_METHODS = ("auto", "scipy", "radau", "dop853-half", "none")
SCIPY_LOOSER = 10.0      # the scipy check runs 10x looser: see the module docstring
SCIPY_MAX_STEPS = 20000  # "auto" check: more reference steps make scipy's Python loop too slow
REFERENCE_METHODS = ("auto", "dop853", "radau")
RADAU_FINEST = 1e-12    # Radau IIA's reference tolerance is not pushed below this
# The reference's (rtol, atol) tied to the finest tolerance measured, as `eomc check` ties its
# references to the checked tolerance (runtime/stability.REF_TOLS): 1000x tighter (1e-13 at
# the default grid's 1e-10, as before; 1e-9 for a contact model reported at 1e-2..1e-6, where
# a fixed 1e-13 atol costs without telling anything: Go2 resting on 124 contact points takes
# ~70 000 Radau steps per simulated second at atol 1e-12).  atol shrinks as much as rtol, not
# 10x as check's: the report reads errors down to its finest tolerance and asks the two
# computations to agree to a tenth of it (the pendulum reported down to 1e-8 with atol 10x
# tighter: agreement 4.2e-9; 100x: 1.2e-9 -- both warned as not resolving the finest runs).
TIED = (1000, 1000)
REF_FINEST = 1e-13
MIN_WINDOW = 5          # output times the two references must agree on for any error to be judged


def tied_tolerances(finest):
    """(rtol, atol) of the reference for a grid whose finest tolerance is ``finest``."""
    return max(finest / TIED[0], REF_FINEST), max(finest / TIED[1], 1e-15)


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
    with np.errstate(over="ignore", invalid="ignore"):     # a blown-up run: error inf, no warning
        e = np.sqrt(np.mean(((x - x_ref) / scale) ** 2, axis=1))
    if not np.all(np.isfinite(e)):
        return float("inf")
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
    atol: float = None        # None: = tol
    check_atol: float = None
    agreement_t: np.ndarray = None   # the scaled error per output time (None if unchecked)
    check_stopped_at: float = None   # t where the check was stopped, having parted (None: ran to the end)

    def __post_init__(self):
        self.atol = self.tol if self.atol is None else self.atol
        self.check_atol = self.check_tol if self.check_atol is None else self.check_atol

    def horizon(self, level):
        """Index of the first output time where the two computations differ by more than
        ``level`` (scaled error): errors are measured before it.  The whole span if they
        never do or the reference was not checked."""
        if self.agreement_t is None:
            return self.t.size
        beyond = np.flatnonzero(~(self.agreement_t <= level))
        return int(beyond[0]) if beyond.size else self.t.size

    def describe(self):
        """One sentence: how the reference was obtained and checked."""
        text = (f"reference: {self.method} at {_tols(self.tol, self.atol)} "
                f"({self.stats.get('accepted', '?')} steps, {self.wall_time:.3g} s)")
        if self.check_method == "none":
            return text + "; not checked"
        text += (f"; checked against {self.check_method} at {_tols(self.check_tol, self.check_atol)}: "
                 f"agreement {self.agreement:.2e} (scaled error)")
        if self.check_stopped_at is not None:
            text += (f" (its check stopped at t={self.check_stopped_at:.4g}, past where the two part: "
                     f"nothing after is judged)")
        return text


def _tols(rtol, atol):
    return f"rtol=atol={rtol:.0e}" if rtol == atol else f"rtol={rtol:.0e}, atol={atol:.0e}"


def plan(method, tol, atol=None):
    """What :func:`compute_reference` will run, said before it runs: Radau's rtol is clipped
    to RADAU_FINEST, and "auto" is DOP853 with Radau only if DOP853 reports stiffness (first
    hour s26: `eomc report` announced "auto at rtol 1e-13", then ran Radau at 1e-12)."""
    atol = tol if atol is None else atol
    radau = f"radau at {_tols(max(tol, RADAU_FINEST), atol)}"
    if method == "radau":
        return radau + (f" (its finest rtol; {tol:.0e} asked)" if tol < RADAU_FINEST else "")
    if method == "dop853":
        return f"dop853 at {_tols(tol, atol)}"
    return f"dop853 at {_tols(tol, atol)}, or {radau} if DOP853 finds the motion stiff"


def _c_run(model, x0, t_span, p, r, t_eval, method, tol, project, stiff_check=False, atol=None):
    atol = tol if atol is None else atol
    a = prepare(model, x0, t_span, p=p, r=r, method=method, rtol=tol, atol=atol, t_eval=t_eval,
                max_steps=10 ** 7, project=project, stiff_check=stiff_check)
    start = time.perf_counter()
    x_out, stats, x_last = run_prepared(model, a)
    elapsed = time.perf_counter() - start
    return finish(model, a, x_out, stats, x_last, raise_on_failure=False), elapsed, a


STOP_POLL_S = 0.05     # how often a check run's new rows are compared with the reference's
ABORTED = 9             # EOMC_ABORTED: a run stopped through eomc_options.stop


def scaled_rows(x, x_ref, scale):
    """The scaled RMS error per output time (the rows of :func:`scaled_error`'s maximum)."""
    with np.errstate(over="ignore", invalid="ignore"):
        return np.sqrt(np.mean(((np.asarray(x, float) - x_ref) / scale) ** 2, axis=1))


class _CheckRun(BackgroundRun):
    """Our own check run (Radau or DOP853) on a thread of its own (the C loop releases the GIL),
    stoppable (eomc_options.stop, read at each model evaluation), its rows readable as they come.

    Started before the reference when the report may use two cores (``parallel``): a DOP853
    reference of more than SCIPY_MAX_STEPS steps is checked by Radau, and the two then take
    the longer of their times, not the sum (G1: 34 s and 82 s, s34)."""

    def __init__(self, model, x0, t_span, p, r, t_eval, method, tol, project, atol):
        self.method, self.tol, self.atol = method, tol, atol
        super().__init__(model, prepare(model, x0, t_span, p=p, r=r, method=method, rtol=tol, atol=atol,
                                        t_eval=t_eval, max_steps=10 ** 7, project=project),
                         name="eomc-reference-check")
        self.thread.start()

    def cancel(self):
        self.flag[0] = 1
        self.thread.join()

    def result(self, model, ref_x, scale, level):
        """Follow the run to its end, comparing its rows with the reference's (``ref_x``) as they
        come, and stop it at the first one that differs by more than ``level`` (scaled error;
        None: never).  Returns (SimulationResult, stopped): the rows written, the parting row
        among them."""
        def watch():
            seen = 0
            while True:
                alive = self.thread.is_alive()
                n = min(self.written(), len(ref_x))
                if level is not None and n > seen:
                    if np.any(~(scaled_rows(self.x_out[seen:n], ref_x[seen:n], scale) <= level)):
                        self.cancel()
                        return
                    seen = n
                if not alive:
                    return
                self.thread.join(STOP_POLL_S)
        try:
            follow_integration(lambda: (self.stats.t, self.stats.steps), self.a["t0"], self.a["t1"], watch)
        except BaseException:      # Ctrl-C, SIGTERM: the check stops too
            self.cancel()
            raise
        if self.error is not None:
            raise self.error
        got = {f: getattr(self.stats, f) for f in _STAT_FIELDS}
        res = finish(model, self.a, self.x_out, got, self.x_last, raise_on_failure=False)
        return res, bool(self.flag[0]) and got["status"] == ABORTED


def _input_function(a, ninput):
    """r(t) as the C side sees it: none, constant, or linear interpolation on a grid."""
    if a["n_r"] == 0:
        return lambda t: None
    if a["n_r"] == 1:
        return lambda t: a["r_v"][:ninput]
    r_t, r_v = a["r_t"], a["r_v"]
    return lambda t: np.array([np.interp(t, r_t, r_v[:, k]) for k in range(ninput)])


def _scipy_check(model, a, t_eval, method, tol, atol=None):
    """solve_ivp (DOP853, or Radau with the model's Jacobian) on model.rhs: an independent code."""
    from scipy.integrate import solve_ivp
    p, r_of_t = a["p"][:-1], _input_function(a, model.ninput)
    if "r_fun" in a or "K" in a or "r_slopes" in a:      # inputs that depend on x, or a callable: as C applies them
        from .feedback import applied_inputs
        r_of_tx = applied_inputs(model, a)

        def fun(t, x):
            return np.array(model.rhs(t, x, p, r_of_tx(t, x)), dtype=float, copy=True)

        def jac(t, x):
            return np.array(model.jacobian(t, x, p, r_of_tx(t, x)), dtype=float, copy=True)
    elif a["n_r"] <= 1:
        fun, jac = scipy_fun(model, p, r_of_t(0.0))
    else:
        def fun(t, x):
            return np.array(model.rhs(t, x, p, r_of_t(t)), dtype=float, copy=True)

        def jac(t, x):
            return np.array(model.jacobian(t, x, p, r_of_t(t)), dtype=float, copy=True)
    kw = dict(method="DOP853") if method == "dop853" else dict(method="Radau", jac=jac)
    sol = solve_ivp(fun, (a["t0"], a["t1"]), a["x0"], rtol=tol, atol=tol if atol is None else atol,
                    t_eval=t_eval, **kw)
    if not sol.success:
        raise SimulationError(f"{model.name}: scipy {kw['method']} reference check failed: "
                              f"{sol.message}")
    return sol.y.T


def _primary(model, x0, t_span, p, r, t_eval, method, tol, project, atol, on_radau=None):
    """The reference run: DOP853 at tol, or (method="auto") Radau when DOP853 says stiff
    (``on_radau()`` is called before that Radau run)."""
    if method not in REFERENCE_METHODS:
        raise ValueError(f"unknown reference method {method!r}; valid: {', '.join(REFERENCE_METHODS)}")
    if method in ("dop853", "auto"):
        res, elapsed, a = _c_run(model, x0, t_span, p, r, t_eval, "dop853", tol, project,
                                 stiff_check=(method == "auto"), atol=atol)
        if res.status == 0 or method == "dop853" or res.status not in (6, 7):
            return res, elapsed, a, tol
        if on_radau is not None:
            on_radau()
    tol = max(tol, RADAU_FINEST)
    res, elapsed, a = _c_run(model, x0, t_span, p, r, t_eval, "radau", tol, project, atol=atol)
    return res, elapsed, a, tol


def _auto_check(model, res):
    if res.stats["steps"] <= SCIPY_MAX_STEPS:
        return "scipy"
    if res.method != "radau" and model.c_model.jac_x != model.ffi.NULL:
        return "radau"
    return "dop853-half" if res.method == "dop853" else "scipy"


def compute_reference(model, x0, t_span, t_eval, p=None, r=None, tol=1e-13, check="auto",
                      project=False, method="auto", atol=None, stop_level=None, parallel=False):
    """Integrate the reference at rtol ``tol`` (and ``atol``, default ``tol``; the report ties
    both to its finest tolerance, :func:`tied_tolerances`) and check it a second way.

    method: "dop853"; "radau" (at max(tol, 1e-12)); or "auto" (default): DOP853,
    switching to Radau when DOP853 reports stiffness or runs out of steps.
    check: "auto" (default: "scipy" unless the reference took more than
    SCIPY_MAX_STEPS steps, then "radau" if the model has jac_x, else
    "dop853-half"), "scipy" (scipy's solve_ivp with the same method at 10 x
    tol on model.rhs -- an independent implementation), "radau" (our Radau IIA at
    max(tol, 1e-12); needs jac_x), "dop853-half" (our DOP853 at tol/2: the
    same code, a weaker check) or "none".  Under "auto", a scipy check that fails (its DOP853
    has no stiffness test) gives way to "radau" (or "dop853-half"), and check_method says why.
    Raises SimulationError naming the reason if the reference itself cannot be computed.
    ``stop_level``: a check run by our own code ("radau", "dop853-half") is stopped at the first
    output time where it differs from the reference by more than this (scaled error): nothing
    after it is judged (Reference.horizon at that level); agreement_t is NaN from where it
    stopped, and ``check_stopped_at`` says where.  ``parallel``: where the check may be our Radau
    (check "auto" or "radau", a DOP853 reference, a model with jac_x) it starts at once on a
    thread of its own, and is dropped if the reference ends up checked another way.
    """
    if check not in CHECK_METHODS:
        raise ValueError(f"unknown reference check {check!r}; valid: {', '.join(CHECK_METHODS)}")
    atol = tol if atol is None else atol
    early = None
    if (parallel and check in ("auto", "radau") and method in ("auto", "dop853")
            and model.c_model.jac_x != model.ffi.NULL):
        early = _CheckRun(model, x0, t_span, p, r, t_eval, "radau", max(tol, RADAU_FINEST), project, atol)
    try:
        res, elapsed, a, tol = _primary(model, x0, t_span, p, r, t_eval, method, tol, project, atol,
                                        on_radau=early.cancel if early is not None else None)
    except BaseException:
        if early is not None:
            early.cancel()
        raise
    if early is not None and (res.status or res.method != "dop853"):
        early.cancel()
        early = None
    if res.status:
        reached = float(res.t[-1]) if res.t.size else float(t_span[0])
        raise SimulationError(f"the reference solution failed ({res.method} at {_tols(tol, atol)}, "
                              f"reached t = {reached:.6g} of {float(t_span[1]):g}): {res.message}")
    scale = state_scale(res.x)
    chosen = check == "auto"
    if chosen:
        check = _auto_check(model, res)
    if early is not None and check != "radau":
        early.cancel()
        early = None
    check_tol, check_atol, agreement, other_x = float("nan"), None, float("nan"), None
    check_stopped_at = None
    scipy_failed = None
    if check == "scipy":
        check_tol, check_atol = SCIPY_LOOSER * tol, SCIPY_LOOSER * atol
        try:
            other_x = _scipy_check(model, a, a["t_eval"], res.method, check_tol, check_atol)
        except SimulationError as e:
            if not chosen:
                raise
            # scipy's DOP853 has no stiffness test: 10x looser than ours it can blow up on a stiff
            # stretch ours passed (gymnasium's half_cheetah, its feet landing: a non-finite state
            # at t = 0.26, and `eomc report` stopped there, first hour s27).  "auto" checks the
            # same reference our other way instead, and says why.
            scipy_failed = f"scipy {res.method} failed: {str(e).split(', state ')[0]}"
            check = "radau" if res.method != "radau" and model.c_model.jac_x != model.ffi.NULL else "dop853-half"
    if check in ("radau", "dop853-half"):
        how, check_tol = ("radau", max(tol, RADAU_FINEST)) if check == "radau" else ("dop853", tol / 2)
        check_atol = atol if check == "radau" else atol / 2
        stopped = False
        with stage(f"its check, {how} at rtol={check_tol:g}"):      # named in the progress lines
            if early is not None and (how, check_tol, check_atol) == (early.method, early.tol, early.atol):
                other, stopped = early.result(model, res.x, scale, stop_level)
            elif stop_level is None:
                other, _, _ = _c_run(model, x0, t_span, p, r, t_eval, how, check_tol, project,
                                     atol=check_atol)
            else:
                other, stopped = _CheckRun(model, x0, t_span, p, r, t_eval, how, check_tol, project,
                                           check_atol).result(model, res.x, scale, stop_level)
            if early is not None and early.thread.is_alive():
                early.cancel()
        if other.status and not stopped:
            raise SimulationError(f"the reference check failed: {other.message}")
        other_x = other.x
        if stopped:
            check_stopped_at = float(other.stats["t"])
    agreement_t = None
    if other_x is not None:
        n = len(other_x)
        agreement = scaled_error(other_x, res.x[:n], scale)
        agreement_t = np.full(len(res.x), np.nan)
        agreement_t[:n] = scaled_rows(other_x, res.x[:n], scale)
    return Reference(t=res.t, x=res.x, scale=scale, method=res.method, tol=tol, wall_time=elapsed,
                     stats=res.stats, outputs=res.outputs,
                     constraint_residual=res.constraint_residual,
                     check_method=(check if check != "scipy" else f"scipy {res.method}")
                     + (f" ({scipy_failed})" if scipy_failed else ""),
                     check_tol=check_tol, agreement=agreement, atol=atol, check_atol=check_atol,
                     agreement_t=agreement_t, check_stopped_at=check_stopped_at)
