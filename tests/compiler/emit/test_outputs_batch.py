"""NAME_outputs_batch (compiler/emit/batch.py, fn="outputs"): a model's outputs over many states in
SIMD lanes in one call (issue 31 item 1), equal to the scalar outputs bit for bit when sin/cos go
through libm (-DEOMC_BATCH_LIBM_TRIG), within the vector sin/cos's ulp bound otherwise -- on the
Kane-form double pendulum (energy, tip position) and the recursive cart with inputs per state,
with a tail that is not a whole group of lanes; failures are named per row; asking for it leaves
the scalar functions' C, and rhs_batch's, byte for byte as they were.

Oracle: the scalar outputs of the same library (the same generated expressions)."""
from pathlib import Path

import numpy as np
import pytest

from eomc.compiler.build.builder import machine_lanes
from eomc.compiler.driver import compile as compile_model, generate
from eomc.runtime.errors import SimulationError

STRICT = "-O2 -std=c99 -fPIC -Wall -Wextra -Werror"
EXAMPLES = Path(__file__).resolve().parents[3] / "examples"
PENDULUM, CART = EXAMPLES / "double_pendulum.py", EXAMPLES / "cart_pole_system.py"


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("outputs_batch_cache")


def _scalar(model, X, R=None):
    return np.array([list(model.outputs(0.3, x, r=None if R is None else R[k]).values())
                     for k, x in enumerate(X)])


def _states(model, n, seed):
    return np.random.default_rng(seed).uniform(-2.0, 2.0, (n, model.nx))


@pytest.mark.parametrize("trig", ["libm", "vector"])
def test_pendulum_outputs_in_lanes(cache, trig):
    flags = f"{STRICT} -DEOMC_BATCH_LIBM_TRIG" if trig == "libm" else STRICT
    model = compile_model(str(PENDULUM), f"ob_{trig}", functions=("rhs", "outputs", "outputs_batch"),
                          cache_dir=cache, cflags=flags, progress=False)
    meta = model.metadata["outputs_batch"]
    assert meta["vectorized"] and meta["layout"] == "noutput x n", meta
    X = _states(model, 3 * machine_lanes() + 3, 1)        # whole groups of lanes and a scalar tail
    got, want = model.outputs_batch(0.3, X), _scalar(model, X)
    assert got.shape == (X.shape[0], model.noutput)
    if trig == "libm":
        assert np.array_equal(got, want)
    else:   # sin/cos within 1 ulp of libm's (test_batch.test_vector_trig_ulp)
        assert (np.abs(got - want) / np.maximum(np.abs(want), 1.0)).max() < 1e-14
        assert np.mean(got == want) > 0.5
    P = np.array(model.param_defaults, dtype=float) * 1.5
    assert np.array_equal(model.outputs_batch(0.3, X, p=P)[:, 0] != got[:, 0], np.ones(len(X), bool))


def test_cart_inputs_per_state_and_failures(cache):
    model = compile_model(str(CART), "obcart", functions=("rhs", "outputs", "outputs_batch"), formulation="recursive",
                          cache_dir=cache, cflags=f"{STRICT} -DEOMC_BATCH_LIBM_TRIG", progress=False)
    assert model.noutput > 0 and model.ninput > 0
    X = _states(model, 2 * machine_lanes() + 5, 3)
    R = np.random.default_rng(4).uniform(-1, 1, (X.shape[0], model.ninput))
    assert np.array_equal(model.outputs_batch(0.3, X, r=R), _scalar(model, X, R))
    for row in (1, X.shape[0] - 2):          # in a group of lanes, in the scalar tail
        bad = X.copy()
        bad[row, 1] = np.nan
        with pytest.raises(SimulationError, match=rf"outputs_batch: non-finite input \(row {row} of X\)"):
            model.outputs_batch(0.3, bad, r=R)
    assert model.outputs_batch(0.3, X[:0]).shape == (0, model.noutput)


def test_scalar_and_rhs_batch_c_unchanged_and_on_request_only():
    def gen(functions):
        return generate(str(PENDULUM), "obc", functions=functions, use_cache=False, progress=False)[1]
    plain, rhs_b, both, default = (gen(("rhs", "outputs")), gen(("rhs", "outputs", "rhs_batch")),
                                   gen(("rhs", "outputs", "rhs_batch", "outputs_batch")), gen(None))
    assert "outputs_batch" not in default.metadata["functions"]
    for fn in ("rhs", "outputs"):
        start = plain.c_source.index(f"int obc_{fn}(")
        assert plain.c_source[start:plain.c_source.index("\n}\n", start)] in both.c_source
    start = rhs_b.c_source.index("#if defined(__GNUC__) && !defined(EOMC_NO_SIMD)")
    end = rhs_b.c_source.index("int obc_rhs_batch(")
    assert rhs_b.c_source[start:end] in both.c_source         # one prelude, helpers not repeated
    assert both.c_source.count("typedef double eomc_vd") == 1
    assert gen(("rhs", "outputs", "outputs_batch")).c_source.count("typedef double eomc_vd") == 1
    assert gen(("rhs", "outputs", "rhs_batch", "outputs_batch")).c_source == both.c_source   # byte-identical
