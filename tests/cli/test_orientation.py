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


# a base and one hinged leg with a joint limit: the command line's path for a URDF with
# --floating-base --orientation quaternion --limits off and --x0 names is the one Go2 took
# (the orientation is the base's, whatever hangs below it); Go2's 12 legs cost 5.3 s CPU to
# build and run, this 1.6 s.  The base's y axis is a principal axis, the leg hangs in the
# x-z plane off its hinge: the pitch rate stays ~2 rad/s, qy(0.05 s) ~ sin(0.05) = 0.04996.
TINY = """<?xml version="1.0"?>
<robot name="tiny_quadruped">
  <link name="base">
    <inertial><origin xyz="0 0 0"/><mass value="6.0"/>
      <inertia ixx="0.03" ixy="0" ixz="0" iyy="0.08" iyz="0" izz="0.1"/></inertial>
  </link>
  <link name="leg">
    <inertial><origin xyz="0 0 -0.1"/><mass value="0.5"/>
      <inertia ixx="0.002" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.0002"/></inertial>
  </link>
  <joint name="hip" type="revolute">
    <parent link="base"/><child link="leg"/>
    <origin xyz="0.2 0.1 0"/><axis xyz="1 0 0"/>
    <limit lower="-0.8" upper="0.8" effort="20" velocity="20"/>
  </joint>
</robot>
"""


def test_quaternion_floating_base_simulates_from_upright_with_x0_names(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    urdf = tmp_path / "tiny.urdf"
    urdf.write_text(TINY)
    out = tmp_path / "tiny.csv"
    code = main(["simulate", str(urdf), "--floating-base", "--orientation", "quaternion", "--limits",
                 "off", "--t-final", "0.05", "--x0", "q_base_floating_z=0.5", "u_base_floating_wy=2", "-o",
                 str(out), "-q"])
    assert code == 0, capsys.readouterr().err
    names = out.read_text().splitlines()[0].split(",")
    assert names[4:8] == [f"q_base_floating_{c}" for c in ("qw", "qx", "qy", "qz")]
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    assert data[0, 3] == 0.5 and data[0, 4] == 1.0            # the start: upright unless named
    assert np.all(np.abs(np.linalg.norm(data[:, 4:8], axis=1) - 1) < 1e-6)
    assert data[-1, 6] > 0.04                                 # it pitched (qy ≈ sin(wy t / 2))
