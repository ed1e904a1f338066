"""eomc.sweep: thousands of simulations of one model, in chunks, on any map-like executor.

Why: parameter studies, Monte Carlo and controller tuning outgrow one
process.  ``simulate_many`` already fills every core of one machine (threads,
GIL released); ``sweep`` cuts the cases into chunks and hands each chunk,
with the model, to an executor the user already has -- builtin ``map``, a
``concurrent.futures`` executor, a ``multiprocessing`` pool (any start
method) or a ``dask.distributed.Client`` -- where it runs ``simulate_many``.
The model travels by content (``travel.py``): a worker needs numpy, cffi and
maybe a C compiler, never SymPy.  We do not schedule anything ourselves.

Results come back in case order as a ``BatchResult``, exactly what
``simulate_many`` returns for the same cases (bit for bit), or reduced on the
worker so a huge sweep does not ship trajectories home: ``reduce="final"``
keeps each case's last output row, ``reduce=f`` keeps ``f(result)`` of each
case's ``SimulationResult`` (a ``SweepValues``).

Dask is optional and imported only when a Client is passed.
"""
import builtins
import math
import numbers
import os
import sys
from dataclasses import dataclass
from functools import partial

import numpy as np

from eomc.runtime.errors import SimulationError

from . import loader  # noqa: F401  (registers Model pickling by content)
from .batch import BatchResult, CaseError, check_batch_memory, collect, prepare_cases, run_cases
from .names import index_of
from .progress import is_terminal
from .simulate import final_outputs, prepare

__all__ = ["sweep", "SweepValues", "case_arrays", "run_chunk"]

MIN_CHUNK = 100   # cases; below this the per-chunk cost shows (benchmarks/results/sweep.md)
CHUNKS_PER_WORKER = 4


@dataclass
class SweepValues:
    """values[i] = reduce(result of case i); status, messages, stats, x_final, t_final and
    event_stop per case as in BatchResult."""
    values: object          # an (n_cases, ...) array when the values stack, else a list
    status: np.ndarray
    messages: list
    stats: list
    x_final: np.ndarray = None
    t_final: np.ndarray = None
    event_stop: list = None

    @property
    def success(self):
        return bool(np.all(self.status == 0))


# ---- cases ------------------------------------------------------------------------------------
ROW_KEYS = {"x0": "states", "p": "parameters", "r": "inputs"}


def _column(value, what):
    a = np.asarray(value)
    if a.dtype.kind not in "fiub":
        raise ValueError(f"sweep cases: column {what!r} must hold numbers; got dtype {a.dtype}")
    a = np.asarray(a, dtype=np.float64)
    if a.ndim != 1:
        raise ValueError(f"sweep cases: column {what!r} must hold one number per case; got shape {a.shape}")
    return a


def _rows(value, size, what):
    """An (n, size) array of per-case rows, or a (size,) vector shared by every case."""
    a = np.asarray(value)
    if a.dtype.kind not in "fiub":
        raise ValueError(f"sweep cases: {what!r} must hold numbers; got dtype {a.dtype}")
    a = np.asarray(a, dtype=np.float64)
    if a.ndim == 1 and a.shape == (size,):
        return a
    if a.ndim != 2 or a.shape[1] != size:
        raise ValueError(f"sweep cases: {what!r} (the whole {ROW_KEYS[what][:-1]} row) must have shape "
                         f"({size},) for every case or (n_cases, {size}) for one row per case; got {a.shape}")
    return a


