"""A model with extra first-order states, built to a directory and used without the compiler:
state_names, nz, NAME.json, the header, initial_state naming a state, the CSV of
`eomc simulate` and an exact solution of the state's ODE.

The model (helpers.state_models.PENDULUM_Z + a motor state): z' = (e - z)/tau drives the
pendulum's torque k·z; with e constant, z(t) = e + (z0 - e)·exp(-t/tau) whatever the
pendulum does, so the integrated z is checked in closed form.
"""
import json

import numpy as np
import pytest

import eomc
from eomc.cli import main
from helpers.state_models import PENDULUM_Z

MODEL = PENDULUM_Z + "states = {z: (e - z) / tau}\ninitial_state = {q: 0.3, z: 0.5}\n" \
        "outputs = {'torque': k * z}\nevents = {'half_way': z - 1.0}\n"


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("pendz")
    (tmp / "pendz.py").write_text(MODEL)
    eomc.compile(tmp / "pendz.py", output_dir=tmp / "out", cache_dir=tmp / "cache")
    return tmp, eomc.load(tmp / "out")


def test_loaded_model_names_its_states(built):
    tmp, model = built
    assert model.state_names == ("q", "u", "z") and (model.nq, model.nu, model.nz, model.nx) == (1, 1, 1, 3)
    np.testing.assert_array_equal(model.initial_state, [0.3, 0.0, 0.5])
    meta = json.loads((tmp / "out" / "pendz.json").read_text())
    assert meta["state_names"] == ["q", "u", "z"] and meta["nx"] == 3
    header = (tmp / "out" / "pendz.h").read_text()
    assert "then nz = 1 extra first-order states" in header and "[2] z" in header


def test_state_follows_its_ode_exactly(built):
    _, model = built
    res = model.simulate(model.initial_state, (0.0, 0.5), r=[2.0], rtol=1e-11, atol=1e-11)
    exact = 2.0 + (0.5 - 2.0) * np.exp(-res.t / 0.1)
    assert np.max(np.abs(res["z"] - exact)) < 1e-8
    np.testing.assert_allclose(res.outputs["torque"], 2.0 * res["z"], rtol=1e-14)
    assert abs(res["q"][-1] - 0.3) > 1e-3         # the torque moved the pendulum
    # an event on the state: z = 1 at t = tau ln(1.5)
    assert abs(res.t_events["half_way"][0] - 0.1 * np.log(1.5)) < 1e-9


def test_cli_simulate_writes_the_states_to_csv(built, tmp_path):
    tmp, model = built
    out = tmp_path / "traj.csv"
    assert main(["simulate", str(tmp / "out"), "--t-final", "0.2", "-o", str(out), "--points", "11",
                 "--input", "e=1.0", "--rtol", "1e-10", "--atol", "1e-10"]) == 0
    data = np.genfromtxt(out, delimiter=",", names=True)
    assert data.dtype.names[:4] == ("t", "q", "u", "z")
    assert data["z"][0] == 0.5
    np.testing.assert_allclose(data["z"], 1.0 - 0.5 * np.exp(-data["t"] / 0.1), atol=1e-8)
