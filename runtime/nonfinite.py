"""Name where a run that stopped on a non-finite value (status 3) went non-finite.

Why: the message said only "a non-finite value appeared" and the last finite state.  A user
then cannot tell a model that is singular or undefined there (a NaN in the rhs: a derivative, a
mass-matrix row, a contact's slopes) from a step that diverged from a state where the model is
fine (a step too long for a stiff law), and each wants another remedy.  So the failure message
evaluates the model's own functions at the last state and says which entries are not finite, by
name; where they all are finite, it says so, and for a fixed-step method it takes that step again
and says whether the failure repeats (a failure that does not is no property of the model; a CI
run of session 42 met one: tests/runtime/test_rollout_energy_watch.py, implicitfast at t = 0 from a
state whose every function is finite, not seen again in 30 000 runs of it here).
"""
import threading
import warnings

import numpy as np

from .generated_call import call_generated

__all__ = ["nonfinite_source"]

_INSIDE = threading.local()     # the step taken again must not explain its own failure again
_NAMED = 4                      # entries named per function; the rest counted
NONFINITE = 3                   # EOMC_NONFINITE: a generated function's own finiteness check


def _listed(names):
    shown = ", ".join(names[:_NAMED])
    return shown + (f" and {len(names) - _NAMED} more" if len(names) > _NAMED else "")


def _implicit_names(model, bad):
    """NAME_implicit's non-finite entries ``bad`` (indices) in the user's words: the mass matrix's
    rows, the forces' speeds, the contacts by name (their slopes), the joint laws' speeds."""
    info = model.metadata["implicit"]
    layout, nu = info["layout"], model.nu
    speeds = list(model.state_names)[model.nq:]
    contacts = [c.get("name") or f"#{k}" for k, c in enumerate(info["contacts"])]
    parts = {}
    for i in bad:
        if layout["M"] <= i < layout["M"] + nu * nu:
            parts.setdefault("the mass matrix's rows", []).append(speeds[(i - layout["M"]) // nu])
        elif layout["f"] <= i < layout["f"] + nu:
            parts.setdefault("the forces on", []).append(speeds[i - layout["f"]])
        elif layout["contact"] <= i < layout["contact"] + 25 * len(contacts):
            parts.setdefault("the contacts", []).append(contacts[(i - layout["contact"]) // 25])
        elif layout["joint"] <= i < layout["joint"] + 2 * nu:
            parts.setdefault("the joint laws' slopes of", []).append(speeds[(i - layout["joint"]) // 2])
        else:
            parts.setdefault("other terms", []).append(str(i))
    return "; ".join(f"{what} {_listed(list(dict.fromkeys(names)))}" for what, names in parts.items())


def _again(step):
    """'; ...' on taking the failed step again: ``step()`` -> (status, final state)."""
    _INSIDE.on = True
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            status, x1 = step()
    except Exception as err:       # noqa: BLE001 -- a courtesy: the failure is already reported
        return f"; taking that step again raised {type(err).__name__}"
    finally:
        _INSIDE.on = False
    if status == 0 and np.all(np.isfinite(x1)):
        return ("; that step, taken again from the same state, ended finite: the failure did not repeat "
                "(not a property of the model at this state; please report it with this message)")
    return "; that step, taken again from the same state, fails again (a step too long for the model here: a smaller dt)"


def nonfinite_source(model, method, t, x, p, r, step=None):
    """'; ...' naming what is not finite at the failed run's last state (t, x) with parameters
    ``p`` (the model's, or a prepared run's: one slot more) and inputs ``r``: the rhs's
    derivatives, NAME_implicit's entries (implicitfast), or that both are finite -- then, given
    ``step`` (a fixed-step method's step from (t, x) taken again: () -> (status, state)), whether
    it fails again.  '' when nothing can be said."""
    if getattr(_INSIDE, "on", False) or not np.all(np.isfinite(x)):
        return ""
    try:
        got = call_generated(model, "rhs", t, x, p, r, model.nx)
        if got is not None and got[0] not in (0, NONFINITE):
            return ""       # another failure there (a singular mass matrix): its own status says it
        if got is not None and not np.all(np.isfinite(got[1])):
            names = [f"{n}'" for n, v in zip(model.state_names, got[1]) if not np.isfinite(v)]
            return f"; at that state the rhs is not finite: {_listed(names)}"
        info = model.metadata.get("implicit")
        if method == "implicitfast" and info and "implicit" in getattr(model, "functions", ()):
            got = call_generated(model, "implicit", t, x, p, r, info["layout"]["size"])
            if got is not None and got[0] not in (0, NONFINITE):
                return ""
            if got is not None and not np.all(np.isfinite(got[1])):
                return (f"; at that state the implicit step's terms (NAME_implicit) are not finite: "
                        f"{_implicit_names(model, np.flatnonzero(~np.isfinite(got[1])))}")
    except Exception:       # noqa: BLE001 -- naming is a courtesy; the failure is already reported
        return ""
    said = "; the model's functions are finite at that state: the value went non-finite inside the step from it"
    if step is not None:
        said += _again(step)
    return said
