"""eomc.rollout(lanes=True): RK4 over many rows with every stage one NAME_rhs_batch call.

Oracle: the scalar C rollout (itself simulate bit for bit).  Built with -DEOMC_BATCH_LIBM_TRIG
the lanes compute the scalar rhs's bits and the step is the C loop's arithmetic in the same
order, so the rows must be equal, not close; built with the vector sin/cos they agree to
rounding.  Also: rows that fail keep their last good state and status, and what lanes cannot
take (other methods, a model without rhs_batch) is refused by name.  The loop is C
(eomc_rollout_lanes): blocks of rows per thread, one NAME_rhs_batch_p call per stage.
method="implicitfast" with lanes=True (eomc_rollout_implicit_lanes) on the gym hopper with its
contacts: rows in fibers, their NAME_implicit calls one NAME_implicit_batch call per round --
equal to the scalar rollout bit for bit with libm's sin/cos, split steps and per-row parameters
included.
"""
from pathlib import Path

import numpy as np
import pytest

from helpers.mjcf_builds import gym_model

from eomc.compiler.driver import compile as compile_model
from eomc.errors import SimulationError
from eomc.runtime.rollout import rollout
from eomc.runtime.simulate import simulate

CART = Path(__file__).resolve().parents[2] / "examples" / "cart_pole_system.py"


@pytest.fixture(scope="module")
def cart(tmp_path_factory):
    return compile_model(str(CART), "rl_cart", functions=("rhs", "rhs_batch"), formulation="recursive",
                         cache_dir=tmp_path_factory.mktemp("rl"), progress=False,
                         cflags="-O2 -std=c99 -fPIC -DEOMC_BATCH_LIBM_TRIG")


def _starts(model, n, seed=0):
    return np.random.default_rng(seed).uniform(-1.0, 1.0, (n, model.nx))


@pytest.mark.parametrize("threads", [1, 2])
def test_final_and_steps_equal_the_scalar_rollout(cart, threads):
    X0 = _starts(cart, 203)                    # not a multiple of the lanes: a scalar tail too
    want = rollout(cart, X0, dt=0.01, steps=40, threads=threads)
    got = rollout(cart, X0, dt=0.01, steps=40, threads=threads, lanes=True)
    assert got.ok.all() and np.array_equal(got.x, want.x) and np.array_equal(got.steps, want.steps)
    assert np.abs(got.x - X0).min() > 1e-6     # the rows moved
    want = rollout(cart, X0[:9], dt=0.01, t_final=0.255, record="steps", threads=threads)
    got = rollout(cart, X0[:9], dt=0.01, t_final=0.255, record="steps", threads=threads, lanes=True)
    assert got.x.shape == (9, 27, cart.nx) and np.array_equal(got.t, want.t)
    assert np.array_equal(got.x, want.x)       # the shortened last step included


@pytest.mark.parametrize("threads", [1, 2])
def test_one_parameter_row_per_trajectory_equals_the_scalar_rollout(cart, threads):
    """Each row its own parameters (NAME_rhs_batch_p: the parameters in lanes too)."""
    X0 = _starts(cart, 141, seed=3)
    rng = np.random.default_rng(4)
    P = np.asarray(cart.param_defaults) * rng.uniform(0.5, 1.5, (141, cart.nparam))
    want = rollout(cart, X0, dt=0.01, steps=30, p=P, threads=threads)
    got = rollout(cart, X0, dt=0.01, steps=30, p=P, threads=threads, lanes=True)
    assert got.ok.all() and np.array_equal(got.x, want.x) and np.array_equal(got.steps, want.steps)
    shared = rollout(cart, X0, dt=0.01, steps=30, threads=threads, lanes=True)
    assert np.abs(shared.x - got.x).max() > 1e-6       # the parameters mattered


@pytest.mark.parametrize("threads", [1, 2])
def test_control_sequences_per_trajectory_equal_the_scalar_rollout(cart, threads):
    """r=(t_grid, values) per row: each stage's inputs interpolated in the C loop as the scalar
    integrator does (grid ends inside the span: held), passed to NAME_rhs_batch_p in lanes."""
    assert cart.ninput > 0
    X0 = _starts(cart, 75, seed=6)
    t_grid = np.array([0.0, 0.05, 0.12, 0.2])
    values = np.random.default_rng(7).uniform(-3.0, 3.0, (75, t_grid.size, cart.ninput))
    P = np.asarray(cart.param_defaults) * np.random.default_rng(8).uniform(0.8, 1.2, (75, cart.nparam))
    want = rollout(cart, X0, dt=0.01, steps=30, p=P, r=(t_grid, values), threads=threads)
    got = rollout(cart, X0, dt=0.01, steps=30, p=P, r=(t_grid, values), threads=threads, lanes=True)
    assert got.ok.all() and np.array_equal(got.x, want.x) and np.array_equal(got.steps, want.steps)
    const = rollout(cart, X0, dt=0.01, steps=30, r=values[:, 1], threads=threads, lanes=True)
    assert np.array_equal(const.x, rollout(cart, X0, dt=0.01, steps=30, r=values[:, 1], threads=threads).x)
    assert np.abs(const.x - got.x).max() > 1e-6


