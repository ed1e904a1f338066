"""``rollout`` with feedback, events, contacts or joint limits (eomc_rollout_ex in C threads).

Why a module of its own: these rows need more than a final state.  Feedback gains (constant
or scheduled in time, one set per trajectory) ride into C with each row, so the loop runs
without the GIL; events and the switching functions of contacts and limits are recorded per
row in C.  Each row is one ``eomc_integrate_ex`` call with the options, feedback and events
``simulate`` would pass, so its states equal simulate's bit for bit; then each row with
events or switching points is judged by simulate's own ``finish`` (penetration and limit
overshoot, created energy, events by name), so its verdict is simulate's too.  Rows that
method="auto" finds stiff under DOP853 are run again through ``simulate`` (its switch to
Radau mid-run is made in Python), one at a time.
"""
import warnings
from types import SimpleNamespace

import numpy as np

from .errors import SimulationError
from .events import EventsBinding
from .integrators_api import STATUS_NAMES
from .native import integrator_library
from .rollout_result import RolloutResult, _rollout_ffi
from .simulate import (IMPLICITFAST_SPLIT, STIFF_STATUS, _STAT_FIELDS, _options, _user_level, depth_limits, finish,
                       implicit_for_run, implicit_terms, simulate, watch_options)
from .switching import watched_stats

__all__ = ["rollout_extras"]


class _RowEvents:
    """One row's slice of the rollout's event records, read as simulate's EventsBinding is."""

    switch_maxima = EventsBinding.switch_maxima
    results = EventsBinding.results

    def __init__(self, binding, t_rec, id_rec, x_rec, gmax, n_rec, terminated):
        self._layout, self.events = binding._layout, binding.events
        self.t_rec, self.id_rec, self.x_rec, self.gmax = t_rec, id_rec, x_rec, gmax
        self.struct = SimpleNamespace(n_rec=int(n_rec), terminated=int(terminated),
                                      capacity=binding.struct.capacity)


class _Applied:
    """Stands for simulate's FeedbackBinding in finish(): the inputs along a row are then the
    ones the C loop applied (feedback included); nothing is raised (no Python callable ran)."""

    @staticmethod
    def raise_error():
        return None


def _row_inputs(controls, i, ninput):
    """(n_r, r_t, r_v) of simulate's prepared dict for row i of rollout's controls."""
    n_rgrid, r_tgrid, R, r_stride = controls
    if n_rgrid == 0:
        return 0, np.zeros(1), np.zeros(max(ninput, 1))
    flat = R.reshape(-1)
    size = n_rgrid * ninput
    rows = flat[i * r_stride:i * r_stride + size] if r_stride else flat[:size]
    return n_rgrid, (np.zeros(1) if r_tgrid is None else r_tgrid), np.ascontiguousarray(rows)


def _row_r(controls, i, ninput):
    """Row i's inputs as simulate's r= takes them (the oracle re-run of an "auto" row)."""
    n_r, r_t, r_v = _row_inputs(controls, i, ninput)
    if n_r == 0:
        return None
    return r_v if n_r == 1 else (r_t, r_v.reshape(n_r, ninput))


