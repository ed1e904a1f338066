"""Error against run time: a grid of methods x tolerances measured against a checked reference.

Why this module exists (issue 4 §5): a user choosing an integrator and a
tolerance needs to know what accuracy each choice buys and what it costs *on
their model*.  :func:`work_precision` runs every (method, tolerance) pair,
measures the error against a reference integrated much tighter (and checked
a second way, see :mod:`eomc.runtime.reference`), the wall time of the
integration, the step statistics, the drift of the model's "energy" output
and the constraint residual, and returns a :class:`WorkPrecisionReport` that
writes a CSV, a work-precision diagram and a Markdown recommendation.

Definitions used throughout:

* error -- :func:`eomc.runtime.reference.scaled_error`: at each of the
  ``n_points`` equally spaced output times, the RMS over states of the error
  divided by that state's largest magnitude along the reference trajectory;
  the reported error is the maximum over the output times.
* tolerance -- adaptive methods run with rtol = atol = tolerance.  RK4 is
  fixed-step: at each tolerance its step is dt = (t1 - t0) / N with N the
  number of steps DOPRI5 accepted at that tolerance (so RK4 is compared with
  the adaptive method of nearly the same order at the same number of steps;
  DOPRI5 is run once for this if it is not in the grid).
* wall time -- of the bare C call that integrates (argument checking,
  buffer allocation and output evaluation excluded): the median over
  ``repeats`` samples, each the mean of enough back-to-back calls to last
  >= 5 ms (at most 200 calls); the minimum sample is kept too (wall_time_min_s).
  A run whose first call took ONCE_S of CPU time or more is timed by that call alone
  (``samples`` 1): repeating it would multiply the report's time by ``repeats`` + 1 for a
  figure whose CPU time varies by a few per cent (G1's report with no flags: 41 min, s33).
* row budget -- each run is stopped once the thread running it has used ``row_budget``
  seconds of CPU time (eomc_options.stop; wall time where the platform has no thread CPU
  clock): the row is kept, marked cut (status 9, the message says after how long and at
  which t), never recommended, and the method's tighter tolerances, which take longer, are
  not run (their rows say so).  So are they once the method's runs so far have used
  SWEEP_BUDGETS row budgets together: a method's sweep costs at most (SWEEP_BUDGETS + 1) x
  ``row_budget`` of CPU time.  None: no budget.
* CPU time -- the same samples' thread CPU time (``time.thread_time``): what the
  integration cost this thread, which another process's load does not inflate
  the way it inflates wall time; the diagram's time axis (cpu_time_s).
* cost -- the work of a run in rhs-equivalents: nfev + w_jac * njev + w_lu * nlu,
  with w_jac = ops(jac_x) / ops(rhs) and w_lu = (5/3) nx^3 / ops(rhs) (one real
  or complex LU; Radau counts two per factorization) from the model's operation
  counts.  The recommendation ranks by cost, not wall time: counted work is
  the same on every run of the same command, timings on a busy machine are not.
* energy drift -- max_t |E(t) - E(0)| / |E(0)| for the output named
  "energy" (absolute when |E(0)| is below 1e-300).
* constraint residual -- max over output times of the largest |constraint|.
"""
import os
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np

from .reference import MIN_WINDOW, Reference, compute_reference, plan, scaled_error, tied_tolerances
from .report_output import (COLUMNS, CUT_STATUS, DEFAULT_TARGET, ONCE_S, SWEEP_BUDGETS, cost_key, cpu_ms,
                            is_cut, plot_report, recommendation, summary_markdown, table_text, write_csv)
from .diagnose import leaving_state
from .progress import bar, integration, stage, ticker
from .simulate import bind_call, finish, prepare, resolve_method, run_prepared

__all__ = ["work_precision", "WorkPrecisionReport", "DEFAULT_METHODS", "DEFAULT_TOLERANCES",
           "DEFAULT_TARGET", "COLUMNS"]

