"""`eomc check`'s two references: run at once, compared as they go, stopped where they part.

Why: check measures each method against a reference (rtol 1000x tighter) whose trust is its
agreement with a second, looser one (100x tighter; runtime/stability.REF_TOLS).  Where the motion
amplifies small differences (a chaotic pendulum; a robot collapsing onto hundreds of contact
points) the two part, and from then on nothing can be judged against them: a method is judged
only where they agree.  Run one after the other to t_final they were most of a cold check: G1
falling onto its feet, 110 s and 106 s of 305 s, the two parting at t = 1.15 of 10 (s30), so
more than half of their steps judged nothing.

Here the two run on two threads (the C loops release the GIL), this thread compares the rows
both have written as they come, and once a row differs by more than AGREE x tolerance both runs
stop (eomc_options.stop: at their next model evaluation).  The rows each writes are the rows
the same run to t_final writes (the same steps; a stop only ends it), and the verdict is read
from the finished rows afterwards, never from what a poll happened to see: the first row where
they part is the same row however the threads were scheduled.  A run that stops by itself (out
of steps, stiff, a singular configuration) ends the other only once that one has written as
many rows, so whether they part before the stop is decided on the same rows every time.
"""
import threading
from dataclasses import dataclass

import numpy as np

from .progress import follow_integration, stage
from .simulate import _STAT_FIELDS, bind_call, checked_start, finish, prepare

__all__ = ["References", "run_references", "apart", "POLL_S"]

POLL_S = 0.05       # how often the rows written so far are compared (a poll reads a few rows)
ABORTED = 9         # EOMC_ABORTED: what a run stopped through eomc_options.stop ends with


def apart(loose, tight, rtol, atol):
    """Per row, the two references' largest difference in units of the checked tolerance
    (atol + rtol |tight|): what stability.AGREE bounds."""
    return np.max(np.abs(loose - tight) / (atol + rtol * np.abs(tight)), axis=1)


@dataclass
class References:
    """The two runs (SimulationResults; a run stopped here has status 9 and ``stopped`` True),
    their method, and ``rows``: how many output rows both wrote.  ``parted``: the first of those
    rows where they differ by more than the bound (None: nowhere); the runs were stopped there."""
    method: str
    loose: object
    tight: object
    rows: int
    parted: int = None

    @property
    def failed(self):
        """The run that stopped by itself before they parted (looser first), or None."""
        if self.parted is not None:
            return None
        for run in (self.loose, self.tight):
            if run.status and not run.stopped:
                return run
        return None


class BackgroundRun:
    """A prepared integration (simulate.prepare's ``a``) on a thread of its own -- the C loop
    releases the GIL -- its rows readable as they come, stoppable through eomc_options.stop (read
    at each model evaluation).  Shared by check's references (:class:`_Run`) and the report's
    own-code check (reference._CheckRun)."""

    def __init__(self, model, a, name):
        self.model, self.a = model, a
        self.flag = model.ffi.new("int *")
        self.a["stop"] = self.flag
        self.call, self.x_out, self.x_last, self.stats = bind_call(model, self.a)
        self.error = None
        self.thread = threading.Thread(target=self._go, daemon=True, name=name)

    def _go(self):
        try:
            self.call()
        except BaseException as exc:        # noqa: BLE001 -- raised again on the caller's thread
            self.error = exc

    def written(self):
        """Rows certainly written: all of them once the run ended, else those before the time it
        has reached (the integrators write a step's rows before they move stats.t past it)."""
        if not self.thread.is_alive():
            return int(self.stats.n_out)
        return int(np.searchsorted(self.a["t_eval"], self.stats.t, side="left"))


