"""eomc.rollout(lanes=True, method="implicitfast") gives the same numbers every run.

With the lanes' vector sin/cos (a model built without -DEOMC_BATCH_LIBM_TRIG) a row's call made in
a batch differs from the scalar call in the last bits.  Every call of a lanes rollout is a batch
lane (a round of fewer rows than lanes is padded, never made by the scalar call: eomc_rollout.c,
lanes_run), and a lane's sin/cos depends on its own argument alone (compiler/emit/batch.py: each
reduction round taken only in the lanes that need it), so a row's bits depend on that row alone:
not on the rows that share its rounds, the thread timing or the thread count (session 19 had rows
in fixed groups instead, whose rows' bits depended on the group's other rows).  Oracle: the same
rollout again, with other thread counts, and the rows run among other rows; the gym hopper with
its contacts and split steps.
"""
import numpy as np
import pytest

from helpers.mjcf_builds import gym_model

from eomc.runtime.rollout import rollout


@pytest.fixture(scope="module")
def hopper_vec(tmp_path_factory):
    return gym_model("hopper.xml", "rl_hopper_vec", tmp_path_factory.mktemp("rlhv"),
                     ("rhs", "implicit", "implicit_batch"), cflags="-O2 -std=c99 -fPIC")     # the vector sin/cos


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
    """Many rows per thread, each fiber taking the job's next row when its row ends (in an order
    the threads' timing sets): still the same bits with any thread count."""
    from eomc.runtime.cpu import machine_lanes
    n = 2 * 16 * machine_lanes() + 5          # not a multiple of the lanes
    X0 = _starts(hopper_vec, n, seed=8)
    kw = dict(dt=0.004, steps=60, method="implicitfast", lanes=True)
    one = rollout(hopper_vec, X0, threads=1, **kw)
    assert one.ok.all()
    for threads in (2, 3):
        again = rollout(hopper_vec, X0, threads=threads, **kw)
        assert np.array_equal(again.x, one.x) and np.array_equal(again.steps, one.steps)


def test_a_rows_bits_do_not_depend_on_the_rows_beside_it(hopper_vec):
    """A row run among other rows -- a subset of the rows, in another order, so that other rows
    share its rounds and its calls fall in other lanes -- gives the same bits: every call is a batch
    lane, and a lane's vector sin/cos is its own (failed before: rows in fixed groups, a tail round
    of fewer than half the lanes made by the scalar call, the sin/cos's 2nd reduction round taken
    in every lane when one lane needed it)."""
    X0 = _starts(hopper_vec, 40, seed=5)
    kw = dict(dt=0.002, steps=400, method="implicitfast", lanes=True, threads=1)
    full = rollout(hopper_vec, X0, **kw)
    assert full.ok.all()
    for rows in (np.arange(40)[::-1], np.arange(3, 14), np.array([17, 2, 33, 9, 25]), np.array([11])):
        part = rollout(hopper_vec, X0[rows], **kw)
        assert np.array_equal(part.x, full.x[rows]) and np.array_equal(part.steps, full.steps[rows])
        assert np.array_equal(part.unsolved, full.unsolved[rows])