def rollout_extras(model, a, X0, P, p_stride, controls, r, gains, t1, record, nthreads, raise_on_failure,
                   scalar):
    """eomc_rollout_ex over the rows, then each row judged as simulate judges it (see above).

    a: simulate's prepared dict for row 0 (options, events, switches); gains: rollout's
    _RowGains or None; scalar: simulate's keywords for a row run again the ordinary way."""
    ffi, lib = _rollout_ffi(model.ffi)
    n, nx = X0.shape
    buf = lambda arr: ffi.from_buffer("double[]", arr)  # noqa: E731
    ints = lambda arr: ffi.from_buffer("int[]", arr)  # noqa: E731
    t_eval = a["t_eval"] if record == "steps" else np.array([t1])
    X_out = np.full((n, t_eval.size, nx), np.nan)
    X_last = np.empty((n, nx))
    status = np.full(n, 9, dtype=np.intc)      # EOMC_ABORTED until a row's run says otherwise
    nstep = np.zeros(n, dtype=np.int_ if ffi.sizeof("long") == 8 else np.int32)   # 0: a row not run (a stop)
    stats = ffi.new("eomc_stats[]", max(n, 1))
    ex = ffi.new("eomc_rollout_extras *")
    keep = []
    if gains is not None:
        g = gains.g
        fb = ffi.new("eomc_feedback *")
        fb.K = buf(g.K)
        keep += [fb, fb.K]
        if g.ref is not None:
            fb.x_ref = buf(g.ref)
            keep.append(fb.x_ref)
        if g.t_grid is not None:
            fb.n_kgrid, fb.ref_on_grid, fb.k_tgrid = g.n_grid, int(g.ref_on_grid), buf(g.t_grid)
            keep.append(fb.k_tgrid)
        ex.fb, ex.K_stride, ex.ref_stride = fb, g.K_stride, g.ref_stride
    binding = None
    if "events" in a or "switches" in a:
        source, chosen = a.get("events", (None, []))
        binding = EventsBinding(model, source, chosen, max_events=a["max_events"], switches=a.get("switches"),
                                observe_only=not a.get("switch_steps", True))
        cap = binding.struct.capacity
        t_rec, id_rec = np.empty((n, cap)), np.empty((n, cap), dtype=np.intc)
        x_rec = np.empty((n, cap, nx))
        n_rec, terminated = np.zeros(n, dtype=np.intc), np.zeros(n, dtype=np.intc)
        gmax = np.full((n, binding.gmax.size), -np.inf)
        ex.ev = binding.struct
        ex.t_rec, ex.id_rec, ex.x_rec = buf(t_rec), ints(id_rec), buf(x_rec)
        ex.n_rec, ex.terminated, ex.gmax, ex.gmax_len = ints(n_rec), ints(terminated), buf(gmax), gmax.shape[1]
        keep += [ex.t_rec, ex.id_rec, ex.x_rec, ex.n_rec, ex.terminated, ex.gmax]
    implicit = None
    if a["method"] == "implicitfast" and implicit_terms(model) is not None:
        implicit, ikeep = implicit_for_run(model, P[0, :-1], split=scalar.get("split", IMPLICITFAST_SPLIT))
        if p_stride:        # the smallest radius of each contact over the rows
            for k, v in enumerate(np.min([depth_limits(model, row[:-1]) for row in P], axis=0)):
                ikeep[1][k] = v
        keep.append(ikeep)
    try:
        opt = _options(ffi, a, implicit)
        # simulate's C energy watch (implicitfast: the energy's range over every step, which its verdict
        # reads): without it a row judged by its output rows alone missed a rise between them (session 52,
        # example-robot-data's allegro hand at 1 ms: simulate status 20, the same row here 0)
        nwatch = watch_options(model, opt, a)
        opt.interrupt_base = integrator_library(model.ffi)._arm()   # Ctrl-C stops every thread at its next evaluation
        if n:
            n_rgrid, r_tgrid, R, r_stride = controls
            lib.eomc_rollout_ex(model.c_model, opt, 0.0, t1, n, buf(X0), buf(P), p_stride,
                                n_rgrid, buf(r_tgrid) if r_tgrid is not None else ffi.NULL,
                                buf(R) if R is not None else ffi.NULL, r_stride, ex, t_eval.size, buf(t_eval),
                                buf(X_out), buf(X_last), ffi.from_buffer("int[]", status),
                                ffi.from_buffer("long[]", nstep), stats, nthreads)
    except BaseException as stop:
        # Ctrl-C or a SIGTERM handler's exception as the C threads return (s29: this path kept
        # nothing): the rows as they are, unjudged, as rollout's own (rollout._keep_rows; not
        # imported from there: rollout imports this module)
        if not isinstance(stop, Exception):
            try:
                stop.partial_result = _stopped_rows(model, t_eval, X_out if record == "steps" else X_last,
                                                    status, nstep)
            except BaseException:       # noqa: BLE001 -- the rows cannot be wrapped: the stop goes on
                pass
        raise
    status = status.astype(int)
    event_stop = np.full(n, None, dtype=object)
    t_events = [None] * n if binding is not None and "events" in a else None
    messages, notes = {}, []
    judged = binding is not None
    for i in range(n):
        st = {f: getattr(stats[i], f) for f in _STAT_FIELDS}
        if status[i] == STIFF_STATUS and a.get("auto_switch"):
            res = _again(model, X0[i], P[i if p_stride else 0, :-1], controls, gains, i, t1, scalar)
            X_last[i], status[i], nstep[i] = res.x_final, res.status, res.stats["steps"]
            X_out[i, :len(res.x)] = res.x
            _keep_events(res, i, event_stop, t_events, messages)
            continue
        if not judged:
            if status[i]:
                messages[i] = STATUS_NAMES.get(int(status[i]), f"status {status[i]}")
            continue
        b = dict(a)
        b["x0"], b["p"] = X0[i], P[i if p_stride else 0]
        # the rows' output times, not the prepared grid: with record="final" X_out holds the end alone,
        # which the prepared grid's first time (t0) labelled the start, so the verdict took the end's
        # energy for the start's and saw no rise (session 52: no row here ever failed for created
        # energy with record="final"; simulate failed 5 of 16 allegro-hand rows)
        b["t_eval"] = t_eval
        if nwatch is not None:
            b["_watched"] = watched_stats(stats[i], nwatch)
        b["n_r"], b["r_t"], b["r_v"] = _row_inputs(controls, i, model.ninput)
        if gains is not None:
            b["K"], b["x_ref"] = gains.row_argument(i)
        b["_bindings"] = (_Applied() if gains is not None else None,
                          _RowEvents(binding, t_rec[i], id_rec[i], x_rec[i], gmax[i], n_rec[i], terminated[i]))
        with warnings.catch_warnings(record=True) as said:
            warnings.simplefilter("always")
            res = finish(model, b, X_out[i], st, X_last[i], raise_on_failure=False)
        notes += [(i, w) for w in said]
        status[i] = res.status
        _keep_events(res, i, event_stop, t_events, messages)
    if notes:       # one warning for the rows, the first row's words
        i, w = notes[0]
        rows = sorted({j for j, _ in notes})
        warnings.warn(w.category(f"rollout: {len(rows)} of {n} row(s) warned (rows "
                                 f"{', '.join(map(str, rows[:8]))}{', ...' if len(rows) > 8 else ''}); "
                                 f"row {i}: {w.message}"), stacklevel=_user_level())
    failed = np.flatnonzero(status != 0)
    if failed.size and raise_on_failure:
        i = int(failed[0])
        if status[i] == 9:
            raise KeyboardInterrupt
        raise SimulationError(f"{model.name}: rollout row {i} of {n} failed ({failed.size} row(s) failed in all) "
                              f"-- {messages.get(i, STATUS_NAMES.get(int(status[i]), status[i]))}; pass "
                              f"raise_on_failure=False to keep the other rows")
    out = RolloutResult(t=np.asarray(t_eval, dtype=np.float64).copy(),
                        x=X_out if record == "steps" else X_last, status=status, steps=nstep.astype(int),
                        state_names=tuple(model.state_names))
    out.event_stop, out.t_events, out.messages = event_stop, t_events, messages
    return out