def test_failed_rows_keep_their_last_good_state(cart):
    X0 = _starts(cart, 10)
    X0[3, 3] = 1e200                           # overflows within the first step
    want = rollout(cart, X0, dt=0.01, steps=20, raise_on_failure=False)
    got = rollout(cart, X0, dt=0.01, steps=20, raise_on_failure=False, lanes=True)
    assert not got.ok[3] and got.ok[np.arange(10) != 3].all()
    assert np.array_equal(got.status, want.status) and np.array_equal(got.steps, want.steps)
    assert np.array_equal(got.x, want.x)
    with pytest.raises(SimulationError, match="rollout row 3 of 10 failed"):
        rollout(cart, X0, dt=0.01, steps=20, lanes=True)


def test_refusals_name_the_reason(cart, tmp_path):
    X0 = _starts(cart, 4)
    with pytest.raises(ValueError, match=r"lanes=True\) does not take method 'implicitfast'"):
        rollout(cart, X0, dt=0.01, steps=2, method="implicitfast", lanes=True)
    plain = compile_model(str(CART), "rl_plain", functions=("rhs",), cache_dir=tmp_path, progress=False)
    with pytest.raises(ValueError, match="built without rhs_batch"):
        rollout(plain, X0, dt=0.01, steps=2, lanes=True)


def test_quaternion_rows_in_lanes_equal_the_scalar_rollout(tmp_path):
    """An MJCF free and ball joint as quaternions: each lane's quaternions
    are normalised at the start and after every step with its k2 rows scaled alike, as the
    scalar RK4 does (runtime/c/eomc_rollout.c lane_quats), so the rows equal the scalar
    rollout's bit for bit -- starts whose quaternions are 0.6-1.5 long included (row 0 of
    record="steps" is the normalised start, as the scalar's)."""
    pytest.importorskip("mujoco")
    from eomc.compiler.mjcf.model import MjcfModel
    from ..compiler.mjcf.test_mjcf import SMALL
    path = tmp_path / "small.xml"
    path.write_text(SMALL.replace(' ctrlrange="-1 1" ctrllimited="true"', ''))     # no switching
    model = compile_model(MjcfModel(path, limits=False, pairs=False, orientation="quaternion"), "rl_quat", functions=("rhs", "rhs_batch"),
                          cache_dir=tmp_path, progress=False, cflags="-O2 -std=c99 -fPIC -DEOMC_BATCH_LIBM_TRIG")
    assert len(model.quaternions) == 2                  # the ball and the free joint
    rng = np.random.default_rng(5)
    X0 = np.tile(np.array(model.initial_state, dtype=float), (70, 1))
    X0[:, model.nq:] = rng.uniform(-2.0, 2.0, (70, model.nu))
    for i in model.quaternions:
        X0[:, i:i + 4] += rng.uniform(-0.3, 0.3, (70, 4))
        X0[:, i:i + 4] *= (rng.uniform(0.6, 1.5, 70) / np.linalg.norm(X0[:, i:i + 4], axis=1))[:, None]
    for threads in (1, 2):
        want = rollout(model, X0, dt=0.005, t_final=0.2025, record="steps", threads=threads)
        got = rollout(model, X0, dt=0.005, t_final=0.2025, record="steps", threads=threads, lanes=True)
        assert got.ok.all() and np.array_equal(got.x, want.x) and np.array_equal(got.steps, want.steps)
    for i in model.quaternions:
        assert np.abs(np.linalg.norm(got.x[:, :, i:i + 4], axis=2) - 1.0).max() < 4e-16
    assert np.abs(got.x[:, -1] - got.x[:, 0]).min() > 1e-6      # every row moved


# ---------------------------------------------------------------- implicitfast with contacts
# eomc_rollout_implicit_lanes: each thread's rows in fibers running the scalar row's code, their
# NAME_implicit calls made together by NAME_implicit_batch (the contacts' branches as masks)


@pytest.fixture(scope="module")
def hopper(tmp_path_factory):
    return gym_model("hopper.xml", "rl_hopper", tmp_path_factory.mktemp("rlh"), ("rhs", "implicit", "implicit_batch"),
                     cflags="-O2 -std=c99 -fPIC -DEOMC_BATCH_LIBM_TRIG")


