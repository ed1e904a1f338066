"""simulate_many equals single runs; cases over states and parameters; failures per case."""

import numpy as np
import pytest

from helpers.stand_in import get_model

from eomc.errors import SimulationError
from eomc.runtime.batch import simulate_many
from eomc.runtime.simulate import simulate


@pytest.mark.parametrize("threads", [1, 2])
def test_batch_over_8_states_equals_8_single_runs(threads):
    m = get_model("pendulum")
    X0 = np.column_stack([np.linspace(0.1, 3.0, 8), np.linspace(-1, 1, 8)])
    batch = simulate_many(m, X0, (0, 5), threads=threads, progress=False, rtol=1e-9, atol=1e-9,
                          n_points=101)
    assert batch.x.shape == (8, 101, 2) and batch.success
    for i in range(8):
        single = simulate(m, X0[i], (0, 5), rtol=1e-9, atol=1e-9, n_points=101)
        np.testing.assert_array_equal(batch.x[i], single.x)
        np.testing.assert_array_equal(batch["energy"][i], single["energy"])
        assert batch.stats[i]["nfev"] == single.stats["nfev"]


def test_batch_over_parameters_and_progress_counter(capsys):
    m = get_model("oscillator")
    P = np.array([[k, 1.0, 0.0] for k in (1.0, 4.0, 9.0)])
    batch = simulate_many(m, [1.0, 0.0], (0, 2), p=P, t_eval=[2.0], rtol=1e-10, atol=1e-12,
                          progress=True)
    np.testing.assert_allclose(batch["q"][:, 0], np.cos(np.sqrt(P[:, 0]) * 2.0), atol=1e-8)
    err = capsys.readouterr().err
    assert "3/3" in err or "simulate" in err


def test_batch_failure_names_the_case():
    m = get_model("singular")
    P = np.array([[2.0], [0.5], [3.0]])
    with pytest.raises(SimulationError, match="case 1 of 3.*the mass matrix is singular"):
        simulate_many(m, [0.0], (0, 1), p=P, progress=False)
    res = simulate_many(m, [0.0], (0, 1), p=P, progress=False, raise_on_failure=False,
                        n_points=11)
    assert list(res.status) == [0, 1, 0]
    assert np.all(np.isnan(res.x[1, -1])) and np.all(np.isfinite(res.x[0]))


def test_batch_shape_errors():
    m = get_model("pendulum")
    with pytest.raises(ValueError, match="x0 has 2 cases but p has 3"):
        simulate_many(m, np.zeros((2, 2)), (0, 1), p=np.ones((3, 2)), progress=False)
    with pytest.raises(ValueError, match=r"\(n_cases, 2\)"):
        simulate_many(m, np.zeros((2, 3)), (0, 1), progress=False)


# ---- issue 24: a batch carries what a single run carries; memory is refused up front ----------
from pathlib import Path  # noqa: E402

import eomc  # noqa: E402

CARTPOLE = str(Path(__file__).resolve().parents[2] / "examples" / "cartpole_lqr.py")


@pytest.fixture(scope="module")
def cartpole():
    """examples/cartpole_lqr.py: its terminal event `fallen` stops an uncontrolled pole."""
    return eomc.compile(CARTPOLE, progress=False)


def _starts(model, angles):
    X0 = np.tile(model.initial_state, (len(angles), 1))
    X0[:, model.state_names.index("th")] = angles
    return X0


def test_terminal_event_cases_carry_the_final_state_and_the_events(cartpole):
    """N2: status 0 with x_final = the event state, as simulate() gives it, not the NaN grid rows."""
    X0 = _starts(cartpole, [3.0, 2.9, 2.5])
    batch = simulate_many(cartpole, X0, (0, 10), progress=False, n_points=201, threads=2)
    assert batch.success and batch.event_stop == ["fallen"] * 3
    for i in range(3):
        single = simulate(cartpole, X0[i], (0, 10), n_points=201)
        assert single.event_stop == "fallen" and single.t_final < 10
        np.testing.assert_array_equal(batch.x_final[i], single.x_final)
        assert batch.t_final[i] == single.t_final
        np.testing.assert_array_equal(batch.t_events[i]["fallen"], single.t_events["fallen"])
        np.testing.assert_array_equal(batch.x_events[i]["fallen"], single.x_events["fallen"])
        n = len(single.t)
        np.testing.assert_array_equal(batch.x[i, :n], single.x)
        assert np.all(np.isnan(batch.x[i, n:]))          # after the stop: no made-up rows
    assert np.all(np.isfinite(batch.x_final))


