"""--orientation quaternion on the command line: a URDF's --floating-base and an MJCF's free joints."""
import numpy as np

from eomc.cli import main
from helpers.robots import robot_path

GO2 = "go2_description/urdf/go2.urdf"


def test_orientation_without_a_floating_base_is_refused_in_one_line(capsys):
    code = main(["simulate", str(robot_path(GO2)), "--orientation", "quaternion", "--t-final", "0.1", "-q"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1, err
    assert "--orientation quaternion: a URDF robot has a free joint only with --floating-base" in err


def test_quaternion_floating_base_simulates_from_upright_with_x0_names(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    out = tmp_path / "go2.csv"
    code = main(["simulate", str(robot_path(GO2)), "--floating-base", "--orientation", "quaternion", "--limits",
                 "off", "--t-final", "0.05", "--x0", "q_base_floating_z=0.5", "u_base_floating_wy=2", "-o",
                 str(out), "-q"])
    assert code == 0, capsys.readouterr().err
    names = out.read_text().splitlines()[0].split(",")
    assert names[4:8] == [f"q_base_floating_{c}" for c in ("qw", "qx", "qy", "qz")]
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    assert data[0, 3] == 0.5 and data[0, 4] == 1.0            # the start: upright unless named
    assert np.all(np.abs(np.linalg.norm(data[:, 4:8], axis=1) - 1) < 1e-6)
    assert data[-1, 6] > 0.04                                 # it pitched (qy ≈ sin(wy t / 2))