DEFAULT_METHODS = ("rk4", "dopri5", "dop853", "bdf", "radau")   # auto takes one of the last four
DEFAULT_TOLERANCES = tuple(10.0 ** -k for k in range(3, 11))
TINY = 1e-300
MIN_SAMPLE_S = 0.005     # one timing sample lasts at least this long ...
MAX_INNER = 200          # ... or this many integrations
ROW_BUDGET_S = 60.0      # default: a run is stopped after this much CPU time (see "row budget")
BUDGET_POLL_S = 0.05     # how often the budget's watcher reads the running thread's CPU clock


@dataclass
class WorkPrecisionReport:
    """One row (dict with COLUMNS) per (method, tolerance), plus the reference used."""
    model_name: str
    t_span: tuple
    n_points: int
    methods: tuple
    tolerances: tuple
    reference: Reference
    rows: list = field(default_factory=list)
    has_energy: bool = False
    has_constraints: bool = False
    skipped: dict = field(default_factory=dict)   # method -> why it could not run on this model
    cost_weights: tuple = (1.0, 1.0)              # (w_jac, w_lu): see "cost" in the module docstring
    cost_from_op_counts: bool = False
    # errors are measured on the output times [0, window) where the two computations of the
    # reference agree to window_level (AGREE x the target); None: on all of them
    window: int = None
    window_level: float = None
    inconclusive: str = None      # why no error could be judged (the references part at once)
    row_budget: float = None      # seconds of CPU time a run may take before it is cut (None: no limit)
    budget_clock: str = "CPU"     # what the budget counts: "CPU" (thread CPU time) or "wall"
    threads: int = 1              # methods run at once, each on a thread of its own

    def cut_rows(self):
        """The rows whose run was stopped at the row budget."""
        return [r for r in self.rows if is_cut(r)]

    def ok_rows(self):
        return [r for r in self.rows if r["status"] == 0 and np.isfinite(r["error"])]

    def recommend(self, target_error=None):
        """The cheapest successful row (by counted work, see "cost") whose error <= target, or None.

        Ties on cost go to the smaller error, then to the settings: the choice
        never depends on wall time, so it is the same on every run.
        """
        target = DEFAULT_TARGET if target_error is None else float(target_error)
        meeting = [r for r in self.ok_rows() if r["error"] <= target]
        return min(meeting, key=cost_key) if meeting else None

    def reference_energy_drift(self):
        return energy_drift(self.reference.outputs) if self.has_energy else None

    def table(self):
        """The rows as a fixed-width text table (what the CLI prints)."""
        return table_text(self)

    def to_csv(self, path):
        """Write one line per (method, tolerance) with COLUMNS as header; returns the path."""
        return write_csv(self, path)

    def plot(self, path, target_error=None):
        """Work-precision diagram (error vs wall time, log-log, one line per method) as PNG."""
        return plot_report(self, path, target_error)

    def recommendation_text(self, target_error=None):
        """One Markdown sentence: the recommended run for the target, or why there is none."""
        return recommendation(self, DEFAULT_TARGET if target_error is None else target_error)

    def summary_markdown(self, target_error=None):
        """Short Markdown: reference, recommendation for the target, energy, stiffness."""
        return summary_markdown(self, DEFAULT_TARGET if target_error is None else target_error)


def energy_drift(outputs):
    """max |E(t) - E(0)| / |E(0)| of outputs["energy"] (absolute if E(0) ~ 0); None if absent."""
    e = outputs.get("energy") if outputs else None
    if e is None or len(e) == 0:
        return None
    e = np.asarray(e, float)
    scale = abs(e[0]) if abs(e[0]) > TINY else 1.0
    return float(np.max(np.abs(e - e[0])) / scale)


def _c_call(model, a):
    """A zero-argument function making exactly the integrator's C call for prepared args `a`
    (buffers allocated once: timing it measures the integration in C, not simulate's allocations)."""
    return bind_call(model, a)[0]


