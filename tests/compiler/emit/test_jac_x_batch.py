"""NAME_jac_x_batch (compiler/emit/batch.py, fn="jac_x"): jac_x over many states in SIMD lanes,
its tangent loop kept as a loop over vectors, agrees with the scalar jac_x -- bit for bit when
sin/cos go through libm (-DEOMC_BATCH_LIBM_TRIG), within the vector sin/cos's ulp bound
otherwise -- on a recursive-form robot (UR5, split into parts) and the recursive cart with
inputs per state, with a tail that is not a whole group of lanes; failures are reported per
state; asking for it leaves the scalar functions' C, and rhs_batch's, byte for byte as they were.

Oracle: the scalar jac_x of the same library (the same generated expressions)."""
from pathlib import Path

import numpy as np
import pytest

from eomc.compiler.build.builder import machine_lanes
from eomc.compiler.driver import compile as compile_model, generate
from eomc.runtime.errors import SimulationError

from helpers.robots import robot_path

STRICT = "-O2 -std=c99 -fPIC -Wall -Wextra -Werror"
FUNCTIONS = ("rhs", "jac_x", "jac_x_batch")
CART = Path(__file__).resolve().parents[3] / "examples" / "cart_pole_system.py"
CHAIN = Path(__file__).resolve().parents[3] / "benchmarks" / "tree_models" / "cart_rel_joints.py"


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("jac_batch_cache")


def _ur5(cache, cflags, limits=False):
    from eomc.compiler.urdf.model import UrdfModel
    return compile_model(UrdfModel(robot_path("ur5"), limits=limits), "jbur5", functions=FUNCTIONS,
                         cache_dir=cache, cflags=cflags, progress=False)


def _states(model, n, seed):
    return np.random.default_rng(seed).uniform(-2.0, 2.0, (n, model.nx))


def _scalar(model, X, R=None):
    return np.array([model.jacobian(0.3, x, r=None if R is None else R[k]) for k, x in enumerate(X)])


@pytest.mark.parametrize("lanes", [4, 8])
def test_robot_bit_for_bit_with_libm_trig(cache, lanes):
    if lanes > machine_lanes():
        pytest.skip(f"this machine has {machine_lanes()} double lanes")
    model = _ur5(cache, f"{STRICT} -DEOMC_BATCH_LIBM_TRIG -DEOMC_BATCH_LANES={lanes}")
    assert model.metadata["jac_x_batch"]["vectorized"], model.metadata["jac_x_batch"]
    c = "".join(f.read_text() for f in Path(model.directory).glob("*.c"))
    assert "jbur5_jac_x_lanes" in c and "const eomc_vd *G;" in c       # the tangent loop in lanes
    X = _states(model, 3 * lanes + 3, 1)          # whole groups of lanes and a scalar tail
    got = model.jac_x_batch(0.3, X)
    assert got.shape == (X.shape[0], model.nx, model.nx)
    assert np.array_equal(got, _scalar(model, X))


def test_joint_limits_sign_and_step_in_lanes_bit_for_bit(cache):
    """UR5 with its joint limits: jac_x holds SymPy's Heaviside of each limit's violation,
    printed as a C comparison; in lanes it is a per-lane helper (a vector compare would give
    -1/0 masks, not 1/0).  Bit for bit with libm trig, also at states past the limits."""
    model = _ur5(cache, f"{STRICT} -DEOMC_BATCH_LIBM_TRIG", limits=True)
    assert model.metadata["jac_x_batch"]["vectorized"], model.metadata["jac_x_batch"]
    c = "".join(f.read_text() for f in Path(model.directory).glob("*.c"))
    assert "jbur5_v_step(" in c
    X = _states(model, 2 * machine_lanes() + 3, 8) * 4.0        # many states outside the limits
    want = _scalar(model, X)
    assert np.array_equal(model.jac_x_batch(0.3, X), want)
    assert np.any(want[:, model.nq:, :model.nq] != _scalar(_ur5(cache, f"{STRICT} -DEOMC_BATCH_LIBM_TRIG"),
                                                           X)[:, model.nq:, :model.nq])   # the limits act


def test_robot_vector_trig_within_bound(cache):
    model = _ur5(cache, STRICT)
    X = _states(model, 4 * machine_lanes() + 1, 2)
    got, want = model.jac_x_batch(0.3, X), _scalar(model, X)
    # sin/cos within 1 ulp of libm's (test_batch.test_vector_trig_ulp), amplified by the
    # Jacobian's conditioning: the measured worst on UR5 is ~1e-14 of each state's largest entry
    scale = np.abs(want).max(axis=(1, 2))
    assert (np.abs(got - want).max(axis=(1, 2)) / scale).max() < 1e-12
    assert np.mean(got == want) > 0.5                  # most entries are the same bits


