"""The Kane model files in examples/ run, form, validate and conserve what they should."""
import pathlib
import random
import runpy

import pytest
import sympy as sm

from eomc.compiler.mechanics.formed import FormedSystem
from eomc.compiler.model.spec import model_spec

EXAMPLES = pathlib.Path(__file__).resolve().parents[3] / "examples"
KANE_EXAMPLES = ["double_pendulum", "n_link_cart", "heavy_top", "rolling_disc"]


@pytest.fixture(scope="module", params=KANE_EXAMPLES)
def example(request):
    return request.param, runpy.run_path(str(EXAMPLES / f"{request.param}.py"))


def test_example_defines_a_formed_system(example):
    name, ns = example
    formed = ns["system"].formed()
    assert isinstance(formed, FormedSystem) and formed.method == "kane"
    assert set(ns["parameters"]) == set(formed.parameters)
    assert set(ns["initial_state"]) == set(formed.coordinates) | set(formed.speeds)
    assert ns["outputs"]
    spec = model_spec(str(EXAMPLES / f"{name}.py"))
    assert spec.name == name and spec.formed.nq == formed.nq


def _energy_rate(ns, seed):
    """dE/dt along the equations of motion at a random state (inputs zero)."""
    km = ns["system"]
    rng = random.Random(seed)
    point = {k: sm.Float(v) for k, v in ns["parameters"].items()}
    states = list(km.q) + list(km.u)
    point.update({s: sm.Float(rng.uniform(-1, 1)) for s in states})
    point.update({F: 0 for F in km.formed().inputs})
    qdot = [e.xreplace(point) for e in km.formed().kinematics]
    udot = km.mass_matrix.xreplace(point).evalf().LUsolve(km.forcing.xreplace(point).evalf())
    E = ns["outputs"]["energy"]
    rate = sum(E.diff(s).xreplace(point) * v for s, v in zip(states, list(qdot) + list(udot)))
    scale = sum(abs(E.diff(s).xreplace(point)) for s in states)
    return float(rate), float(scale)


@pytest.mark.parametrize("seed", [1, 2])
def test_energy_is_conserved(example, seed):
    name, ns = example
    rate, scale = _energy_rate(ns, seed)
    assert abs(rate) < 1e-9 * max(scale, 1.0), (name, rate)


def test_rolling_disc_normal_force_at_rest_is_weight():
    ns = runpy.run_path(str(EXAMPLES / "rolling_disc.py"))
    km = ns["system"]
    m, g = sm.symbols("m g", positive=True)
    rest = {**{s: 0 for s in list(km.q) + list(km.u)}, m: 2.0, g: 9.81,
            sm.Symbol("r", positive=True): 0.5}
    assert float(ns["outputs"]["normal_force"].xreplace(rest)) == pytest.approx(2.0 * 9.81)
    assert float(ns["outputs"]["friction_lateral"].xreplace(rest)) == pytest.approx(0.0, abs=1e-12)


def test_n_link_cart_reads_link_count_from_environment(monkeypatch):
    monkeypatch.setenv("EOMC_N_LINKS", "2")
    ns = runpy.run_path(str(EXAMPLES / "n_link_cart.py"))
    assert ns["system"].formed().nq == 3
