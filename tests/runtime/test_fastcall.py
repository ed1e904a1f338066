"""eomc.runtime._fastcall: the cffi backend's compiled per-call path, against the checked path.

The fast path and the checked Python path (the ``Model`` class's own methods)
call the same C function, so on every call the fast path takes their results
must be bit-identical; every call it does not take (other types, shapes,
layouts, a nonzero status) must behave exactly like the checked path -- same
values or the same error.  A closed form (tests/helpers/model_files.cart_rhs) is the
independent oracle for the values themselves.
"""
import gc
import threading

import numpy as np
import pytest

from helpers import model_files
from helpers import zoo
from helpers.spies import spy_kernels
import eomc
import eomc.mechanics as em
from eomc.errors import ModelError, SimulationError
from eomc.runtime import model as model_module
from eomc.runtime._fastcall import FastCalls  # noqa: E402  (built by setup.py; its absence is a failure)
from eomc.runtime.loader import load

RNG = np.random.default_rng(11)
METHODS = ("rhs", "jacobian", "mass_matrix", "forcing")


@pytest.fixture(scope="module")
def cart(tmp_path_factory):
    """The cart-pendulum model file (one input F), built with the default (cffi) backend."""
    path = model_files.write(tmp_path_factory.mktemp("src"), model_files.CART, "cart")
    return eomc.compile(str(path), cache_dir=str(tmp_path_factory.mktemp("cache")))


@pytest.fixture(scope="module")
def chain(tmp_path_factory):
    """PyDy's 3-link pendulum on a cart, formed by eomc.mechanics."""
    kane, _ = zoo.n_link_pendulum_on_cart(3, em)
    return eomc.compile(kane, name="chain3", cache_dir=str(tmp_path_factory.mktemp("cache")))


def checked(model, fn):
    """The validating Python method the fast path falls back to."""
    return getattr(type(model), fn).__get__(model)


def test_cffi_models_use_fastcalls(cart, chain):
    for model in (cart, chain):
        assert model.backend == "cffi"
        for fn in METHODS:
            assert isinstance(getattr(model, fn).__self__, FastCalls), fn