def test_cart_with_inputs_per_state_and_failures(cache):
    model = compile_model(str(CART), "jbcart", functions=FUNCTIONS, formulation="recursive", cache_dir=cache,
                          cflags=f"{STRICT} -DEOMC_BATCH_LIBM_TRIG", progress=False)
    assert model.metadata["jac_x_batch"]["vectorized"], model.metadata["jac_x_batch"]
    X = _states(model, 2 * machine_lanes() + 5, 3)
    R = np.random.default_rng(4).uniform(-1, 1, (X.shape[0], model.ninput))
    assert np.array_equal(model.jac_x_batch(0.3, X, r=R), _scalar(model, X, R))
    for row in (1, X.shape[0] - 2):          # in a group of lanes, in the scalar tail
        bad = X.copy()
        bad[row, 1] = np.nan
        with pytest.raises(SimulationError, match=rf"jac_x_batch: non-finite input \(row {row} of X\)"):
            model.jac_x_batch(0.3, bad, r=R)
    with pytest.raises(ValueError, match=rf"X must have shape \(n, {model.nx}\)"):
        model.jac_x_batch(0.3, X[:, :3])
    assert model.jac_x_batch(0.3, X[:0]).shape == (0, model.nx, model.nx)


def test_scalar_tile_sizes():
    """Where jac_x is not vectorized (Go2: pivoting on values) the batch loops the scalar
    jac_x in tiles (compiler/emit/batch.scalar_tile): 8 states of Go2's 1296 outputs, 2 of
    cart n = 40's 6724 (the tile within SCALAR_TILE_BYTES), a tile row an odd number of cache
    lines."""
    from eomc.compiler.emit.batch import SCALAR_TILE_BYTES, scalar_tile
    assert scalar_tile(36, 0, 1296) == (8, 1304) and scalar_tile(82, 1, 82 * 82) == (2, 6728)
    assert scalar_tile(4, 1, 4) == (8, 8) and scalar_tile(10, 0, 16) == (8, 24)
    for nx in (4, 10, 36, 82, 200):
        ts, width = scalar_tile(nx, 1, nx * nx)
        assert width >= nx * nx and width % 16 == 8 and ts * (nx + 1 + width) * 8 <= max(SCALAR_TILE_BYTES, (
            nx + 1 + width) * 8)


def test_cart_without_simd_scalar_tiles(cache):
    """-DEOMC_NO_SIMD: every state through the scalar jac_x, in tiles of 8: n = 1024 (output
    rows a power of two apart) and 2 whole tiles plus a partial one, inputs per state, give
    the scalar jac_x's bits; a failure in a whole tile and one in the partial tile name their
    rows."""
    model = compile_model(str(CART), "jbcart", functions=FUNCTIONS, formulation="recursive", cache_dir=cache,
                          cflags=f"{STRICT} -DEOMC_NO_SIMD", progress=False)
    assert "enum { T = 8, W = " in "".join(f.read_text() for f in Path(model.directory).glob("*.c"))
    for n in (1024, 21):
        X = _states(model, n, n)
        R = np.random.default_rng(n + 1).uniform(-1, 1, (n, model.ninput))
        assert np.array_equal(model.jac_x_batch(0.3, X, r=R), _scalar(model, X, R))
    for row in (9, 19):
        bad = X.copy()
        bad[row, 0] = np.inf
        with pytest.raises(SimulationError, match=rf"jac_x_batch: non-finite input \(row {row} of X\)"):
            model.jac_x_batch(0.3, bad, r=R)


