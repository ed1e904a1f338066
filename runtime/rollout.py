"""``eomc.rollout``: many trajectories of one model, integrated in C threads on all cores.

Monte Carlo, reinforcement learning and sampling-based MPC integrate thousands of
starts over the same span.  ``simulate_many`` makes one Python-level call per case;
here Python crosses into C once: ``eomc_rollout`` (runtime/c/eomc_rollout.c) hands the
rows to POSIX threads, each row being exactly one ``eomc_integrate`` call with the
options ``simulate`` would pass, so every row equals the scalar ``simulate`` result bit
for bit.  The GIL is released for the whole call (cffi releases it on every C call).

Issue 31: fixed-step methods (rk4, implicitfast) and adaptive ones (dopri5, dop853, radau,
bdf, auto; final states), inputs per row (constant or a control sequence on a time grid).
``simulate_many`` and ``eomc.sweep`` (each chunk, on any executor) run their plain cases through
``rollout_stats`` (runtime/batch.py).  Contacts and joint limits with implicitfast's fast path
(NAME_implicit: they are forces in its matrix, no switching points needed).  Feedback gains per
row (constant or scheduled in time), events, and contacts or limits under the other methods
(switching points per row, in C) run through runtime/rollout_extras.py.

A call is a plan (``_Plan``: the arguments' checks, the method, simulate's prepared options, the
path the rows take, its C set-up) and the plan's run (the rows' own checks, the C loop, the
verdicts); ``eomc.Rollout`` (runtime/rollout_session.py) keeps plans and runs them call after call.
"""
import numbers
import os

import numpy as np

from .errors import SimulationError
from .integrators_api import FIXED_STEP, METHOD_IDS, STATUS_NAMES
from .law_parameters import check_law_parameters
from .rollout_result import RolloutResult, _rollout_ffi
from .rollout_starts import starts_on_constraints
from .native import integrator_library
from .events import DEFAULT_MAX_EVENTS
from .feedback import gain_schedule
from .rollout_extras import _row_inputs
from .simulate import (IMPLICITFAST_SPLIT, _along, _options, _positive, _user_level, auto_method, check_quaternions,
                       depth_limits, energy_fn, failure_message, implicit_for_run, implicit_terms, input_grid,
                       place_finder, prepare, resolve_method)
from .switching import (WATCHED, PhysicsWarning, _no_sources, energy_allowance, energy_allowances, energy_tolerance,
                        energy_verdict, find_switches, total_known, watch_springs, watched_rows)

__all__ = ["rollout", "RolloutResult", "rollout_stats"]


def _threads(threads):
    if threads is None:
        try:
            return len(os.sched_getaffinity(0))
        except AttributeError:      # not Linux
            return os.cpu_count() or 1
    if isinstance(threads, bool) or not isinstance(threads, numbers.Integral) or threads < 1:
        raise ValueError(f"threads must be a whole number >= 1 (or None for every core); got {threads!r}")
    return int(threads)


def _terminal_events(model):
    """True when one of the model's compiled events ends a run, kept on the model (its metadata's
    events are fixed; the humanoid has hundreds, each made an Event on every rollout call)."""
    cache = getattr(model, "__dict__", None)    # an instance's dict (a stand-in class's is read-only)
    got = cache.get("_terminal_events") if isinstance(cache, dict) else None
    if got is None:
        from .events import model_events
        got = any(e.terminal for e in model_events(model))
        if isinstance(cache, dict):
            cache["_terminal_events"] = got
    return got


