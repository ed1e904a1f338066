"""Where a run starts when the caller names no state: one rule for simulate, consistent_state and
check_stability (and the command line without --x0), in a module of its own so each can import it
without importing the others."""
import warnings

import numpy as np

from eomc.runtime.errors import EomcWarning


def start_or_default(model, x0):
    """x0, or the model's initial_state for x0=None; rest (x = 0) with a warning when it has none.

    As the command line does without --x0 (first hour s26: ``model.simulate(None, ...)``
    raised where ``eomc simulate`` started from rest with a note).  The default start of a
    floating robot with its contacts under the ground is lifted onto it, with a warning, by the
    command line's rule (runtime/ground_start.py; first hour s27: A1 compiled with
    floating_base=True and contacts=["@ground"] started with its legs 0.34 m in the floor and was
    thrown out).  A given x0 is never changed."""
    if x0 is not None:
        return x0
    if getattr(model, "initial_state", None) is None:
        warnings.warn(f"{model.name} has no initial_state and no x0 was given: starting from rest "
                      f"at x = 0 (give x0: an array of {model.nx} or a dict by state name)",
                      EomcWarning, stacklevel=3)
        start = np.zeros(model.nx)
    else:
        start = np.array(model.initial_state, dtype=np.float64)
    return _onto_ground(model, start)


def _onto_ground(model, start):
    """``start`` lifted onto the ground (runtime/ground_start.py), warning what was lifted and by
    how much, or that a welded robot cannot be lifted."""
    from .ground_start import GROUND_CLEARANCE, onto_ground
    c_model = getattr(model, "c_model", None)
    if c_model is None or c_model.outputs == model.ffi.NULL:
        return start        # built without outputs: no depths to read
    lifted, found = onto_ground(model, dict(zip(model.state_names, (float(v) for v in start))))
    if found is None:
        return start
    if found.kind == "welded":
        warnings.warn(f"{model.name}'s default start puts its contacts up to {found.deepest:.4g} m under the "
                      f"ground, and its root link is welded to the world (a fixed base), so eomc cannot lift "
                      f"it onto the ground: give x0 with the links posed above the ground, or compile with "
                      f"floating_base=True (--floating-base) for a robot that stands on the ground",
                      EomcWarning, stacklevel=4)
        return start
    before = start[model.state_names.index(found.state)]
    warnings.warn(f"{model.name}'s default start put its contacts up to {found.deepest:.4g} m under the "
                  f"ground: lifted {found.state} from {before:.6g} to {found.value:.6g} (by "
                  f"{found.value - before:.4g} m), the deepest contact {GROUND_CLEARANCE * 1e3:g} mm above "
                  f"the ground (give x0 to choose the start)", EomcWarning, stacklevel=4)
    return np.array([lifted[n] for n in model.state_names], dtype=np.float64)
