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