def _timed(model, a, repeats):
    """(SimulationResult, (median, min) wall time, median thread CPU time per integration)
    over `repeats` samples.

    The result comes from simulate.run_prepared (the public path), run under the row's budget
    (``a["_budget"]``, a :class:`_Budget`, if any).  A run that took ONCE_S of CPU time or more is
    timed by that call alone (``res.samples`` 1).  Otherwise a timing sample repeats the bare C
    call (:func:`_c_call`) until it lasts MIN_SAMPLE_S (at most MAX_INNER calls) and divides by
    the count, so sub-millisecond runs are not dominated by timer resolution and Python.
    """
    budget = a.get("_budget")
    with budget if budget is not None else _NO_BUDGET:
        start, start_cpu = time.perf_counter(), time.thread_time()
        x_out, stats, x_last = run_prepared(model, a)
        first, first_cpu = time.perf_counter() - start, time.thread_time() - start_cpu
    res = finish(model, a, x_out, stats, x_last, raise_on_failure=False)
    res.samples, res.first_cpu = 1, first_cpu
    if res.status:
        return res, (first, first), first_cpu
    if budget is not None:
        budget.flag[0] = 0      # a run that ended as its budget ran out: the timing calls go on
    if first_cpu >= ONCE_S:
        return res, (first, first), first_cpu
    res.samples = max(1, int(repeats))
    call = _c_call(model, a)
    start = time.perf_counter()
    call()
    first = time.perf_counter() - start
    inner = int(min(MAX_INNER, max(1, np.ceil(MIN_SAMPLE_S / max(first, 1e-9)))))
    samples, cpu = [], []
    for _ in range(max(1, int(repeats))):
        start, start_cpu = time.perf_counter(), time.thread_time()
        for _ in range(inner):
            call()
        cpu.append((time.thread_time() - start_cpu) / inner)
        samples.append((time.perf_counter() - start) / inner)
    return res, (float(np.median(samples)), float(np.min(samples))), float(np.median(cpu))


def _row(method, tol, dt, a, res, wall, ref, cpu=float("nan"), window=None, cut=False):
    wall, wall_min = wall
    s = res.stats
    ok = res.status == 0
    # a cut run's rows up to where it was stopped are the same run's rows: its error is measured
    # if they cover the output times errors are measured on (the CSV has it; never recommended)
    covers = cut and window != 0 and res.x.shape[0] >= (ref.t.size if window is None else window)
    return dict(
        method=method, tolerance=tol, rtol=a["rtol"] if method != "rk4" else None,
        atol=a["atol"] if method != "rk4" else None, dt=dt, status=res.status,
        error=(scaled_error(res.x[:window], ref.x[:window], ref.scale) if (ok or covers) and window != 0
               else float("nan")),
        wall_time_s=wall if ok else float("nan"),
        wall_time_min_s=wall_min if ok else float("nan"), cpu_time_s=cpu if ok else float("nan"),
        samples=getattr(res, "samples", None) if ok else None,
        steps=s["steps"], accepted=s["accepted"],
        rejected=s["rejected"], nfev=s["nfev"], njev=s["njev"], nlu=s["nlu"],
        energy_drift=energy_drift(res.outputs) if ok else None,
        constraint_residual=(float(np.max(res.constraint_residual))
                             if ok and res.constraint_residual is not None else None),
        message=res.message)


def _failed_row(method, tol, dt, message):
    row = {c: None for c in COLUMNS}
    row.update(method=method, tolerance=tol, dt=dt, status=-1, error=float("nan"),
               wall_time_s=float("nan"), wall_time_min_s=float("nan"), cpu_time_s=float("nan"),
               message=message)
    return row


def _rk4_dt(t_span, dopri5_result):
    """RK4's step at a tolerance: the span over DOPRI5's accepted steps (None if it failed)."""
    if dopri5_result is None or dopri5_result.status != 0:
        return None
    return (t_span[1] - t_span[0]) / max(1, int(dopri5_result.stats["accepted"]))


def _thread_clock():
    """(clock, what): a function giving the calling thread's CPU time that another thread can
    read, and "CPU"; (time.monotonic, "wall") where the platform has no such clock."""
    try:
        clock_id = time.pthread_getcpuclockid(threading.get_ident())
        time.clock_gettime(clock_id)
    except (AttributeError, OSError):
        return time.monotonic, "wall"
    return (lambda: time.clock_gettime(clock_id)), "CPU"


