"""Mesh files are read only with the ``mesh`` extra (trimesh, pycollada for DAE); without it,
drawing a model that has meshes stops with one line naming the extra, and nothing else in
the base install needs it."""
import sys

import pytest

from eomc.cli import main
from eomc.errors import EomcError
from eomc.runtime.errors import MissingExtraError
from eomc.runtime.geometry import pack_shapes, shape

ARM = """<?xml version="1.0"?>
<robot name="arm">
  <link name="base"/>
  <link name="arm">
    <inertial><mass value="1"/><origin xyz="0 0 0.25"/>
      <inertia ixx="0.02" iyy="0.02" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><mesh filename="meshes/forearm.dae"/></geometry></visual>
  </link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="1 0 0"/><limit effort="1" velocity="1" lower="-3" upper="3"/></joint>
</robot>
"""


def _without(monkeypatch, *modules):
    for m in modules:
        monkeypatch.setitem(sys.modules, m, None)    # importlib.util.find_spec then says: absent


def test_meshes_without_trimesh_name_the_mesh_extra(monkeypatch):
    _without(monkeypatch, "trimesh")
    geometry = {"arm": [shape("mesh", path="/robot/meshes/forearm.stl")], "hand": [shape("box", (1, 1, 1))]}
    with pytest.raises(MissingExtraError) as err:
        pack_shapes(geometry)
    assert isinstance(err.value, EomcError) and err.value.extra == "mesh"
    assert str(err.value) == ("drawing this model's meshes (1 file, e.g. forearm.stl) needs trimesh, which is "
                              "not installed: pip install \"eomc[mesh]\" (from a clone of eomc: "
                              "pip install \".[mesh]\")")


def test_dae_meshes_need_pycollada_too(monkeypatch):
    _without(monkeypatch, "collada")
    with pytest.raises(MissingExtraError, match=r"needs pycollada, which is not installed.*\.\[mesh\]"):
        pack_shapes({"arm": [shape("mesh", path="/r/a.dae"), shape("mesh", path="/r/b.stl")]})


def test_shapes_without_meshes_need_no_extra(monkeypatch):
    _without(monkeypatch, "trimesh", "collada")
    out, meshes = pack_shapes({"arm": [shape("box", (1, 2, 3)), shape("sphere", (0.1,))]})
    assert meshes == [] and [s["kind"] for s in out["arm"]] == ["box", "sphere"]


def test_animate_a_robot_with_meshes_without_the_extra_is_one_error_line(tmp_path, monkeypatch, capsys):
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(ARM)
    _without(monkeypatch, "trimesh")
    assert main(["animate", str(urdf), "--t-final", "0.1", "-o", str(tmp_path / "arm.html")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("eomc animate: error: drawing this model's meshes (1 file, e.g. forearm.dae) "
                              "needs trimesh"), err
    assert err[-1].endswith('pip install ".[mesh]")'), err
    assert not any("Traceback" in line for line in err)


def test_the_cython_backend_without_cython_names_its_extra(monkeypatch):
    from eomc.compiler.build.cython_ext import extension_key_inputs
    _without(monkeypatch, "Cython")
    with pytest.raises(MissingExtraError, match=r"the Cython backend .* needs Cython, .*\.\[cython\]"):
        extension_key_inputs()
