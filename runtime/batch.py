"""simulate_many: many initial states or parameter sets in one call, on threads.

Why threads work here: each case is one foreign call into the C integrator,
and cffi releases the GIL for the whole call, so cases run truly in parallel.
Every case gets its own work buffer (the C code is reentrant) and writes
straight into its slice of one preallocated (n_cases, n_t, nx) array.
"""
import os
import sys
import threading
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import dataclass, field

import numpy as np

from eomc.runtime.errors import SimulationError

from .simulate import check_keywords, finish, prepare, run_prepared

__all__ = ["simulate_many", "BatchResult"]


@dataclass
class BatchResult:
    """t (n_t,), x (n_cases, n_t, nx); rows after a failed case's stop are NaN."""
    t: np.ndarray
    x: np.ndarray
    state_names: tuple
    status: np.ndarray
    messages: list
    stats: list
    outputs: dict = field(default_factory=dict)   # name -> (n_cases, n_t)

    @property
    def success(self):
        return bool(np.all(self.status == 0))

    def __getitem__(self, name):
        if name in self.state_names:
            return self.x[:, :, self.state_names.index(name)]
        return self.outputs[name]


def _cases(value, size, what):
    """A list of n per-case values from one value, an (n, size) array or a list of dicts."""
    if value is None or isinstance(value, dict):
        return None
    if isinstance(value, (list, tuple)) and value and isinstance(value[0], dict):
        return list(value)
    a = np.asarray(value, dtype=float)
    if a.ndim == 1:
        return None
    if a.ndim != 2 or a.shape[1] != size:
        raise ValueError(f"{what} must have shape ({size},) for all cases or (n_cases, {size}); "
                         f"got {a.shape}")
    return list(a)


class _Progress:
    """tqdm when installed, else a counter on stderr every ~5 %."""

    def __init__(self, total, enabled):
        self.total, self.done, self.bar, self.lock = total, 0, None, threading.Lock()
        self.enabled = enabled and total > 1
        if self.enabled:
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
                print(f"\rsimulate: {self.done}/{self.total} cases", end="", file=sys.stderr,
                      flush=True)

    def close(self):
        if self.bar is not None:
            self.bar.close()
        elif self.enabled:
            print(file=sys.stderr)


def _prepare_case(model, i, n, x0, t_span, p, kw):
    """prepare() for case i; a bad value's ValueError says which case (like a failed run does).

    Errors about the model itself (a ModelError, e.g. built without rhs) concern every case and
    pass through unchanged."""
    try:
        return prepare(model, x0, t_span, p=p, **kw)
    except ValueError as exc:
        if n == 1 or type(exc) is not ValueError:
            raise
        raise ValueError(f"case {i} of {n}: {exc}") from None


def _input_cases(r, ninput):
    """Per-case constant inputs (an (n, ninput) array or a list of dicts), else None: r is shared.

    Only these two forms: a 1-d array, a dict, an (t_grid, values) tuple or a
    callable is one r for every case, as before.
    """
    if (isinstance(r, np.ndarray) and r.ndim == 2) or (isinstance(r, list) and r and isinstance(r[0], dict)):
        return _cases(r, ninput, "r")
    return None


def simulate_many(model, x0, t_span, p=None, threads=None, progress=True,
                  raise_on_failure=True, **kw):
    """Integrate every case; x0 (nx,) or (n, nx), p None, (nparam,) or (n, nparam).

    r (constant inputs) may also be per case: an (n, ninput) array or a list of dicts.

    All cases share t_span and the output times (t_eval / n_points / dt); other
    keywords are simulate()'s.  threads=None uses every CPU.  Returns a
    BatchResult; a failed case raises SimulationError naming the case unless
    raise_on_failure=False (then its status is nonzero and its tail is NaN).
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
    preps = [_prepare_case(model, i, n, xs[i] if xs is not None else x0, t_span,
                           ps[i] if ps is not None else p,
                           kw if rs is None else {**kw, "r": rs[i]}) for i in range(n)]
    t = preps[0]["t_eval"]
    x = np.full((n, t.size, model.nx), np.nan)
    raw = [None] * n
    bar = _Progress(n, progress)

    def one(i):
        raw[i] = run_prepared(model, preps[i], out=x[i])
        bar.step()

    workers = max(1, min(int(threads or os.cpu_count() or 1), n))
    try:
        with ThreadPoolExecutor(max_workers=workers) as pool:
            for fut in as_completed([pool.submit(one, i) for i in range(n)]):
                fut.result()
    finally:
        bar.close()
    results = [finish(model, preps[i], raw[i][0], raw[i][1], raw[i][2], raise_on_failure=False)
               for i in range(n)]
    status = np.array([r.status for r in results])
    if raise_on_failure and np.any(status):
        i = int(np.flatnonzero(status)[0])
        raise SimulationError(f"case {i} of {n}: {results[i].message}")
    outputs = {}
    for name in model.output_names:
        outputs[name] = np.full((n, t.size), np.nan)
        for i, r in enumerate(results):
            if name in r.outputs:
                outputs[name][i, :len(r.t)] = r.outputs[name]
    return BatchResult(t=t, x=x, state_names=tuple(model.state_names), status=status,
                       messages=[r.message for r in results], stats=[r.stats for r in results],
                       outputs=outputs)
