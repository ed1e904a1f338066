"""Parameter vectors for a built model's runs: defaults with some values replaced."""
import numpy as np


def params_with(model, **values):
    """The model's default parameters with ``values`` (by parameter name) in place."""
    p = np.array(model.param_defaults)
    for name, v in values.items():
        p[model.param_names.index(name)] = v
    return p


def undamped(model, pair_k=None):
    """Defaults with every contact's damping c_* and friction mu_* at 0, and (``pair_k``) each
    body-body pair's stiffness (k_<a>__<b>) set: the contacts then store energy and dissipate none."""
    p = np.array(model.param_defaults)
    for i, n in enumerate(model.param_names):
        if n.startswith(("c_", "mu_")):
            p[i] = 0.0
        if pair_k is not None and n.startswith("k_") and "__" in n:
            p[i] = pair_k
    return p
