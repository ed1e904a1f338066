"""implicitfast with the body-body pairs' slopes in its matrix (runtime/c/eomc_fixedstep.c: a pair
point's J = J_B - J_A from its signed chain; where a pressed pair joins two branches the
factorisation gets that pair's fill, fs_pattern).

Why: since the MJCF self-pairs default, gymnasium's humanoid had its 109 pairs' forces in
NAME_implicit's f without their slopes, so the fixed step took a pressed pair explicitly: the
residual test split those steps down to h/64 (54 of 334 steps, 499 of 780 calls), and unchecked it
blew up (benchmarks/results/fixedstep.md).  Here on a small scene: a ball thrown at a free body's
trunk and arm (pairs across two trees: the fill), against the same run with the pairs' slopes left
out of the matrix (the old fast path: ncontact cut to the ground's contacts), a tight Radau run, and
the lanes rollout (per call, the fill of the pairs in touch in any of its lanes) bit for bit."""
import warnings

import numpy as np
import pytest

pytest.importorskip("mujoco")

import eomc  # noqa: E402
import eomc.runtime.simulate as simulate_module  # noqa: E402
from eomc.runtime.rollout import rollout  # noqa: E402

from ..compiler.contact.test_narrow import LIMBS  # noqa: E402


@pytest.fixture(scope="module")
def limbs(tmp_path_factory):
    from eomc.compiler.mjcf.model import MjcfModel
    path = tmp_path_factory.mktemp("limbs") / "limbs.xml"
    path.write_text(LIMBS)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return eomc.compile(MjcfModel(path, pairs=True), "lstep", functions=("rhs", "jac_x", "outputs", "implicit",
                                                                                    "implicit_batch"),
                            cache_dir=path.parent / "cache", progress=False,
                            cflags="-O2 -std=c99 -fPIC -DEOMC_BATCH_LIBM_TRIG")


def _thrown(model, speed):
    """The ball (10 mm from the trunk at the start, on the side away from the arm) thrown at the
    trunk across y, both falling."""
    x0 = np.zeros(model.nx)
    x0[list(model.quaternions)] = 1.0       # upright (the MJCF default: each quaternion's w)
    names = list(model.state_names)
    x0[names.index("q_joint0_z")] = 0.3
    x0[names.index("q_joint3_y")] = -0.1
    x0[names.index("q_joint3_z")] = 0.3
    x0[names.index("u_joint3_vy")] = speed
    return x0


def _explicit_pairs(monkeypatch):
    """The fast path without the pairs' slopes in its matrix, as it was: every pair's chain empty
    (J has no columns; their forces are still in f, their depths still seen by the regime test)."""
    plain = simulate_module.implicit_for_run

    def cut(model, p, split=simulate_module.IMPLICITFAST_SPLIT):
        st, keep = plain(model, p, split)
        contacts = model.metadata["implicit"]["contacts"]
        sizes = [0 if c.get("pair") else len(c["speeds"]) for c in contacts]
        starts = model.ffi.new("int[]", np.cumsum([0] + sizes).tolist())
        st.chain_start = starts
        return st, (keep, starts)
    monkeypatch.setattr(simulate_module, "implicit_for_run", cut)


def test_a_pressed_pair_step_is_taken_whole(limbs, monkeypatch):
    m = limbs
    x0 = _thrown(m, 1.0)
    T, dt = 0.1, 0.002
    names = list(m.output_names)
    assert any(c["speeds"][0] >= 10 and min(c["speeds"]) < 0 for c in m.metadata["implicit"]["contacts"])
    new = m.simulate(x0, (0.0, T), method="implicitfast", dt=dt, n_points=51)
    assert new.status == 0
    touched = new.outputs["depth_trunk__ball"].max()
    assert 0 < touched < 0.02                        # the ball presses on the trunk and bounces
    ref = m.simulate(x0, (0.0, T), method="radau", rtol=1e-10, atol=1e-10, t_eval=[T])
    err_new = np.abs(new.x[-1][:m.nq] - ref.x[-1][:m.nq]).max()
    with monkeypatch.context() as mp:
        _explicit_pairs(mp)
        old = m.simulate(x0, (0.0, T), method="implicitfast", dt=dt, n_points=51, raise_on_failure=False)
    err_old = np.abs(old.x[-1][:m.nq] - ref.x[-1][:m.nq]).max()
    steps = round(T / dt)
    # measured: 63 calls for 50 steps with the slopes, 146 without (the touch-down's steps split
    # down to h/64); errors 0.0028 and 0.019 (at 1 ms: 0.0011 and 2.1)
    assert old.status == 0 and new.stats["nfev"] < 1.3 * steps and 2 * new.stats["nfev"] < old.stats["nfev"], (
        new.stats["nfev"], old.stats["nfev"])
    assert err_new < 0.5 * err_old and err_new < 0.005, (err_new, err_old)


@pytest.mark.parametrize("width", ["8", "4"])
def test_lanes_rollout_is_the_scalar_rollout_bit_for_bit(limbs, monkeypatch, width):
    """The lanes assemble with the fill of the pairs in touch in any lane of the group (the kernel's
    pattern per call: M's tree's, grown by the trunk-ball pair's fill while it presses in one of
    them), the scalar rows with the pressed pairs' only: the same bits (the bigger pattern adds exact
    zeros), with either kernel width.  The lanes' calls write the pairs' slope block
    straight into each row's buffer (NAME_implicit_batch_rows; the assembly in lanes reads the pair
    points from the rows): the same rows as with the block through the batch's columns."""
    import eomc.runtime.rollout as rollout_module
    monkeypatch.setenv("EOMC_FS_LANES_WIDTH", width)       # read by each rollout thread
    m = limbs
    # the lanes' kernel is vectorized (the pairs' loop lane by lane, its slopes into out[]), not the
    # scalar loop it falls back to on a call it does not know
    assert m.metadata["implicit_batch"]["vectorized"], m.metadata["implicit_batch"]
    assert rollout_module._implicit_rows_block(m) is not None
    X0 = np.array([_thrown(m, s) for s in np.linspace(0.3, 2.0, 9)])
    X0[:, m.nq + 6:m.nq + 10] = np.random.default_rng(3).uniform(-2, 2, (9, 4))    # the arm swinging
    kw = dict(dt=0.002, steps=60, method="implicitfast")
    want = rollout(m, X0, **kw)
    got = rollout(m, X0, lanes=True, **kw)
    assert want.ok.all() and got.ok.all()
    assert np.array_equal(got.x, want.x) and np.array_equal(got.steps, want.steps)
    assert np.array_equal(got.unsolved, want.unsolved)
    touched = [m.simulate(x, (0.0, 0.12), method="implicitfast", dt=0.002, n_points=61).outputs["depth_trunk__ball"].max()
               for x in X0[::4]]
    assert max(touched) > 0, touched             # a pair pressed within the run
    monkeypatch.setattr(rollout_module, "_implicit_rows_block", lambda model: None)
    cols = rollout(m, X0, lanes=True, **kw)      # the block through the columns (NAME_implicit_batch)
    assert np.array_equal(cols.x, got.x) and np.array_equal(cols.steps, got.steps)
