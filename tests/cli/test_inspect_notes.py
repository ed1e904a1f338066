"""`eomc inspect` and NAME.json say how the model was formulated: the System -> tree
reader's fallbacks (``tree_notes``), and the other formulation is generated from the same
robot (a URDF's ``--floating-base`` included).  Small models: a few seconds in all."""
import json
import shutil
import textwrap

import pytest

from eomc.cli import main
from eomc.runtime.loader import LoadError, load

# An interframe oriented from another frame (two steps from the ground's frame): the tree
# reader takes this joint through SymPy's kinematics and says so (compiler/tree/recognize.py).
TWO_STEP = textwrap.dedent('''\
    import sympy as sm
    from sympy.physics import mechanics as sme
    ground = sme.RigidBody("ground")
    B = sme.RigidBody("B", mass=sm.Symbol("m"))
    B.central_inertia = sme.inertia(B.frame, 1, 2, 3)
    mid = sme.ReferenceFrame("mid")
    mid.orient_axis(ground.frame, ground.frame.x, sm.pi / 3)
    inter = sme.ReferenceFrame("inter")
    inter.orient_axis(mid, mid.y, sm.pi / 5)
    system = sme.System.from_newtonian(ground)
    system.add_joints(sme.PinJoint("p", ground, B, parent_interframe=inter, joint_axis=inter.z,
                                   child_point=-B.y))
    system.apply_uniform_gravity(-sm.Symbol("g") * ground.frame.z)
    parameters = {sm.Symbol("m"): 1.0, sm.Symbol("g"): 9.81}
''')

# One free body: no joint, so it has states only with --floating-base (6 speeds: auto compares
# both formulations, so inspect generates the other one too).
BRICK = """<?xml version="1.0"?>
<robot name="brick">
  <link name="body">
    <inertial><mass value="2"/><origin xyz="0.1 0 0"/>
      <inertia ixx="0.02" iyy="0.03" izz="0.04" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
</robot>
"""

NOTE = "joint p: its frames or points are not one step from its bodies'"


@pytest.fixture(scope="module")
def two_step(tmp_path_factory):
    folder = tmp_path_factory.mktemp("twostep")
    path = folder / "twostep.py"
    path.write_text(TWO_STEP)
    return path


def test_tree_notes_are_in_name_json_and_load(two_step, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["build", str(two_step), "-o", str(out), "--formulation", "recursive", "-q",
                 "--cache-dir", str(tmp_path / "cache")]) == 0
    capsys.readouterr()
    data = json.loads((out / "twostep.json").read_text())
    assert data["formulation"] == "recursive"
    assert len(data["tree_notes"]) == 1 and data["tree_notes"][0].startswith(NOTE), data["tree_notes"]
    assert load(out).metadata["tree_notes"] == data["tree_notes"]
    # NAME.json is checked before use: notes that are not text are refused, naming the field
    copy = tmp_path / "copy"      # without the export manifest, so the JSON may be edited
    shutil.copytree(out, copy, ignore=shutil.ignore_patterns(".eomc-files*"))
    data["tree_notes"] = [3]
    (copy / "twostep.json").write_text(json.dumps(data))
    with pytest.raises(LoadError, match="tree_notes must be a list of strings"):
        load(copy)


def test_inspect_shows_the_tree_notes_beside_the_formulation(two_step, capsys):
    assert main(["inspect", str(two_step), "--formulation", "recursive", "-q"]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    at = lines.index("formulation: recursive")
    assert lines[at + 1].startswith(f"  tree reader: {NOTE}"), out


def test_a_system_read_from_its_joints_has_no_tree_notes(tmp_path, capsys):
    """The notes are the reader's: a System whose joints it reads directly has none."""
    from helpers import model_files
    model = model_files.write(tmp_path, TWO_STEP.replace("parent_interframe=inter, joint_axis=inter.z",
                                                         "joint_axis=ground.frame.x"), "direct")
    assert main(["inspect", str(model), "--formulation", "recursive", "-q"]) == 0
    assert "tree reader:" not in capsys.readouterr().out


def test_inspect_generates_the_other_formulation_with_the_floating_base(tmp_path, capsys, monkeypatch):
    """--floating-base reaches both generations: without it the other one would read a robot
    without a moving joint (an error), or another robot."""
    import eomc.compiler.driver as driver
    urdf = tmp_path / "brick.urdf"
    urdf.write_text(BRICK)
    real, sources = driver.generate, []

    def recording(source, *args, **kwargs):
        sources.append((source, kwargs.get("formulation")))
        return real(source, *args, **kwargs)
    monkeypatch.setattr(driver, "generate", recording)
    assert main(["inspect", str(urdf), "--floating-base", "-q"]) == 0
    out = capsys.readouterr().out
    assert [f for _, f in sources][0] == "auto" and {f for _, f in sources[1:]} <= {"kane", "recursive"}
    assert len(sources) == 2, sources
    assert all(getattr(s, "floating_base", False) for s, _ in sources), sources
    assert "sizes: nq=6, nu=6, nx=12" in out
    row = next(line.split() for line in out.splitlines() if line.startswith("  rhs:"))
    kane_ops, recursive_ops = map(int, row[1:])      # both generated: numbers in both columns
    assert kane_ops > 0 and recursive_ops > 0 and "no kane form" not in out