def case_arrays(model, cases, rows=True):
    """(n, X0, P, R) from ``cases``: X0 (n, nx); P (n, nparam) or None; R (n, ninput) or None.

    ``cases`` is one of
    - a mapping of columns (a dict, a pandas DataFrame): a state, parameter or input name
      holds one value per case;
    - a list of dicts, one per case, keyed the same way;
    - an (n, nx) array: one initial state per case.
    With rows=True (the Python API) the keys "x0", "p" and "r" hold whole rows (one per
    case, or one shared) -- unless the model has a state, parameter or input of that
    name: a model's own name always means its column (a 2-d value under it is an error,
    not a guess).  rows=False (a CSV file) takes every key as a name.
    Unset states start at the model's initial_state (0 without one), unset parameters
    keep their defaults and unset inputs are 0 (or simulate's r=, when given).  A
    non-finite value raises CaseError naming its case and column.
    """
    if isinstance(cases, (list, tuple)) and cases and isinstance(cases[0], dict):
        keys = list(dict.fromkeys(k for case in cases for k in case))
        missing = [(i, k) for i, case in enumerate(cases) for k in keys if k not in case]
        if missing:
            i, k = missing[0]
            raise ValueError(f"sweep cases: case {i} has no {k!r} (every case must set the same names)")
        cases = {k: [case[k] for case in cases] for k in keys}
    elif isinstance(cases, (list, tuple)) and not cases:
        raise ValueError("sweep cases: no cases (an empty list)")
    elif not hasattr(cases, "keys"):
        cases = {"x0": cases}
    names = set(model.state_names) | set(model.param_names) | set(model.input_names)
    columns, whole = {}, {}
    for key in cases.keys():
        name = str(key)
        if rows and name in ROW_KEYS and name not in names:
            size = {"x0": model.nx, "p": model.nparam, "r": model.ninput}[name]
            whole[name] = _rows(cases[key], size, name)
            continue
        if name in ROW_KEYS and name in names and np.ndim(cases[key]) == 2:
            raise ValueError(f"sweep cases: {name!r} is a {_kind(model, name, noun=True)} of {model.name}, "
                             f"so cases[{name!r}] is its column (one number per case); it cannot also "
                             f"be the whole {ROW_KEYS[name][:-1]} row: give the other "
                             f"{ROW_KEYS[name]} by name")
        columns[key] = _column(cases[key], name)
    lengths = {f"column {k!r}": len(v) for k, v in columns.items()}
    lengths.update({f"{k!r}": len(v) for k, v in whole.items() if v.ndim == 2})
    if not lengths:
        raise ValueError("sweep cases: nothing varies from case to case; give columns named by "
                         "states, parameters or inputs" + (" (or per-case rows x0, p, r)" if rows else ""))
    n = next(iter(lengths.values()))
    if any(v != n for v in lengths.values()):
        raise ValueError("sweep cases: columns differ in length: "
                         + ", ".join(f"{k} has {v}" for k, v in lengths.items()))
    if n == 0:
        raise ValueError("sweep cases: no cases (the columns are empty)")
    kinds = {key: _kind(model, key, rows=rows) for key in columns}   # "x", "p" or "r"; unknown fail here

    def per_case(row, default, kind, size):
        """(n, size) rows from the shared or per-case row, or None when no case sets any entry."""
        if row is None and kind not in kinds.values():
            return None
        return np.array(np.broadcast_to(default if row is None else row, (n, size)), dtype=np.float64)

    base = model.initial_state if model.initial_state is not None else np.zeros(model.nx)
    X0 = np.array(np.broadcast_to(whole.get("x0", base), (n, model.nx)), dtype=np.float64)
    P = per_case(whole.get("p"), model.param_defaults, "p", model.nparam)
    R = per_case(whole.get("r"), np.zeros(model.ninput), "r", model.ninput)
    for key, values in columns.items():
        target, names_ = {"x": (X0, model.state_names), "p": (P, model.param_names),
                          "r": (R, model.input_names)}[kinds[key]]
        target[:, index_of(key, names_, "name", model.name)] = values
    for array, labels, what in ((X0, model.state_names, "x0 (initial state)"),
                                (P, model.param_names, "p (parameters)"),
                                (R, model.input_names, "r (inputs)")):
        if array is not None and not np.all(np.isfinite(array)):
            bad = ~np.isfinite(array)
            i = int(np.flatnonzero(bad.any(axis=1))[0])
            raise CaseError(i, n, f"{model.name}: {what} is not finite for "
                                  f"{', '.join(nm for nm, b in zip(labels, bad[i]) if b)}")
    return n, X0, P, R


