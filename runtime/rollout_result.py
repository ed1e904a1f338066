"""What ``rollout`` returns, and the cffi handle of eomc_rollout.h it calls.

A module of its own so that rollout.py and rollout_extras.py (its feedback / events / contacts
path) both build results without importing each other."""
from dataclasses import dataclass

import numpy as np

from .header_cdef import header_cdef
from .native import extension_library

__all__ = ["ROLLOUT_CDEF", "RolloutResult"]

ROLLOUT_CDEF = header_cdef("eomc_rollout.h")


def _rollout_ffi(base):
    """(ffi, lib): eomc_rollout in an FFI that includes the model's base FFI (shared types)."""
    return extension_library(base, ROLLOUT_CDEF)


@dataclass
class RolloutResult:
    """What ``rollout`` returns.

    x: (n, nx) final states (record="final"), or (n, n_t, nx) with the state at every
    step (record="steps"; row 0 is x0).  t: the times of x's rows ((1,) = t_final for
    "final").  status: (n,) eomc_status per trajectory (0 = ok); steps: (n,) steps taken.
    A failed trajectory's final row holds its last good state.  unsolved: (n,) per
    trajectory, implicitfast's (sub-)steps taken with their implicit Euler equation not solved
    to tolerance even split into 64 (what ``simulate`` warns of; 0 for other methods): such a row ran to the end (status 0) but its result is worth checking with a
    smaller dt or an adaptive method.  event_stop: (n,) the terminal event that ended each row
    (None: ran to t_final); t_events: per row, {event name: times} as simulate's result.t_events
    (None when no events were recorded); messages: {row: why} for the rows that failed,
    simulate's words (a row judged by simulate's verdict: penetration, created energy -- on
    implicitfast's fast path the energy verdict only: status 20).  method: the method the rows ran
    (what method=None or "auto" picked; with "auto", a row DOP853 finds stiff goes on with Radau, as
    in simulate).
    """
    t: np.ndarray
    x: np.ndarray
    status: np.ndarray
    steps: np.ndarray
    state_names: tuple
    unsolved: np.ndarray = None
    event_stop: np.ndarray = None
    t_events: list = None
    messages: dict = None
    method: str = None

    def __post_init__(self):
        if self.unsolved is None:
            self.unsolved = np.zeros(len(self.status), dtype=int)
        if self.event_stop is None:
            self.event_stop = np.full(len(self.status), None, dtype=object)
        if self.messages is None:
            self.messages = {}

    @property
    def ok(self):
        """(n,) bool: which trajectories ran to the end."""
        return self.status == 0

    @property
    def clean(self):
        """(n,) bool: ran to the end with every step solved (ok and no unsolved steps)."""
        return (self.status == 0) & (self.unsolved == 0)
