"""One call of a model's generated C function NAME_<f>(t, x, p, r, out, work) at one state, by name.

Why: the failure messages read a function the Model object has no method for (NAME_implicit, the
fixed step's terms) or read one raw, status and all (the rhs where it went non-finite): the
penetration message (simulate.deepest_contacts) and the non-finite one (nonfinite.py) both call
it this way; one place owns the buffers (the work array, the parameters with one slot more, as a
prepared run holds them)."""
import numpy as np

__all__ = ["call_generated"]


def call_generated(model, name, t, x, p, r, size):
    """(status, out[size]) of NAME_<name> at (t, x) with parameters ``p`` (the model's, or a
    prepared run's: its slots past nparam are not read) and inputs ``r``; None when the library
    has no such function.  ``out`` starts as NaN: a function that returns early leaves it so."""
    ffi = model.ffi
    try:
        fp = ffi.addressof(model.model_lib, f"{model.name}_{name}")
    except (AttributeError, KeyError, ffi.error):
        return None
    out = np.full(size, np.nan)
    work = np.zeros(max(model.work_size, 1) + 1)
    x = np.ascontiguousarray(x, dtype=np.float64)
    pp = np.ascontiguousarray(np.append(np.asarray(p, dtype=np.float64)[:model.nparam], 0.0))
    rr = np.ascontiguousarray(np.append(np.asarray(r, dtype=np.float64), 0.0))
    buf = lambda a: ffi.from_buffer("double[]", a)      # noqa: E731
    status = fp(float(t), buf(x), buf(pp), buf(rr) if model.ninput else ffi.NULL, buf(out), buf(work))
    return status, out
