"""Record which of a model's checked-path kernels get called (to show no C ran)."""


def spy_kernels(model, monkeypatch):
    """Wrap ``model._kernels`` so each call appends its name; returns (model, calls)."""
    calls = []
    kernels = {k: (lambda *a, _k=k, _f=f: calls.append(_k) or _f(*a)) for k, f in model._kernels.items()}
    monkeypatch.setattr(model, "_kernels", kernels)
    return model, calls