def test_events_given_to_simulate_many_are_kept(cartpole):
    X0 = _starts(cartpole, [3.0, 3.1])
    batch = simulate_many(cartpole, X0, (0, 3), progress=False, n_points=11,
                          events={"fallen": {"terminal": False}})
    assert batch.event_stop == [None, None] and batch.t_final.tolist() == [3.0, 3.0]
    for i in range(2):
        single = simulate(cartpole, X0[i], (0, 3), n_points=11, events={"fallen": {"terminal": False}})
        np.testing.assert_array_equal(batch.t_events[i]["fallen"], single.t_events["fallen"])


def test_a_batch_too_large_for_memory_is_refused_with_the_figure(cartpole, monkeypatch):
    """N12: 10**6 cases x 1001 rows of 4 states and an output (~39 GiB) is refused before any
    case is prepared or run (the limit is half the machine's memory; fixed here at 8 GiB so the
    test does not depend on the machine)."""
    from eomc.runtime import batch as batch_module
    monkeypatch.setattr(batch_module, "_memory_limit", lambda: 2 ** 33)
    prepared = []
    prepare = batch_module.prepare
    monkeypatch.setattr(batch_module, "prepare", lambda *a, **k: prepared.append(1) or prepare(*a, **k))
    X0 = np.tile(cartpole.initial_state, (10 ** 6, 1))
    with pytest.raises(ValueError, match=r"1000000 cases x 1001 rows x 5 columns \(states and outputs\) "
                                         r"would need 39\.\d GiB, more than .* \(8 GiB"):
        simulate_many(cartpole, X0, (0, 1e-9), progress=False)
    assert len(prepared) == 1   # refused up front: after the first case (its rows size the batch), not every case


def test_case_errors_name_the_case(cartpole):
    X0 = _starts(cartpole, [3.0, np.nan, 3.0])
    with pytest.raises(ValueError, match=r"case 1 of 3: cartpole: x0 \(initial state\) is not finite for th"):
        simulate_many(cartpole, X0, (0, 1), progress=False)


def test_plain_cases_run_through_rollout_in_blocks_equal_to_single_runs(monkeypatch):
    """Cases without events or inputs go through eomc_rollout's C threads (issue 31) block by
    block: each case still equals its own simulate() bit for bit, stats included, and a
    failed case is run again the ordinary way, so it carries simulate's message."""
    import eomc.runtime.batch as batch
    import eomc.runtime.simulate as sim
    m = get_model("singular")
    P = np.array([[2.0], [1.5], [0.5], [3.0], [2.5], [0.5], [4.0]])
    monkeypatch.setattr(batch, "ROLLOUT_BLOCK", 3)          # three blocks, the last one short
    calls = []
    real = batch.run_prepared
    monkeypatch.setattr(batch, "run_prepared", lambda *a, **k: calls.append(1) or real(*a, **k))
    res = simulate_many(m, [0.3], (0, 1), p=P, threads=2, progress=False, raise_on_failure=False,
                        n_points=11, rtol=1e-9, atol=1e-9)
    assert len(calls) == 2          # only the two failing cases ran outside eomc_rollout
    assert list(res.status) == [0, 0, 1, 0, 0, 1, 0]
    for i in range(len(P)):
        single = sim.simulate(m, [0.3], (0, 1), p=P[i], n_points=11, rtol=1e-9, atol=1e-9,
                              raise_on_failure=False)
        np.testing.assert_array_equal(res.x[i], np.vstack([single.x, np.full((11 - len(single.t), 1),
                                                                            np.nan)]))
        np.testing.assert_array_equal(res.x_final[i], single.x_final)
        assert res.stats[i] == single.stats and res.messages[i] == single.message


def test_inputs_per_case_run_through_rollout(monkeypatch):
    """Constant inputs per case (and a shared input table) are rows of eomc_rollout's input
    grid: no case leaves the C threads, and each equals its own simulate() bit for bit."""
    import eomc.runtime.batch as batch
    m = get_model("oscillator")
    R = np.linspace(-1.0, 1.0, 5)[:, None]
    calls = []
    real = batch.run_prepared
    monkeypatch.setattr(batch, "run_prepared", lambda *a, **k: calls.append(1) or real(*a, **k))
    res = simulate_many(m, [0.5, 0.0], (0, 2), r=R, progress=False, n_points=21)
    table = (np.array([0.0, 1.0, 2.0]), np.array([[0.0], [1.0], [-1.0]]))
    shared = simulate_many(m, np.array([[0.5, 0.0], [0.2, 0.1]]), (0, 2), r=table, progress=False, n_points=21)
    assert not calls and res.success and shared.success
    for i in range(5):
        np.testing.assert_array_equal(res.x[i], simulate(m, [0.5, 0.0], (0, 2), r=R[i], n_points=21).x)
    np.testing.assert_array_equal(shared.x[1], simulate(m, [0.2, 0.1], (0, 2), r=table, n_points=21).x)
