"""Python API arguments that used to escape the checks (reliability report F8).

Each case is the report's call: it must be a ValueError naming the argument
before any allocation or C call (or, for a non-finite state handed to a
model function, an error that says the *input* is non-finite rather than
"singular mass matrix").  simulate() runs on the hand-written stand-in
models; the Model methods on the built oscillator (tests/helpers/osc_model.py).
"""
import numpy as np
import pytest

from helpers import model_files, osc_model
from helpers.stand_in import get_model
from eomc.compiler.build import build
from eomc.errors import SimulationError
from eomc.runtime import simulate as simulate_module
from eomc.runtime.batch import simulate_many
from eomc.runtime.loader import load
from eomc.runtime.simulate import simulate


@pytest.fixture(scope="module")
def pend():
    return get_model("pendulum")


@pytest.fixture(scope="module")
def osc():
    return get_model("oscillator")  # one input, F


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    return load(build(osc_model.oscillator(), cache_dir=tmp_path_factory.mktemp("cache")).directory)


@pytest.fixture(scope="module")
def generated(tmp_path_factory):
    """A real generated model (its C checks for non-finite values): the pendulum model file."""
    from eomc.compiler.driver import compile as compile_model
    path = model_files.write(tmp_path_factory.mktemp("model"), model_files.PENDULUM, "pend")
    return compile_model(str(path), cache_dir=tmp_path_factory.mktemp("cache"), progress=False)


@pytest.fixture
def no_allocation(monkeypatch):
    """Fail the test if simulate gets as far as allocating the output or calling C."""
    def refuse(*args, **kwargs):
        raise AssertionError("reached run_prepared: the bad argument was not caught first")
    monkeypatch.setattr(simulate_module, "run_prepared", refuse)


@pytest.mark.parametrize("kw, match", [
    (dict(n_points=0), r"n_points must be an integer >= 2 .*got 0"),
    (dict(n_points=2.5), r"n_points must be an integer >= 2 .*got 2\.5"),
    (dict(n_points=1), r"n_points must be an integer >= 2"),
    (dict(n_points=True), r"n_points must be an integer"),
    (dict(n_points=10 ** 9), r"the output would hold 1e\+09 rows .*pass a smaller n_points"),
    (dict(method="rk4", dt=1e-12), r"rk4 with dt=1e-12 needs 1e\+12 steps .*more than max_steps=100000"),
    (dict(method="rk4", dt=1e-300), r"rk4 with dt=1e-300 needs 1e\+300 steps"),
    (dict(method="rk4", dt=1e-3, t_span=(0.0, 1e5)), r"needs 1e\+08 steps over t_span \(0, 100000\)"),
    (dict(method="rk4", dt=1e-4, t_span=(0.0, 1e5), max_steps=10 ** 12),
     r"the output would hold 1e\+09 rows .*rk4 writes every step"),
    (dict(max_steps=10 ** 20), r"max_steps must be a positive integer up to 2\*\*63 - 1"),
    (dict(max_steps=True), r"max_steps must be a positive integer"),
    (dict(x0={"q1": None}), r"x0 \(initial state\) q1 must be a real number; got NoneType None"),
    (dict(x0={"q1": 10 ** 400}), r"x0 \(initial state\) q1 must be a real number that fits a double; "
                                 r"got an integer of about 400 digits"),
    (dict(t_eval=[0.1j]), r"t_eval must hold real times; got dtype complex128"),
    (dict(t_span=(1e16, 1e16 + 2)), r"doubles are 2 apart.*every step would underflow relative to t"),
    (dict(method="rk4"), r"dt= in Python, --dt on the command line"),
])
def test_bad_arguments_are_value_errors_before_allocating(pend, no_allocation, kw, match):
    args = dict(x0=[1.0, 0.0], t_span=(0.0, 1.0))
    args.update(kw)
    with pytest.raises(ValueError, match=match):
        simulate(pend, args.pop("x0"), args.pop("t_span"), **args)


def test_rk4_within_max_steps_still_runs(pend):
    res = simulate(pend, [1.0, 0.0], (0.0, 1.0), method="rk4", dt=1e-3, max_steps=1000)
    assert res.success and res.t.size == 1001


def test_t_fail_only_on_failure(pend):
    assert "t_fail" not in simulate(pend, [1.0, 0.0], (0.0, 1.0)).stats
    failed = simulate(get_model("singular"), [1.0], (0.0, 1.0), raise_on_failure=False)
    assert failed.status != 0 and "t_fail" in failed.stats


def test_callable_input_names_the_offending_sample(osc):
    with pytest.raises(ValueError, match=r"r\(t\) must return 1 value\(s\) \[F\]; at t=0\.5\d* it returned 2"):
        simulate(osc, [0.0, 0.0], (0.0, 1.0), r=lambda t: [1.0] if t < 0.5 else [1.0, 2.0])
    with pytest.raises(ValueError, match=r"at t=0 it returned NoneType None"):
        simulate(osc, [0.0, 0.0], (0.0, 1.0), r=lambda t: None)
    with pytest.raises(ValueError, match=r"r\(t\) raised ZeroDivisionError at t=0") as info:
        simulate(osc, [0.0, 0.0], (0.0, 1.0), r=lambda t: 1 / 0)
    assert isinstance(info.value.__cause__, ZeroDivisionError)


