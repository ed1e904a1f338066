"""NAME_energy and NAME_poses as loops over a robot's bodies (compiler/tree/body_loops.py): each calls
NAME_dyn_inputs (the kernels' inputs an[], already in the file) and loops over the bodies and per-body
tables, instead of placing every body again in straight-line code (issue 30's build bar).  Checked against the straight-line functions of the same model (``BODY_LOOPS`` off: the C
before session 26, bit for bit the generator's old output) at random states: the energy within
1e-13 of its size (measured against main's libraries: <= 2.4 ulp on G1, Talos, Panda), every pose
entry within 1e-13 of max(|value|, 1) (<= 2.6 ulp).  A body whose term the loop dropped (its share
of the energy, its frame) changes the values far beyond that: each body moves and has mass."""
import re

import numpy as np
import pytest

from eomc.compiler.driver import compile as compile_model
from eomc.compiler.tree import body_loops
from helpers.robots import robot_path

# a floating torso with two legs of two hinges each, masses off their frames' origins, armature,
# a motor per hinge, a limited knee and a hip spring (so it has an energy output), no floor
LEGS = """<mujoco model="legs">
  <option gravity="0 0 -9.81"/>
  <worldbody>
    <body name="torso" pos="0 0 1.2">
      <freejoint name="root"/>
      <inertial pos="0.02 -0.01 0.05" mass="4" diaginertia="0.1 0.08 0.05"/>
      <body name="thigh_l" pos="0 0.1 -0.1">
        <joint name="hip_l" type="hinge" axis="0 1 0" armature="0.02" damping="0.1"/>
        <inertial pos="0 0 -0.2" mass="1.2" diaginertia="0.02 0.02 0.004"/>
        <body name="shin_l" pos="0 0 -0.4">
          <joint name="knee_l" type="hinge" axis="0.6 0.8 0" armature="0.01" limited="true" range="-2 0.1"/>
          <inertial pos="0.01 0 -0.18" quat="0.9 0.1 0.3 0" mass="0.8" diaginertia="0.01 0.012 0.002"/>
        </body>
      </body>
      <body name="thigh_r" pos="0 -0.1 -0.1" euler="0.2 0 0.1">
        <joint name="hip_r" type="hinge" axis="0 1 0" armature="0.02" stiffness="3" springref="0.2"/>
        <inertial pos="0 0 -0.2" mass="1.2" diaginertia="0.02 0.02 0.004"/>
        <body name="shin_r" pos="0 0 -0.4">
          <joint name="knee_r" type="hinge" axis="1 0 0"/>
          <inertial pos="0 0.01 -0.18" mass="0.8" diaginertia="0.01 0.012 0.002"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor joint="hip_l"/><motor joint="knee_l"/><motor joint="hip_r"/><motor joint="knee_r"/>
  </actuator>
</mujoco>
"""


def _body(text, name, fn):
    start = text.index(f"int {name}_{fn}(")
    return text[start:text.index("\n}\n", start)]


def _both(model_in, name, tmp_path, monkeypatch):
    """(the model with the loops, the same model straight-line), each from its own cache."""
    looped = compile_model(model_in, name, cache_dir=tmp_path / "loops", progress=False)
    monkeypatch.setattr(body_loops, "BODY_LOOPS", False)
    straight = compile_model(model_in, name, cache_dir=tmp_path / "straight", progress=False)
    monkeypatch.setattr(body_loops, "BODY_LOOPS", True)
    return looped, straight