class _Budget:
    """The row budget: stops the C run of the thread inside the ``with`` block (through
    eomc_options.stop, read at each model evaluation) once that thread has used ``seconds``."""

    def __init__(self, ffi, seconds, method=None):
        self.flag = ffi.new("int *")
        self.seconds, self.method = seconds, method
        self.cut = False
        self.kind = "CPU"

    def __enter__(self):
        clock, self.kind = _thread_clock()
        start = clock()
        self._done = threading.Event()

        def watch():
            while not self._done.wait(BUDGET_POLL_S):
                if clock() - start >= self.seconds:
                    self.cut = True
                    self.flag[0] = 1
                    return
        self._watcher = threading.Thread(target=watch, daemon=True, name="eomc-report-budget")
        self._watcher.start()
        return self

    def __exit__(self, *exc):
        self._done.set()
        self._watcher.join()
        return False


class _NoBudget:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


_NO_BUDGET = _NoBudget()


def _one(model, method, tol, dt, common, repeats, ref, window=None, budget=None, follow=False,
         stops=None):
    """Measure one (method, tolerance); failures become rows, not exceptions.  ``budget``:
    seconds of CPU time its run may take (None: no limit); ``follow``: progress lines while it
    runs (a log's, every 10 % of the span and 5 s); ``stops``: a set the run's stop flag is kept
    in while it runs (the grid stops them all on Ctrl-C)."""
    kw = dict(dt=dt) if method == "rk4" else dict(rtol=tol, atol=tol)
    try:
        a = prepare(model, max_steps=10 ** 7, stiff_check=True, **common, method=method, **kw)
    except ValueError as exc:                 # e.g. radau without a Jacobian
        return _failed_row(method, tol, dt, f"not run: {exc}"), None
    guard = _Budget(model.ffi, budget, method) if budget else None
    if guard is not None:
        a["stop"], a["_budget"] = guard.flag, guard
    if stops is not None and guard is not None:
        stops.add(guard)
    what = f"{method} {'dt=%.3g' % dt if method == 'rk4' else 'tol=%.0e' % tol}"
    try:
        with integration("eomc report", sys.stderr, follow), stage(what):
            res, wall, cpu = _timed(model, a, repeats)
    finally:
        if stops is not None:
            stops.discard(guard)
    cut = guard is not None and guard.cut and res.status == CUT_STATUS
    row = _row(method, tol, dt, a, res, wall, ref, cpu, window, cut=cut)
    if cut:
        t1 = common["t_span"][1]
        row["cut_at"] = float(res.stats["t"])
        row["message"] = (f"cut: stopped after {budget:g} s of {guard.kind} time (the report's row "
                          f"budget, --row-budget) at t = {res.stats['t']:.4g} of {t1:g}, "
                          f"{res.stats['steps']} steps")
    return row, res


def _progress(enabled, row, live):
    if not enabled:
        return
    live.update(1, f"{row['method']} {_setting_text(row)}")
    rk4 = row["method"] == "rk4" and row["dt"]
    what = f"dt={row['dt']:.3g}" if rk4 else f"tol={row['tolerance']:.0e}"
    if row["status"] == 0:
        # the table's figure, named: the wall time printed here read as a second, larger number for
        # the same run under load (first hour s27: a1's bdf at 1e-3, 32.2 ms here, 16.1 in the table)
        text = f"error {row['error']:.2e}  {cpu_ms(row):.3g} ms CPU  {row['steps']} steps"
    elif is_cut(row) or str(row["message"]).startswith("not run"):
        text = row["message"]
    else:
        text = f"failed: {row['message']}"
    line = f"eomc report: {row['method']:<7} {what:<12} {text}"
    if live.active:
        live.write(line)
    else:
        print(line, file=sys.stderr, flush=True)


def _setting_text(row):
    return f"dt={row['dt']:.3g}" if row["method"] == "rk4" and row["dt"] else f"tol={row['tolerance']:.0e}"


