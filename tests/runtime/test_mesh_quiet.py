"""A URDF whose visual mesh is missing: eomc's one warning, and nothing from the libraries it
reads the file with (yourdfpy logged "Unable to resolve filename: ..." to stderr, twice: once
while the model's poses were built, once while the page was written)."""
import logging
import warnings

from eomc.cli import main
from eomc.errors import EomcWarning

ARM = """<?xml version="1.0"?>
<robot name="arm">
  <link name="base"/>
  <link name="arm">
    <inertial><mass value="1"/><origin xyz="0 0 0.25"/>
      <inertia ixx="0.02" iyy="0.02" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><mesh filename="meshes/nowhere.stl"/></geometry></visual>
  </link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="1 0 0"/><limit effort="1" velocity="1" lower="-3" upper="3"/></joint>
</robot>
"""


def test_a_missing_mesh_gives_our_warning_and_no_library_log_line(tmp_path, capsys, caplog):
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(ARM)
    caplog.set_level(logging.DEBUG)          # a record at any level would show up here
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert main(["animate", str(urdf), "--t-final", "0.2", "-o", str(tmp_path / "arm.html")]) == 0
    err = capsys.readouterr().err
    assert "Unable to resolve" not in err, err
    assert not [r for r in caplog.records if r.name.split(".")[0] in ("yourdfpy", "trimesh")
                and r.levelno >= logging.WARNING], caplog.text
    assert "nowhere.stl" not in err, err      # (the CLI prints warnings; here pytest records them)
    ours = [str(w.message) for w in caught if "nowhere.stl" in str(w.message)]
    assert len(ours) == 1 and ours[0].startswith("arm: cannot read mesh meshes/nowhere.stl"), ours
    assert all(issubclass(w.category, EomcWarning) for w in caught if "nowhere" in str(w.message))
    # the libraries' loggers are as they were afterwards
    assert logging.getLogger("yourdfpy").level == logging.NOTSET
    assert logging.getLogger("trimesh").level == logging.NOTSET
