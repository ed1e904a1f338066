"""One call of a compiled model's NAME_implicit (the implicitfast step's terms) at a state,
through cffi, as the runtime makes it: the tests of those terms read its output by the
metadata's layout."""
import numpy as np


def implicit_terms_at(model, x):
    """(out, layout): NAME_implicit's output at state ``x`` (t = 0, the model's default
    parameters and inputs) and the metadata's layout of it; asserts status 0."""
    layout = model.metadata["implicit"]["layout"]
    out = np.zeros(layout["size"])
    ffi = model.ffi
    fp = ffi.addressof(model.model_lib, f"{model.name}_implicit")
    r = model._default_r if model.ninput else ffi.NULL
    status = fp(0.0, ffi.from_buffer("double[]", x), model._default_p, r, ffi.from_buffer("double[]", out), ffi.NULL)
    assert status == 0
    return out, layout
