"""The Model object over the hand-written oscillator, with both backends.

Checks values against numpy (tests/helpers/osc_model.py), that every bad argument is
a ValueError naming it *before* any C runs (kernels are spied on), and that a
nonzero C status becomes an error naming the failure, time and state.
"""
import threading

import numpy as np
import pytest

from helpers import osc_model
from helpers.spies import spy_kernels
from eomc.compiler.build import build
from eomc.errors import ModelError, SimulationError
from eomc.runtime.loader import load

RNG = np.random.default_rng(7)


@pytest.fixture(scope="module", params=["cffi", "cython"])
def model(request, tmp_path_factory):
    result = build(osc_model.oscillator(), backend=request.param, cache_dir=tmp_path_factory.mktemp("cache"))
    m = load(result.directory)
    assert m.backend == request.param
    return m


def test_sizes_names_and_defaults(model):
    assert (model.nq, model.nu, model.nx, model.nparam, model.ninput, model.noutput) == (1, 1, 2, 3, 1, 1)
    assert model.state_names == ("q", "u") and model.param_names == ("m", "c", "k")
    assert model.param_defaults.tolist() == [2.0, 0.5, 8.0]
    assert model.ffi.string(model.c_model.name) == b"osc"
    assert model.source_path.name == "osc.c" and model.header_path.is_file()


def test_functions_match_numpy_oracle(model):
    for _ in range(20):
        x, p, r = RNG.normal(size=2), RNG.uniform(0.5, 3, size=3), RNG.normal(size=1)
        m, c, k = p
        np.testing.assert_allclose(model.rhs(0.1, x, p, r), osc_model.oscillator_rhs(0.1, x, p, r), rtol=1e-14)
        np.testing.assert_allclose(model.jacobian(0.0, x, p, r), [[0, 1], [-k / m, -c / m]], rtol=1e-14)
        np.testing.assert_allclose(model.input_jacobian(0.0, x, p, r), [[0], [1 / m]], rtol=1e-14)
        np.testing.assert_allclose(model.mass_matrix(0.0, x, p, r), [[m]])
        np.testing.assert_allclose(model.forcing(0.0, x, p, r), [r[0] - c * x[1] - k * x[0]], rtol=1e-14)
        assert model.outputs(0.0, x, p, r) == pytest.approx({"energy": 0.5 * m * x[1] ** 2 + 0.5 * k * x[0] ** 2})
        udot = model.rhs(0.0, x, p, r)[1:]
        np.testing.assert_allclose(model.inverse_dynamics(0.0, x, udot, p, r), [0.0], atol=1e-12)
        A, B = model.linearize(0.0, x, p, r)
        np.testing.assert_allclose(A, model.jacobian(0.0, x, p, r))
        np.testing.assert_allclose(B, model.input_jacobian(0.0, x, p, r))


def test_defaults_dicts_and_plain_sequences(model):
    x = [0.3, -0.2]
    np.testing.assert_allclose(model.rhs(0, x), osc_model.oscillator_rhs(0, x))
    np.testing.assert_allclose(model.rhs(0, x, {"k": 1.0}, {"F": 2.0}),
                               osc_model.oscillator_rhs(0, x, (2.0, 0.5, 1.0), (2.0,)))
    np.testing.assert_allclose(model.rhs(np.float32(0), (1, 2), (1, 1, 1), (0,)),
                               osc_model.oscillator_rhs(0, (1, 2), (1, 1, 1), (0,)))


def test_rhs_many_equals_rhs_per_row(model):
    X = RNG.normal(size=(50, 2))
    t = np.linspace(0, 1, 50)
    R = RNG.normal(size=(50, 1))
    many = model.rhs_many(t, X, r=R)
    rows = np.array([model.rhs(ti, xi, r=ri) for ti, xi, ri in zip(t, X, R)])
    np.testing.assert_array_equal(many, rows)
    np.testing.assert_array_equal(model.rhs_many(0.0, X), np.array([model.rhs(0.0, xi) for xi in X]))
    assert model.rhs_many(0.0, np.empty((0, 2))).shape == (0, 2)


@pytest.fixture
def spied(model, monkeypatch):
    return spy_kernels(model, monkeypatch)