def _hopper_starts(model, n, seed=0):
    """The file's start, hinge and slide speeds uniform in +-0.5 (bench_rollout_contacts' starts):
    the hopper falls onto its foot, the rows' steps split at different times."""
    X0 = np.tile(np.array(model.initial_state, dtype=float), (n, 1))
    X0[:, model.nq:] = np.random.default_rng(seed).uniform(-0.5, 0.5, (n, model.nu))
    return X0


@pytest.mark.parametrize("threads", [1, 2])
def test_implicitfast_rows_in_lanes_equal_the_scalar_rollout(hopper, threads):
    X0 = _hopper_starts(hopper, 21)           # not a multiple of the lanes
    kw = dict(dt=0.008, steps=60, method="implicitfast", threads=threads)
    want = rollout(hopper, X0, **kw)
    got = rollout(hopper, X0, lanes=True, **kw)
    assert got.ok.all() and np.array_equal(got.x, want.x) and np.array_equal(got.steps, want.steps)
    assert np.array_equal(got.unsolved, want.unsolved)
    z = list(hopper.state_names).index("q_rootz")
    assert (want.x[:, z] < X0[:, z] - 0.03).all()          # every row fell onto its foot (0.1 m below)
    want = rollout(hopper, X0[:5], record="steps", **kw)
    got = rollout(hopper, X0[:5], record="steps", lanes=True, **kw)
    assert np.array_equal(got.x, want.x)
    # the split steps: the rows' calls beyond one a step (each step's split tries, in lanes too)
    assert simulate(hopper, X0[0], (0.0, 0.48), method="implicitfast", dt=0.008).stats["nfev"] > 61


@pytest.mark.parametrize("width", ["4", None])
def test_each_lanes_kernel_gives_the_scalar_rows(hopper, monkeypatch, width):
    """The step's assembly in lanes has two kernels (eomc_fixedstep.c, eomc_fs_lanes_body.h): 8 lanes
    in one group where the machine has AVX-512F and DQ, else 4 lanes in groups of 4; the test hook
    $EOMC_FS_LANES_WIDTH=4 keeps the 4-wide where the 8-wide would run.  Each gives the scalar
    rollout's rows bit for bit, split steps included (on a machine without AVX-512 both runs take
    the 4-wide)."""
    if width is not None:
        monkeypatch.setenv("EOMC_FS_LANES_WIDTH", width)
    else:
        monkeypatch.delenv("EOMC_FS_LANES_WIDTH", raising=False)
    X0 = _hopper_starts(hopper, 19, seed=11)
    kw = dict(dt=0.008, steps=60, method="implicitfast", threads=1)
    want = rollout(hopper, X0, **kw)
    got = rollout(hopper, X0, lanes=True, **kw)
    assert got.ok.all() and np.array_equal(got.x, want.x) and np.array_equal(got.steps, want.steps)
    assert np.array_equal(got.unsolved, want.unsolved)


@pytest.mark.parametrize("threads", [1, 2])
def test_rows_left_with_unsolved_cells_are_counted_warned_and_flagged_alike(hopper, threads):
    """The bookkeeping of unsolved rows (each row's count, result.clean, the one warning naming
    the rows; simulate's stats["rejected"] and its warning) lost its coverage when fs_last_cell
    (c938e38b) solved the last cells the tests' models left unsolved.  A residual test tighter
    than the last cell's Newton reaches (split=1e-4; the default is 0.5) leaves one or two 1/64
    cells unsolved in some of the hopper's rows and none in others: the scalar rollout and the
    lanes count the same cells in the same rows, bit for bit, as simulate does row by row."""
    import warnings
    from eomc.runtime.switching import PhysicsWarning
    X0 = _hopper_starts(hopper, 9)
    kw = dict(dt=0.008, steps=60, method="implicitfast", split=1e-4, threads=threads)
    runs = {}
    for lanes in (False, True):
        with warnings.catch_warnings(record=True) as said:
            warnings.simplefilter("always", PhysicsWarning)
            runs[lanes] = res = rollout(hopper, X0, lanes=lanes, **kw)
        rows = np.flatnonzero(res.unsolved)
        warned = [str(w.message) for w in said if "left unsolved" in str(w.message)]
        assert len(warned) == 1, [str(w.message) for w in said]
        assert (f"rl_hopper: rollout: {rows.size} of 9 row(s) ran to the end with implicitfast (sub-)steps left "
                f"unsolved (rows {', '.join(map(str, rows))}; ") in warned[0], warned[0]
    want, got = runs[False], runs[True]
    assert np.array_equal(got.x, want.x) and np.array_equal(got.unsolved, want.unsolved)
    assert want.ok.all() and 0 < np.count_nonzero(want.unsolved) < 9, want.unsolved
    assert np.array_equal(want.clean, want.unsolved == 0) and np.array_equal(got.clean, want.clean)
    for i in (int(np.flatnonzero(want.unsolved)[0]), int(np.flatnonzero(want.clean)[0])):
        with warnings.catch_warnings(record=True) as seen:
            warnings.simplefilter("always", PhysicsWarning)
            one = simulate(hopper, X0[i], (0.0, 0.48), method="implicitfast", dt=0.008, split=1e-4)
        assert one.status == 0 and np.array_equal(one.x[-1], want.x[i])
        assert one.stats["rejected"] == want.unsolved[i]
        missed = [str(w.message) for w in seen if "still missed implicit Euler" in str(w.message)]
        assert missed == ([f"rl_hopper: implicitfast: {want.unsolved[i]} step(s) of 1/64 dt still missed implicit "
                           f"Euler: after Newton iterations the step's Newton correction was more than 0.002 x the "
                           f"step's own change of the speeds (a hard impact, or the solution blows up); a smaller "
                           f"dt, or an adaptive method (the default 'auto'), checks the result"]
                          if want.unsolved[i] else []), missed