@pytest.mark.parametrize("solver", ["ltdl", "aba"])
def test_analytic_kernel_in_lanes_bit_for_bit(cache, monkeypatch, solver):
    """A cart with 6 links: its jac_x calls the analytic kernel NAME_rnea_derivs (loops over
    the tree's int tables, compiler/tree/analytic.py), retyped into lanes (every double a
    vector, the same loops): bit for bit with libm trig, inputs per state, a scalar tail.
    With M⁻¹ by LᵀDL (its own choice) and articulated (forced): the scalar kernel built at
    -O2 then runs the solve's AVX2 row helpers on an AVX2 CPU, which the lanes leave out."""
    from eomc.compiler.tree import analytic
    monkeypatch.setenv("EOMC_N_LINKS", "6")
    if solver == "aba":
        monkeypatch.setattr(analytic, "ABA_DEPTH", 0)
    name = "jbchain" if solver == "ltdl" else "jbchaba"
    model = compile_model(str(CHAIN), name, functions=FUNCTIONS, formulation="recursive", cache_dir=cache,
                          cflags=f"{STRICT} -DEOMC_BATCH_LIBM_TRIG", progress=False)
    assert model.metadata["jac_x_batch"]["vectorized"], model.metadata["jac_x_batch"]
    c = "".join(f.read_text() for f in Path(model.directory).glob("*.c"))
    assert f"{name}_vrnea_derivs(an, u, {'ud' if solver == 'ltdl' else 'u'}, out," in c
    # the scalar kernel's AVX2 row helpers are not retyped into lanes (the lanes are vectors already)
    assert (f"{name}_rd_bw_avx2(" in c) == (f"{name}_vrd_bw(" in c) == (solver == "aba") and "vrd_bw_avx2" not in c
    X = _states(model, 2 * machine_lanes() + 3, 6)
    R = np.random.default_rng(7).uniform(-1, 1, (X.shape[0], model.ninput))
    assert np.array_equal(model.jac_x_batch(0.3, X, r=R), _scalar(model, X, R))


def test_scalar_and_rhs_batch_c_unchanged_and_on_request_only():
    def gen(functions):
        return generate(str(CART), "jsc", functions=functions, formulation="recursive", use_cache=False,
                        progress=False)[1]
    plain, rhs_b, both, default = (gen(("rhs", "jac_x")), gen(("rhs", "jac_x", "rhs_batch")),
                                   gen(("rhs", "jac_x", "rhs_batch", "jac_x_batch")), gen(None))
    assert "jac_x_batch" not in default.metadata["functions"]
    for fn in ("rhs", "jac_x"):
        start = plain.c_source.index(f"int jsc_{fn}(")
        assert plain.c_source[start:plain.c_source.index("\n}\n", start)] in both.c_source
    # rhs_batch's code (prelude, helpers, lanes) is the same text with jac_x_batch beside it,
    # which defines no helper twice and no second prelude
    start = rhs_b.c_source.index("#if defined(__GNUC__) && !defined(EOMC_NO_SIMD)")
    end = rhs_b.c_source.index("int jsc_rhs_batch(")
    assert rhs_b.c_source[start:end] in both.c_source
    assert both.c_source.count("typedef double eomc_vd") == 1
    assert both.c_source.count("static EOMC_VTARGET EOMC_VINLINE void jsc_vkernel(") == 1
    assert gen(("rhs", "jac_x", "rhs_batch", "jac_x_batch")).c_source == both.c_source   # byte-identical


def test_floating_robot_with_ground_contacts_bit_for_bit(cache):
    """jac_x's analytic kernel with ground contacts in lanes (batch._ground_contact_lanes): the
    scalar kernel skips a contact clear of the ground with an ``if`` on its depth, which on a
    vector was a compile error (every URDF robot with contacts and jac_x_batch).  A contact is
    now skipped when every lane is clear, and its rows are added under the lanes' mask, so a
    group holding pressed and clear states gives each the scalar jac_x's bits."""
    from eomc.compiler.urdf.model import UrdfModel
    from helpers.urdf_arm import FLOATING_FEET
    path = cache / "feet.urdf"
    path.write_text(FLOATING_FEET)
    lanes = machine_lanes()
    model = compile_model(UrdfModel(path, floating_base=True), "jbfeet", contacts="@collision",
                          functions=FUNCTIONS + ("outputs",), cache_dir=cache, progress=False,
                          cflags=f"{STRICT} -DEOMC_BATCH_LIBM_TRIG -DEOMC_BATCH_LANES={lanes}")
    assert model.metadata["jac_x_batch"]["vectorized"], model.metadata["jac_x_batch"]
    rng = np.random.default_rng(3)
    X = rng.normal(scale=0.3, size=(4 * lanes + 3, model.nx))
    X[:, list(model.state_names).index("q_trunk_floating_z")] = rng.uniform(-0.15, 0.35, len(X))
    pressed = [any(v > 0 for k, v in model.outputs(0.0, x).items() if k.startswith("Fn_")) for x in X]
    assert 3 <= sum(pressed) <= len(X) - 3          # groups of lanes mixing pressed and clear states
    got, want = model.jac_x_batch(0.0, X), np.array([model.jacobian(0.0, x) for x in X])
    assert np.array_equal(got.view(np.uint64), want.view(np.uint64))     # the bits, -0.0 included