def _kind(model, key, noun=False, rows=True):
    for kind, names, word in (("x", model.state_names, "state"), ("p", model.param_names, "parameter"),
                              ("r", model.input_names, "input")):
        try:
            index_of(key, names, "", model.name)
            return word if noun else kind
        except ValueError:
            pass
    hint = ("; whole rows (x0, p, r) are for the Python API (eomc.sweep), a CSV column names one "
            "state, parameter or input" if not rows and str(key) in ROW_KEYS else "")
    from .names import euler_hint
    hint = euler_hint([str(key)], model.state_names) + hint
    raise ValueError(f"sweep cases: {key!r} is not a state, parameter or input of {model.name}; "
                     f"states: {', '.join(model.state_names)}; parameters: "
                     f"{', '.join(model.param_names) or 'none'}; inputs: {', '.join(model.input_names) or 'none'}"
                     + hint)


# ---- the work of one chunk (runs on a worker) --------------------------------------------------
def run_chunk(model, task):
    """Simulate one chunk on threads and reduce each case on the spot.

    reduce=None: simulate_many's BatchResult parts.  reduce="final": each case's real
    final state, time, outputs there and event records -- the C loop is asked for the
    last output row only (the steps do not depend on the output times), so no
    trajectory is ever held.  reduce=f: f(result) of each case's SimulationResult,
    exactly what simulate() returns, one case per thread at a time.
    """
    kw = dict(task["simulate"])
    consistent = kw.pop("consistent", None)
    if task["r"] is not None:
        kw["r"] = task["r"]
    reduce = task["reduce"]
    start, total = task["start"], task.get("total")
    if reduce == "final":
        kw.update(t_eval=[float(task["t_span"][1])], n_points=None)
    preps, _ = prepare_cases(model, task["x0"], task["t_span"], p=task["p"], consistent=consistent,
                             first=start, total=total, keep_rows=reduce is None, **kw)
    n = len(preps)
    if reduce is None:
        res = collect(model, preps, task["threads"], progress=False, raise_on_failure=False)
        return {"start": start, "status": res.status, "messages": res.messages, "stats": res.stats,
                "t": res.t, "x": res.x, "outputs": res.outputs, "x_final": res.x_final,
                "t_final": res.t_final, "t_events": res.t_events, "x_events": res.x_events,
                "event_stop": res.event_stop}
    out = {"start": start, "status": np.zeros(n, dtype=int), "messages": [None] * n, "stats": [None] * n,
           "x_final": np.full((n, model.nx), np.nan), "t_final": np.full(n, np.nan),
           "t_events": [None] * n, "x_events": [None] * n, "event_stop": [None] * n}
    if reduce == "final":
        outputs = {name: np.full(n, np.nan) for name in model.output_names}
        stream = run_cases(model, preps, task["threads"],
                           extra=lambda a, r: final_outputs(model, a, r.t_final, r.x_final))
    else:
        values = [None] * n
        stream = ((i, r, None) for i, r in run_cases(model, preps, task["threads"]))
    for i, r, final in stream:
        out["status"][i], out["messages"][i], out["stats"][i] = r.status, r.message, r.stats
        out["x_final"][i], out["t_final"][i] = r.x_final, r.t_final
        out["t_events"][i], out["x_events"][i], out["event_stop"][i] = r.t_events, r.x_events, r.event_stop
        if reduce == "final":
            for name, v in final.items():
                outputs[name][i] = v
        else:
            r.t = r.t.copy()        # the cases share one array of output times; f gets its own
            values[i] = reduce(r)
    if reduce == "final":
        out.update(t=np.array([float(task["t_span"][1])]), x=out["x_final"][:, None, :],
                   outputs={k: v[:, None] for k, v in outputs.items()})
    else:
        out["values"] = values
    return out


def _run_packed(args):
    return run_chunk(*args)