def test_a_row_whose_try_needs_the_start_matrix_after_an_answer_ahead_is_the_scalar_row(hopper):
    """A lanes row's try that passes with a contact touching down from in touch is measured with
    the start's matrix A as well (eomc_fixedstep.c, fs_onset / fs_start_ratio), which the row writes
    first when the lanes made the try's du without writing A (they answered the last try ahead).
    Whether A was unwritten was asked after this try's own answer had replaced the mark (q->bare:
    then A1's), so such a row measured with a stale A and left the scalar row's path: row 22 of
    these 64 starts at 2 ms (measured, session 22: the only one; now each row is the scalar row's
    bits)."""
    X0 = _hopper_starts(hopper, 64)
    kw = dict(dt=0.002, steps=250, method="implicitfast", threads=1)
    want = rollout(hopper, X0, **kw)
    got = rollout(hopper, X0, lanes=True, **kw)
    assert got.ok.all() and want.ok.all()
    assert np.array_equal(got.x, want.x) and np.array_equal(got.steps, want.steps)
    assert np.array_equal(got.unsolved, want.unsolved)


@pytest.fixture(scope="module")
def hopper_bench(tmp_path_factory):
    """The hopper as bench_rollout_contacts builds it: the default functions and implicit_batch
    (so outputs and energy: NAME_implicit ends with the energy and the rollout's energy watch is
    on) and the default flags with this machine's (-mavx2 -ffp-contract=off ... where it has AVX2),
    plus -DEOMC_BATCH_LIBM_TRIG: libm's sin/cos in the lanes."""
    from eomc.compiler.build.toolchain import DEFAULT_CFLAGS, find_compiler, machine_flags
    from eomc.compiler.emit.signatures import FUNCTION_ORDER, ON_REQUEST
    functions = tuple(f for f in FUNCTION_ORDER if f not in ON_REQUEST) + ("implicit_batch",)
    return gym_model("hopper.xml", "rl_hopper_bench", tmp_path_factory.mktemp("rlhb"), functions,
                     cflags=[*DEFAULT_CFLAGS, *machine_flags(find_compiler()), "-DEOMC_BATCH_LIBM_TRIG"])


def test_the_benchmarks_build_with_libm_trig_gives_the_scalar_rows_over_a_second(hopper_bench):
    """bench_rollout_contacts' hopper build (default functions + implicit_batch, the energy watch
    on) with -DEOMC_BATCH_LIBM_TRIG: 64 starts, one second at the file's 2 ms, every row the scalar
    row's bits.  Built as the bench builds it (the vector sin/cos) the same rows differ from the
    scalar rows in all 64 (first at steps 41-261, up to 3.8e-13 after 1 s; measured session 23,
    AVX-512, 8 lanes): the difference is the lanes' sin/cos alone."""
    from eomc.runtime.rollout import _energy_watch
    assert _energy_watch(hopper_bench) > 0                  # the watch's path, unlike `hopper`'s build
    X0 = _hopper_starts(hopper_bench, 64)
    kw = dict(dt=0.002, steps=500, method="implicitfast", threads=2)
    want = rollout(hopper_bench, X0, **kw)
    got = rollout(hopper_bench, X0, lanes=True, **kw)
    assert np.array_equal(got.status, want.status) and np.array_equal(got.steps, want.steps)
    assert np.array_equal(got.x, want.x) and np.array_equal(got.unsolved, want.unsolved)
    assert want.ok.sum() > 32                               # most rows end clean (not all-failed rows)