def _x0s(model, x0s):
    a = np.asarray(x0s)
    if a.dtype.kind not in "fiu":
        raise ValueError(f"{model.name}: x0s must be an (n, {model.nx}) array of real initial states; "
                         f"got dtype {a.dtype}")
    a = np.ascontiguousarray(a, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != model.nx:
        raise ValueError(f"{model.name}: x0s must have shape (n, {model.nx}) -- one row per trajectory, "
                         f"columns {', '.join(model.state_names)}; got shape {a.shape}")
    if np.isfinite(a).all():        # (the test alone: argwhere's search was ~3 us of a one-row call)
        return a
    bad = np.argwhere(~np.isfinite(a))
    if bad.size:
        i, j = bad[0]
        raise ValueError(f"{model.name}: x0s row {i} has a non-finite {model.state_names[j]} "
                         f"({a[i, j]}); {len(bad)} non-finite value(s) in all")
    return a


def _params(model, p, n):
    """(P, stride): rows of nparam + 1 doubles (the padding simulate adds), stride 0 for one row."""
    if p is None:
        rows = np.asarray(model.param_defaults, dtype=np.float64).reshape(1, -1)
    else:
        a = np.asarray(p)
        if a.dtype.kind not in "fiu":
            raise ValueError(f"{model.name}: p must hold real parameter values; got dtype {a.dtype}")
        rows = np.asarray(a, dtype=np.float64)
        if rows.ndim == 1:
            rows = rows.reshape(1, -1)
        if rows.ndim != 2 or rows.shape[1] != model.nparam or rows.shape[0] not in (1, n):
            raise ValueError(f"{model.name}: p must have shape ({model.nparam},) or ({n}, {model.nparam}) "
                             f"(parameters {', '.join(model.param_names)}); got shape {a.shape}")
        bad = np.argwhere(~np.isfinite(rows))
        if bad.size:
            i, j = bad[0]
            raise ValueError(f"{model.name}: p row {i} has a non-finite {model.param_names[j]} ({rows[i, j]})")
    for i, row in enumerate(rows if p is not None else ()):    # the defaults: prepare checks them
        check_law_parameters(model, row, where=f"p row {i}" if len(rows) > 1 else "")
    P = np.ascontiguousarray(np.hstack([rows, np.zeros((len(rows), 1))]))
    return P, (0 if len(rows) == 1 else P.shape[1])


def _controls(model, r, n):
    """(n_rgrid, r_tgrid, R, r_stride) of eomc_rollout_stats from ``r`` (see ``rollout``)."""
    if r is None:
        return 0, None, None, 0
    if callable(r):
        raise ValueError(f"{model.name}: rollout runs its rows in C threads without Python, so r cannot be a "
                         f"callable; state feedback r = r0(t) + K(t) (x_ref(t) - x) is K=, x_ref= (gains, or a "
                         f"schedule (t_grid, gains)) with r=(t_grid, r0); a Python controller runs through "
                         f"simulate_many")
    if model.ninput == 0:
        raise ValueError(f"{model.name}: this model has no inputs, but r was given")
    ni, names = model.ninput, ", ".join(model.input_names)
    if isinstance(r, tuple):
        if len(r) != 2:
            raise ValueError(f"{model.name}: r as a tuple is a control sequence (t_grid, values); got a tuple "
                             f"of {len(r)} items")
        k, t_grid, values = input_grid(model, r[0], r[1], rows=n)
        return k, t_grid, values, (0 if values.ndim == 2 else k * ni)
    values = np.asarray(r, dtype=np.float64)
    if values.shape not in ((ni,), (n, ni)):
        raise ValueError(f"{model.name}: r must have shape ({ni},) (the same inputs for every row), ({n}, {ni}) "
                         f"(one row each; inputs {names}) or be a control sequence (t_grid, values); got "
                         f"shape {values.shape}")
    if not np.all(np.isfinite(values)):
        i = int(np.flatnonzero(~np.isfinite(values.reshape(-1, ni)).any(axis=1))[0])
        raise ValueError(f"{model.name}: r row {i} holds a non-finite input")
    return 1, None, np.ascontiguousarray(values), (0 if values.ndim == 1 else ni)


def rollout(model, x0s, *, dt=None, t_final=None, steps=None, method=None, p=None, r=None, threads=None,
            record="final", raise_on_failure=True, lanes=False, split=IMPLICITFAST_SPLIT,
            rtol=1e-6, atol=1e-9, max_steps=100000, K=None, x_ref=None, events=None,
            max_events=DEFAULT_MAX_EVENTS, consistent=None):
    """Integrate every row of ``x0s`` ((n, nx)) from t = 0 with a fixed step ``dt``, or
    with an adaptive method to ``rtol``/``atol``.

    Give the span as ``t_final`` or as ``steps`` (t_final = steps * dt); the last step is
    shortened to end on t_final, as ``simulate`` does.  method=None (the default): with ``dt``
    (or ``steps``), "implicitfast" on a model with contacts' fast path (NAME_implicit: an MJCF
    file or URDF robot with contacts; RK4 diverges on stiff contact at such steps), on a model with
    other contacts or with joint limits, and on one stiff at dt (an eigenvalue of jac_x at its first rows past RK4's
    stability, |dt lambda| > 2), when it has jac_x; else "rk4" (lanes=True: "rk4" unless the fast
    path); without, "auto", simulate's default: ``rollout(model, X0,
    t_final=2)`` runs what ``simulate(model, x0, (0, 2))`` runs.  method: "rk4" or "implicitfast"
    (needs jac_x), fixed-step with ``dt``; or "dopri5", "dop853", "radau", "bdf" (the last
    two need jac_x), adaptive: ``t_final``, ``rtol``, ``atol``, ``max_steps`` as in
    ``simulate``, record="final" only (row i equals ``simulate(model, x0s[i], (0, t_final),
    method=method, rtol=rtol, atol=atol).x_final`` bit for bit: the steps do not depend on
    the output times).  "auto" picks as simulate does; a row DOP853 finds stiff is run again
    through simulate (its switch to Radau is made in Python).  p: None (defaults), (nparam,) for all rows or (n, nparam), one
    parameter row per trajectory.  threads: C threads (None: every core this process
    may run on).  record: "final" (x is (n, nx): what Monte Carlo and RL episodes
    consume, n * nx doubles whatever the span) or "steps" (x is (n, steps + 1, nx), the
    step grid of ``simulate``).  Row i equals ``simulate(model, x0s[i], (0, t_final),
    p=..., method=method, dt=dt)`` bit for bit (its ``x[-1]``, or all of ``x``).

    Contacts and joint limits: with method="implicitfast" on a model that has NAME_implicit
    (the recursive formulation with ground contacts: MJCF files, URDF robots with contacts),
    each row runs the fast path as ``simulate`` does (its residual test with ``split``, 0 =
    off: one model call per step, MuJoCo's implicitfast; see runtime/c/eomc_fixedstep.c), and a
    row whose contact sinks past its radius fails with status 10 (with per-row parameters,
    the smallest radius of each contact over the rows), and a row that ran to the end is judged
    by simulate's energy verdict (switching.energy_verdict: a model with an ``energy`` output and
    no inputs, or zero ones): one that created energy fails with status 20 and simulate's words
    (result.messages), a lesser gain warns.  The energy is read at every step as simulate
    reads it, with either record (the C loop keeps each row's lowest and highest energy:
    eomc_options.watch_output; the model's NAME_energy where it has one), so each row's status is simulate's.  Every other method ends each row's
    steps at touch-down, lift-off and limit entry as ``simulate`` does, and each row is judged
    by simulate's verdict (result.status, result.messages; runtime/rollout_extras.py).

    K, x_ref: state feedback r + K (x_ref - x) in C (no Python, no GIL): K (ninput, nx) or
    (n, ninput, nx), or a schedule (t_grid, Ks) with Ks (k, ninput, nx) or (n, k, ninput, nx),
    linear between the grid times and held at its ends; x_ref (nx,), (n, nx), or with a
    schedule (k, nx) / (n, k, nx) on its grid (feedback.gain_schedule).  Row i equals
    ``simulate(..., K=Ks[i], x_ref=...)`` bit for bit.  A callable r is refused (a Python
    controller would hold every thread on the GIL; simulate_many runs it).

    events: None -- the model's compiled events when one of them is terminal (a row ends there,
    as simulate ends it: result.event_stop, result.t_events), else none; False: none; else
    what simulate's events= takes.  max_events: records kept per row.

    consistent: a model with constraints starts each row as simulate starts x0 (its consistent=):
    None (the default) completes a row off the constraints on them, keeping its independent
    coordinates and speeds (one ConstraintWarning names the rows), True completes every row, False
    runs them as given (with the warning) -- so row i equals simulate of that start, as below.

    r: the inputs, None (zeros), (ninput,) for every row, (n, ninput) one constant row per
    trajectory, or a control sequence (t_grid, values) with values (k, ninput) for every row or
    (n, k, ninput) one per trajectory, linearly interpolated between the grid times (held at
    its ends) -- row i then equals ``simulate(..., r=(t_grid, values[i]))`` bit for bit.

    A failed trajectory (singular mass matrix, non-finite state) raises SimulationError
    naming the first failed row; with raise_on_failure=False, result.status says which
    rows failed and their final rows hold the last good state.

    lanes=True (rk4, a model built with ``rhs_batch``, no constraints): each C
    thread takes blocks of 64 rows and integrates them together, every RK4 stage one
    NAME_rhs_batch_p call over the block (several rows per instruction; one parameter row per
    trajectory or one for all), with the scalar loop's arithmetic in the same order
    (runtime/c/eomc_rollout.c).  Rows then equal the scalar rollout's bit for bit when the
    model was built with -DEOMC_BATCH_LIBM_TRIG, else within what the lanes' sin/cos (1 ulp
    of libm's) make of it.

    lanes=True with method="implicitfast" (a model built with ``implicit_batch``; its fast path,
    no feedback or events): each C thread runs as many rows at once as the machine has double
    lanes, each row the scalar row's code in a fiber (a fiber whose row ends takes the next row),
    and their NAME_implicit calls are made together, one NAME_implicit_batch call per round
    (eomc_rollout_implicit_lanes; fewer rows than lanes padded), and with
    them each row's step matrix is assembled and factored for the whole batch in vector code
    (eomc_fs_assemble_lanes, runtime/c/eomc_fixedstep.c; 8 rows per vector with AVX-512, else 4 with AVX2):
    every row is the scalar rollout's row step for step (bit for bit with
    -DEOMC_BATCH_LIBM_TRIG; the assembly in lanes is bit for bit in any case).  With the vector
    sin/cos every call is still a batch lane whose bits depend on its own state alone, so a row's
    bits depend on that row alone: the same result every run, with any thread count and among any
    other rows.  A model whose NAME_implicit_batch is not in lanes (metadata implicit_batch.vectorized
    false: its scalar function row by row, e.g. dm_control's humanoid_CMU with its ground table)
    runs the scalar rows instead: the same bits, without the lanes' copies (5.8x faster there).
    """
    X0 = _plan_x0s(model, x0s, dt, t_final, steps, method, record, lanes, rtol)
    n = X0.shape[0]
    P, p_stride = _params(model, p, n)
    controls = _controls(model, r, n)
    plan = _Plan(model, X0, P, p_stride, dt=dt, t_final=t_final, steps=steps, method=method, threads=threads,
                 record=record, lanes=lanes, split=split, rtol=rtol, atol=atol, max_steps=max_steps, K=K,
                 x_ref=x_ref, events=events, max_events=max_events)
    return plan.run(X0, controls, r, consistent, raise_on_failure)


def _plan_x0s(model, x0s, dt, t_final, steps, method, record, lanes, rtol):
    """The rows of x0s checked (_x0s), after the span's and method's arguments (_Plan checks them
    again, cheaply: their errors come first, as they always did)."""
    _Plan.arguments(model, dt, t_final, steps, method, record, lanes, rtol)
    return _x0s(model, x0s)


class _Plan:
    """What one rollout decides and checks once for all its rows: the method (method=None's choice),
    the span, the C options simulate would pass (``prepare``), the path the rows take (the fast path
    in C, RK4's lanes, or rollout_extras for feedback, events and switching points), and the fast
    path's C set-up (_FastSetup: its depth limits, energy watch, options struct).

    Why a plan of its own: ``eomc.Rollout`` keeps one and runs it again and again (the RL pattern,
    a few steps a call: the checks and set-up were ~200 us of a 265 us one-step humanoid call),
    and ``rollout`` makes one per call; both then run the same code (``run``), so a Rollout call
    equals the rollout call with the same arguments bit for bit.  The rows' own checks (their
    constraints, quaternions, inputs) are made by ``run`` on every call."""

    @staticmethod
    def arguments(model, dt, t_final, steps, method, record, lanes, rtol):
        """(method, named, auto, may_switch, chosen, adaptive, t_final): the method's, record's and
        span's arguments checked, and method=None resolved as far as it can be without the rows."""
        if method is None:
            # first hour s28: rollout(model, X0, t_final=2) refused (its default was rk4, which needs
            # dt) where simulate(model, x0, (0, 2)) runs "auto"; a step given means RK4, or on contacts
            # with their fast path implicitfast (RK4 at gymnasium's hopper's 8 ms diverged in 10 of 16
            # rows: "a non-finite value appeared")
            stepped = dt is not None or steps is not None or lanes
            method = "auto" if not stepped else "implicitfast" if implicit_terms(model) is not None else "rk4"
            chosen = stepped and not lanes and method == "rk4"      # may become implicitfast (below)
        else:
            chosen = False
        method = named = resolve_method(method)
        auto = method == "auto"
        may_switch = False
        if auto:
            method, may_switch = auto_method(model, _positive(rtol, "rtol"))
        if record not in ("final", "steps"):
            raise ValueError(f"record must be 'final' or 'steps'; got {record!r}")
        adaptive = method not in FIXED_STEP
        if adaptive:
            if dt is not None or steps is not None:
                raise ValueError(f"method {named!r} is adaptive: give t_final= (and rtol=, atol=), not dt= or "
                                 f"steps= (those are for {', '.join(FIXED_STEP)})")
            if record != "final":
                raise ValueError(f"record='steps' is the fixed-step grid; an adaptive rollout ({method!r}) "
                                 f"returns the final states (record='final'); for states at chosen times "
                                 f"use simulate_many(..., t_eval=)")
            if lanes:
                raise ValueError(f"rollout(lanes=True) takes method 'rk4'; got {method!r}")
        elif dt is None:
            # first hour s24: eomc.rollout(model, X0, t_final=1) said only "dt ... got None"
            raise ValueError(f"method {method!r} is fixed-step: give dt= (and t_final= or steps=), or an "
                             f"adaptive method with t_final= (method='auto', the default without dt=; 'dop853', ...)")
        elif isinstance(dt, bool) or not isinstance(dt, numbers.Real) or not np.isfinite(dt) or dt <= 0:
            raise ValueError(f"dt must be a finite step > 0; got {dt!r}")
        if (t_final is None) == (steps is None):
            raise ValueError("give the span as exactly one of t_final= or steps=")
        if steps is not None:
            if isinstance(steps, bool) or not isinstance(steps, numbers.Integral) or steps < 1:
                raise ValueError(f"steps must be a whole number >= 1; got {steps!r}")
            t_final = float(steps) * float(dt)
        elif (isinstance(t_final, bool) or not isinstance(t_final, numbers.Real) or not np.isfinite(t_final)
              or t_final <= 0):
            raise ValueError(f"t_final must be a finite time > 0; got {t_final!r}")
        return method, named, auto, may_switch, chosen, adaptive, float(t_final)

    def __init__(self, model, X0, P, p_stride, *, dt, t_final, steps, method, threads, record, lanes, split, rtol,
                 atol, max_steps, K, x_ref, events, max_events):
        method, named, auto, may_switch, chosen, adaptive, t_final = self.arguments(
            model, dt, t_final, steps, method, record, lanes, rtol)
        n = X0.shape[0]
        if chosen and _rk4_diverges(model, X0, P, p_stride, float(dt)):
            method = "implicitfast"
        fast = method == "implicitfast" and implicit_terms(model) is not None
        # implicitfast's fast path needs no switching points: contacts and limits are in its matrix,
        # and its depth limit fails a row whose contact sinks past its radius (in C); every other
        # method ends its steps at them as simulate does (the events machinery, per row in C)
        switching = bool(find_switches(model)) and not fast
        if events is None:
            # the model's events when one of them ends a run (simulate ends it there too, and
            # records them all); a model with recorded events only runs without them (pass
            # events= as simulate takes it to record them)
            events = None if _terminal_events(model) else False
        if model.c_model.rhs == model.ffi.NULL:
            raise model._missing("rhs")
        nthreads = _threads(threads)     # (C starts no more threads than rows: eomc_rollout.c)
        gains = _gains(model, K, x_ref, n) if (K is not None or x_ref is not None) else None
        implicit_lanes = lanes and method == "implicitfast"
        if implicit_lanes:
            _implicit_lanes_allowed(model, fast)
            if not _implicit_vectorized(model):
                lanes = implicit_lanes = False      # its batch is the scalar rows: run them as such
        elif lanes:
            _lanes_allowed(model, method)
            if gains is not None or events is not False or switching:
                raise ValueError(f"{model.name}: rollout(lanes=True) takes no feedback, events, contacts or "
                                 f"limits (they run in the scalar loop); use lanes=False")
        row0 = dict(events=events, max_events=max_events, switching=switching,
                    K=None if gains is None else gains.row_argument(0)[0],
                    x_ref=None if gains is None else gains.row_argument(0)[1])
        # The options and step grid simulate would use (and its checks: jac_x for implicitfast,
        # radau and bdf; tolerances).
        if adaptive:
            a = prepare(model, X0[0] if n else None, (0.0, t_final), p=P[0, :-1],
                        method="auto" if auto else method, rtol=rtol, atol=atol, max_steps=max_steps,
                        t_eval=[t_final], **row0)
        else:
            nsteps = int(np.ceil(t_final / dt * (1 - 1e-12)))
            a = prepare(model, X0[0] if n else None, (0.0, t_final), p=P[0, :-1], method=method,
                        dt=float(dt), max_steps=max(100000, nsteps + 10), **row0)
        if not switching:
            a.pop("switches", None)
        # feedback, events, contacts or limits (or "auto", whose stiff rows go on with Radau):
        # eomc_rollout_ex, and simulate's verdict per row
        extras = "switches" in a or "events" in a or gains is not None or a.get("auto_switch")
        if extras and implicit_lanes:
            raise ValueError(f"{model.name}: rollout(lanes=True, method='implicitfast') takes no feedback, "
                             f"events or switching points (they run in the scalar loop); use lanes=False")
        self.model, self.P, self.p_stride, self.n = model, P, p_stride, n
        self.method, self.auto, self.adaptive, self.fast, self.extras = method, auto, adaptive, fast, extras
        self.dt = None if adaptive else float(dt)
        self.t_final, self.record, self.lanes, self.implicit_lanes = t_final, record, lanes, implicit_lanes
        self.split, self.nthreads, self.gains, self.a = split, nthreads, gains, a
        self.rtol, self.atol, self.max_steps, self.events, self.max_events = rtol, atol, max_steps, events, max_events
        self.t_eval = a["t_eval"] if record == "steps" else np.array([t_final])
        self._setup = None

    def setup(self):
        """The fast path's C set-up (_FastSetup), made on the first run and kept."""
        if self._setup is None:
            self._setup = _FastSetup(self)
        return self._setup

    def run(self, X0, controls, r, consistent, raise_on_failure):
        """The rows X0 ((n, nx), checked by _x0s) with inputs ``controls`` (_controls; ``r`` as given, for
        rollout_extras' rows run again) started as simulate starts them (``consistent``), integrated."""
        model, P, p_stride, method, dt, record = self.model, self.P, self.p_stride, self.method, self.dt, self.record
        t_final, n = self.t_final, X0.shape[0]
        X0 = starts_on_constraints(model, X0, P, p_stride, controls, self.atol, consistent)
        check_quaternions(model, X0, "x0s", c_array=False)     # every row's (the first one's: prepare)
        if self.extras:
            from .rollout_extras import rollout_extras
            scalar = dict(method="auto" if self.auto else method, rtol=self.rtol, atol=self.atol,
                          max_steps=self.max_steps, events=self.events, max_events=self.max_events, split=self.split,
                          **({"dt": dt} if not self.adaptive else {}))
            return _ran(method, rollout_extras(model, self.a, X0, P, p_stride, controls, r, self.gains, t_final,
                                               record, self.nthreads, raise_on_failure, scalar))
        t_eval = self.t_eval
        if self.lanes and not self.implicit_lanes:
            rows = []
            try:
                X_out, X_last, status, nstep = _rollout_lanes(model, X0, P, p_stride, controls, t_final, dt,
                                                              record == "steps", self.nthreads, rows)
            except BaseException as stop:
                _keep_rows(stop, rows and (lambda: _finish(model, method, X0, P, p_stride, dt, t_eval, record,
                                                             *rows, False)))
                raise
            return _ran(method, _finish(model, method, X0, P, p_stride, dt, t_eval, record, X_out, X_last, status,
                                        nstep, raise_on_failure))
        ffi = self.setup().ffi
        X_out = np.empty((n, t_eval.size, model.nx)) if record == "steps" else None
        X_last = np.empty((n, model.nx))
        status = np.full(n, 9, dtype=np.intc)   # EOMC_ABORTED until a row's run says otherwise (a stop before C)
        nstep = np.zeros(n, dtype=np.int_ if ffi.sizeof("long") == 8 else np.int32)   # 0: a row not run (a stop)
        try:       # (_run_rows arms Ctrl-C and SIGTERM: they stop every thread at its next evaluation)
            return _ran(method, _run_rows(self, X0, controls, X_out, X_last, status, nstep, raise_on_failure))
        except BaseException as stop:
            _keep_rows(stop, lambda: _finish(model, method, X0, P, p_stride, dt, t_eval, record, X_out, X_last,
                                             status, nstep, False))
            raise


def _ran(method, result):
    """result with the method its rows ran (result.method): what method=None or "auto" picked."""
    result.method = method
    return result


def _keep_rows(stop, make):
    """Ctrl-C (KeyboardInterrupt) or a SIGTERM handler's exception as the C threads return: the
    rows as a RolloutResult in ``stop.partial_result`` (``make()``), those that did not run to the
    end marked status 9 (EOMC_ABORTED) -- those never started also NaN with 0 steps --, as
    simulate's (runtime/simulate._keep_rows).  The threads take no row after the signal
    (eomc_rollout.c; s29: they took every row left first)."""
    if isinstance(stop, Exception) or not make:
        return
    try:
        stop.partial_result = res = make()
        unrun = (res.status == 9) & (res.steps == 0)       # never started: nothing was written
        res.x[unrun] = np.nan
    except BaseException:       # noqa: BLE001 -- the rows cannot be wrapped: the stop goes on without them
        pass


class _FastSetup:
    """A plan's C side, made once: eomc_rollout's FFI, the options struct simulate would pass, and on
    implicitfast's fast path its terms with the depth limits of the rows' parameters and the energy
    watch (the output C keeps each row's range of, and the limit springs it leaves out)."""

    def __init__(self, plan):
        model, P, p_stride = plan.model, plan.P, plan.p_stride
        self.ffi, self.lib = ffi, lib = _rollout_ffi(model.ffi)
        self.arm = integrator_library(model.ffi)._arm     # (its lookup, under a lock, ~1 us a call)
        # implicitfast's fast path: the energy's range over every step, kept in C (eomc_options.
        # watch_output), for simulate's energy verdict on each row (_energy_verdicts)
        self.watch = watch = _energy_watch(model) if plan.fast else 0
        implicit, keep = (None, None)
        if plan.fast:
            # the depth limits of the row with the smallest radii (each limit a contact's radius)
            implicit, keep = implicit_for_run(model, P[0, :-1], split=plan.split)
            if p_stride:
                lim = np.min([depth_limits(model, row[:-1]) for row in P], axis=0)
                for k, v in enumerate(lim):
                    keep[1][k] = v
        self.opt = opt = _options(ffi, plan.a, implicit)
        opt.watch_output = watch
        self.nspring, keep_springs = 0, None
        if watch:
            opt.watch_fn = _energy_fn(model, ffi)
            # the limit springs the energy output leaves out (the tables of the first row's widths:
            # a row with other widths gets no total, so no rise verdict)
            self.nspring, springs, keep_springs = watch_springs(model, model.ffi, P[0])
            opt.nspring, opt.spring = self.nspring, springs
        self._keep = (keep, keep_springs)       # what opt points into, alive while the plan is
        self.P = ffi.from_buffer("double[]", P)
        self.t_eval = ffi.from_buffer("double[]", plan.t_eval)


def _run_rows(plan, X0, controls, X_out, X_last, status, nstep, raise_on_failure):
    """The C rollout of every row (eomc_rollout_stats, or the implicit lanes' fibers) and its verdicts."""
    model, method, n = plan.model, plan.method, X0.shape[0]
    s = plan.setup()
    ffi, lib, opt = s.ffi, s.lib, s.opt
    buf = lambda arr: ffi.from_buffer("double[]", arr)  # noqa: E731
    unsolved = ranges = stats = None
    if n:
        n_rgrid, r_tgrid, R, r_stride = controls
        # implicitfast: each row's stats, whose rejected count is the (sub-)steps left unsolved
        # (what simulate warns of)
        stats = ffi.new("eomc_stats[]", n) if method == "implicitfast" else ffi.NULL
        args = (0.0, plan.t_final, n, buf(X0), s.P, plan.p_stride, n_rgrid,
                buf(r_tgrid) if r_tgrid is not None else ffi.NULL, buf(R) if R is not None else ffi.NULL, r_stride,
                plan.t_eval.size if plan.record == "steps" else 0, s.t_eval,
                buf(X_out) if X_out is not None else ffi.NULL, buf(X_last),
                ffi.from_buffer("int[]", status), ffi.from_buffer("long[]", nstep), stats, plan.nthreads)
        opt.interrupt_base = s.arm()   # Ctrl-C, SIGTERM: every thread stops
        if plan.implicit_lanes:     # each thread's rows in fibers, their NAME_implicit calls in lanes
            from .cpu import machine_lanes
            size, block = model.metadata["implicit"]["layout"]["size"], _implicit_rows_block(model)
            if block is not None:   # the pairs' slope block straight into the rows (NAME_implicit_batch_rows)
                lib.eomc_rollout_implicit_lanes_rows(model.c_model, opt, _implicit_batch(model, ffi, rows=True),
                                                     block[0], block[1], machine_lanes(), size,
                                                     _implicit_reads_t(model), *args)
            else:
                lib.eomc_rollout_implicit_lanes(model.c_model, opt, _implicit_batch(model, ffi), machine_lanes(),
                                                size, _implicit_reads_t(model), *args)
        else:
            lib.eomc_rollout_stats(model.c_model, opt, *args)
        if method == "implicitfast":
            columns = _stats_columns(ffi, stats, n, ("rejected",) + (tuple(f"watch_{k}" for k in WATCHED)
                                                                       if s.watch else ()))
            unsolved = columns["rejected"].astype(int)
            if s.watch:
                ranges = watched_rows(columns, s.nspring)
    messages = (_energy_verdicts(model, plan.a, X0, plan.P, plan.p_stride, controls, plan.t_eval, X_out, X_last,
                                 status, ranges, stats=stats if ranges is not None else None) if plan.fast else {})
    return _finish(model, method, X0, plan.P, plan.p_stride, plan.dt, plan.t_eval, plan.record, X_out, X_last,
                   status, nstep, raise_on_failure, unsolved=unsolved if n and method == "implicitfast" else None,
                   messages=messages)


_STATS_DTYPES = {}


def _stats_columns(ffi, stats, n, fields=None):
    """An eomc_stats[n] array as numpy columns ({field: (n,) array}, copies; ``fields``: only
    those, None: all), read through one structured view of its memory (the fields' offsets and
    types from ``ffi``) rather than a cffi attribute read per row and field: rollout's per-row
    unsolved counts and energy watch."""
    dtype = _STATS_DTYPES.get(ffi)
    if dtype is None:
        kinds = {"double": np.float64, "long": np.dtype(f"i{ffi.sizeof('long')}"), "int": np.intc}
        each = ffi.typeof("eomc_stats").fields
        dtype = _STATS_DTYPES[ffi] = np.dtype({"names": [name for name, _ in each],
                                                "formats": [kinds[f.type.cname] for _, f in each],
                                                "offsets": [f.offset for _, f in each],
                                                "itemsize": ffi.sizeof("eomc_stats")})
    # one copy of the whole table (its fields then views of it): a copy per field was ~1 us each
    # and a tenth of rollout's numpy work after the C call; the table's words as plain doubles and
    # longs (a field a strided view) rather than numpy's structured fields, ~2x faster for one row
    names = dtype.names if fields is None else fields
    raw = np.frombuffer(ffi.buffer(stats, n * dtype.itemsize), dtype=np.uint8).copy()
    if dtype.itemsize % 8 == 0 and all(dtype.fields[k][1] % 8 == 0 and dtype.fields[k][0].itemsize == 8
                                       for k in names):
        words = raw.view(np.float64).reshape(n, dtype.itemsize // 8)
        return {k: (words[:, dtype.fields[k][1] // 8] if dtype.fields[k][0].kind == "f"
                    else words[:, dtype.fields[k][1] // 8].view(dtype.fields[k][0])) for k in names}
    table = raw.view(dtype)
    return {k: table[k] for k in names}


def _energy_watch(model):
    """eomc_options.watch_output for a fast-path rollout: the energy output's index + 1 when
    simulate's energy verdict can judge the model (switching points and an ``energy`` output),
    else 0 (nothing kept)."""
    cache = getattr(model, "__dict__", None)    # kept on the model (its names are fixed): the list of
    got = cache.get("_energy_watch") if isinstance(cache, dict) else None    # a humanoid's names, 17 us a call
    if got is None:
        names = list(model.output_names)
        got = (0 if "energy" not in names or not find_switches(model) or model.c_model.outputs == model.ffi.NULL
               else names.index("energy") + 1)
        if isinstance(cache, dict):
            cache["_energy_watch"] = got
    return got


def _energy_fn(model, ffi):
    """NAME_energy (the energy output alone, compiler/emit/generate.energy_program) as the
    eomc_rhs_fn ``ffi`` declares, for eomc_options.watch_fn; NULL for a model built without it
    (before session 16, or an energy that reads u'): the watch then calls the whole outputs."""
    return energy_fn(model, ffi)


def _energy_verdicts(model, a, X0, P, p_stride, controls, t_eval, X_out, X_last, status, watched=None, stats=None):
    """simulate's energy verdict on each implicitfast fast-path row that ran to the end
    (switching.energy_verdict: the same conditions, tolerance and numbers): a row that created
    energy gets status 20 (STATUS_ENERGY, in place) and simulate's message, returned as {row:
    message}; the rows' lesser gains and their total energy's rises make one PhysicsWarning, as
    simulate's would.  watched: each row's C energy watch over every step (switching.WatchedRows:
    row i is switching.watched_stats's dict, column(k) a field of every row; the energy output's range, and the total -- the output plus the limit springs it leaves out --
    its largest rise above its running minimum), the same numbers simulate's watch keeps, so every
    record mode gives simulate's verdict.  The energy is evaluated at the start and the end only, by
    NAME_energy (_row_energies), the whole outputs only for the rows whose energy rose (one call
    for them when they share parameters and constant inputs, else one per row); only
    rows whose energy rose past energy_tolerance (below it the verdict says nothing) go through the
    verdict's Python, and only the row the warning quotes is run again to name what touched down
    where its total rose (switching.place_finder; record="steps": from its recorded states).
    stats: the run's eomc_stats array (cdata) behind ``watched``, for the first look in C
    (:func:`_screened`), None: the look in numpy."""
    sw = find_switches(model)
    # a model built without its outputs function (functions=("rhs", "implicit")) names its energy
    # output but cannot evaluate it: not judged, as simulate, whose run then has no outputs
    # (_energy_watch: those three tests, kept on the model -- "energy" in a humanoid's ~200 output
    # names was 7 us a call)
    if not _energy_watch(model):
        return {}
    rtol = energy_tolerance(a["rtol"], a["atol"])
    screened = _screened(model, sw, X0, X_last, P, p_stride, controls, float(t_eval[-1]), status, stats, rtol)
    if screened is not None and not screened[1]:
        return {}       # no row's energy rose (or none ran to the end): the common case, decided in C
    rows = np.flatnonzero(status == 0)
    if not rows.size:
        return {}
    energy, depth = _verdict_columns(model, sw)
    t = np.array([0.0, float(t_eval[-1])])
    X = np.empty((rows.size, 2, model.nx))      # (rows, 2, nx): each row's start and end
    whole = rows.size == X0.shape[0]
    X[:, 0] = X0 if whole else X0[rows]
    X[:, 1] = X_last if whole else X_last[rows]

    def row_args(i):
        b = dict(a, x0=X0[i], p=P[i if p_stride else 0])
        b["n_r"], b["r_t"], b["r_v"] = _row_inputs(controls, i, model.ninput)
        return b

    E = screened[0][rows] if screened is not None else _row_energies(model, rows, t, X, P, p_stride, controls)
    out = None
    if E is None:       # no NAME_energy (or inputs on a grid): the whole outputs give the energy column
        out = _row_outputs(model, row_args, rows, t, X, p_stride, controls)
        E = out[:, :, energy]
    seen = E
    if watched is not None:     # [start, lowest, highest, end]: the whole run's gain and scale
        seen = np.concatenate([E[:, :1], watched.column("lo")[rows, None], watched.column("hi")[rows, None],
                               E[:, 1:]], axis=1)
    with np.errstate(invalid="ignore"):
        # (ndarray methods rather than np.max: the same reductions without numpy's Python dispatch)
        scale = np.maximum(np.maximum(np.abs(seen[:, 0]), np.abs(seen - seen[:, :1]).max(axis=1)), 1e-300)
        gain, tol = seen.max(axis=1) - seen[:, 0], rtol * scale
        rose = gain > tol
        risen = np.zeros(rows.size, dtype=bool)
        if watched is not None and total_known(model, sw):
            rise = watched.column("rise")[rows]
            T0 = watched.column("total0")[rows]
            tscale = np.maximum.reduce([np.abs(T0), watched.column("total_hi")[rows] - T0,
                                        T0 - watched.column("total_lo")[rows], np.full(T0.shape, 1e-300)])
            risen = rise > rtol * tscale
    messages, notes = {}, []
    # the verdict is silent on a gain within what the start's limit springs held (gymnasium's
    # ant: every row, its ankles start outside their range): its allowance alone decides that,
    # unless the total energy rose above its running minimum beyond its tolerance (risen); the
    # allowances of rows sharing parameters in one pass (energy_allowances: the same numbers)
    judged = np.flatnonzero(rose | risen)
    if not judged.size:     # no row's energy rose: nothing to word (the common case; its allowances' numpy
        return messages     # was a tenth of a one-row rollout's Python)
    if out is None:     # the whole outputs of the rows judged only (their depths, the verdict's)
        out = np.full((rows.size, t.size, model.noutput), np.nan)
        out[judged] = _row_outputs(model, row_args, rows[judged], t, X[judged], p_stride, controls)
        judged = judged[np.isfinite(out[judged, 0, energy])]    # outputs not finite: not judged, as before
    touching = (out[judged, 0][:, depth] > 0).any(axis=1) if judged.size else np.zeros(0, dtype=bool)
    if p_stride:
        held, sprung = np.zeros(judged.size), np.zeros(judged.size, dtype=bool)
        for m, k in enumerate(judged):
            held[m], sprung[m], _, _ = energy_allowance(model, np.asarray(P[rows[k]], dtype=float), X0[rows[k]],
                                                        bool(touching[m]), sw)
    else:
        held, sprung = energy_allowances(model, np.asarray(P[0], dtype=float), X0[rows[judged]], touching, sw)
    quiet_rows = (gain[judged] - held <= tol[judged]) & ~sprung     # no gain words, no status: at most the rise's
    for k, quiet in zip(judged, quiet_rows):
        if quiet and not risen[k]:
            continue
        i = int(rows[k])
        if quiet and notes:
            # a rise alone, once a row is quoted: the verdict would only add its note (a known total,
            # so nothing sprung) -- counted, not worded (gymnasium's ant: 23 of 64 rows, 2 ms)
            if _no_sources(model, row_args(i)):
                notes.append((i, None))
            continue
        outputs = dict(zip(model.output_names, out[k].T), energy=E[k])
        b = row_args(i)
        # the row the warning quotes, when its words are the rise's: where it rose, named (one run)
        recorded = (t_eval, X_out[i]) if X_out is not None else (None, None)
        place = place_finder(model, b, *recorded) if quiet and not notes else None
        bad, why, said = energy_verdict(model, b, outputs, sw, watched=None if watched is None else watched[i],
                                        place=place)
        if bad:
            status[i] = bad
            messages[i] = f"{model.name}: {a['method']}: {why}"
        notes += [(i, w) for w in said]
    if notes:       # one warning for the rows, the first row's words (as rollout_extras)
        import warnings
        i, w = notes[0]
        seen_rows = sorted({j for j, _ in notes})
        warnings.warn(PhysicsWarning(f"{model.name}: rollout: {len(seen_rows)} of {len(X0)} row(s) warned (rows "
                                     f"{', '.join(map(str, seen_rows[:8]))}{', ...' if len(seen_rows) > 8 else ''}); "
                                     f"row {i}: {w}"), stacklevel=_user_level())
    return messages


def _screened(model, sw, X0, X_last, P, p_stride, controls, t_end, status, stats, rtol):
    """(E, flagged): every row's energy at its start and end ((n, 2): _row_energies's numbers, NaN
    for a row not run) and how many rows the verdict must look at closer -- their energy over
    [start, watch's lowest, highest, end] rose above the start beyond rtol of its scale, or their
    total above its running minimum -- in one C call (eomc_energy_screen, runtime/c/eomc_rows.c:
    _energy_verdicts's numpy look, operation for operation); None where that call does not apply (no NAME_energy,
    inputs on a grid, no stats, an integrator library without it).  Why: with nothing flagged, the
    common case, the verdict's numpy was ~45 of a one-row, one-step eomc.Rollout call's ~75 us
    (the RL pattern: a call per environment step)."""
    screen = getattr(getattr(model, "integrators", None), "eomc_energy_screen", None)
    k_r, _, R, r_stride = controls
    if screen is None or stats is None or k_r > 1 or model.model_lib is None:
        return None
    fn, zeros = _energy_rows_fn(model)
    if fn is None:
        return None
    ffi, n, nx = model.ffi, X0.shape[0], model.nx
    Rr = zeros if not k_r else np.reshape(R, (1 if r_stride == 0 else -1, model.ninput))
    Pc, Rc = np.ascontiguousarray(P, dtype=np.float64), np.ascontiguousarray(Rr, dtype=np.float64)
    X0c, Xl = np.ascontiguousarray(X0, dtype=np.float64), np.ascontiguousarray(X_last, dtype=np.float64)
    E, flag = np.empty((n, 2)), np.empty(n, dtype=np.uint8)
    work = np.empty(max(int(model.work_size), 1))
    buf = ffi.from_buffer
    flagged = screen(fn, n, t_end, buf("double[]", X0c), buf("double[]", Xl), nx, buf("double[]", Pc),
                     Pc.shape[1] if p_stride else 0, buf("double[]", Rc), Rc.shape[1] if Rc.shape[0] > 1 else 0,
                     buf("int[]", status), stats, int(total_known(model, sw)), rtol, buf("double[]", E),
                     buf("unsigned char[]", flag), buf("double[]", work))
    return E, int(flagged)


def _row_outputs(model, row_args, rows, t, X, p_stride, controls):
    """(len(rows), t.size, noutput): the outputs at the rows' points X ((len(rows), t.size, nx)), in one
    C call when the rows share parameters and constant inputs, else row by row; a row whose outputs
    are not finite somewhere is NaN (no energy to judge, as simulate's _energy_gain)."""
    if not p_stride and controls[0] <= 1:      # one call: the rows' points one after another
        try:
            tt = np.empty((len(rows), t.size))
            tt[:] = t
            return _along(model, row_args(rows[0]), 0, tt.reshape(-1),
                          X.reshape(-1, model.nx)).reshape(len(rows), t.size, -1)
        except SimulationError:     # an output not finite somewhere: row by row below
            pass
    out = np.full((len(rows), t.size, model.noutput), np.nan)
    for k, i in enumerate(rows):
        try:
            out[k] = _along(model, row_args(i), 0, t, X[k])
        except SimulationError:
            pass
    return out


def _row_energies(model, rows, t, X, P, p_stride, controls):
    """(len(rows), t.size): the energy at the rows' points by NAME_energy (the energy output alone,
    the outputs' own expression: the same bits), NaN where not finite; None when the model has no
    NAME_energy or the inputs are a table (the whole outputs then give it).  Why: the verdict read
    the start and end of every row through the whole outputs -- gymnasium's humanoid: 2.6 ms of a
    2.9 ms rollout of 64 rows x 1 step (the RL pattern: one step a call), its contacts' and pairs'
    outputs for one number -- while only the rows whose energy rose need them.  The points in one C
    call (a cffi call per point was ~4 us a row of a 64-row one-step rollout)."""
    many = getattr(getattr(model, "integrators", None), "eomc_mat_rows", None)
    if controls[0] > 1 or many is None or model.model_lib is None:
        return None
    ffi = model.ffi
    fn, zeros = _energy_rows_fn(model)
    if fn is None:
        return None
    buf, nx = ffi.from_buffer, model.nx
    k_r, _, R, r_stride = controls
    n, m = len(rows), t.size
    tt, Xc = np.ascontiguousarray(np.tile(t, n)), np.ascontiguousarray(X.reshape(n * m, nx))
    got, work = np.full(n * m, np.nan), np.empty(max(int(model.work_size), 1))
    Rr = zeros if not k_r else np.reshape(R, (1 if r_stride == 0 else -1, model.ninput))
    t_p, x_p, o_p, w_p = buf("double[]", tt), buf("double[]", Xc), buf("double[]", got), buf("double[]", work)
    failed = ffi.new("size_t *")

    def points(lo, hi, p, r):
        """NAME_energy at points lo .. hi - 1 with one p and r, in C (eomc_mat_rows, runtime/c/eomc_rows.c);
        a point whose call fails is NaN and the next go on"""
        while lo < hi:
            status = many(fn, hi - lo, t_p + lo, x_p + lo * nx, nx, p, r, o_p + lo, 1, w_p, failed)
            if status == 0:
                return
            got[lo + int(failed[0])] = np.nan
            lo += int(failed[0]) + 1

    if not p_stride and Rr.shape[0] == 1:       # every row's points in one call
        pr, rr = np.ascontiguousarray(P[0]), np.ascontiguousarray(Rr[0], dtype=np.float64)
        points(0, n * m, buf("double[]", pr), buf("double[]", rr))
    else:
        for k, i in enumerate(rows):
            pr = np.ascontiguousarray(P[i if p_stride else 0])
            rr = np.ascontiguousarray(Rr[i if Rr.shape[0] > 1 else 0], dtype=np.float64)
            points(k * m, (k + 1) * m, buf("double[]", pr), buf("double[]", rr))
    E = got.reshape(n, m)
    E[~np.isfinite(E)] = np.nan
    return E


def _energy_rows_fn(model):
    """(NAME_energy as eomc_mat_fn, a zero input row) for _row_energies, or (None, None) for a model
    built without NAME_energy; kept on the model (its library is fixed).  Why: looking it up and
    casting it were ~9 us of every call of a few steps (the RL pattern, eomc.Rollout)."""
    cache = getattr(model, "__dict__", None)    # an instance's dict (a stand-in class's is read-only)
    got = cache.get("_energy_rows_fn") if isinstance(cache, dict) else None
    if got is None:
        ffi = model.ffi
        fp = energy_fn(model, ffi)
        zeros = np.zeros((1, max(model.ninput, 1)))
        got = (None, None) if fp == ffi.NULL else (ffi.cast("eomc_mat_fn", fp), zeros)
        if isinstance(cache, dict):
            cache["_energy_rows_fn"] = got
    return got


def _verdict_columns(model, sw):
    """The energy output's column and the contacts' depth outputs' columns (an int array) for
    _energy_verdicts, kept on the model's Switches (a model's names are fixed).  Why: the depth
    names' searches in output_names were ~40 us of every fast-path rollout's verdict."""
    got = sw.__dict__.get("_verdict_columns")
    if got is None:
        names = list(model.output_names)
        got = (names.index("energy"),
               np.array([names.index(f"depth_{c.name}") for c in sw.contacts if f"depth_{c.name}" in names],
                        dtype=np.intp))
        object.__setattr__(sw, "_verdict_columns", got)     # one tuple: read whole by any thread
    return got


def _gains(model, K, x_ref, n):
    """rollout's K= and x_ref= checked (feedback.gain_schedule with one row per trajectory)."""
    if model.ninput == 0:
        raise ValueError(f"{model.name}: this model has no inputs, so it takes no feedback K")
    if K is None:
        raise ValueError(f"{model.name}: x_ref= is the reference of the feedback K (x_ref - x); pass K= too")
    if callable(K) or callable(x_ref):
        raise ValueError(f"{model.name}: rollout evaluates feedback in C without Python: give K as gains "
                         f"(ninput, nx), or a schedule (t_grid, (k, ninput, nx)), with x_ref; a Python "
                         f"controller runs through simulate_many (r=callable, one Python call per stage)")
    return _RowGains(gain_schedule(model, K, x_ref, rows=n))


class _RowGains:
    """A GainSchedule over rollout's rows, and each row's K=/x_ref= as simulate takes them."""

    def __init__(self, g):
        self.g = g

    def row_argument(self, i):
        g = self.g
        K = g.K[i] if g.K_stride else g.K
        ref = None if g.ref is None else (g.ref[i] if g.ref_stride else g.ref)
        return ((g.t_grid, K) if g.t_grid is not None else K), ref


def rollout_stats(model, opt, t0, t1, X0, P, p_stride, t_eval, X_out, threads, controls=(0, None, None, 0)):
    """One eomc_rollout_stats call over (t0, t1) (the batch path of simulate_many and eomc.sweep).

    opt: the eomc_options of one prepared case (every row runs with it); t_eval: the output
    times (X_out (n, len(t_eval), nx) is written in place), or None for the final state only.
    Returns (X_last, status, stats) with stats the C array of each row's eomc_stats."""
    ffi, lib = _rollout_ffi(model.ffi)
    n = X0.shape[0]
    X_last = np.empty((n, model.nx))
    status = np.empty(n, dtype=np.intc)
    stats = ffi.new("eomc_stats[]", max(n, 1))
    buf = lambda arr: ffi.from_buffer("double[]", arr)  # noqa: E731
    n_eval = 0 if t_eval is None else int(np.size(t_eval))
    opt.interrupt_base = integrator_library(model.ffi)._arm()   # Ctrl-C stops every thread at its next evaluation
    if n:
        n_rgrid, r_tgrid, R, r_stride = controls
        lib.eomc_rollout_stats(model.c_model, opt, float(t0), float(t1), n, buf(X0), buf(P), p_stride, n_rgrid,
                               buf(r_tgrid) if r_tgrid is not None else ffi.NULL,
                               buf(R) if R is not None else ffi.NULL, r_stride, n_eval,
                               buf(t_eval) if n_eval else ffi.NULL, buf(X_out) if n_eval else ffi.NULL,
                               buf(X_last), ffi.from_buffer("int[]", status), ffi.NULL, stats, threads)
    return X_last, status, stats


def _finish(model, method, X0, P, p_stride, dt, t_eval, record, X_out, X_last, status, nstep, raise_on_failure,
            unsolved=None, messages=None):
    n = X0.shape[0]
    messages = messages or {}
    failed = np.flatnonzero(status) if status.any() else ()
    if len(failed) and raise_on_failure:
        i = int(failed[0])
        if status[i] == 9:
            raise KeyboardInterrupt
        if i in messages:       # a row judged by simulate's verdict (created energy)
            raise SimulationError(f"{model.name}: rollout row {i} of {n} failed ({failed.size} row(s) failed in "
                                  f"all) -- {messages[i]}; pass raise_on_failure=False to keep the other rows")
        stats = {"status": int(status[i]), "t": float("nan"), "t_fail": float("nan"), "steps": int(nstep[i]),
                 "h": float(dt) if dt else float("nan"), "stiff_hlambda": 0.0}
        reason = STATUS_NAMES.get(int(status[i]), f"status {status[i]}")
        raise SimulationError(f"{model.name}: rollout row {i} of {n} failed ({reason}; {failed.size} row(s) "
                              f"failed in all) -- "
                              + failure_message(model, method, stats, X_last[i], P[0 if p_stride == 0 else i, :-1])
                              + "; pass raise_on_failure=False to keep the other rows")
    if unsolved is not None and unsolved.any() and np.any((unsolved > 0) & (status == 0)):
        import warnings
        rows = np.flatnonzero((unsolved > 0) & (status == 0))
        warnings.warn(PhysicsWarning(
            f"{model.name}: rollout: {rows.size} of {n} row(s) ran to the end with implicitfast (sub-)steps "
            f"left unsolved (rows {', '.join(map(str, rows[:8]))}{', ...' if rows.size > 8 else ''}; "
            f"result.unsolved counts them, result.clean marks the others): in each, one or more steps of "
            f"1/64 dt still missed implicit Euler (a hard impact, or the solution blows up); a smaller dt, "
            f"or an adaptive method, checks those rows"), stacklevel=_user_level())
    return RolloutResult(t=np.asarray(t_eval, dtype=np.float64).copy(),
                         x=X_out if record == "steps" else X_last, status=status.astype(int),
                         steps=nstep.astype(int), state_names=tuple(model.state_names),
                         unsolved=unsolved, messages=messages)


def _lanes_allowed(model, method):
    why = []
    if method != "rk4":
        why.append(f"method {method!r} (lanes: rk4)")
    if "rhs_batch" not in model.functions or "rhs_batch" not in model._kernels:
        why.append("a model built without rhs_batch (functions=(..., 'rhs_batch'), --outputs ...,rhs_batch)")
    if model.nhol or model.nvel:
        why.append("constraints (their projection runs in the scalar loop)")
    if why:
        raise ValueError(f"{model.name}: rollout(lanes=True) does not take " + "; ".join(why)
                         + "; use lanes=False")


RK4_STABLE = 2.0     # |dt lambda| on the negative real axis RK4 is stable to: 2.785, less a margin


def _rk4_diverges(model, X0, P, p_stride, dt):
    """True when the default fixed-step method, RK4, would diverge at dt and implicitfast can run the
    model (it has jac_x): a model with contacts or joint limits (stiff where they act, and only
    piecewise smooth: they engage after the start), or whose jac_x at its first rows (up to 8) has
    an eigenvalue with |dt lambda| > RK4_STABLE.  Why: session 52's rollout sweep over the 31 MJCF
    files at each file's timestep: RK4 failed every row ("a non-finite value appeared") on
    dm_control's manipulator and stacker (body-body contacts without a ground plane: no fast path;
    manipulator's |dt lambda| = 137 at 1 ms) and 12 of 16 on fish (its fluid forces: 2.6-5.9 at
    4 ms); implicitfast ran all of them.  The models RK4 ran, 0.01-0.16.  Over example-robot-data's
    URDFs at 1 ms, RK4 failed 9-10 of 16 rows of both limited double pendulums (|dt lambda| = 0.14
    at the start: their limits engage later); implicitfast none."""
    if model.c_model.jac_x == model.ffi.NULL:
        return False
    found = find_switches(model)
    if found.contacts or found.unchecked or found.limits:
        return True
    for i in range(min(len(X0), 8)):
        with np.errstate(all="ignore"):
            try:
                J = model.jac_x(0.0, X0[i], P[0 if p_stride == 0 else i, :-1])
            except Exception:       # noqa: BLE001 -- a start the run itself will report
                continue
            if np.all(np.isfinite(J)) and dt * np.max(np.abs(np.linalg.eigvals(J))) > RK4_STABLE:
                return True
    return False


def _implicit_lanes_allowed(model, fast):
    """lanes=True with implicitfast: the model's NAME_implicit_batch, and its fast path."""
    why = None
    if "implicit_batch" not in model.functions:
        why = "a model built without implicit_batch (functions=(..., 'implicit_batch'))"
    elif not fast:
        why = "a model whose implicitfast does not take its fast path (NAME_implicit, cffi backend)"
    if why:
        raise ValueError(f"{model.name}: rollout(lanes=True) does not take method 'implicitfast' on {why}; "
                         f"use lanes=False")


def _implicit_vectorized(model):
    """False when the model's NAME_implicit_batch is the scalar NAME_implicit row by row (the
    compiler's implicit_batch.vectorized: a statement its lanes lowering does not take, e.g. the
    ground table of a model with many ground points).  lanes=True then runs the scalar rows: the
    same bits (the batch calls the scalar function, and the lanes' assembly is the scalar
    assembly's arithmetic), without the fibers moving every row's outputs into the batch's columns
    and back.  Why: on dm_control's humanoid_CMU (62 speeds, 37297 outputs a call) the lanes
    rollout took 5.8x the scalar one's CPU (16 rows x 0.5 s, one thread: 0.79 s against 0.136 s;
    perf: 51 % in the scalar loop's copies, materialize and memset another 14 %)."""
    return bool(model.metadata.get("implicit_batch", {}).get("vectorized", True))


def _implicit_reads_t(model):
    """1 when the model's NAME_implicit reads t (the compiler's implicit_batch.reads_t; a
    library built before it recorded that: 1), else 0: the lanes rollout then batches rows whose
    call times differ (a split step's sub-steps end an ulp off the other rows')."""
    return int(bool(model.metadata.get("implicit_batch", {}).get("reads_t", True)))


def _implicit_rows_block(model):
    """(first, length) of the pairs' slope block NAME_implicit_batch_rows writes into the rows'
    own buffers (the compiler's implicit_batch.rows_block), or None: a model without body-body
    pairs, or built before that function (the lanes rollout then takes NAME_implicit_batch)."""
    block = model.metadata.get("implicit_batch", {}).get("rows_block")
    return (int(block[0]), int(block[1])) if block else None


def _implicit_batch(model, ffi, rows=False):
    """NAME_implicit_batch of the model's library as the eomc_batch_fn ``ffi`` declares (rows:
    NAME_implicit_batch_rows as eomc_batch_rows_fn, declared here: the model's own cdef has only
    the public functions)."""
    if not rows:
        fp = model.ffi.addressof(model.model_lib, f"{model.name}_implicit_batch")
        return ffi.cast("eomc_batch_fn", int(model.ffi.cast("uintptr_t", fp)))
    fn = _own_function(model, "implicit_batch_rows",
                       "(int n, double t, const double *X, const double *p, const double *R, double *OUT, "
                       "double *const *rows, int *status, double *work)")
    return ffi.cast("eomc_batch_rows_fn", fn)


LANES_BLOCK = 64    # rows per thread's block: 8 groups of 8 lanes; its columns stay in cache


def _batch_p(model, ffi):
    """NAME_rhs_batch_p of the model's library as the eomc_batch_fn ``ffi`` declares (the
    model's own cdef lists only the functions of its ABI; this one is looked up here)."""
    try:
        fn = _own_function(model, "rhs_batch_p", "(int n, double t, const double *X, const double *P, "
                           "const double *R, double *XDOT, int *status, double *work)")
    except AttributeError:
        raise ValueError(f"{model.name}: its library has no {model.name}_rhs_batch_p (built by an older "
                         f"eomc); rebuild it for rollout(lanes=True)") from None
    return ffi.cast("eomc_batch_fn", fn)


def _own_function(model, suffix, params):
    """The address of the model library's int NAME_<suffix><params> (a function its own cdef does
    not list), looked up once through an FFI of its own and kept on the model (the FFI and the
    library with it, so the address stays valid while the model lives)."""
    key = f"_{suffix}_fn"
    cached = model.__dict__.get(key)
    if cached is None:
        import cffi
        own = cffi.FFI()
        own.cdef(f"int {model.name}_{suffix}{params};")
        lib = own.dlopen(str(model.library_path))
        fn = getattr(lib, f"{model.name}_{suffix}")
        cached = model.__dict__[key] = (own, lib, own.cast("uintptr_t", fn))
    return cached[2]


def _rollout_lanes(model, X0, P, p_stride, controls, t1, h, steps_too, nthreads, rows=None):
    """RK4 over the rows in SIMD lanes, in C threads (eomc_rollout_lanes): each thread's block of
    rows stored as columns, every stage one NAME_rhs_batch_p call, run_rk4's step grid and
    arithmetic; one parameter row per row (P, p_stride) or one for all; the model's unit
    quaternions normalised in each lane after every step, as the scalar RK4 does.  ``rows``: a list
    that gets the four arrays before the C call (the caller's partial result on Ctrl-C or SIGTERM)."""
    ffi, lib = _rollout_ffi(model.ffi)
    n, nx = X0.shape
    nsteps = max(int(np.ceil((t1 - 0.0) / h * (1 - 1e-12))), 1)
    X_out = np.empty((n, nsteps + 1, nx)) if steps_too else None
    X_last = np.empty((n, nx))
    status = np.empty(n, dtype=np.intc)
    nstep = np.zeros(n, dtype=np.int_ if ffi.sizeof("long") == 8 else np.int32)   # 0: a row not run (a stop)
    buf = lambda arr: ffi.from_buffer("double[]", arr)  # noqa: E731
    if rows is not None:
        rows.extend((X_out, X_last, status, nstep))
    integrator_library(model.ffi)._arm()      # Ctrl-C, SIGTERM stop the blocks at their next step
    quat = ffi.new("int[]", [int(i) for i in model.quaternions]) if model.quaternions else ffi.NULL
    if n:
        n_rgrid, r_tgrid, R, r_stride = controls
        lib.eomc_rollout_lanes(_batch_p(model, ffi), nx, model.nparam, model.ninput, max(model.work_size, 1), 0.0,
                               t1, h, n, buf(X0), buf(P), p_stride, n_rgrid,
                               buf(r_tgrid) if r_tgrid is not None else ffi.NULL,
                               buf(R) if R is not None else ffi.NULL, r_stride,
                               buf(X_out) if steps_too else ffi.NULL, buf(X_last),
                               ffi.from_buffer("int[]", status), ffi.from_buffer("long[]", nstep), LANES_BLOCK,
                               nthreads, len(model.quaternions or ()), quat)
    return X_out, X_last, status, nstep


assert set(FIXED_STEP) <= set(METHOD_IDS)
