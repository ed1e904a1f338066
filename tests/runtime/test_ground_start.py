"""Python's x0=None lifts a floating robot whose default start puts its contacts under the
ground onto it, by the command line's rule (runtime/ground_start.py), and warns."""
import warnings

import numpy as np
import pytest

import eomc
from eomc.compiler.urdf.model import UrdfModel
from eomc.runtime.errors import EomcWarning

BLOCK = """<?xml version="1.0"?>
<robot name="block">
  <link name="body"><inertial><origin xyz="0 0 0"/><mass value="1.0"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
</robot>
"""

LEGS = """<?xml version="1.0"?>
<robot name="legs">
  <link name="base"><inertial><mass value="1.0"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="hip" type="revolute"><parent link="base"/><child link="leg"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <link name="leg"><inertial><origin xyz="0 0 -0.15"/><mass value="0.5"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 -0.3"/><geometry><sphere radius="0.05"/></geometry></collision></link>
</robot>
"""


def _build(tmp_path, text, **kw):
    path = tmp_path / "robot.urdf"
    path.write_text(text)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return eomc.compile(UrdfModel(path, **kw), cache_dir=tmp_path / "c", progress=False)


def _simulate(model, x0):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = model.simulate(x0, (0.0, 0.05))
    return res, [str(w.message) for w in caught if issubclass(w.category, EomcWarning)]


@pytest.fixture(scope="module")
def block(tmp_path_factory):
    return _build(tmp_path_factory.mktemp("block"), BLOCK, floating_base=True, contacts=("body:0,0,-0.1:0.05",))


def test_a_floating_robot_in_the_ground_starts_lifted_onto_it(block):
    """The zero pose has the sphere (0.1 m below the base, radius 0.05) 0.15 m deep: simulate(None)
    starts with the base at 0.151, every contact above the ground, says so, and the block rests
    (before: it started 0.15 m deep, as the command line did before it lifted it)."""
    res, said = _simulate(block, None)
    z = res.x[:, block.state_names.index("q_body_floating_z")]
    assert z[0] == pytest.approx(0.151, abs=1e-12)
    depths = [n for n in block.output_names if n.startswith("depth_")]
    start = block.outputs(0.0, res.x[0])
    assert depths and all(start[d] < 0 for d in depths)        # every contact above the ground
    assert any("lifted q_body_floating_z from 0 to 0.151 (by 0.151 m)" in s for s in said), said
    assert abs(z[-1] - 0.15) < 0.01                             # it settles, not launched


def test_a_given_start_is_never_changed(block):
    x0 = np.zeros(block.nx)
    res, said = _simulate(block, x0)
    assert res.x[0, block.state_names.index("q_body_floating_z")] == 0.0
    assert not any("lifted" in s for s in said), said


def test_a_welded_robot_in_the_ground_is_told_to_float(tmp_path):
    model = _build(tmp_path, LEGS, contacts=("@ground",))
    res, said = _simulate(model, None)
    assert np.all(res.x[0] == 0.0)
    assert any("welded to the world" in s and "floating_base=True" in s for s in said), said
