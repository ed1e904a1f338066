"""simulate_many: many initial states or parameter sets in one call, on threads.

Why threads work here: each case is one foreign call into the C integrator,
and cffi releases the GIL for the whole call, so cases run truly in parallel.
Every case gets its own work buffer (the C code is reentrant) and writes
straight into its slice of one preallocated (n_cases, n_t, nx) array.

A batch carries what a single run carries (issue 24, N2): besides the rows on
the shared time grid (NaN after a case stopped -- a failure or a terminal
event), each case's real final state and time (``x_final``, ``t_final``: the
event state for a run a terminal event ended), its event records
(``t_events``, ``x_events``, ``event_stop``), status and message.  Memory is
checked before anything is allocated (N12): a batch whose arrays would not fit
is refused with the figure.  ``run_cases`` is the streaming core the sweep's
reductions use: one case at a time per thread, each case's result handed to
the caller and then dropped, so memory does not grow with the number of cases.
"""
import os
import sys
import threading
import warnings
from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait
from dataclasses import dataclass, field

import numpy as np

from eomc.runtime.errors import SimulationError

from .progress import is_terminal
from .simulate import check_keywords, checked_start, finish, prepare, run_prepared

__all__ = ["simulate_many", "BatchResult", "CaseError", "run_cases", "prepare_cases",
           "check_batch_memory"]

CASE_OVERHEAD_BYTES = 2048     # a prepared case's own arrays and dict (x0, p, inputs, ...)


class CaseError(ValueError):
    """A bad value in one case of a batch; ``case`` is its index among all cases of the call
    (a sweep's CSV reader turns it into the file's line)."""

    def __init__(self, case, total, detail):
        self.case, self.total, self.detail = case, total, detail
        super().__init__(f"case {case} of {total}: {detail}")

    def __reduce__(self):       # travels back from a worker process intact
        return (CaseError, (self.case, self.total, self.detail))


@dataclass
class BatchResult:
    """t (n_t,), x (n_cases, n_t, nx); rows after a case's stop (a failure or a terminal
    event) are NaN.  x_final (n_cases, nx) and t_final (n_cases,) are where each case
    really ended (simulate()'s ``x_final``/``t_final``); with events, t_events/x_events
    hold each case's records (a dict per case, as simulate() gives them) and event_stop
    the terminal event that ended it (or None)."""
    t: np.ndarray
    x: np.ndarray
    state_names: tuple
    status: np.ndarray
    messages: list
    stats: list
    outputs: dict = field(default_factory=dict)   # name -> (n_cases, n_t)
    x_final: np.ndarray = None
    t_final: np.ndarray = None
    t_events: list = None
    x_events: list = None
    event_stop: list = None

    @property
    def success(self):
        return bool(np.all(self.status == 0))

    def __getitem__(self, name):
        if name in self.state_names:
            return self.x[:, :, self.state_names.index(name)]
        return self.outputs[name]