@pytest.mark.parametrize("call, needle", [
    (lambda m: m.rhs(0.0, [1.0, 2.0, 3.0]), r"x \(state\) must have shape \(2,\) \[q, u\]; got shape \(3,\)"),
    (lambda m: m.rhs(0.0, [[1.0, 2.0]]), r"x \(state\) must have shape \(2,\)"),
    (lambda m: m.rhs(0.0, ["a", "b"]), r"x \(state\) must hold real numbers"),
    (lambda m: m.rhs(0.0, [1 + 1j, 0]), r"real numbers"),
    (lambda m: m.rhs([0.0, 1.0], [1.0, 2.0]), r"t must be a real scalar"),
    (lambda m: m.rhs(0.0, [1.0, 2.0], [1.0, 2.0]), r"p \(parameters\) must have shape \(3,\) \[m, c, k\]"),
    (lambda m: m.rhs(0.0, [1.0, 2.0], {"mass": 1.0}), r"unknown parameter 'mass'; valid names: m, c, k"),
    (lambda m: m.rhs(0.0, [1.0, 2.0], r=[1.0, 2.0]), r"r \(inputs\) must have shape \(1,\) \[F\]"),
    (lambda m: m.rhs(0.0, [1.0, 2.0], r={"G": 1.0}), r"unknown input 'G'"),
    (lambda m: m.rhs_many(0.0, np.zeros((4, 3))), r"X must have shape \(n, 2\)"),
    (lambda m: m.rhs_many(np.zeros(3), np.zeros((4, 2))), r"t \(one time per row of X\) must have shape \(4,\)"),
    (lambda m: m.rhs_many(0.0, np.zeros((4, 2)), r=np.zeros((3, 1))), r"must have shape \(4, 1\)"),
    (lambda m: m.inverse_dynamics(0.0, [1.0, 2.0], [1.0, 2.0]), r"udot \(speed derivatives\) must have shape \(1,\)"),
    (lambda m: m.jacobian(0.0, np.zeros(2, dtype=bool)), r"real numbers"),
])
def test_bad_arguments_raise_valueerror_before_c_runs(spied, call, needle):
    model, calls = spied
    with pytest.raises(ValueError, match=needle):
        call(model)
    assert calls == []


def test_nonzero_status_names_failure_time_and_state(model):
    with pytest.raises(SimulationError, match=r"osc\.rhs: the mass matrix is singular at t=1\.5, state q=0\.3, u=-0\.2"):
        model.rhs(1.5, [0.3, -0.2], [0.0, 1.0, 1.0])
    with pytest.raises(SimulationError, match=r"singular at t=2, state q=0\.3"):  # arrays: Cython's fast path
        model.rhs(2.0, np.array([0.3, -0.2]), np.array([0.0, 1.0, 1.0]), np.zeros(1))
    X = np.array([[0.0, 0.0], [0.3, -0.2]])
    with pytest.raises(SimulationError, match=r"singular .* \(row 0 of X\)"):
        model.rhs_many(0.0, X, p=[0.0, 1.0, 1.0])


def test_function_not_built_is_named(model, monkeypatch):
    assert model.constraints(0.0, [0.0, 0.0]).shape == (0,)  # no constraints: nothing to compute
    assert model.constraints_jacobian(0.0, [0.0, 0.0]).shape == (0, 2)
    with pytest.raises(ValueError, match="x \\(state\\)"):
        model.constraints(0.0, [0.0])
    monkeypatch.setattr(model, "nhol", 1)  # pretend it has one, built without the function
    with pytest.raises(ModelError, match="built without `constraints`"):
        model.constraints(0.0, [0.0, 0.0])


def test_fast_path_accepts_arrays_and_falls_back_for_the_rest(model):
    x, p, r = np.array([0.3, -0.2]), np.array([1.0, 0.5, 2.0]), np.array([0.7])
    expected = osc_model.oscillator_rhs(0.0, x, p, r)
    for args in [(0.0, x, p, r), (0, x, p, r), (0.0, x.tolist(), p, r), (0.0, x.astype(np.float32), p, r),
                 (0.0, x, p.astype(int) * 0 + p, r), (0.0, np.asfortranarray(x), p, r), (0.0, x, list(p), [0.7])]:
        np.testing.assert_allclose(model.rhs(*args), expected, rtol=1e-6 if np.asarray(args[1]).dtype == np.float32 else 1e-15)
    with pytest.raises(ValueError, match="p \\(parameters\\) must have shape"):
        model.rhs(0.0, x, np.ones(4))
    with pytest.raises(ValueError, match="this model has no inputs|r \\(inputs\\) must have shape"):
        model.rhs(0.0, x, p, np.ones(2))


def test_threads_share_a_model(model):
    X = RNG.normal(size=(8, 2))
    expected = [osc_model.oscillator_rhs(0, x) for x in X]
    results = [None] * 8

    def work(i):
        for _ in range(200):
            results[i] = model.rhs(0.0, X[i])
    threads = [threading.Thread(target=work, args=(i,)) for i in range(8)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    np.testing.assert_allclose(results, expected, rtol=1e-14)
