"""A floating-base robot whose zero pose puts its contacts under the ground starts lifted onto it."""
import numpy as np
import pytest

from eomc.cli import main

BLOCK = """<?xml version="1.0"?>
<robot name="block">
  <link name="body"><inertial><origin xyz="0 0 0"/><mass value="1.0"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
</robot>
"""


@pytest.fixture
def block(tmp_path, monkeypatch):
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    path = tmp_path / "block.urdf"
    path.write_text(BLOCK)
    return path


def _run(block, tmp_path, capsys, *extra):
    out = tmp_path / "traj.csv"
    code = main(["simulate", str(block), "--floating-base", "--contact", "body:0,0,-0.1:0.05",
                 "--t-final", "0.05", "-q", "-o", str(out), *extra])
    err = capsys.readouterr().err
    assert code == 0, err
    return np.genfromtxt(out, delimiter=",", names=True), err


def test_contacts_under_the_ground_at_the_start_lift_the_base_onto_it(block, tmp_path, capsys):
    """The zero pose has the sphere (centre 0.1 m below the base, radius 0.05) 0.15 m deep:
    the run starts with the base at 0.151 (the sphere 1 mm above the ground), says so, and does
    not throw the block out of the ground (before: it started 0.15 m deep, 3x its radius)."""
    traj, err = _run(block, tmp_path, capsys)
    z = traj["q_body_floating_z"]
    assert z[0] == pytest.approx(0.151, abs=1e-12)
    assert "starting with q_body_floating_z = 0.151, the deepest 1 mm above it" in err, err
    assert abs(z[-1] - 0.15) < 0.01             # it rests on the ground, not launched


def test_a_given_base_height_is_kept(block, tmp_path, capsys):
    traj, err = _run(block, tmp_path, capsys, "--x0", "q_body_floating_z=0.5")
    assert traj["q_body_floating_z"][0] == 0.5 and "above it" not in err
