"""eomc simulate --input NAME=VALUE|CSV and --events on models compiled from model files."""
import textwrap

import numpy as np
import pytest

from helpers import model_files

import eomc
import eomc.cli.common as cli_common
from eomc.cli import main


@pytest.fixture(scope="module")
def cart(tmp_path_factory):
    d, cache = tmp_path_factory.mktemp("models"), tmp_path_factory.mktemp("cache")
    return eomc.compile(str(model_files.write(d, model_files.CART, "cart")), cache_dir=cache,
                        progress=False)


@pytest.fixture
def use(monkeypatch):
    def install(model):
        monkeypatch.setattr(cli_common, "load_model", lambda spec, quiet=False, **_: model)
    return install


def test_constant_and_csv_inputs(cart, use, tmp_path, capsys):
    use(cart)
    out = tmp_path / "a.csv"
    assert main(["simulate", "cart", "--t-final", "2", "-o", str(out), "--input", "F=0.5",
                 "--rtol", "1e-10", "--atol", "1e-12"]) == 0
    cli = np.genfromtxt(out, delimiter=",", names=True)
    ref = cart.simulate(cart.initial_state, (0, 2), r=[0.5], rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(cli["x"][-1], ref["x"][-1], rtol=1e-12)
    table = tmp_path / "force.csv"
    grid = np.linspace(0, 2, 401)
    np.savetxt(table, np.column_stack([grid, np.sin(3 * grid)]), delimiter=",", header="t,F",
               comments="")
    assert main(["simulate", "cart", "--t-final", "2", "-o", str(out), "--input", f"F={table}",
                 "--rtol", "1e-10", "--atol", "1e-12"]) == 0
    cli = np.genfromtxt(out, delimiter=",", names=True)
    ref = cart.simulate(cart.initial_state, (0, 2), r=(grid, np.sin(3 * grid)), rtol=1e-10,
                        atol=1e-12)
    np.testing.assert_allclose(cli["v"][-1], ref["v"][-1], rtol=1e-12)
    capsys.readouterr()
    assert main(["simulate", "cart", "--t-final", "1", "--input", "G=1"]) == 2
    assert "unknown input G in --input; inputs: F" in capsys.readouterr().err


def test_events_option_prints_times_and_stops(tmp_path, use, capsys):
    text = model_files.PENDULUM + textwrap.dedent('''\
        events = {"up": {"expr": u, "direction": 1}}
        ''')
    pend = eomc.compile(str(model_files.write(tmp_path, text, "pend")), cache_dir=tmp_path / "c",
                        progress=False)
    use(pend)
    assert main(["simulate", "pend", "--t-final", "3", "--rtol", "1e-12", "--atol", "1e-12"]) == 0
    shown = capsys.readouterr().out
    assert "event up: 2 at t = " in shown
    assert main(["simulate", "pend", "--t-final", "3", "--events", "up:terminal"]) == 0
    shown = capsys.readouterr().out
    assert "event up: 1 at t = " in shown and "stopped by event up at t=" in shown
    assert main(["simulate", "pend", "--t-final", "3", "--events", "none"]) == 0
    assert "event" not in capsys.readouterr().out


def test_events_that_never_fire_share_one_line(tmp_path, use, capsys):
    """A URDF robot's default ground adds a contact event per collision corner (Solo12 with its four
    feet named: over 100, most never touching): those that never fire are one line, not one each."""
    far = ", ".join(f'"far{i}": {{"expr": q - {100 + i}}}' for i in range(5))
    text = model_files.PENDULUM + f'events = {{"up": {{"expr": u, "direction": 1}}, {far}}}\n'
    pend = eomc.compile(str(model_files.write(tmp_path, text, "pend")), cache_dir=tmp_path / "c",
                        progress=False)
    use(pend)
    assert main(["simulate", "pend", "--t-final", "3", "--rtol", "1e-12", "--atol", "1e-12"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert any(line.startswith("  event up: 2 at t = ") for line in lines)
    assert not any("far" in line and "0 at t" in line for line in lines)
    silent = [line for line in lines if "never fired" in line]
    assert silent == ["  events that never fired: far0, far1, far2, ... (5 in all)"]
