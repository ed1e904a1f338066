"""Model._batch (runtime/model.py) when the batch C does not evaluate the states: a refusal
(EOMC_BAD_ARGUMENT, no status written) is an error naming the function and the argument, never
a row blamed on an uninitialised status."""
from pathlib import Path

import numpy as np
import pytest

import eomc
from eomc.errors import ModelError

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    return eomc.compile(str(EXAMPLES / "double_pendulum.py"), "dpbatch",
                        functions=["rhs", "rhs_batch", "jac_x", "jac_x_batch"],
                        cache_dir=tmp_path_factory.mktemp("cache"), progress=False)


def _garbage_status(monkeypatch):
    """np.empty's int arrays filled with a nonzero pattern, as reused memory may be: a reader of
    statuses the C never wrote then sees a failed row (as seen in session 22)."""
    empty = np.empty

    def filled(shape, dtype=float, *args, **kwargs):
        a = empty(shape, dtype, *args, **kwargs)
        if np.dtype(dtype) == np.intc:
            a.fill(1)
        return a
    monkeypatch.setattr(np, "empty", filled)


@pytest.mark.parametrize("fn", ["rhs_batch", "jac_x_batch"])
def test_a_refused_call_names_the_function_and_the_argument(model, fn, monkeypatch):
    X = np.random.default_rng(3).normal(size=(5, model.nx))
    getattr(model, fn)(0.0, X)              # the call itself works
    # p NULL for a model with parameters: the C returns EOMC_BAD_ARGUMENT before any state
    monkeypatch.setattr(model, "_params", lambda p: model.ffi.NULL)
    _garbage_status(monkeypatch)
    with pytest.raises(ValueError) as info:
        getattr(model, fn)(0.0, X)
    assert str(info.value) == (
        f"dpbatch.{fn} refused its arguments (bad argument) and evaluated none of the 5 states: "
        f"p (parameters) was NULL, and the model has 5 parameters [m1, m2, l1, l2, g]; pass p=None "
        f"for the defaults or an array of shape (5,)")


def test_a_failure_without_a_failed_row_is_not_blamed_on_a_row(model, monkeypatch):
    kernel = model._kernels["rhs_batch"]

    def no_row(n, t, X, p, R, XD, status, work):
        kernel(n, t, X, p, R, XD, status, work)
        return 3                                   # EOMC_NONFINITE, yet every row's status is 0
    monkeypatch.setitem(model._kernels, "rhs_batch", no_row)
    with pytest.raises(ModelError, match=r"^model 'dpbatch': rhs_batch returned status 3 \(a non-finite value "
                                         r"appeared\) but marked no row of X as failed \(eomc bug"):
        model.rhs_batch(0.0, np.zeros((4, model.nx)))