def work_precision(model, x0, t_span, p=None, r=None, methods=DEFAULT_METHODS,
                   tolerances=DEFAULT_TOLERANCES, repeats=3, reference=None, progress=True,
                   n_points=201, reference_tol=None, reference_check="auto", reference_method="auto",
                   project=False, target=DEFAULT_TARGET, row_budget=ROW_BUDGET_S, threads=None):
    """Run every method at every tolerance and measure error, time, drift and residual.

    The module docstring defines error, tolerance (and RK4's dt), wall time and
    drift.  ``reference``: a precomputed :class:`Reference` on the same output
    times, or None to compute one (``reference_method`` at ``reference_tol``,
    checked by ``reference_check``; see eomc.runtime.reference.compute_reference).
    ``reference_tol`` None (the default): tied to the finest tolerance of the grid
    (eomc.runtime.reference.tied_tolerances: rtol 1000x, atol 10x tighter), as `eomc check`
    ties its references; a number: rtol = atol = it.

    Errors are measured where the reference's two computations agree to AGREE x ``target``
    (a tenth of what the recommendation asks): on a motion that amplifies differences (a
    chaotic pendulum, a robot collapsing onto many contacts) later times measure the problem's
    conditioning, not a method -- ``report.window`` says until when.  If they part within
    MIN_WINDOW output times nothing can be judged: ``report.inconclusive`` says why.
    Failed runs (stiffness detected, step limits) are kept as rows with their
    status and message.  ``row_budget``: seconds of CPU time a run may take before it is cut
    (module docstring, "row budget"; None or 0: no limit).  ``threads``: methods run at once
    (None: one per core this process may use).  Bad arguments raise ValueError before anything
    runs.
    """
    methods = tuple(dict.fromkeys(resolve_method(m) for m in methods))
    tolerances = tuple(sorted({float(t) for t in tolerances}, reverse=True))
    if not methods or not tolerances or min(tolerances) <= 0:
        raise ValueError("work_precision needs at least one method and tolerances > 0")
    if row_budget is not None and not row_budget >= 0:
        raise ValueError(f"row_budget must be >= 0 seconds (0 or None: no limit); got {row_budget}")
    if threads is not None and int(threads) < 1:
        raise ValueError(f"threads must be >= 1; got {threads}")
    if int(n_points) < 2:
        raise ValueError(f"n_points must be >= 2 (output times the error is measured at); "
                         f"got {n_points}")
    t0, t1 = _check(model, x0, t_span, p, r)
    t_eval = np.linspace(t0, t1, int(n_points))
    common = dict(x0=x0, t_span=(t0, t1), p=p, r=r, t_eval=t_eval, project=project)
    if reference is None:
        rtol, atol = ((reference_tol, reference_tol) if reference_tol is not None
                      else tied_tolerances(min(tolerances)))
        if progress:
            print(f"eomc report: computing the reference ({plan(reference_method, rtol, atol)}; "
                  f"checked by {reference_check}) ...", file=sys.stderr, flush=True)
        # its runs say how far they got, as simulate's and check's do: in a log, a line per 10 % of
        # the span and 5 s (first hour s33: G1's reference, DOP853 then its Radau check, ran
        # minutes without a line); on a terminal, the ticker's live line
        with ticker("eomc report: reference", sys.stderr, progress) as live, \
                integration("eomc report", sys.stderr, progress, ticker=live), stage("reference"):
            # its check stops where the two part by more than the errors are measured to (report.window)
            reference = compute_reference(model, x0, (t0, t1), t_eval, p=p, r=r, tol=rtol, atol=atol,
                                          check=reference_check, project=project,
                                          method=reference_method, stop_level=AGREE * float(target),
                                          parallel=(int(threads) if threads else default_threads(2)) >= 2)
        if progress:   # what ran (auto resolves, Radau's rtol is clipped): as report.md records it
            print(f"eomc report: {reference.describe()}", file=sys.stderr, flush=True)
    if reference.x.shape != (t_eval.size, model.nx):
        raise ValueError(f"reference has shape {reference.x.shape}; expected "
                         f"({t_eval.size}, {model.nx}) on the report's output times")
    report = WorkPrecisionReport(model_name=model.name, t_span=(t0, t1), n_points=int(n_points),
                                 methods=methods, tolerances=tolerances, reference=reference,
                                 has_energy="energy" in model.output_names,
                                 has_constraints=(model.nhol + model.nvel) > 0)
    report.window_level = AGREE * float(target)
    report.window = reference.horizon(report.window_level)
    if report.window < min(MIN_WINDOW, t_eval.size):
        report.inconclusive = _parted(reference, report.window, report.window_level)
    elif not np.any(reference.x != reference.x[0]):
        # first hour s24: gymnasium's swimmer from rest (x = 0, an equilibrium) had every error 0
        # and recommended `method="rk4", dt=1.25`
        report.inconclusive = (f"nothing moved: the start is an equilibrium (every state of the reference "
                               f"stayed at its start value over [{t0:g}, {t1:g}]), so every run's error is 0 "
                               f"and no method can be told from another; give a start that moves "
                               f"(--x0 / x0=, e.g. {leaving_state(model, reference.x[0], p, t0)}=0.1)")
    report.skipped = _unrunnable(model, methods, common)
    report.row_budget = float(row_budget) if row_budget else None
    report.budget_clock = _thread_clock()[1]
    report.threads = int(threads) if threads else default_threads(len(methods))
    report.cost_weights, report.cost_from_op_counts = cost_weights(model)
    _run_grid(report, model, common, repeats, progress)
    for row in report.rows:
        row["cost"] = run_cost(row, report.cost_weights)
    return report


