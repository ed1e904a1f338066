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


def _legs(n):
    """A base welded to the world with n legs hinged at its origin, each a sphere 0.3 m below."""
    legs = "".join(f"""
  <joint name="hip{k}" type="revolute"><parent link="base"/><child link="leg{k}"/>
    <origin xyz="{0.2 * k} 0 0"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <link name="leg{k}"><inertial><origin xyz="0 0 -0.15"/><mass value="0.5"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 -0.3"/><geometry><sphere radius="0.05"/></geometry></collision></link>"""
                   for k in range(n))
    return f"""<?xml version="1.0"?>
<robot name="legs">
  <link name="base"><inertial><mass value="1.0"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>{legs}
</robot>
"""


def test_a_welded_robot_in_the_ground_is_told_to_float_and_warned_in_short(tmp_path, monkeypatch, capsys):
    """`eomc simulate a1.urdf --ground` without --floating-base (first hour s27): the trunk is
    welded at the origin with the legs 0.34 m into the floor; the run's warning named all 100
    contacts and 12 bodies, each body with the same remedy (9 kB), and the remedy it gave (--x0)
    cannot lift a welded base.  Now a note names --x0 and --floating-base, and the warning names the
    deepest four of each kind and counts the rest."""
    import warnings
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    path = tmp_path / "legs.urdf"
    path.write_text(_legs(6))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        code = main(["simulate", str(path), "--ground", "--t-final", "0.02", "-q", "-o", str(tmp_path / "t.csv")])
    err = capsys.readouterr().err
    assert code == 0, err
    assert ("legs's start puts its contacts up to 0.35 m under the ground, and its root link is welded to "
            "the world (a fixed base), so eomc cannot lift the start onto it: pose the links above the ground "
            "with --x0, or give --floating-base for a robot that stands on the ground") in err, err
    text, = [str(w.message) for w in caught if "started that deep" in str(w.message)]
    assert text.count("more than 0.5 of its radius 0.05 m") == 4, text
    assert " and 2 more (0.35 m) started that deep" in text, text
    assert "bodies leg" in text and " and 2 more (" in text.split("bodies leg")[1], text
    assert text.count("the robot passed through the floor there") == 1, text
    assert len(text) < 1000, len(text)


def test_report_says_the_lifted_start_is_not_x_0(block, tmp_path, capsys):
    """`eomc report` on a floating robot with no initial_state lifted its start onto the ground
    (the note) and then said it started "from rest at x = 0" (first hour s33, Solo12 and Go2):
    it names the state it moved."""
    code = main(["report", str(block), "--floating-base", "--contact", "body:0,0,-0.1:0.05",
                 "--t-final", "0.05", "--methods", "bdf", "--tolerances", "1e-3", "--repeats", "1",
                 "-o", str(tmp_path / "rep")])
    err = capsys.readouterr().err
    assert code == 0, err
    assert "starting with q_body_floating_z = 0.151" in err, err
    assert "starting from rest at x = 0 but q_body_floating_z = 0.151" in err, err