def _memory_limit():
    """Bytes one batch may allocate: half of this machine's memory (at least 2 GiB)."""
    try:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        total = 0
    return max(2 ** 31, total // 2) if total > 0 else 2 ** 33


def check_batch_memory(n, rows, cols, what="simulate_many", advice=""):
    """Refuse, before allocating anything, a batch whose arrays would not fit in memory."""
    size = float(n) * (rows * max(cols, 1) * 8.0 + CASE_OVERHEAD_BYTES)
    limit = _memory_limit()
    if size > limit:
        raise ValueError(
            f"{what}: {n} cases x {rows} rows x {cols} columns (states and outputs) would need "
            f"{size / 2 ** 30:.3g} GiB, more than eomc allocates for one batch ({limit / 2 ** 30:.3g} GiB, "
            f"half of this machine's memory); "
            + (advice or "run fewer cases per call, ask for fewer rows (n_points= or t_eval=), or use "
                         "eomc.sweep(..., reduce='final' or reduce=f), which keeps only what it needs"))


def _cases(value, size, what):
    """A list of n per-case values from one value, an (n, size) array or a list of dicts."""
    if value is None or isinstance(value, dict):
        return None
    if isinstance(value, (list, tuple)) and value and isinstance(value[0], dict):
        return list(value)
    a = np.asarray(value)
    if a.dtype.kind not in "fiub":
        raise ValueError(f"{what} must be real numbers; got dtype {a.dtype}")
    a = np.asarray(a, dtype=float)
    if a.ndim == 1:
        return None
    if a.ndim != 2 or a.shape[1] != size:
        raise ValueError(f"{what} must have shape ({size},) for all cases or (n_cases, {size}); "
                         f"got {a.shape}")
    if a.shape[0] == 0:
        raise ValueError(f"{what} holds no cases (shape {a.shape})")
    return list(a)


class _Progress:
    """tqdm when installed, else a counter on stderr every ~5 %."""

    def __init__(self, total, enabled):
        self.total, self.done, self.bar, self.lock = total, 0, None, threading.Lock()
        self.enabled = enabled and total > 1
        self.tty = is_terminal(sys.stderr)
        if self.enabled and self.tty:       # a bar on a terminal; a log gets plain lines
            try:
                from tqdm import tqdm
                self.bar = tqdm(total=total, unit="case", desc="simulate")
            except ImportError:
                self.bar = None

    def step(self):
        if not self.enabled:
            return
        with self.lock:
            self.done += 1
            if self.bar is not None:
                self.bar.update(1)
            elif self.done == self.total or self.done % max(1, self.total // 20) == 0:
                start, end = ("\r", "") if self.tty else ("", "\n")
                print(f"{start}simulate: {self.done}/{self.total} cases", end=end, file=sys.stderr,
                      flush=True)

    def close(self):
        if self.bar is not None:
            self.bar.close()
        elif self.enabled and self.tty:
            print(file=sys.stderr)


def _input_cases(r, ninput):
    """Per-case constant inputs (an (n, ninput) array or a list of dicts), else None: r is shared.

    Only these two forms: a 1-d array, a dict, an (t_grid, values) tuple or a
    callable is one r for every case, as before.
    """
    if (isinstance(r, np.ndarray) and r.ndim == 2) or (isinstance(r, list) and r and isinstance(r[0], dict)):
        return _cases(r, ninput, "r")
    return None


def prepare_cases(model, x0, t_span, p=None, consistent=None, first=0, total=None,
                  keep_rows=True, **kw):
    """(preps, kw): every case checked and prepared before any runs.

    A bad value raises CaseError naming the case by its index ``first + i`` among
    ``total`` cases (a sweep's chunk knows where it starts).  The cases share one
    array of output times.  consistent: as simulate's, per case -- None (the default)
    completes a start off the model's constraints, True completes every start
    (model.consistent_state), False runs them as given; one ConstraintWarning for the
    whole batch says how many were off.
    """
    check_keywords(kw, prepare, skip=4)
    xs = _cases(x0, model.nx, "x0")
    ps = _cases(p, model.nparam, "p")
    if xs is not None and ps is not None and len(xs) != len(ps):
        raise ValueError(f"x0 has {len(xs)} cases but p has {len(ps)}; give as many of each")
    rs = _input_cases(kw.get("r"), model.ninput)
    n = len(xs if xs is not None else ps if ps is not None else rs if rs is not None else [0])
    if rs is not None:
        if len(rs) != n:
            raise ValueError(f"r has {len(rs)} cases but x0/p have {n}; give as many of each")
        kw = {k: v for k, v in kw.items() if k != "r"}
    total = n if total is None else total
    constrained = model.nhol + model.nvel and not kw.get("project") and not kw.get("baumgarte")
    preps, off = [], []
    for i in range(n):
        xi = xs[i] if xs is not None else x0
        pi = ps[i] if ps is not None else p
        kwi = kw if rs is None else {**kw, "r": rs[i]}
        if preps:   # share the first case's output times (not one copy per case)
            kwi = {**kwi, "t_eval": preps[0]["t_eval"], "n_points": None}
        try:
            if consistent or constrained:
                with warnings.catch_warnings(record=True) as seen:
                    warnings.simplefilter("always")
                    xi = checked_start(model, xi, t_span, pi, kwi.get("r"), kwi.get("atol", 1e-9),
                                       consistent)
                off += [w for w in seen]
            preps.append(prepare(model, xi, t_span, p=pi, **kwi))
        except ValueError as exc:
            if type(exc) is not ValueError and not isinstance(exc, CaseError) and \
                    not (consistent and isinstance(exc, ValueError)):
                raise
            if total == 1:
                raise
            raise CaseError(first + i, total, str(exc)) from None
        if i == 0 and keep_rows:
            check_batch_memory(n, preps[0]["t_eval"].size, model.nx + model.noutput)
    if off:
        w = off[0]
        warnings.warn(w.message.__class__(f"{len(off)} of {n} cases: {w.message}")
                      if len(off) > 1 else w.message, stacklevel=3)
    return preps, kw


def run_cases(model, preps, threads=None, progress=False, out=None, extra=None):
    """Yield (i, SimulationResult) for every prepared case as it finishes, on threads.

    At most a few cases per thread are in flight, and a case's prepared arguments
    and event buffers are dropped once its result is handed over, so memory is
    that of the results the caller keeps.  out: an (n, n_t, nx) array the cases
    write their rows into (simulate_many), else each case has its own.  extra(a, result)
    runs on the case's thread while its prepared arguments still exist; its value is
    yielded too: (i, result, extra value).

    Cases that are each one plain eomc_integrate call (no events, switching points or
    feedback, inputs on one time grid; see ``_rollout_ready``) run in blocks through eomc_rollout's C
    threads instead (issue 31): the same call per case, so the same bits; a case that
    fails there is run again the ordinary way, so its message, and method="auto"'s switch
    to Radau, are simulate's.
    """
    n = len(preps)
    bar = _Progress(n, progress)

    def one(i):
        a = preps[i]
        x_out, stats, x_last = run_prepared(model, a, out=None if out is None else out[i])
        res = finish(model, a, x_out, stats, x_last, raise_on_failure=False)
        more = extra(a, res) if extra is not None else None
        bar.step()
        return i, res, more

    workers = max(1, min(int(threads or os.cpu_count() or 1), n))
    if _rollout_ready(model, preps):
        try:
            for i, res, more in _rollout_cases(model, preps, workers, out, extra, one, bar):
                preps[i] = None
                yield (i, res) if extra is None else (i, res, more)
        finally:
            bar.close()
        return
    try:
        with ThreadPoolExecutor(max_workers=workers) as pool:
            todo = iter(range(n))
            pending = {pool.submit(one, i) for _, i in zip(range(4 * workers), todo)}
            try:
                while pending:
                    done, pending = wait(pending, return_when=FIRST_COMPLETED)
                    for fut in done:
                        i, res, more = fut.result()
                        preps[i] = None
                        yield (i, res) if extra is None else (i, res, more)
                        nxt = next(todo, None)
                        if nxt is not None:
                            pending.add(pool.submit(one, nxt))
            finally:
                for fut in pending:
                    fut.cancel()
    finally:
        bar.close()


ROLLOUT_BLOCK = 512     # cases per eomc_rollout call: progress and results come block by block


def _rollout_ready(model, preps):
    """True when every case is one eomc_integrate call with the same options but x0, p and
    the input values: no events or switching points (their buffers and verdicts live in
    Python), no feedback or input callables, inputs on one time grid (constant per case, or
    tables sharing their times), not implicitfast (its fast path's per-run terms and its
    warning)."""
    a = preps[0] if preps else None
    if a is None or any(k in a for k in ("events", "switches", "r_fun", "K", "r_slopes")):
        return False
    if a["method"] == "implicitfast" or model.c_model.rhs == model.ffi.NULL:
        return False
    return all(b is not None and b["t0"] == a["t0"] and b["t1"] == a["t1"] and b["t_eval"] is a["t_eval"]
               and b["n_r"] == a["n_r"] and (b["n_r"] < 2 or np.array_equal(b["r_t"], a["r_t"]))
               for b in preps)


def _rollout_cases(model, preps, workers, out, extra, one, bar):
    """Yield (i, result, extra value) for every case, eomc_rollout running one block ahead of
    the Python that wraps the previous block's results (finish(): outputs, messages)."""
    from .cdef import STATUS_ABORTED
    from .rollout import _rollout_ffi, rollout_stats
    from .simulate import _STAT_FIELDS, _options
    n, a0 = len(preps), preps[0]
    t_eval = a0["t_eval"]
    opt = _options(_rollout_ffi(model.ffi)[0], a0)
    blocks = [range(lo, min(n, lo + ROLLOUT_BLOCK)) for lo in range(0, n, ROLLOUT_BLOCK)]

    def run(block):
        X0 = np.ascontiguousarray([preps[i]["x0"] for i in block], dtype=np.float64)
        P = np.ascontiguousarray([preps[i]["p"] for i in block], dtype=np.float64)
        X_out = (out[block.start:block.stop] if out is not None
                 else np.full((len(block), t_eval.size, model.nx), np.nan))
        controls = (0, None, None, 0)
        if a0["n_r"] and model.ninput:
            R = np.ascontiguousarray([preps[i]["r_v"].ravel() for i in block], dtype=np.float64)
            controls = (a0["n_r"], np.ascontiguousarray(a0["r_t"], dtype=np.float64), R, R.shape[1])
        X_last, status, stats = rollout_stats(model, opt, a0["t0"], a0["t1"], X0, P, P.shape[1], t_eval,
                                              X_out, workers, controls)
        return X_out, X_last, status, stats

    with ThreadPoolExecutor(max_workers=1) as ahead:
        nxt = ahead.submit(run, blocks[0])
        for b, block in enumerate(blocks):
            X_out, X_last, status, stats = nxt.result()
            if np.any(status == STATUS_ABORTED):
                raise KeyboardInterrupt
            if b + 1 < len(blocks):
                nxt = ahead.submit(run, blocks[b + 1])
            for k, i in enumerate(block):
                if status[k] != 0:          # run again the ordinary way: simulate's message, auto's switch
                    if out is not None:
                        out[i] = np.nan
                    yield one(i)
                    continue
                a = preps[i]
                got = {f: getattr(stats[k], f) for f in _STAT_FIELDS}
                res = finish(model, a, X_out[k], got, X_last[k].copy(), raise_on_failure=False)
                more = extra(a, res) if extra is not None else None
                bar.step()
                yield i, res, more


def simulate_many(model, x0, t_span, p=None, threads=None, progress=True,
                  raise_on_failure=True, consistent=None, **kw):
    """Integrate every case; x0 (nx,) or (n, nx) (or None: the model's initial_state),
    p None, (nparam,) or (n, nparam).

    r (constant inputs) may also be per case: an (n, ninput) array or a list of dicts.

    All cases share t_span and the output times (t_eval / n_points / dt); other
    keywords are simulate()'s (events=, K=, ...); consistent is simulate's too, per case
    (None: a start off the constraints is completed on them, as simulate() completes
    it -- so case i is simulate() of that start; True: every start; False: as given).  threads=None uses
    every CPU.  Returns a BatchResult; a failed case raises SimulationError naming
    the case unless raise_on_failure=False (then its status is nonzero and its
    tail is NaN).  A batch whose arrays would not fit in memory is refused first.
    """
    preps, kw = prepare_cases(model, x0, t_span, p=p, consistent=consistent, **kw)
    return collect(model, preps, threads, progress, raise_on_failure)


def collect(model, preps, threads=None, progress=False, raise_on_failure=True):
    """Run prepared cases into one BatchResult (simulate_many's second half)."""
    n = len(preps)
    t = preps[0]["t_eval"]
    x = np.full((n, t.size, model.nx), np.nan)
    outputs = {name: np.full((n, t.size), np.nan) for name in model.output_names}
    status = np.zeros(n, dtype=int)
    messages, stats = [None] * n, [None] * n
    x_final, t_final = np.full((n, model.nx), np.nan), np.full(n, np.nan)
    with_events = "events" in preps[0]
    t_events, x_events, event_stop = ([None] * n for _ in range(3))
    for i, r in run_cases(model, preps, threads, progress, out=x):
        status[i], messages[i], stats[i] = r.status, r.message, r.stats
        x_final[i], t_final[i] = r.x_final, r.t_final
        t_events[i], x_events[i], event_stop[i] = r.t_events, r.x_events, r.event_stop
        for name, values in r.outputs.items():
            outputs[name][i, :len(r.t)] = values
    if raise_on_failure and np.any(status):
        i = int(np.flatnonzero(status)[0])
        raise SimulationError(f"case {i} of {n}: {messages[i]}")
    return BatchResult(t=t, x=x, state_names=tuple(model.state_names), status=status,
                       messages=messages, stats=stats, outputs=outputs, x_final=x_final,
                       t_final=t_final, t_events=t_events if with_events else None,
                       x_events=x_events if with_events else None,
                       event_stop=event_stop if with_events else None)