class _Run(BackgroundRun):
    """One reference on a thread of its own: its rows readable as they come, stoppable."""

    def __init__(self, model, x0, p, t_final, t_eval, method, rtol, atol, max_steps):
        if model.nhol + model.nvel:     # a constrained start completed as simulate completes it
            x0 = checked_start(model, x0, (0.0, t_final), p, None, atol, None)
        self.t_eval = t_eval
        super().__init__(model, prepare(model, x0, (0.0, t_final), p=p, method=method, rtol=rtol, atol=atol,
                                        t_eval=t_eval, max_steps=max_steps),
                         name=f"eomc-check-reference-{rtol:g}")

    def stop(self):
        self.flag[0] = 1

    def result(self):
        got = {f: getattr(self.stats, f) for f in _STAT_FIELDS}
        res = finish(self.model, self.a, self.x_out, got, self.x_last, raise_on_failure=False)
        res.stopped = bool(self.flag[0]) and got["status"] == ABORTED
        return res


def _watch(runs, rtol, atol, agree, on_parting):
    """Compare the rows both runs wrote as they come; stop both where they part (when
    ``on_parting``), and a run that goes on once the other stopped by itself and it has written
    as many rows."""
    loose, tight = runs
    seen = 0
    while True:
        alive = [r for r in runs if r.thread.is_alive()]
        n = min(r.written() for r in runs)
        if n > seen:
            if on_parting and np.any(apart(loose.x_out[seen:n], tight.x_out[seen:n], rtol, atol) > agree):
                for r in runs:
                    r.stop()
                return
            seen = n
        ended = [r for r in runs if not r.thread.is_alive() and r.stats.status not in (0, ABORTED)]
        for r in alive:
            if any(r.written() >= e.stats.n_out for e in ended):
                r.stop()
        if not alive:
            return
        alive[-1].thread.join(POLL_S)


def _both(model, x0, p, t_final, t_eval, method, tols, rtol, atol, max_steps, agree, on_parting):
    runs = [_Run(model, x0, p, t_final, t_eval, method, *tol, max_steps) for tol in tols]
    for r in runs:
        r.thread.start()
    tight = runs[1]
    try:
        with stage(f"references: {method} at rtol={tols[0][0]:g} and {tols[1][0]:g}, compared as they go"):
            follow_integration(lambda: (tight.stats.t, tight.stats.steps), 0.0, t_final,
                               lambda: _watch(runs, rtol, atol, agree, on_parting))
    finally:        # Ctrl-C, SIGTERM: the C loops stop by themselves too (runtime/native.py)
        for r in runs:
            if r.thread.is_alive():
                r.stop()
        for r in runs:
            r.thread.join()
    for r in runs:
        if r.error is not None:
            raise r.error
    loose, tight = (r.result() for r in runs)
    rows = min(len(loose.t), len(tight.t))
    beyond = np.flatnonzero(apart(loose.x[:rows], tight.x[:rows], rtol, atol) > agree)
    return References(method, loose, tight, rows, int(beyond[0]) if beyond.size else None)


def run_references(model, x0, p, t_final, t_eval, method, tols, rtol, atol, max_steps, agree,
                   implicit=True):
    """The two references (``method`` at tols[0], the looser, and tols[1]), run at once and
    stopped where their rows differ by more than ``agree`` x (atol + rtol |x|); a dop853 pair
    whose looser run stops as stiff (or out of steps) before they part is run again with radau
    where the model has jac_x (``implicit``)."""
    while True:
        refs = _both(model, x0, p, t_final, t_eval, method, tols, rtol, atol, max_steps, agree, True)
        if refs.parted is None and any(r.stopped for r in (refs.loose, refs.tight)) and refs.failed is None:
            # stopped, yet no row parts among the finished ones: a poll misread a row being
            # written (no known path does); the pair runs again to their ends, unstopped
            refs = _both(model, x0, p, t_final, t_eval, method, tols, rtol, atol, max_steps, agree, False)
        failed = refs.failed
        if failed is refs.loose and failed.status in (6, 7) and implicit and method != "radau":
            method = "radau"
            continue
        return refs