def test_groups_of_several_lanes_equal_the_scalar_rollout(hopper):
    """Many more rows than lanes on 2 threads: a fiber whose row ends takes the job's next row
    (eomc_rollout.c, take_row); every row still the scalar row's bits."""
    from eomc.runtime.cpu import machine_lanes
    X0 = _hopper_starts(hopper, 2 * 16 * machine_lanes() + 3, seed=7)
    kw = dict(dt=0.008, steps=30, method="implicitfast", threads=2)
    want = rollout(hopper, X0, **kw)
    got = rollout(hopper, X0, lanes=True, **kw)
    assert got.ok.all() and np.array_equal(got.x, want.x) and np.array_equal(got.steps, want.steps)
    assert np.array_equal(got.unsolved, want.unsolved)


def test_implicitfast_lanes_without_the_residual_test_equal_the_scalar_rollout(hopper):
    """split=0 (one model call a step, no residual test): the lanes kernel is asked for no ratio,
    only the step's matrix and the next try's du and rate (eomc_fs_request.du NULL), and each row
    still equals the scalar rollout's bit for bit -- a run that differs from the checked one."""
    X0 = _hopper_starts(hopper, 9, seed=5)
    kw = dict(dt=0.008, steps=40, method="implicitfast", threads=1)
    want = rollout(hopper, X0, split=0, **kw)
    got = rollout(hopper, X0, split=0, lanes=True, **kw)
    assert got.ok.all() and np.array_equal(got.x, want.x) and np.array_equal(got.steps, want.steps)
    assert not np.array_equal(want.x, rollout(hopper, X0, **kw).x)      # the checked rows split steps


def test_rows_at_times_an_ulp_apart_share_a_batch_only_when_the_model_ignores_t(hopper, monkeypatch):
    """The hopper's NAME_implicit does not read t (the compiler's implicit_batch.reads_t), so the
    scheduler batches waiting rows whatever their times -- a split step's sub-steps end an ulp off
    the other rows' (the tests above run that path).  A model that reads t keeps the exact test
    (the batch takes one t): forced here on the hopper, its rows too equal the scalar rollout."""
    assert hopper.metadata["implicit_batch"]["reads_t"] is False
    import eomc.runtime.rollout as ro
    X0 = _hopper_starts(hopper, 13, seed=4)
    kw = dict(dt=0.008, steps=50, method="implicitfast", threads=1)
    want = rollout(hopper, X0, **kw)
    monkeypatch.setattr(ro, "_implicit_reads_t", lambda model: 1)
    got = rollout(hopper, X0, lanes=True, **kw)
    assert got.ok.all() and np.array_equal(got.x, want.x) and np.array_equal(got.steps, want.steps)
    assert np.array_equal(got.unsolved, want.unsolved)


def test_a_batch_that_is_the_scalar_function_row_by_row_runs_the_scalar_rows(hopper, monkeypatch):
    """Session 52: dm_control's humanoid_CMU's NAME_implicit_batch is its scalar NAME_implicit row by
    row (its ground table is a statement the lanes lowering does not take: metadata
    implicit_batch.vectorized false), and lanes=True took 5.8x the scalar rollout's CPU moving its
    37297 outputs a call into the batch's columns and back.  Such a model now runs the scalar rows
    (the same bits): forced here on the hopper, the batch function is never called."""
    import eomc.runtime.rollout as ro
    X0 = _hopper_starts(hopper, 9, seed=5)
    kw = dict(dt=0.008, steps=40, method="implicitfast", threads=1)
    want = rollout(hopper, X0, **kw)

    def no_batch(*args, **kwargs):
        raise AssertionError("the lanes path ran")
    monkeypatch.setattr(ro, "_implicit_batch", no_batch)
    monkeypatch.setitem(hopper.metadata, "implicit_batch", {**hopper.metadata["implicit_batch"], "vectorized": False})
    got = rollout(hopper, X0, lanes=True, **kw)
    assert got.ok.all() and np.array_equal(got.x, want.x) and np.array_equal(got.steps, want.steps)
    monkeypatch.setitem(hopper.metadata, "implicit_batch", {**hopper.metadata["implicit_batch"], "vectorized": True})
    with pytest.raises(AssertionError, match="the lanes path ran"):
        rollout(hopper, X0, lanes=True, **kw)


def test_implicitfast_lanes_with_a_parameter_row_per_trajectory(hopper):
    """Rows with their own parameters share a batch call only with equal rows: each is its own."""
    X0 = _hopper_starts(hopper, 6, seed=1)
    masses = [k for k, name in enumerate(hopper.param_names) if name.startswith("m_")]
    P = np.tile(np.asarray(hopper.param_defaults, dtype=float), (6, 1))
    P[:, masses] *= np.random.default_rng(2).uniform(0.8, 1.2, (6, len(masses)))   # the links' masses per row
    kw = dict(dt=0.008, steps=30, method="implicitfast", p=P)
    want = rollout(hopper, X0, **kw)
    got = rollout(hopper, X0, lanes=True, **kw)
    assert np.array_equal(got.x, want.x) and np.array_equal(got.status, want.status)
    assert np.abs(rollout(hopper, X0, dt=0.008, steps=30, method="implicitfast", lanes=True).x - got.x).max() > 1e-6


