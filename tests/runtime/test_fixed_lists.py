"""The fast path's fixed lists, made once per model (eomc_implicit.pattern; eomc_fs_pattern).

Why: implicitfast's fast path made M's tree pattern, the contacts' branch masks and M's and N's
column lists at every run's start -- every rollout row -- though they depend on the model alone:
~4 us of a humanoid row's ~19 us in a rollout of one step a call (session 53).  Now the model's
struct carries them, made by the same C (runtime/c/eomc_fixedstep.c fs_fixed_lists), and a run
copies them.

Oracle: the same runs with the struct's pattern left out (a run then makes its lists as before):
the same states bit for bit and the same model calls and factorisations, on the limbs -- a pair
across two branches of the tree (the ball on the trunk: a branch mask that is not 0) pressed, a
ball joint, free joints -- scalar, in lanes, and through simulate.
"""
import warnings

import numpy as np
import pytest

from helpers.mjcf_builds import text_model

import eomc
import eomc.runtime.simulate as simulate_module
from eomc.runtime.simulate import implicit_terms
from tests.runtime.test_rollout_energy_watch import FLOORED, WATCHED


@pytest.fixture(scope="module")
def limbs(tmp_path_factory):
    return text_model(FLOORED, "fl_limbs", tmp_path_factory.mktemp("fl"), WATCHED + ("jac_x",), mjcf=dict(pairs=True))


def _starts(model):
    """The ball dropped onto the trunk lying on the floor (their pair presses), three heights."""
    names = list(model.state_names)
    x0 = np.array(model.initial_state, dtype=float)
    x0[names.index("q_joint0_z")] = 0.05
    x0[names.index("q_joint3_y")] -= 0.1
    x0[names.index("q_joint3_z")] = 0.25
    X0 = np.tile(x0, (6, 1))
    X0[:, names.index("q_joint3_z")] += np.linspace(0.0, 0.05, 6)
    X0[:, model.nq:] = np.random.default_rng(0).uniform(-0.3, 0.3, (6, model.nu))
    return X0


def _runs(model, X0):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        one = model.simulate(X0[0], (0.0, 0.4), method="implicitfast", dt=0.002)
        rows = [eomc.rollout(model, X0, dt=0.002, steps=200, method="implicitfast", lanes=lanes, threads=2,
                             record="steps", raise_on_failure=False) for lanes in (False, True)]
    return one, rows


def test_the_lists_made_once_are_the_ones_a_run_makes(limbs, monkeypatch):
    base = implicit_terms(limbs)
    assert base.pattern != limbs.ffi.NULL and base.pattern_len > 0
    nu, nc = limbs.nu, base.ncontact
    masks = np.frombuffer(limbs.ffi.buffer(base.pattern, base.pattern_len * 8), dtype=np.uint64)[nu:nu + nc]
    assert masks.any()       # a chain across two branches: the pair of the ball and the trunk
    X0 = _starts(limbs)
    one, rows = _runs(limbs, X0)
    pairs = [c["name"] for c in limbs.metadata["implicit"]["contacts"] if c.get("pair")]
    assert max(one.outputs[f"depth_{n}"].max() for n in pairs) > 0        # a pair pressed

    monkeypatch.setattr(simulate_module, "_fixed_lists", lambda model, st: ())
    del limbs.__dict__["_implicit_struct"]      # made again, without the lists: each run makes them
    try:
        assert implicit_terms(limbs).pattern == limbs.ffi.NULL
        plain_one, plain_rows = _runs(limbs, X0)
    finally:
        del limbs.__dict__["_implicit_struct"]
    assert np.array_equal(one.x.view(np.int64), plain_one.x.view(np.int64))
    assert one.stats["nfev"] == plain_one.stats["nfev"] and one.stats["nlu"] == plain_one.stats["nlu"]
    for got, want in zip(rows, plain_rows):
        assert np.array_equal(got.x.view(np.int64), want.x.view(np.int64))
        assert np.array_equal(got.status, want.status) and np.array_equal(got.steps, want.steps)


def test_a_pattern_of_another_length_is_not_read(limbs):
    """A struct whose pattern_len is not this model's (a stale or foreign pattern) makes its lists."""
    base = implicit_terms(limbs)
    st, keep = simulate_module.implicit_for_run(limbs, np.asarray(limbs.param_defaults, dtype=float))
    st.pattern_len = base.pattern_len - 1
    X0 = _starts(limbs)[:1]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        want = limbs.simulate(X0[0], (0.0, 0.1), method="implicitfast", dt=0.002)
    garbage = limbs.ffi.new("double[]", [np.nan] * base.pattern_len)
    st.pattern = garbage        # would be read were the length not checked
    got = _simulate_with(limbs, X0[0], st)
    assert np.array_equal(got.view(np.int64), want.x_final.view(np.int64))


def _simulate_with(model, x0, st):
    """simulate's implicitfast run with the struct ``st`` instead of the model's."""
    saved = model.__dict__["_implicit_struct"]
    model._implicit_struct = (st,) + tuple(saved[1:])
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return model.simulate(x0, (0.0, 0.1), method="implicitfast", dt=0.002).x_final
    finally:
        model._implicit_struct = saved
