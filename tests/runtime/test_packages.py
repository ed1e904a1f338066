"""package:// meshes found as ROS and Pinocchio find them: package_dirs / --package-dir,
ROS_PACKAGE_PATH, AMENT_PREFIX_PATH and the example-robot-data layout; one hint otherwise."""
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

import eomc
from eomc.cli import main
from eomc.errors import EomcWarning
from eomc.runtime.packages import find_package_file
from eomc.runtime.result import SimulationResult
from helpers.robots import robot_path

BOT = """<?xml version="1.0"?>
<robot name="mybot">
  <link name="base"/>
  <link name="arm">
    <inertial><mass value="1"/><origin xyz="0 0 0.25"/>
      <inertia ixx="0.02" iyy="0.02" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><mesh filename="package://mybot_description/meshes/arm.stl"/></geometry></visual>
  </link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="1 0 0"/><limit effort="1" velocity="1" lower="-3" upper="3"/></joint>
</robot>
"""


@pytest.fixture
def packages(tmp_path):
    """A package folder with the mesh, and the URDF somewhere else (copied out of it)."""
    trimesh = pytest.importorskip("trimesh")
    meshes = tmp_path / "ws" / "src" / "mybot_description" / "meshes"
    meshes.mkdir(parents=True)
    trimesh.creation.box((0.05, 0.05, 0.5)).export(meshes / "arm.stl")
    urdf = tmp_path / "elsewhere" / "mybot.urdf"
    urdf.parent.mkdir()
    urdf.write_text(BOT)
    return tmp_path / "ws" / "src", urdf


def _page(model, tmp_path, **options):
    t = np.linspace(0, 1, 11)
    res = SimulationResult(t=t, x=np.column_stack([t, 0 * t]), state_names=model.state_names, stats={},
                           model_name=model.name, nq=model.nq, model=model)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        anim = res.animate(tmp_path / "page.html", **options)
    return anim, [str(w.message) for w in caught if issubclass(w.category, EomcWarning)]


def test_package_dirs_and_the_hint(packages, tmp_path, monkeypatch):
    root, urdf = packages
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    model = eomc.compile(urdf, functions=["rhs", "poses"], cache_dir=tmp_path / "c", progress=False)
    assert model.metadata["poses"]["geometry"]["arm"][0]["path"].startswith("package://")
    anim, said = _page(model, tmp_path)
    assert len(said) == 1 and "arm: cannot read mesh package://mybot_description/meshes/arm.stl" in said[0]
    assert "--package-dir DIR" in said[0] and "ROS_PACKAGE_PATH" in said[0] and "\n" not in said[0]
    anim, said = _page(model, tmp_path, package_dirs=[root])
    assert not said and '"nf":12' in anim.html            # the box mesh's 12 triangles, packed
    # from the environment, when the model is built
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(root))
    model = eomc.compile(urdf, functions=["rhs", "poses"], cache_dir=tmp_path / "c2", progress=False)
    assert Path(model.metadata["poses"]["geometry"]["arm"][0]["path"]).is_file()


def test_ament_prefix_and_the_package_itself(packages, tmp_path, monkeypatch):
    root, _ = packages
    url = "package://mybot_description/meshes/arm.stl"
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    prefix = tmp_path / "install"
    shutil.copytree(root, prefix / "share")
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(prefix))
    assert find_package_file(url) == str(prefix / "share" / "mybot_description" / "meshes" / "arm.stl")
    monkeypatch.delenv("AMENT_PREFIX_PATH")
    assert find_package_file(url) is None
    assert find_package_file(url, [root / "mybot_description"]) is not None   # the package's own folder


def test_example_robot_data_layout_for_a_copied_urdf(tmp_path):
    """go2.urdf copied out of example-robot-data keeps its meshes (package://example-robot-data/...)."""
    copy = tmp_path / "go2.urdf"
    shutil.copy(robot_path("go2_description/urdf/go2.urdf"), copy)
    model = eomc.compile(copy, functions=["rhs", "poses"], cache_dir=tmp_path / "c", progress=False)
    paths = [s["path"] for shapes in model.metadata["poses"]["geometry"].values() for s in shapes
             if s["kind"] == "mesh"]
    assert paths and all(Path(p).is_file() for p in paths), [p for p in paths if not Path(p).is_file()][:3]


def test_cli_package_dir_must_exist(tmp_path, capsys):
    assert main(["animate", "nowhere.urdf", "--package-dir", str(tmp_path / "nope"), "-o",
                 str(tmp_path / "a.html")]) == 2
    assert "--package-dir" in capsys.readouterr().err
