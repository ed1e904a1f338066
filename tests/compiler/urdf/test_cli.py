"""The eomc command on a URDF file: build (with the header documenting the order), check, simulate."""
import subprocess
import sys

import numpy as np
import pytest

import eomc
from helpers.robots import robot_path


def _eomc(*args, cache):
    return subprocess.run([sys.executable, "-m", "eomc", *map(str, args)], capture_output=True, text=True,
                          timeout=600, env={**__import__("os").environ, "EOMC_CACHE_DIR": str(cache)})


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("cli")
    cache, out = tmp / "cache", tmp / "ur5"
    result = _eomc("build", robot_path("ur5"), "-o", out, cache=cache)   # every function; no -q: the summary is read
    assert result.returncode == 0, result.stderr
    return out, cache, result.stdout


def test_build_writes_a_library_named_after_the_file(built):
    out, _, stdout = built
    assert "built model 'ur5_robot' (nq=6, nu=6" in stdout
    assert {"ur5_robot.c", "ur5_robot.h", "libur5_robot.so", "ur5_robot.json"} <= {p.name for p in out.iterdir()}
    model = eomc.load(out)
    assert model.input_names[0] == "tau_shoulder_pan_joint"
    tau = model.inverse_dynamics(0.0, np.zeros(12), np.zeros(6), r=np.zeros(6))
    assert abs(tau[0]) < 1e-12 and abs(tau[1]) > 1.0     # holding the arm out against gravity


def test_header_documents_the_order(built):
    out, _, _ = built
    header = (out / "ur5_robot.h").read_text()
    assert "int ur5_robot_inverse_dynamics(" in header and "int ur5_robot_mass_matrix(" in header
    assert "x[0] q_shoulder_pan_joint\n *     x[1] q_shoulder_lift_joint" in header
    assert "x[6] u_shoulder_pan_joint" in header
    assert "r[0] tau_shoulder_pan_joint\n *     r[1] tau_shoulder_lift_joint" in header
    assert "g = 9.81" in header
    assert "rows follow the speeds" in header


def test_check_passes_and_simulate_runs(built, tmp_path):
    out, cache, _ = built
    result = _eomc("check", out, "--t-final", "1", "--methods", "dop853,radau", "--x0", "q_shoulder_lift_joint=-1",
                   cache=cache)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "checks passed" in result.stdout
    csv = tmp_path / "ur5.csv"
    result = _eomc("simulate", robot_path("ur5"), "--t-final", "0.5", "-o", csv, cache=cache)
    assert result.returncode == 0, result.stderr
    rows = np.loadtxt(csv, delimiter=",", skiprows=1)
    # t, 12 states and the energy output its joint limits give it (since session 17)
    assert rows.shape[1] == 14 and abs(rows[-1, 0] - 0.5) < 1e-12
    assert csv.read_text().splitlines()[0].split(",")[-1] == "energy"
    assert abs(rows[-1, 2]) > 0.1      # q_shoulder_lift_joint fell from 0 under gravity


def test_floating_base_option(tmp_path):
    result = _eomc("inspect", robot_path("solo12"), "--floating-base", "--outputs", "rhs", cache=tmp_path)
    assert result.returncode == 0, result.stderr
    assert "nq=18" in result.stdout and "q_base_link_floating_rz" in result.stdout
    result = _eomc("inspect", robot_path("solo12"), "--outputs", "rhs", cache=tmp_path)
    assert "nq=12" in result.stdout