def test_a_lane_whose_pivot_fails_is_assembled_by_the_scalar_code(hopper, monkeypatch):
    """The step's matrix in lanes (eomc_fs_assemble_lanes, eomc_fs_lanes_body.h): a lane whose pivot
    test fails is marked and not written out, the group's other lanes go on, and its row assembles
    its own step (the scalar fs_assemble).  No data can show it: a lane fails exactly where its
    row's own assembly fails (the same arithmetic), and that failure is found again at the next
    step's start.  So the test hook $EOMC_TEST_FS_LANES_FAIL marks lanes 1 and 2 of every group
    failed: their rows take the fallback at every step, and must equal the scalar rollout bit for
    bit (rows that took the unwritten matrix instead would step with a stale one)."""
    X0 = _hopper_starts(hopper, 11, seed=3)
    kw = dict(dt=0.008, steps=40, method="implicitfast", threads=1)
    want = rollout(hopper, X0, **kw)
    monkeypatch.setenv("EOMC_TEST_FS_LANES_FAIL", "6")
    got = rollout(hopper, X0, lanes=True, **kw)
    assert got.ok.all() and np.array_equal(got.x, want.x) and np.array_equal(got.steps, want.steps)
    assert np.array_equal(got.unsolved, want.unsolved)


def test_lanes_that_pass_beside_lanes_whose_pivot_fails(hopper):
    """Real zero pivots beside real passes in one batch call: a foot with no mass, inertia,
    armature or damping has a zero pivot in the air and a contact's slopes on it when pressed,
    and one parameter vector for all rows puts both kinds in the same groups.  Each row equals
    the scalar rollout's bit for bit, its status included (the singular rows' and the ones
    penetrating the ground at such a soft foot)."""
    names = list(hopper.param_names)
    p = np.asarray(hopper.param_defaults, dtype=float).copy()
    for name in ("m_foot", "Iyy_foot", "arm_foot_joint", "d_foot_joint"):
        p[names.index(name)] = 0.0
    X0 = _hopper_starts(hopper, 16, seed=2)
    z = list(hopper.state_names).index("q_rootz")
    X0[:, z] -= np.linspace(0.0, 0.2, 16)         # in the air ... pressed
    X0[:, hopper.nq + z] = 0.0
    kw = dict(dt=0.008, steps=60, method="implicitfast", p=p, raise_on_failure=False)
    want = rollout(hopper, X0, **kw)
    got = rollout(hopper, X0, lanes=True, **kw)
    assert np.array_equal(got.x, want.x) and np.array_equal(got.status, want.status)
    assert np.array_equal(got.steps, want.steps) and np.array_equal(got.unsolved, want.unsolved)
    singular = want.status == 1           # EOMC_SINGULAR_MASS_MATRIX: the zero pivot, at the first step
    assert singular.sum() >= 3 and (want.steps[singular] == 1).all()
    assert ((want.status == 0) & (want.steps == 60)).sum() >= 2      # pressed rows in the same calls ran on


def test_implicitfast_lanes_refused_without_implicit_batch(tmp_path):
    plain = gym_model("hopper.xml", "rl_hplain", tmp_path, ("rhs", "implicit"))
    with pytest.raises(ValueError, match="built without implicit_batch"):
        rollout(plain, _hopper_starts(plain, 2), dt=0.008, steps=2, method="implicitfast", lanes=True)


