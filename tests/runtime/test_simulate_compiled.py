"""simulate() on models built by the real pipeline (eomc.compile -> loader), not stand-ins.

Oracles: the closed-form right-hand sides in tests/helpers/model_files.py integrated by
scipy's DOP853 at rtol=1e-12, and conservation of the model file's energy.
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from helpers import model_files

import eomc
from eomc.runtime.batch import simulate_many


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    d, cache = tmp_path_factory.mktemp("models"), tmp_path_factory.mktemp("cache")
    pend = eomc.compile(str(model_files.write(d, model_files.PENDULUM, "pend")), cache_dir=cache,
                        progress=False)
    cart = eomc.compile(str(model_files.write(d, model_files.CART, "cart")), cache_dir=cache,
                        progress=False)
    return pend, cart


@pytest.mark.parametrize("method", ["dop853", "dopri5", "radau"])
def test_compiled_pendulum_matches_closed_form_and_keeps_energy(built, method):
    pend, _ = built
    t = np.linspace(0, 5, 51)
    ref = solve_ivp(lambda s, x: model_files.pendulum_rhs(x), (0, 5), [0.3, 0.0], method="DOP853",
                    rtol=1e-12, atol=1e-12, t_eval=t)
    res = pend.simulate(pend.initial_state, (0, 5), method=method, rtol=1e-10, atol=1e-10,
                        t_eval=t)
    assert np.max(np.abs(res.x - ref.y.T)) < 1e-7
    assert np.ptp(res["energy"]) < 1e-7 * abs(res["energy"][0])


def test_compiled_cart_with_input_grid_and_batch(built):
    _, cart = built
    grid = np.linspace(0, 3, 3001)
    force = 0.5 * np.sin(2 * grid)
    t = np.linspace(0, 3, 31)
    ref = solve_ivp(lambda s, x: model_files.cart_rhs(x, F=0.5 * np.sin(2 * s)), (0, 3),
                    cart.initial_state, rtol=1e-12, atol=1e-12, method="DOP853", t_eval=t)
    res = cart.simulate(cart.initial_state, (0, 3), r=(grid, force), rtol=1e-10, atol=1e-12,
                        t_eval=t)
    assert np.max(np.abs(res.x - ref.y.T)) < 1e-5        # linear interpolation of F on the grid
    X0 = np.tile(cart.initial_state, (4, 1))
    X0[:, 1] = [0.1, 0.2, 0.3, 0.4]
    batch = simulate_many(cart, X0, (0, 3), t_eval=t, method="radau", rtol=1e-8, atol=1e-10,
                          progress=False, threads=2)
    for i in range(4):
        one = cart.simulate(X0[i], (0, 3), t_eval=t, method="radau", rtol=1e-8, atol=1e-10)
        np.testing.assert_array_equal(batch.x[i], one.x)


def test_eomc_simulate_cli_compiles_a_model_file(tmp_path, monkeypatch, capsys):
    from eomc.cli import main
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    model = model_files.write(tmp_path, model_files.PENDULUM, "pend")
    out, png = tmp_path / "traj.csv", tmp_path / "traj.png"
    argv = ["simulate", str(model), "--t-final", "2", "-o", str(out), "--points", "21",
            "--rtol", "1e-10", "--atol", "1e-10"]
    try:
        import matplotlib  # noqa: F401
        argv += ["--plot", str(png)]
    except ImportError:
        png = None
    assert main(argv) == 0
    data = np.genfromtxt(out, delimiter=",", names=True)
    assert data["q"][0] == 0.3 and data["t"][-1] == 2.0          # the file's initial_state
    assert np.ptp(data["energy"]) < 1e-6 * abs(data["energy"][0])
    assert png is None or png.stat().st_size > 1000
    assert "pend: dop853" in capsys.readouterr().out


def test_eomc_simulate_cli_on_a_built_directory(tmp_path, monkeypatch, capsys):
    """A built directory is loaded (no compile): initial_state comes from its metadata."""
    from eomc.cli import main
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    src = model_files.write(tmp_path, model_files.CART, "cart")
    eomc.compile(str(src), cache_dir=tmp_path / "cache", output_dir=tmp_path / "built",
                 progress=False)
    out = tmp_path / "cart.csv"
    assert main(["simulate", str(tmp_path / "built"), "--t-final", "1", "-o", str(out),
                 "--method", "radau", "--points", "11"]) == 0
    data = np.genfromtxt(out, delimiter=",", names=True)
    assert data["th"][0] == 0.4 and len(data) == 11
    assert "cart: radau" in capsys.readouterr().out


def test_lagrange_model_takes_states_keyed_by_sympy_objects(tmp_path):
    """A Lagrange model's speeds are q'; x0 and p may be keyed by the SymPy objects themselves."""
    import sympy as sm
    from eomc.mechanics import (Lagrangian, LagrangesMethod, Particle, Point, ReferenceFrame,
                                dynamicsymbols)
    q = dynamicsymbols("q")
    m, l, g = sm.symbols("m l g", positive=True)
    N = ReferenceFrame("N")
    O = Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", l * (sm.sin(q) * N.x - sm.cos(q) * N.y))
    P.set_vel(N, P.pos_from(O).dt(N))
    bob = Particle("bob", P, m)
    bob.potential_energy = -m * g * l * sm.cos(q)
    lm = LagrangesMethod(Lagrangian(N, bob), [q])
    lm.form_lagranges_equations()
    model = eomc.compile(lm, parameters={m: 1.0, l: 1.0, g: 9.81}, cache_dir=tmp_path, progress=False)
    assert model.state_names == ("q", "q'")
    by_object = model.simulate({q: 0.3, q.diff(): 0.1}, (0, 1), p={g: 9.81, l: 1.0})
    by_name = model.simulate({"q": 0.3, "q'": 0.1}, (0, 1))
    assert np.array_equal(by_object.x, by_name.x)
    assert by_object["q'"][0] == 0.1


def test_model_built_without_rhs_says_so(tmp_path, capsys):
    """Reliability report 2026-11, F13: simulate said "bad argument ... t=nan"; rhs_many advised
    rebuilding with 'rhs_many', which --outputs rejects."""
    from eomc.cli import main
    from eomc.errors import ModelError
    model_file = model_files.write(tmp_path, model_files.PENDULUM, "pend")
    out = tmp_path / "mm"
    assert main(["build", str(model_file), "-o", str(out), "--outputs", "mass_matrix",
                 "--cache-dir", str(tmp_path / "c"), "-q"]) == 0
    model = eomc.load(out)
    expected = "model 'pend' was built without `rhs`; rebuild it with functions including 'rhs'"
    for method in ("dop853", "rk4", "radau"):
        with pytest.raises(ModelError, match=expected):
            model.simulate([0.3, 0.0], (0, 1), method=method, **({"dt": 0.1} if method == "rk4" else {}))
    with pytest.raises(ModelError, match=expected):
        model.rhs_many(0.0, np.zeros((2, 2)))
    with pytest.raises(ModelError, match=expected):
        simulate_many(model, np.zeros((2, 2)), (0, 1))
    capsys.readouterr()
    assert main(["simulate", str(out), "--t-final", "1"]) == 1
    assert f"eomc simulate: error: {expected}" in capsys.readouterr().err
