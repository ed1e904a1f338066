"""Mesh files are read only with the ``mesh`` extra (trimesh, pycollada for DAE); without it,
a model's meshes are drawn as boxes with one warning naming the extra, and nothing else in
the base install needs it."""
import sys

import pytest

from eomc.cli import main
from eomc.errors import EomcError
from eomc.runtime.errors import EomcWarning, MissingExtraError
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


def test_meshes_without_trimesh_are_boxes_with_one_warning_naming_the_mesh_extra(monkeypatch):
    """first hour s21 L1: without the extra this was a MissingExtraError, so `eomc animate robot.urdf`
    failed on every mesh robot after the README's `.[plot]` install; now the meshes are boxes (as a
    missing mesh file is) and one warning carries the same text."""
    _without(monkeypatch, "trimesh")
    geometry = {"arm": [shape("mesh", path="/robot/meshes/forearm.stl"), shape("mesh", path="/robot/meshes/hand.stl")],
                "hand": [shape("box", (1, 1, 1))]}
    with pytest.warns(EomcWarning) as caught:
        out, meshes = pack_shapes(geometry)
    texts = [str(w.message) for w in caught]
    assert texts == ["drawing this model's meshes (2 files, e.g. forearm.stl) needs trimesh, which is "
                     "not installed: pip install \"eomc[mesh]\" (from a clone of eomc: "
                     "pip install \".[mesh]\"); drawn as boxes meanwhile"], texts
    assert meshes == [] and [s["kind"] for s in out["arm"]] == ["box", "box"]
    assert out["hand"] == geometry["hand"]


def test_dae_meshes_need_pycollada_too(monkeypatch):
    _without(monkeypatch, "collada")
    with pytest.warns(EomcWarning, match=r"needs pycollada, which is not installed.*\.\[mesh\]\"\); drawn as boxes"):
        out, meshes = pack_shapes({"arm": [shape("mesh", path="/r/a.dae"), shape("mesh", path="/r/b.stl")]})
    assert meshes == [] and [s["kind"] for s in out["arm"]] == ["box", "box"]


def test_shapes_without_meshes_need_no_extra(monkeypatch):
    _without(monkeypatch, "trimesh", "collada")
    out, meshes = pack_shapes({"arm": [shape("box", (1, 2, 3)), shape("sphere", (0.1,))]})
    assert meshes == [] and [s["kind"] for s in out["arm"]] == ["box", "sphere"]


def test_animate_a_robot_with_meshes_without_the_extra_draws_boxes_with_one_warning(tmp_path, monkeypatch, capsys):
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(ARM)
    _without(monkeypatch, "trimesh")
    with pytest.warns(EomcWarning) as caught:     # the CLI prints these as "eomc animate: warning: ..."
        assert main(["animate", str(urdf), "--t-final", "0.1", "-o", str(tmp_path / "arm.html")]) == 0
    mesh = [str(w.message) for w in caught if "mesh" in str(w.message)]
    assert mesh == ["drawing this model's meshes (1 file, e.g. forearm.dae) needs trimesh, "
                    "which is not installed: pip install \"eomc[mesh]\" (from a clone of eomc: "
                    "pip install \".[mesh]\"); drawn as boxes meanwhile"], mesh
    err = capsys.readouterr().err.strip().splitlines()
    assert not any("Traceback" in line for line in err)
    assert (tmp_path / "arm.html").stat().st_size > 0


def test_the_cython_backend_without_cython_names_its_extra(monkeypatch):
    from eomc.compiler.build.cython_ext import extension_key_inputs
    _without(monkeypatch, "Cython")
    with pytest.raises(MissingExtraError, match=r"the Cython backend .* needs Cython, .*\.\[cython\]"):
        extension_key_inputs()
