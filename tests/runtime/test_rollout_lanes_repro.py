"""eomc.rollout(lanes=True, method="implicitfast") gives the same numbers every run.

With the lanes' vector sin/cos (a model built without -DEOMC_BATCH_LIBM_TRIG) a row's call made in
a batch differs from the scalar call in the last bits, so a row's result depends on which of its
calls were batched and which ran alone (a tail round below PAD_MIN lanes).  That is fixed by the
rows: each thread takes groups of consecutive rows (`lanes` of them, more with many rows), a
group's rows run in the thread's fibers from their start to their end (eomc_rollout.c,
take_group), so the rounds depend on the group's rows alone -- not on the thread timing, nor on the thread count.  Oracle: the same
rollout again, and with 1 thread; the gym hopper with its contacts and split steps.
"""
from pathlib import Path

import numpy as np
import pytest

from eomc.compiler.driver import compile as compile_model
from eomc.runtime.rollout import rollout


@pytest.fixture(scope="module")
def hopper_vec(tmp_path_factory):
    import warnings
    gymnasium = pytest.importorskip("gymnasium")
    from eomc.compiler.mjcf.model import MjcfModel
    path = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / "hopper.xml"
    with warnings.catch_warnings():      # the file's self-collision pairs left out (said by a warning)
        warnings.simplefilter("ignore")
        return compile_model(MjcfModel(path), "rl_hopper_vec", functions=("rhs", "implicit", "implicit_batch"),
                             cache_dir=tmp_path_factory.mktemp("rlhv"), progress=False,
                             cflags="-O2 -std=c99 -fPIC")        # the vector sin/cos


def _starts(model, n, seed=0):
    X0 = np.tile(np.array(model.initial_state, dtype=float), (n, 1))
    X0[:, model.nq:] = np.random.default_rng(seed).uniform(-0.5, 0.5, (n, model.nu))
    return X0


def test_lanes_rows_are_the_same_every_run_and_with_any_thread_count(hopper_vec):
    X0 = _starts(hopper_vec, 61, seed=3)       # not a multiple of the lanes: a short last group
    kw = dict(dt=0.002, steps=400, method="implicitfast", lanes=True)
    one = rollout(hopper_vec, X0, threads=1, **kw)
    assert one.ok.all()
    for threads in (2, 2, 2, 3):
        again = rollout(hopper_vec, X0, threads=threads, **kw)
        assert np.array_equal(again.x, one.x) and np.array_equal(again.steps, one.steps)
        assert np.array_equal(again.unsolved, one.unsolved)
    # the vector sin/cos is on: the lanes rows are not the scalar rows' bits (so the rounds matter)
    scalar = rollout(hopper_vec, X0, threads=2, dt=0.002, steps=400, method="implicitfast")
    assert not np.array_equal(scalar.x, one.x)
    assert np.allclose(scalar.x, one.x, rtol=0, atol=1e-9)


def test_groups_larger_than_the_lanes_are_the_same_with_any_thread_count(hopper_vec):
    """From 32 groups' worth of rows up a group holds several lanes' worth (eomc_rollout.c:
    EOMC_ROLLOUT_GROUPS), its fibers taking its next row in order when theirs end: still the
    rows alone fix the rounds."""
    from eomc.runtime.cpu import machine_lanes
    n = 2 * 16 * machine_lanes() + 5          # groups of 2 lanes' rows, a short last one
    X0 = _starts(hopper_vec, n, seed=8)
    kw = dict(dt=0.004, steps=60, method="implicitfast", lanes=True)
    one = rollout(hopper_vec, X0, threads=1, **kw)
    assert one.ok.all()
    for threads in (2, 3):
        again = rollout(hopper_vec, X0, threads=threads, **kw)
        assert np.array_equal(again.x, one.x) and np.array_equal(again.steps, one.steps)