def test_simulate_many_names_the_bad_case(pend):
    X0 = np.tile([1.0, 0.0], (5, 1))
    X0[3, 0] = np.nan
    with pytest.raises(ValueError, match=r"case 3 of 5: .*x0 \(initial state\) is not finite for q1"):
        simulate_many(pend, X0, (0.0, 1.0), progress=False)


def test_rhs_of_a_huge_integer_time(model):
    with pytest.raises(ValueError, match=r"t must be a real number that fits a double; got an integer of about 400 digits"):
        model.rhs(10 ** 400, np.zeros(2))
    with pytest.raises(ValueError, match=r"an integer of about 5000 digits"):  # str() would refuse it
        model.rhs(10 ** 5000, np.zeros(2))


@pytest.mark.parametrize("call", ["rhs", "jacobian", "forcing", "linearize", "outputs"])  # M(q) = m l^2
@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_non_finite_state_is_reported_as_input_not_singular(generated, call, bad):
    with pytest.raises(SimulationError) as info:
        getattr(generated, call)(0.0, np.array([bad, 0.0]))
    assert f"pend.{'jac_x' if call == 'jacobian' else call}: non-finite input: x (state) q={bad}" \
        in str(info.value)
    assert "singular" not in str(info.value)
    with pytest.raises(SimulationError, match=r"non-finite input: x \(state\) q=nan"):
        getattr(generated, call)(0.0, [float("nan"), 0.0])   # a list: the checked path


def test_non_finite_parameters_inputs_and_rows_are_named(model, generated):
    # the hand-written oscillator only fails on m = 0; a non-finite value must still be the diagnosis
    with pytest.raises(SimulationError, match=r"osc\.rhs: non-finite input: p \(parameters\) k=inf"):
        model.rhs(0.0, np.zeros(2), p={"m": 0.0, "k": np.inf})
    with pytest.raises(SimulationError, match=r"non-finite input: r \(inputs\) F=nan"):
        model.rhs(0.0, np.zeros(2), p=[0.0, 0.5, 8.0], r=[np.nan])
    X = np.zeros((3, 2))
    X[2, 1] = -np.inf
    with pytest.raises(SimulationError, match=r"non-finite input \(row 0 of X\): x \(state\) u=-inf"):
        model.rhs_many(0.0, X[::-1].copy(), p=[0.0, 0.5, 8.0])
    with pytest.raises(SimulationError, match=r"inverse_dynamics: non-finite input: udot"):
        generated.inverse_dynamics(0.0, np.zeros(2), [np.nan])


def test_singular_mass_matrix_with_finite_inputs_still_says_so(model):
    with pytest.raises(SimulationError, match=r"osc\.rhs: the mass matrix is singular"):
        model.rhs(0.0, np.array([0.3, 0.1]), p=[0.0, 0.5, 8.0])


def test_rhs_of_a_list_takes_the_fast_path(generated, monkeypatch):
    """model.rhs(t, [..]) (the README's old form) converts once and skips the general checked path."""
    x = [0.3, -0.2]
    expected = generated.rhs(0.0, np.array(x))

    def slow(*args, **kwargs):
        raise AssertionError("a list of floats went through the general checked path")
    monkeypatch.setattr(generated, "_vector_call", slow)
    np.testing.assert_array_equal(generated.rhs(0.0, x), expected)
    np.testing.assert_array_equal(generated.rhs(0, [0, 0]), generated.rhs(0.0, np.zeros(2)))
    monkeypatch.undo()
    with pytest.raises(ValueError, match="got dtype bool"):      # still refused, by the checked path
        generated.rhs(0.0, [True, False])
    with pytest.raises(ValueError, match=r"shape \(2,\)"):
        generated.rhs(0.0, [1.0, 2.0, 3.0])


def test_unknown_keyword_is_a_value_error_listing_the_valid_ones(model):
    """Reliability rerun: `m.simulate(x, span, foo=1)` was Python's TypeError from inside eomc."""
    with pytest.raises(ValueError, match=r"simulate\(\) got unknown keyword argument\(s\) 'foo'; "
                                         r"valid keywords: p, r, method, rtol, atol"):
        model.simulate([0.0, 0.0], (0.0, 1.0), foo=1)
    with pytest.raises(ValueError, match=r"unknown keyword argument\(s\) 'rtoll'; valid keywords: r, method"):
        simulate_many(model, np.zeros((2, 2)), (0.0, 1.0), rtoll=1e-8, progress=False)
    assert model.simulate([0.0, 0.0], (0.0, 1.0), rtol=1e-8).success   # known keywords still pass
