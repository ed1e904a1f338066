"""One call of a compiled model's NAME_implicit (the implicitfast step's terms) at a state,
through cffi, as the runtime makes it: the tests of those terms read its output by the
metadata's layout."""
import numpy as np


def call_into(model, fn, x, out, p=None):
    """Status of the model's generated NAME_<fn> (NAME_implicit, _implicit_var, ...) at state
    ``x`` into the array ``out`` (t = 0; ``p`` or the default parameters; the default inputs)."""
    ffi = model.ffi
    fp = ffi.addressof(model.model_lib, f"{model.name}_{fn}")
    par = model._default_p if p is None else ffi.from_buffer("double[]", p)
    r = model._default_r if model.ninput else ffi.NULL
    return fp(0.0, ffi.from_buffer("double[]", np.ascontiguousarray(x, dtype=float)), par, r,
              ffi.from_buffer("double[]", out), ffi.NULL)


def implicit_terms_at(model, x):
    """(out, layout): NAME_implicit's output at state ``x`` (t = 0, the model's default
    parameters and inputs) and the metadata's layout of it; asserts status 0."""
    layout = model.metadata["implicit"]["layout"]
    out = np.zeros(layout["size"])
    assert call_into(model, "implicit", x, out) == 0
    return out, layout