AGREE = 0.1     # the reference's two computations must agree to this fraction of the target


def _parted(ref, h, level):
    """Why no error can be judged: the reference's two computations part at once."""
    t = ref.t[min(max(h, 1), ref.t.size - 1)]
    return (f"the reference's two computations ({ref.method} and {ref.check_method}) differ by more "
            f"than {level:.1e} (a tenth of the target) from t = {ref.t[h]:.4g}, within the first "
            f"{MIN_WINDOW} output times: the motion amplifies their small differences (the "
            f"problem's conditioning), so no run's error can be measured; report a shorter span "
            f"(--t-final {t:.3g}) or a looser --target")


def cost_weights(model):
    """((w_jac, w_lu), from_op_counts): a Jacobian and an LU factorization in rhs-equivalents."""
    ops = (getattr(model, "metadata", None) or {}).get("op_counts") or {}
    rhs = sum((ops.get("rhs") or {}).values())
    jac = sum((ops.get("jac_x") or {}).values())
    n = model.nx
    if rhs > 0 and jac > 0:
        return (jac / rhs, (5.0 / 3.0) * n ** 3 / rhs), True
    rhs = float(max(n * n, 1))
    return (float(n), (5.0 / 3.0) * n ** 3 / rhs), False


def run_cost(row, weights):
    """A row's work in rhs-equivalents (None for a run that failed or did not run)."""
    if row["status"] != 0 or row.get("nfev") is None:
        return None
    w_jac, w_lu = weights
    return float(row["nfev"] + w_jac * (row["njev"] or 0) + w_lu * (row["nlu"] or 0))


def default_threads(n_methods):
    """Methods run at once by default: one per core this process may use, at most one per method."""
    try:
        cores = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cores = os.cpu_count() or 1
    return max(1, min(cores, n_methods))


def _run_grid(report, model, common, repeats, progress):
    """Fill report.rows: every runnable method at every tolerance, loosest first.

    Each method's sweep runs on a thread of its own, ``report.threads`` at once (the C calls
    release the GIL; CPU times are each thread's own, so a row's figure does not count another's
    work).  rk4 goes last: its dt at a tolerance is DOPRI5's step count there.  A run cut at the
    row budget ends its method's sweep: tighter tolerances take longer, and their rows say so."""
    runnable = sorted((m for m in report.methods if m not in report.skipped), key=lambda m: m == "rk4")
    live = bar(len(report.tolerances) * len(runnable), "eomc report", sys.stderr, progress)
    grid = _Grid(report, model, common, repeats, progress, live, runnable)
    threads = max(1, min(int(report.threads or 1), len(runnable) or 1))
    try:
        if threads == 1:
            for method in runnable:
                grid.sweep(method)
        else:
            pool = ThreadPoolExecutor(threads, thread_name_prefix="eomc-report")
            try:
                for job in [pool.submit(grid.sweep, m) for m in runnable]:
                    job.result()
            except BaseException:
                grid.stop_all()     # Ctrl-C, SIGTERM, an error: the other runs stop at once
                raise
            finally:
                pool.shutdown(wait=True, cancel_futures=True)
    finally:
        live.close()
    report.rows.sort(key=lambda r: (report.methods.index(r["method"]), -r["tolerance"]))