def test_values_match_closed_form(cart):
    for _ in range(20):
        x, F = RNG.uniform(-2, 2, size=4), RNG.normal()
        np.testing.assert_allclose(cart.rhs(0.0, x, r=np.array([F])), model_files.cart_rhs(x, F),
                                   rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("which", ["cart", "chain"])
def test_bit_identical_to_checked_path_with_overrides(which, request):
    model = request.getfixturevalue(which)
    for _ in range(25):
        t, x = RNG.uniform(0, 10), RNG.uniform(-1.5, 1.5, size=model.nx)
        p = model.param_defaults * RNG.uniform(0.5, 1.5, size=model.nparam)
        r = RNG.normal(size=model.ninput)
        for fn in METHODS:
            fast, slow = getattr(model, fn), checked(model, fn)
            for args in [(t, x), (t, x, p), (t, x, None, r), (t, x, p, r), (int(t), x, p, r),
                         (np.float64(t), x, p, r)]:
                got, want = fast(*args), slow(*args)
                assert got.dtype == np.float64 and got.shape == want.shape and got.flags.c_contiguous
                np.testing.assert_array_equal(got, want, err_msg=f"{fn}{args}")


def test_overrides_change_the_result(cart):
    x = np.array([0.1, 0.4, -0.3, 0.7])
    base = cart.rhs(0.0, x)
    np.testing.assert_allclose(cart.rhs(0.0, x, r=np.array([2.0])), model_files.cart_rhs(x, 2.0), rtol=1e-12)
    p = cart.param_defaults.copy()
    p[cart.param_names.index("g")] = 3.0
    np.testing.assert_allclose(cart.rhs(0.0, x, p), model_files.cart_rhs(x, 0.0, g=3.0), rtol=1e-12)
    np.testing.assert_array_equal(cart.rhs(0.0, x), base)  # the defaults were not touched
    assert not cart.param_defaults.flags.writeable


def test_layouts_the_fast_path_declines_give_the_same_values(cart):
    x = np.array([0.1, 0.4, -0.3, 0.7])
    want = checked(cart, "rhs")(0.0, x, None, np.array([0.5]))
    strided = np.zeros(8)
    strided[::2] = x
    swapped = x.astype(">f8")
    raw = np.zeros(4 * 8 + 1, dtype=np.uint8)
    unaligned = raw[1:].view(np.float64)
    unaligned[:] = x
    assert not unaligned.flags.aligned and not strided[::2].flags.c_contiguous
    for xv in (strided[::2], swapped, unaligned, x.tolist(), tuple(x), x.astype(np.int64) * 0 + x):
        np.testing.assert_array_equal(cart.rhs(0.0, xv, None, np.array([0.5])), want)
    for r in ([0.5], (0.5,), {"F": 0.5}, np.array([0.5], dtype=">f8"), np.array([[0.5]])[:, 0]):
        np.testing.assert_array_equal(cart.rhs(0.0, x, None, r), want)
    np.testing.assert_array_equal(cart.rhs(0.0, x, cart.param_defaults.tolist(), [0.5]), want)


@pytest.fixture
def spied(cart, monkeypatch):
    """cart with its checked path's kernels recorded (the fast path never uses them)."""
    return spy_kernels(cart, monkeypatch)


@pytest.mark.parametrize("call, needle", [
    (lambda m: m.rhs(0.0, np.zeros(5)), r"x \(state\) must have shape \(4,\) \[x, th, v, w\]; got shape \(5,\)"),
    (lambda m: m.rhs(0.0, np.zeros((1, 4))), r"x \(state\) must have shape \(4,\)"),
    (lambda m: m.rhs(0.0, np.zeros(4, dtype=complex)), r"x \(state\) must hold real numbers"),
    (lambda m: m.rhs(0.0, np.zeros(4, dtype=bool)), r"x \(state\) must hold real numbers"),
    (lambda m: m.rhs(True, np.zeros(4)), r"t must be a real scalar"),
    (lambda m: m.rhs(np.zeros(1), np.zeros(4)), r"t must be a real scalar"),
    (lambda m: m.rhs(10 ** 400, np.zeros(4)), r"."),  # too big for a double: the checked path's error
    (lambda m: m.rhs(0.0, np.zeros(4), np.zeros(3)), r"p \(parameters\) must have shape \(4,\) \[M, m, l, g\]"),
    (lambda m: m.rhs(0.0, np.zeros(4), None, np.zeros(2)), r"r \(inputs\) must have shape \(1,\) \[F\]"),
    (lambda m: m.jacobian(0.0, np.zeros(3)), r"x \(state\) must have shape \(4,\)"),
    (lambda m: m.mass_matrix(0.0, np.zeros(4), np.zeros(5)), r"p \(parameters\) must have shape"),
    (lambda m: m.forcing(0.0, np.zeros(4), None, np.zeros(0)), r"r \(inputs\) must have shape \(1,\)"),
])
def test_bad_arguments_raise_valueerror_before_c_runs(spied, call, needle):
    model, calls = spied
    with pytest.raises((ValueError, OverflowError), match=needle):
        call(model)
    assert calls == []


def test_singular_status_raises_the_checked_paths_error(cart):
    x, p = np.array([0.3, 0.2, 0.0, 0.0]), np.zeros(4)  # M = m = 0: singular mass matrix
    with pytest.raises(SimulationError) as slow:
        checked(cart, "rhs")(1.5, x, p, None)
    with pytest.raises(SimulationError) as fast:
        cart.rhs(1.5, x, p)
    assert str(fast.value) == str(slow.value)
    assert "cart.rhs: the mass matrix is singular at t=1.5, state x=0.3, th=0.2" in str(fast.value)


class _Declined(Exception):
    """Raised by a stand-in checked method: the fast path handed the call over."""


def _fastcalls_for(model, **kw):
    def fallback(*args):
        raise _Declined(args)
    address = int(model.ffi.cast("uintptr_t", model.c_model))
    return FastCalls(address, model.param_defaults, model._zero_inputs, dict.fromkeys(METHODS, fallback), **kw)


def test_fast_path_takes_exactly_the_common_call(cart):
    fast, x, r = _fastcalls_for(cart), np.zeros(4), np.zeros(1)
    for args in [(0.0, x), (0, x), (np.float64(0.5), x), (0.0, x, cart.param_defaults.copy(), r)]:
        np.testing.assert_array_equal(fast.rhs(*args), checked(cart, "rhs")(*args))
    declined = [(np.float32(0), x), ("0", x), (0.0, list(x)), (0.0, x.astype(np.float32)), (0.0, np.zeros(8)[::2]),
                (0.0, x.astype(">f8")), (0.0, np.zeros(5)), (0.0, x, [1.0, 1.0, 1.0, 1.0]), (0.0, x, None, [0.0]),
                (0.0, x, None, np.zeros(0)), (10 ** 400, x)]
    for args in declined:
        for fn in METHODS:
            with pytest.raises(_Declined):
                getattr(fast, fn)(*args)
    with pytest.raises(_Declined):  # a nonzero status (singular M) is handed over too
        fast.rhs(0.0, x, np.zeros(4))


def test_constructor_checks_its_arguments(cart):
    address = int(cart.ffi.cast("uintptr_t", cart.c_model))
    checked_all = {fn: checked(cart, fn) for fn in METHODS}
    with pytest.raises(ValueError, match="NULL"):
        FastCalls(0, cart.param_defaults, cart._zero_inputs, checked_all)
    with pytest.raises(ValueError, match=r"p_default .* shape \(4,\)"):
        FastCalls(address, np.zeros(3), cart._zero_inputs, checked_all)
    with pytest.raises(ValueError, match=r"r_zero .* shape \(1,\)"):
        FastCalls(address, cart.param_defaults, np.zeros(1, dtype=np.float32), checked_all)
    with pytest.raises(ValueError, match="unknown methods"):
        FastCalls(address, cart.param_defaults, cart._zero_inputs, checked_all, nogil=["outputs"])
    assert FastCalls(address, cart.param_defaults, cart._zero_inputs, checked_all, nogil=["rhs"]).nogil == ("rhs",)


def test_gil_released_only_for_big_functions(cart):
    assert cart.rhs.__self__.nogil == ()  # a few dozen operations: holding the GIL is cheaper


def test_function_not_built_is_named(tmp_path):
    path = model_files.write(tmp_path, model_files.CART, "cart")
    model = eomc.compile(str(path), functions=["rhs"], cache_dir=str(tmp_path / "cache"))
    assert model.rhs(0.0, np.zeros(4)).shape == (4,)
    with pytest.raises(ModelError, match="built without `mass_matrix`"):
        model.mass_matrix(0.0, np.zeros(4))
    with pytest.raises(ModelError, match="built without `jac_x`"):
        model.jacobian(0.0, np.zeros(4))


def test_bound_rhs_keeps_the_library_alive(cart, tmp_path):
    model = load(cart.directory)
    rhs, x = model.rhs, np.array([0.1, 0.2, 0.3, 0.4])
    want = rhs(0.0, x)
    del model
    gc.collect()
    np.testing.assert_array_equal(rhs(0.0, x), want)


def test_threads_get_the_same_results(chain):
    X = RNG.uniform(-1, 1, size=(64, chain.nx))
    want = np.array([checked(chain, "rhs")(0.0, x, None, None) for x in X])
    got = [None] * 4

    def work(k):
        got[k] = np.array([chain.rhs(0.0, x) for _ in range(20) for x in X][-len(X):])
    threads = [threading.Thread(target=work, args=(k,)) for k in range(4)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    for g in got:
        np.testing.assert_array_equal(g, want)


def test_without_the_extension_the_cffi_fast_path_is_used(cart, monkeypatch):
    monkeypatch.setattr(model_module, "_FastCalls", None)
    model = load(cart.directory)
    assert not hasattr(model.rhs, "__self__")  # the cffi closure, not FastCalls
    assert model.jacobian.__func__ is type(model).jacobian
    x, r = np.array([0.1, -0.4, 0.3, 0.2]), np.array([0.7])
    np.testing.assert_array_equal(model.rhs(0.0, x, None, r), cart.rhs(0.0, x, None, r))
    with pytest.raises(ValueError, match=r"x \(state\) must have shape"):
        model.rhs(0.0, np.zeros(3))


def test_model_without_inputs(tmp_path):
    path = model_files.write(tmp_path, model_files.PENDULUM, "pend")
    model = eomc.compile(str(path), cache_dir=str(tmp_path / "cache"))
    assert model.ninput == 0 and isinstance(model.rhs.__self__, FastCalls)
    x = np.array([0.3, -0.1])
    want = model_files.pendulum_rhs(x)
    np.testing.assert_allclose(model.rhs(0.0, x), want, rtol=1e-14)
    for r in (None, np.empty(0), []):  # an empty r is what the checked path accepts
        np.testing.assert_array_equal(model.rhs(0.0, x, None, r), checked(model, "rhs")(0.0, x, None, None))
    with pytest.raises(ValueError, match="this model has no inputs, but r was given"):
        model.rhs(0.0, x, None, np.ones(1))