# ---- executors ---------------------------------------------------------------------------------
def _kind_of(executor):
    if executor is None or executor is builtins.map:
        return "here"
    if all(hasattr(executor, a) for a in ("submit", "gather", "scatter")):
        return "dask"
    if hasattr(executor, "imap_unordered"):
        return "pool"
    if hasattr(executor, "submit"):
        return "futures"
    if hasattr(executor, "map"):
        return "map"
    if callable(executor):
        return "callable"
    raise TypeError(f"sweep: map= must be map-like (builtins.map, a concurrent.futures executor, a "
                    f"multiprocessing Pool or a dask.distributed Client); got {type(executor).__name__}")


def _workers(executor, kind):
    """How many chunks can run at once (for the default chunk size)."""
    count = None
    if kind == "dask":
        count = sum(executor.nthreads().values())
    elif kind == "pool":
        count = getattr(executor, "_processes", None)
    elif kind == "futures":
        count = getattr(executor, "_max_workers", None)
    return max(1, int(count or os.cpu_count() or 1))


def _chunk_size(n, workers):
    """~4 chunks per worker balance the load; >= 100 cases each keep the per-chunk cost small."""
    per = math.ceil(n / (CHUNKS_PER_WORKER * workers))
    return max(1, min(math.ceil(n / workers), max(per, MIN_CHUNK)))