def _stopped_rows(model, t_eval, x, status, nstep):
    """The rows of a stopped rollout_extras as a RolloutResult: status and steps as the C threads
    left them (9, EOMC_ABORTED, for a row not run to the end), not judged (no verdict, no events)."""
    out = RolloutResult(t=np.asarray(t_eval, dtype=np.float64).copy(), x=x, status=status.astype(int),
                        steps=nstep.astype(int), state_names=tuple(model.state_names))
    out.x[(out.status == 9) & (out.steps == 0)] = np.nan       # never started: nothing was written
    out.event_stop, out.t_events = np.full(len(status), None, dtype=object), None
    out.messages = {i: STATUS_NAMES.get(9, "stopped") for i in np.flatnonzero(status == 9)}
    return out


def _keep_events(res, i, event_stop, t_events, messages):
    event_stop[i] = res.event_stop
    if t_events is not None:
        t_events[i] = res.t_events
    if res.status:
        messages[i] = res.message


def _again(model, x0, p, controls, gains, i, t1, scalar):
    """Row i through simulate (method="auto" found it stiff: Radau takes over mid-run there)."""
    K, x_ref = gains.row_argument(i) if gains is not None else (None, None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return simulate(model, x0, (0.0, t1), p=p, r=_row_r(controls, i, model.ninput), K=K, x_ref=x_ref,
                        t_eval=[t1], raise_on_failure=False,
                        **{k: v for k, v in scalar.items() if k != "split"})
