"""Where a run starts when the caller names no state: one rule for simulate, consistent_state and
check_stability (and the command line without --x0), in a module of its own so each can import it
without importing the others."""
import warnings

import numpy as np

from eomc.runtime.errors import EomcWarning


def start_or_default(model, x0):
    """x0, or the model's initial_state for x0=None; rest (x = 0) with a warning when it has none.

    As the command line does without --x0 (first hour s26: ``model.simulate(None, ...)``
    raised where ``eomc simulate`` started from rest with a note)."""
    if x0 is not None:
        return x0
    if getattr(model, "initial_state", None) is None:
        warnings.warn(f"{model.name} has no initial_state and no x0 was given: starting from rest "
                      f"at x = 0 (give x0: an array of {model.nx} or a dict by state name)",
                      EomcWarning, stacklevel=3)
        return np.zeros(model.nx)
    return np.array(model.initial_state, dtype=np.float64)