class _Grid:
    """The grid's shared state: the rows, DOPRI5's runs rk4 takes its dt from, the runs' stop
    flags, a lock for the rows and the progress lines."""

    def __init__(self, report, model, common, repeats, progress, live, runnable):
        self.report, self.model, self.common, self.repeats = report, model, common, repeats
        self.progress, self.live = progress, live
        self.lock = threading.Lock()
        self.stops = set()
        self.stopped = False
        self.dopri5 = {}
        self.dopri5_done = {tol: threading.Event() for tol in report.tolerances} \
            if "dopri5" in runnable else None

    def stop_all(self):
        self.stopped = True
        for guard in list(self.stops):
            guard.flag[0] = 1

    def _measure(self, method, tol, dt, repeats=None, window=None):
        report = self.report
        return _one(self.model, method, tol, dt, self.common,
                    self.repeats if repeats is None else repeats, report.reference,
                    window, budget=report.row_budget,
                    follow=self.progress and not self.live.active, stops=self.stops)

    def _dopri5_run(self, tol):
        """DOPRI5's run at ``tol`` for rk4's dt: the grid's own row, or a run of its own."""
        if self.dopri5_done is not None:
            self.dopri5_done[tol].wait()
            return self.dopri5.get(tol)
        if tol not in self.dopri5:
            _, self.dopri5[tol] = self._measure("dopri5", tol, None, repeats=1)
        return self.dopri5[tol]

    def sweep(self, method):
        try:
            self._sweep(method)
        finally:
            if method == "dopri5" and self.dopri5_done is not None:
                for done in self.dopri5_done.values():     # rk4 never waits for a row not run
                    done.set()

    def _sweep(self, method):
        report = self.report
        window = 0 if report.inconclusive else report.window
        cut, spent = None, 0.0
        budget = report.row_budget
        for tol in report.tolerances:
            res = None
            if self.stopped:
                return
            if cut is not None:
                row = _failed_row(method, tol, None, f"not run: {method} at {_setting_text(cut)} was "
                                  f"cut at the row budget, and tighter tolerances take longer")
            elif budget and spent >= SWEEP_BUDGETS * budget:
                row = _failed_row(method, tol, None, f"not run: {method}'s runs at looser tolerances took "
                                  f"{spent:.0f} s of CPU time together, {SWEEP_BUDGETS} x the row budget, "
                                  f"and tighter tolerances take longer")
            elif method == "rk4":
                dt = _rk4_dt(self.common["t_span"], self._dopri5_run(tol))
                if dt is None:
                    row = _failed_row(method, tol, None, "not run: DOPRI5 did not finish at this "
                                      "tolerance (failed, cut or not run), so there is no step "
                                      "count to match")
                else:
                    row, res = self._measure(method, tol, dt, window=window)
            else:
                row, res = self._measure(method, tol, None, window=window)
            if method == "dopri5":
                self.dopri5[tol] = res
                if self.dopri5_done is not None:
                    self.dopri5_done[tol].set()
            if is_cut(row):
                cut = row
            first = getattr(res, "first_cpu", None)
            spent += first if first is not None and np.isfinite(first) else 0.0
            with self.lock:
                report.rows.append(row)
                _progress(self.progress, row, self.live)


def _unrunnable(model, methods, common):
    """{method: reason} for methods this model cannot run at all (e.g. radau without jac_x)."""
    out = {}
    for method in methods:
        span = common["t_span"][1] - common["t_span"][0]
        try:
            prepare(model, **common, method=method, dt=span if method == "rk4" else None)
        except ValueError as exc:
            out[method] = str(exc)
    return out


def _check(model, x0, t_span, p, r):
    """Validate the arguments once (ValueError before any C runs); returns (t0, t1)."""
    a = prepare(model, x0, t_span, p=p, r=r, method="dop853", n_points=2)
    return a["t0"], a["t1"]