class _Progress:
    """tqdm on a terminal (when installed), else a line on stderr per finished chunk (at most
    ~20 lines): a log or a notebook's captured stderr gets plain lines, not bar redraws."""

    def __init__(self, n_cases, n_chunks, enabled, note=""):
        self.n_cases, self.n_chunks, self.cases, self.chunks = n_cases, n_chunks, 0, 0
        self.enabled, self.bar = enabled and n_chunks > 0, None
        if self.enabled:
            if note:
                print(f"sweep: {note}", file=sys.stderr, flush=True)
            try:
                from tqdm import tqdm
                if is_terminal(sys.stderr):
                    self.bar = tqdm(total=n_cases, unit="case", desc="sweep")
            except ImportError:
                pass

    def step(self, cases):
        if not self.enabled:
            return
        self.cases, self.chunks = self.cases + cases, self.chunks + 1
        if self.bar is not None:
            self.bar.update(cases)
        elif self.chunks == self.n_chunks or self.chunks % max(1, self.n_chunks // 20) == 0:
            tty = sys.stderr.isatty()   # a terminal redraws one line; a log gets one line each
            start, end = ("\r", "") if tty else ("", "\n")
            print(f"{start}sweep: {self.cases}/{self.n_cases} cases ({self.chunks}/{self.n_chunks} chunks)",
                  end=end, file=sys.stderr, flush=True)

    def close(self):
        if self.bar is not None:
            self.bar.close()
        elif self.enabled and sys.stderr.isatty():
            print(file=sys.stderr)


def _dispatch(executor, kind, model, tasks):
    """Yield each chunk's result as it finishes (any order)."""
    if kind == "here":
        for task in tasks:
            yield run_chunk(model, task)
    elif kind == "dask":
        from distributed import as_completed
        shipped = executor.scatter(model, broadcast=True, hash=False)   # once per worker, not per task
        futures = executor.map(run_chunk, [shipped] * len(tasks), tasks, pure=False)  # batched: ~1 ms/chunk less
        try:
            for future in as_completed(futures):
                yield future.result()
        finally:
            executor.cancel(futures)
    elif kind == "pool":
        yield from executor.imap_unordered(_run_packed, [(model, task) for task in tasks])
    elif kind == "futures":
        from concurrent.futures import as_completed
        futures = [executor.submit(run_chunk, model, task) for task in tasks]
        try:
            for future in as_completed(futures):
                yield future.result()
        finally:
            for future in futures:
                future.cancel()
    else:
        mapper = executor.map if kind == "map" else executor
        yield from mapper(partial(run_chunk, model), tasks)


def sweep(model, cases, t_span, *, map=None, chunk_size=None, reduce=None, threads=None,
          progress=True, raise_on_failure=True, consistent=None, **simulate_kw):
    """Simulate every case of ``cases`` (see :func:`case_arrays`) over ``t_span``, chunk by chunk.

    map: where chunks run -- None (here, on threads), builtins.map, a concurrent.futures
    executor, a multiprocessing Pool or a dask.distributed Client.  chunk_size: cases per
    chunk, a positive integer (default: ~4 chunks per worker, at least 100 cases each).
    threads: simulate_many's threads per chunk (default: every core here, 1 when an
    executor runs the chunks in parallel).  reduce: None (whole trajectories), "final"
    (each case's final state, time and outputs -- where the run really ended, a terminal
    event's state included -- without holding any trajectory) or a picklable callable
    f(SimulationResult) -> value, applied on the worker to exactly what simulate() returns.
    consistent: simulate's, per case (None: a start off the model's constraints is completed
    on them; True: every start; False: as given).  Other
    keywords are simulate()'s (method, rtol, atol, t_eval, n_points, r, events, ...).

    Returns a BatchResult in case order (bit-identical to simulate_many for the same cases;
    with reduce="final" its x has one row, x[:, 0] = x_final), or a SweepValues for a
    callable reduce.  Both carry each case's x_final, t_final and event records.  A failed
    case raises SimulationError naming it unless raise_on_failure=False (its status is then
    nonzero).  A bad value raises CaseError naming its case (index in ``cases``).
    """
    if reduce is not None and not (isinstance(reduce, str) and reduce == "final") and not callable(reduce):
        raise ValueError(f"sweep: reduce must be None, 'final' or a callable; got {reduce!r}")
    if chunk_size is not None and (isinstance(chunk_size, bool) or not isinstance(chunk_size, numbers.Integral)
                                   or chunk_size < 1):
        raise ValueError(f"sweep: chunk_size must be a positive integer (or None for the default); "
                         f"got {chunk_size!r}")
    kind = _kind_of(map)
    n, X0, P, R = case_arrays(model, cases)
    if R is not None and "r" in simulate_kw:
        raise ValueError("sweep: inputs are given per case and as r=; give one or the other")
    # check the arguments here, once, rather than in every worker (the first case: its start too)
    first, _ = prepare_cases(model, X0[:1], t_span, p=None if P is None else P[:1], consistent=consistent,
                             total=n, keep_rows=False,
                             **({**simulate_kw, "r": R[:1]} if R is not None else simulate_kw))
    if reduce is None:
        check_batch_memory(n, first[0]["t_eval"].size, model.nx + model.noutput, "sweep",
                           "use reduce='final' or reduce=f (a callable run on the workers), which "
                           "bring home only what they keep, or ask for fewer rows (n_points=, t_eval=)")
    workers = _workers(map, kind)
    size = int(chunk_size) if chunk_size else _chunk_size(n, workers)
    if threads is None:
        threads = (os.cpu_count() or 1) if kind == "here" else 1
    simulate_kw = {**simulate_kw, "consistent": consistent}
    tasks = [{"start": lo, "total": n, "x0": X0[lo:lo + size], "p": None if P is None else P[lo:lo + size],
              "r": None if R is None else R[lo:lo + size], "t_span": tuple(t_span),
              "simulate": simulate_kw, "reduce": reduce, "threads": threads}
             for lo in range(0, n, size)]
    note = f"{n} cases in {len(tasks)} chunks of up to {size}"
    if kind == "dask" and "dashboard" in (map.scheduler_info().get("services") or {}):
        note += f"; Dask dashboard: {map.dashboard_link}"
    bar = _Progress(n, len(tasks), progress and len(tasks) > 1, note)
    done = {}
    try:
        for out in _dispatch(map, kind, model, tasks):
            done[out["start"]] = out
            bar.step(len(out["status"]))
    except BaseException as stop:
        _keep_chunks(stop, lambda: _assemble(model, tasks, done, reduce, first[0]["t_eval"], False))
        raise
    finally:
        bar.close()
    return _assemble(model, tasks, done, reduce, first[0]["t_eval"], raise_on_failure)


STOPPED = 9     # EOMC_ABORTED: a case whose chunk had not come back when the sweep was stopped
NOT_RUN = "not run: the sweep was stopped (Ctrl-C or SIGTERM) before this case's chunk came back"


def _keep_chunks(stop, make):
    """Ctrl-C (KeyboardInterrupt) or a SIGTERM handler's exception: every case as the sweep would
    return it in ``stop.partial_result``, the finished chunks' cases as they ended and the others
    status 9 (STOPPED), NaN, message NOT_RUN -- as ``rollout``'s partial_result.  Why: a stopped
    sweep of hours kept nothing (s29); the command line writes this, marked partial."""
    if isinstance(stop, Exception):
        return
    try:
        stop.partial_result = make()
    except BaseException:       # noqa: BLE001 -- the cases cannot be assembled: the stop goes on without them
        pass


def _not_run(model, task, reduce, t_rows):
    """A chunk that did not come back, in run_chunk's layout: status STOPPED, NaN, no stats."""
    m = len(task["x0"])
    rows = np.array([float(task["t_span"][1])]) if reduce == "final" else np.asarray(t_rows, dtype=float)
    out = {"start": task["start"], "status": np.full(m, STOPPED, dtype=int), "messages": [NOT_RUN] * m,
           "stats": [None] * m, "x_final": np.full((m, model.nx), np.nan), "t_final": np.full(m, np.nan),
           "t_events": None, "x_events": None, "event_stop": None}
    if callable(reduce) and not isinstance(reduce, str):
        out["values"] = [None] * m
    else:
        out.update(t=rows, x=np.full((m, rows.size, model.nx), np.nan),
                   outputs={k: np.full((m, rows.size), np.nan) for k in model.output_names})
    return out


def _assemble(model, tasks, done, reduce, t_eval, raise_on_failure):
    """The chunks in case order as sweep returns them (a chunk not in ``done``: _not_run)."""
    n = sum(len(task["x0"]) for task in tasks)
    t_rows = next((part["t"] for part in done.values() if "t" in part), t_eval)   # a finished chunk's
    parts = [done.get(task["start"]) or _not_run(model, task, reduce, t_rows) for task in tasks]
    status = np.concatenate([part["status"] for part in parts])
    messages = [m for part in parts for m in part["messages"]]
    stats = [s for part in parts for s in part["stats"]]
    if raise_on_failure and np.any(status):
        i = int(np.flatnonzero(status)[0])
        raise SimulationError(f"case {i} of {n}: {messages[i]}")
    finals = dict(x_final=np.concatenate([part["x_final"] for part in parts]),
                  t_final=np.concatenate([part["t_final"] for part in parts]))
    records = {key: [v for part in parts for v in (part[key] or [None] * len(part["status"]))]
               for key in ("t_events", "x_events", "event_stop")}
    if all(v is None for v in records["t_events"]):
        records = dict.fromkeys(records)
    if callable(reduce) and not isinstance(reduce, str):
        values = [v for part in parts for v in part["values"]]
        try:
            stacked = np.asarray(values)
            # numbers stack; a value holding a string or an object stays as f returned it
            # (np.asarray would turn (1.5, "fallen") into two strings)
            values = stacked if stacked.dtype.kind in "biufc" else values
        except ValueError:   # ragged
            pass
        return SweepValues(values=values, status=status, messages=messages, stats=stats, **finals,
                           event_stop=records["event_stop"])
    return BatchResult(t=parts[0]["t"], x=np.concatenate([part["x"] for part in parts]),
                       state_names=tuple(model.state_names), status=status, messages=messages,
                       stats=stats, outputs={k: np.concatenate([part["outputs"][k] for part in parts])
                                             for k in parts[0]["outputs"]}, **finals, **records)
