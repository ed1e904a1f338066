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


# an MJCF free body: its orientation is MuJoCo's quaternion by default (session 30), body-XYZ
# angles with --orientation euler
FLOATER = """<mujoco model="floater"><option gravity="0 0 0"/><worldbody>
<body name="box" pos="0 0 1"><freejoint name="root"/><geom type="box" size="0.3 0.1 0.05" mass="1"/></body>
</worldbody></mujoco>"""


def test_an_mjcf_free_joint_is_a_quaternion_and_its_euler_names_say_how_to_get_them(tmp_path, monkeypatch,
                                                                                       capsys):
    """A script written for the Euler default (--x0 q_root_rx=...) gets one line naming the
    quaternion's states and --orientation euler, not only the list of names; with --orientation
    euler the same --x0 runs and the CSV has the angles."""
    import pytest
    pytest.importorskip("mujoco")
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    xml = tmp_path / "floater.xml"
    xml.write_text(FLOATER)
    out = tmp_path / "f.csv"
    code = main(["simulate", str(xml), "--t-final", "0.05", "--x0", "q_root_rx=0.1", "-o", str(out), "-q"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1, err
    assert "q_root_rx: a body-XYZ angle" in err and "q_root_qw, q_root_qx, q_root_qy, q_root_qz" in err
    assert "--orientation euler" in err and not out.exists()
    code = main(["simulate", str(xml), "--t-final", "0.05", "--x0", "u_root_wx=1", "-o", str(out), "-q"])
    assert code == 0, capsys.readouterr().err
    names = out.read_text().splitlines()[0].split(",")
    assert names[1:8] == [f"q_root_{c}" for c in ("x", "y", "z", "qw", "qx", "qy", "qz")]
    code = main(["simulate", str(xml), "--orientation", "euler", "--t-final", "0.05", "--x0", "q_root_rx=0.1",
                 "-o", str(out), "-q"])
    assert code == 0, capsys.readouterr().err
    assert out.read_text().splitlines()[0].split(",")[4:7] == ["q_root_rx", "q_root_ry", "q_root_rz"]
    # linearize: the quaternion in its tangent chart, 12 states (6 speeds), as the Euler build's
    assert main(["linearize", str(xml), "-q"]) == 0
    text = capsys.readouterr().out
    table = text[text.index("\nA"):text.index("eigenvalues")]       # A's rows and columns (in blocks)
    assert "q_root_rotx" in table and "q_root_qw" not in table
    eigenvalues = text.split("eigenvalues: ")[1].split("\n  (")[0]      # wrapped lines included, not the note
    assert eigenvalues.count(",") == 11
