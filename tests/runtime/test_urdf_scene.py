"""eomc.runtime.urdf_scene reads visuals and zero-configuration link placements with lxml, so
the base install needs neither yourdfpy nor trimesh's extras; its numbers must be yourdfpy's
bit for bit (they are compiled into the poses and frames of welded links).  The reference
is yourdfpy itself (a test dependency), on every URDF of example-robot-data."""
import sys
import warnings
from importlib.metadata import distribution
from pathlib import Path

import numpy as np
import pytest

from eomc.compiler.urdf.reader import read_urdf
from eomc.compiler.urdf.tree import build_tree
from eomc.errors import EomcWarning
from eomc.runtime import geometry, urdf_scene

yourdfpy = pytest.importorskip("yourdfpy")

ROBOTS = Path(distribution("example-robot-data").locate_file("cmeel.prefix/share/example-robot-data/robots"))


def _with_yourdfpy(monkeypatch):
    monkeypatch.setattr(geometry, "load_scene", lambda path: yourdfpy.URDF.load(
        str(path), build_scene_graph=True, load_meshes=False, build_collision_scene_graph=False,
        load_collision_meshes=False))
    monkeypatch.setattr(geometry, "resolve_filename",
                        lambda fname, directory: yourdfpy.filename_handler_magic(fname, dir=directory))


def _same(a, b, where):
    """Equal bit for bit, signed zeros included."""
    if isinstance(a, dict):
        assert a.keys() == b.keys(), where
        for k in a:
            _same(a[k], b[k], f"{where}/{k}")
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b)):
            _same(x, y, f"{where}[{i}]")
    elif isinstance(a, (float, np.ndarray, np.floating)):
        x, y = np.asarray(a, float), np.asarray(b, float)
        assert x.shape == y.shape and np.array_equal(x, y) and np.array_equal(np.signbit(x), np.signbit(y)), where
    else:
        assert a == b, where


def _trees():
    for path in sorted(ROBOTS.rglob("*.urdf")):
        try:
            with warnings.catch_warnings():   # real files' repaired inertias: not this test's subject
                warnings.simplefilter("ignore", EomcWarning)
                tree = build_tree(read_urdf(path))
        except Exception:       # files eomc refuses (no robot name, impossible inertia) have no tree
            continue
        yield path, tree


@pytest.mark.slow
def test_visuals_and_welded_placements_equal_yourdfpys_on_every_robot(monkeypatch):
    """urdf_visuals (shapes, origins, colours, resolved mesh files) and urdf_link_transforms
    with the lxml reader and with yourdfpy, on each example-robot-data URDF eomc builds."""
    checked = 0
    for path, tree in _trees():
        ours = geometry.urdf_visuals(tree), geometry.urdf_link_transforms(tree)
        with monkeypatch.context() as m:
            _with_yourdfpy(m)
            theirs = geometry.urdf_visuals(tree), geometry.urdf_link_transforms(tree)
        _same(ours, theirs, str(path.relative_to(ROBOTS)))
        checked += 1
    assert checked >= 60, checked


def test_placements_through_a_mimic_and_an_offset_joint(tmp_path):
    """Transforms in every direction (down, up, across the tree) equal yourdfpy's, including
    a mimic joint held at its offset and a prismatic joint."""
    urdf = tmp_path / "m.urdf"
    urdf.write_text("""<robot name="m">
      <link name="a"/><link name="b"/><link name="c"/><link name="d"/><link name="e"/>
      <joint name="ab" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0.1 -0 0.3" rpy="0.3 -0.2 1.1"/>
        <axis xyz="0 1 1"/></joint>
      <joint name="bc" type="fixed"><parent link="b"/><child link="c"/><origin xyz="0.2 0 0" rpy="1.5707963 0 0"/></joint>
      <joint name="ad" type="revolute"><parent link="a"/><child link="d"/><origin xyz="0 0.4 0"/>
        <mimic joint="ab" multiplier="2" offset="0.25"/><axis xyz="0 0 1"/></joint>
      <joint name="de" type="prismatic"><parent link="d"/><child link="e"/><origin rpy="0 0 0.5"/>
        <axis xyz="1 0 0"/></joint>
    </robot>""")
    ours = urdf_scene.load_scene(urdf)
    theirs = yourdfpy.URDF.load(str(urdf), build_scene_graph=True, load_meshes=False)
    links = "abcde"
    for to in links:
        for frm in links:
            _same(ours.get_transform(frame_to=to, frame_from=frm),
                  np.asarray(theirs.get_transform(frame_to=to, frame_from=frm)), f"{frm}->{to}")


def test_building_a_robot_imports_neither_yourdfpy_nor_trimesh(tmp_path):
    """The build path (frames, poses, contacts on welded links) reads the file with lxml only."""
    import subprocess
    code = ("import sys; from eomc.compiler.driver import generate; from eomc.compiler.urdf.model import UrdfModel;"
            f"generate(UrdfModel({str(ROBOTS / 'ur_description/urdf/ur5_robot.urdf')!r}), frames=['tool0'],"
            " use_cache=False, progress=False, functions=['rhs', 'poses', 'outputs']);"
            "print(sorted(m for m in ('yourdfpy', 'trimesh') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().splitlines()[-1] == "[]", out.stdout