def _agree(looped, straight, energy=True, states=12, seed=26):
    """Energy and every pose entry of the two models at random states, within the module doc's bounds."""
    text, name = looped.source_path.read_text(), looped.name
    place = f"{name}_dyn_inputs(t, x, p, r, an);"
    assert place in _body(text, name, "poses")                      # the loop's inputs
    assert place not in _body(straight.source_path.read_text(), name, "poses")
    if energy:
        assert place in _body(text, name, "energy")
    assert looped.metadata["poses"] == straight.metadata["poses"]
    rng = np.random.default_rng(seed)
    for k in range(states):
        x = rng.normal(size=looped.nx) * (0.4 if k % 2 else 1.5)
        if energy:
            a, b = looped.outputs(0.0, x)["energy"], straight.outputs(0.0, x)["energy"]
            assert abs(a - b) <= 1e-13 * abs(b), (k, a, b)
        pa, pb = looped.poses(0.0, x), straight.poses(0.0, x)
        for got, want in ((pa.positions, pb.positions), (pa.rotations, pb.rotations), (pa.points, pb.points)):
            assert np.all(np.abs(got - want) <= 1e-13 * np.maximum(np.abs(want), 1.0)), k


def test_a_urdf_robots_energy_and_poses_loop_over_its_bodies(tmp_path, monkeypatch):
    """Panda: a fixed base, welded links shown with their own turn and offset (hand, fingers' tips),
    joint limits on (their springs' energy stays straight-line beside the loop's sum)."""
    from eomc.cli.common import with_options
    model_in, name = with_options(str(robot_path("panda")), None)
    with pytest.warns(Warning):
        looped, straight = _both(model_in, "panda_loops", tmp_path, monkeypatch)
    turned = re.search(r"static const int fd\[\d+\] = \{([^}]*)\}", _body(looped.source_path.read_text(), looped.name, "poses"))
    assert any(int(v) >= 0 for v in turned.group(1).split(","))       # some frame has its own turn
    _agree(looped, straight)


def test_a_floating_mjcf_body_with_armature_loops_over_its_bodies(tmp_path, monkeypatch):
    """MJCF: a free joint (the floating base's coordinates in the pose table), mass centres off the
    frames (each frame its mass centre less the offset: the table's o), armature (a u²/2 per dof)."""
    path = tmp_path / "legs.xml"
    path.write_text(LEGS)
    looped, straight = _both(str(path), "legs_loops", tmp_path, monkeypatch)
    body = _body(looped.source_path.read_text(), looped.name, "energy")
    assert re.search(r"eb \+= 0\.5 \* an\[\d+ \+ e\] \* ue \* ue;", body)     # the armature's term
    _agree(looped, straight, states=16)
    x = np.zeros(looped.nx)                     # at rest: gravity alone, -sum m g.p
    x[list(looped.quaternions)] = 1.0           # upright (the MJCF default: the quaternion's w)
    x[2] = 1.2
    assert abs(looped.outputs(0.0, x)["energy"] - straight.outputs(0.0, x)["energy"]) < 1e-12


def test_the_switch_is_in_the_generation_key(tmp_path, monkeypatch):
    """BODY_LOOPS changes the C for the same sources: the cache keys hold it when off."""
    from eomc.compiler.build.reuse import generator_switches
    assert "no_body_loops" not in generator_switches()
    monkeypatch.setattr(body_loops, "BODY_LOOPS", False)
    assert generator_switches()["no_body_loops"] is True


def test_an_energy_of_the_bodies_alone_builds_as_before(tmp_path, monkeypatch):
    """gymnasium's inverted pendulum: no contacts, no springs, no limit energy, so the energy output
    is the bodies' part alone, an atom the recorder leaves unnamed (no assignment reads it).  The
    default build failed there from 20eaa1c1 on (IRError: ('out', 0) reads undefined ['_ebodies'];
    also the swimmer, reacher and inverted double pendulum); now its energy is the straight-line
    build's bit for bit."""
    gymnasium = pytest.importorskip("gymnasium")
    pytest.importorskip("mujoco")
    from pathlib import Path
    path = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / "inverted_pendulum.xml"
    looped, straight = _both(str(path), "ip_energy", tmp_path, monkeypatch)
    assert looped.output_names == ("energy",)
    rng = np.random.default_rng(3)
    for _ in range(6):
        x = rng.normal(size=looped.nx)
        assert looped.outputs(0.0, x)["energy"] == straight.outputs(0.0, x)["energy"]