def test_implicitfast_lanes_turn_a_free_joints_momentum_as_the_scalar_path(tmp_path):
    """A free ball (tests/runtime/test_implicitfast_terms.py's rolling ball) thrown spinning and
    rolling: the lanes kernel's fs_transport (the root free joint's momentum turning, half
    implicit) gives the scalar rollout's rows bit for bit, and without it (eomc_implicit.nfree
    0 on both paths) the rows differ -- so the term ran in both.  (Measured: without it row 9,
    thrown at 11 m/s turning at 10 rad/s, blew up on landing -- status 10, speeds of thousands of m/s --
    on both paths alike; with it every row ends fine.)"""
    import warnings
    from eomc.compiler.mjcf.model import MjcfModel
    from eomc.runtime.simulate import implicit_terms
    from .test_implicitfast_terms import ROLLING
    path = tmp_path / "rolling.xml"
    path.write_text(ROLLING)
    ball = compile_model(MjcfModel(path), "rl_rolling", functions=("rhs", "outputs", "implicit", "implicit_batch"),
                         cache_dir=tmp_path, progress=False, cflags="-O2 -std=c99 -fPIC -DEOMC_BATCH_LIBM_TRIG")
    rng = np.random.default_rng(3)
    X0 = np.zeros((11, ball.nx))
    X0[:, list(ball.quaternions)] = 1.0                  # upright (the MJCF default: a quaternion's w)
    X0[:, 2] = rng.uniform(0.0995, 0.3, 11)               # some in touch, some landing
    X0[:, ball.nq:] = rng.uniform(-10.0, 10.0, (11, ball.nu))
    kw = dict(dt=0.002, steps=100, method="implicitfast", threads=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")                  # landings leave sub-steps unsolved (warned)
        want = rollout(ball, X0, **kw)
        got = rollout(ball, X0, lanes=True, **kw)
    assert got.ok.all() and np.array_equal(got.x, want.x) and np.array_equal(got.steps, want.steps)
    assert np.array_equal(got.unsolved, want.unsolved)
    imp = implicit_terms(ball)
    assert imp.nfree == 1
    imp.nfree = 0
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            off = rollout(ball, X0, raise_on_failure=False, **kw)
            off_lanes = rollout(ball, X0, lanes=True, raise_on_failure=False, **kw)
        assert np.array_equal(off_lanes.x, off.x) and np.array_equal(off_lanes.ok, off.ok)
    finally:
        imp.nfree = 1
    assert not np.array_equal(off.x, want.x)


@pytest.mark.parametrize("name", ["ball", "frames", "pair"])
def test_implicitfast_lanes_take_a_joint_of_several_speeds_bias_as_the_scalar_path(tmp_path, name):
    """A contact below a joint of several speeds (test_implicitfast_terms's ball arm on a slide, and
    its URDF with a floating joint and a planar joint below hinges, their tips on the floor; two
    ball-jointed arms pressing on each other, a pair through the pair table): the
    lanes kernel's FSL_BIAS takes each joint speed's velocity before its joint
    (eomc_implicit.joint) as the scalar fs_point_bias does, bit for bit, and without it (joint NULL on
    both paths: before session 29) the rows differ -- so the joint's bias ran in both."""
    import warnings
    from eomc.compiler.mjcf.model import MjcfModel
    from eomc.runtime.simulate import implicit_terms
    from eomc.compiler.contact import pairs
    from .test_implicitfast_terms import _BALL_ARM, _BALL_PAIR, _FRAMES_URDF, _LOWER, _touching
    kw = dict(cache_dir=tmp_path, progress=False, cflags="-O2 -std=c99 -fPIC -DEOMC_BATCH_LIBM_TRIG",
              functions=("rhs", "outputs", "implicit", "implicit_batch"))
    if name == "pair":                                    # (one pair: through the table, with slopes)
        (tmp_path / "ball_pair.xml").write_text(_BALL_PAIR)
        table_from, pairs.TABLE_FROM = pairs.TABLE_FROM, 1
        try:
            m = compile_model(MjcfModel(tmp_path / "ball_pair.xml"), "rl_ball_pair", **kw)
        finally:
            pairs.TABLE_FROM = table_from
    elif name == "ball":
        (tmp_path / "ball_arm.xml").write_text(_BALL_ARM)
        m = compile_model(MjcfModel(tmp_path / "ball_arm.xml"), "rl_ball_arm", **kw)
    else:
        (tmp_path / "frames.urdf").write_text(_FRAMES_URDF)
        m = compile_model(str(tmp_path / "frames.urdf"), "rl_frames", ground=True, **kw)
    rng = np.random.default_rng(7)
    X0 = np.zeros((13, m.nx)) if m.initial_state is None else np.tile(np.array(m.initial_state, float), (13, 1))
    X0[:, :m.nq] += rng.uniform(-0.3, 0.3, (13, m.nq))
    X0[:, m.nq:] = rng.uniform(-2.0, 2.0, (13, m.nu))
    contacts = [c["name"] for c in m.metadata["implicit"]["contacts"]]
    if name == "pair":                                    # the arms pressed together, off the floor
        X0[:, :m.nq] = np.array(m.initial_state, float)[:m.nq] + rng.uniform(-0.05, 0.05, (13, m.nq))
        X0[:, m.nq:] = rng.uniform(-1.0, 1.0, (13, m.nu))
    for i in range(13 if name != "pair" else 0):          # each tip 0.5 cm in touch
        for contact, coordinate in _LOWER[name].items():
            X0[i] = _touching(m, X0[i], contacts.index(contact), coordinate, depth=0.005)
    run = dict(dt=0.002, steps=100 if name != "pair" else 30, method="implicitfast", threads=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        want = rollout(m, X0, raise_on_failure=False, **run)
        got = rollout(m, X0, lanes=True, raise_on_failure=False, **run)
    assert want.ok.sum() >= 10 and np.array_equal(got.ok, want.ok)      # (a hard landing may go too deep)
    assert np.array_equal(got.x, want.x) and np.array_equal(got.steps, want.steps)
    assert np.array_equal(got.unsolved, want.unsolved)
    imp = implicit_terms(m)
    joint, imp.joint = imp.joint, m.ffi.NULL
    assert joint != m.ffi.NULL
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            off = rollout(m, X0, raise_on_failure=False, **run)
            off_lanes = rollout(m, X0, lanes=True, raise_on_failure=False, **run)
        assert np.array_equal(off_lanes.x, off.x, equal_nan=True) and np.array_equal(off_lanes.ok, off.ok)
    finally:
        imp.joint = joint
    assert not np.array_equal(off.x, want.x)


def _wrapped_batch(model, monkeypatch, after):
    """rollout's NAME_implicit_batch replaced by a cffi callback that makes the real call, then
    after(n, OUT, X) with OUT (size, n) and X (nx, n) as arrays over the batch's columns."""
    import eomc.runtime.rollout as ro
    size = model.metadata["implicit"]["layout"]["size"]
    original, keep = ro._implicit_batch, []

    def batch(model_, ffi):
        real = original(model_, ffi)

        def call(n, t, X, p, R, OUT, status, work):
            s = real(n, t, X, p, R, OUT, status, work)
            after(n, np.frombuffer(ffi.buffer(OUT, size * n * 8), dtype=float).reshape(size, n),
                  np.frombuffer(ffi.buffer(X, model_.nx * n * 8), dtype=float).reshape(model_.nx, n))
            return s
        keep.append(ffi.callback("eomc_batch_fn", call))
        return keep[-1]
    monkeypatch.setattr(ro, "_implicit_batch", batch)


def test_a_tail_of_rows_is_padded_to_a_whole_batch(hopper, monkeypatch):
    """Rows that end at different times leave rounds of fewer waiting calls than lanes: each is
    one batch call padded with the first row's call again (its extra lanes dropped) -- down to one
    row, never the scalar call, whose libm sin/cos would make a row's bits depend on the rows
    beside it (eomc_rollout.c, lanes_run).  Seen through the batch: rounds whose last columns
    repeat the first, some with fewer than half the lanes; the rows still equal the scalar rollout
    bit for bit."""
    X0 = _hopper_starts(hopper, 21, seed=6)       # 21 rows: the last rounds hold 1 .. 7 of them
    kw = dict(dt=0.008, steps=40, method="implicitfast", threads=1)
    want = rollout(hopper, X0, **kw)
    rounds = []

    def seen(n, OUT, X):
        distinct = 1 + max((k for k in range(1, n) if not np.array_equal(X[:, k], X[:, 0])), default=0)
        rounds.append((n, distinct))
    _wrapped_batch(hopper, monkeypatch, seen)
    got = rollout(hopper, X0, lanes=True, **kw)
    assert got.ok.all() and np.array_equal(got.x, want.x) and np.array_equal(got.steps, want.steps)
    assert np.array_equal(got.unsolved, want.unsolved)
    lanes = rounds[0][0]
    padded = [d for n, d in rounds if d < n]
    assert all(n == lanes for n, d in rounds)
    assert padded and min(padded) < (lanes + 1) // 2           # padded rounds, also below half the lanes


def test_outputs_the_terms_never_change_are_not_copied_from_the_batch(hopper, monkeypatch):
    """A model whose NAME_implicit has constant outputs (NAME_implicit_const, written once into
    each of a row's buffers) gets only the others copied from the batch's columns into a row's
    buffer (eomc_rollout.c: var_outputs).  Shown by a batch whose constant outputs are NaN after
    the call and the lanes' own assembly marked failed in every lane ($EOMC_TEST_FS_LANES_FAIL):
    every row assembles its step from its buffer, and still equals the scalar rollout bit for bit
    (a copied NaN would not)."""
    from eomc.runtime.simulate import _const_apart
    assert _const_apart(hopper) is not None
    size = hopper.metadata["implicit"]["layout"]["size"]
    probe = np.full(size, np.nan)
    hopper.ffi.cast("void (*)(double *)", _const_apart(hopper)[1])(hopper.ffi.from_buffer("double[]", probe))
    const = ~np.isnan(probe)
    assert 8 <= const.sum() < size
    X0 = _hopper_starts(hopper, 11, seed=7)
    kw = dict(dt=0.008, steps=30, method="implicitfast", threads=1)
    want = rollout(hopper, X0, **kw)

    def poison(n, OUT, X):
        OUT[const, :] = np.nan
    monkeypatch.setenv("EOMC_TEST_FS_LANES_FAIL", "0xff")
    _wrapped_batch(hopper, monkeypatch, poison)
    got = rollout(hopper, X0, lanes=True, **kw)
    assert got.ok.all() and np.array_equal(got.x, want.x) and np.array_equal(got.steps, want.steps)
    assert np.array_equal(got.unsolved, want.unsolved)
