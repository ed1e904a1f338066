"""compiler/tree/crba.py's world form: NAME_implicit's mass matrix, made from composite inertias
summed in the world and each column's force dotted with its ancestors' world screws, is the
mass matrix -- against MuJoCo's mj_fullM, against the model's own NAME_mass_matrix (the loop
kernel, an independent code path) and against the body-frame CRBA built into the same model.

Why (issues 29, 31): the body-frame CRBA was 22 % of gymnasium humanoid's NAME_implicit call; the
world form took 5 % off its fixed step's simulated second (benchmarks/results/world_crba.md)."""
import warnings

import mujoco
import numpy as np
import pytest

import eomc
import eomc.compiler.tree.crba as crba_module
import eomc.compiler.tree.lower as lower
from eomc.compiler.mjcf.model import MjcfModel
from eomc.compiler.tree.crba import crba, crba_world

from helpers.implicit_call import implicit_terms_at

# a floating torso, two legs whose hips turn about three axes (two massless frames each in the
# lowered tree), knees, an arm with armature; capsules on the floor: the contacts place the tree
# in the world, so NAME_implicit takes the world form
WALKER = """<mujoco model="walker3">
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="torso" pos="0 0 1.3">
      <freejoint name="root"/>
      <geom name="torso" type="capsule" fromto="0 -0.07 0 0 0.07 0" size="0.07"/>
      <body name="thigh_r" pos="0.02 -0.1 -0.1" euler="0 5 10">
        <joint name="hip_rx" type="hinge" axis="1 0 0"/>
        <joint name="hip_rz" type="hinge" axis="0 0 1"/>
        <joint name="hip_ry" type="hinge" axis="0 1 0.2"/>
        <geom name="thigh_r" type="capsule" fromto="0 0 0 0 0.01 -0.34" size="0.06"/>
        <body name="shin_r" pos="0 0.01 -0.4">
          <joint name="knee_r" type="hinge" axis="0 -1 0" pos="0 0 0.02"/>
          <geom name="shin_r" type="capsule" fromto="0 0 0 0 0 -0.3" size="0.049"/>
        </body>
      </body>
      <body name="thigh_l" pos="0 0.1 -0.12">
        <joint name="hip_lx" type="hinge" axis="1 0 0"/>
        <joint name="hip_lz" type="hinge" axis="0 0 1"/>
        <joint name="hip_ly" type="hinge" axis="0 1 0"/>
        <geom name="thigh_l" type="capsule" fromto="0 0 0 0 -0.01 -0.34" size="0.06"/>
        <body name="shin_l" pos="0 -0.01 -0.4">
          <joint name="knee_l" type="hinge" axis="0 -1 0"/>
          <geom name="shin_l" type="capsule" fromto="0 0 0 0 0 -0.3" size="0.049"/>
        </body>
      </body>
      <body name="arm" pos="0 0.17 0.06">
        <joint name="shoulder" type="hinge" axis="2 1 1" armature="0.05"/>
        <geom name="arm" type="capsule" fromto="0 0 0 0.16 0.16 -0.16" size="0.04"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

# the same legs on a fixed base (hinges only): eomc's coordinates and speeds are MuJoCo's qpos,
# qvel, joint by joint, so M compares entry by entry
# one hinge per body, every body with mass, a free root: the ant's shape
SHALLOW = """<mujoco model="star">
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="torso" pos="0 0 0.75">
      <freejoint name="root"/>
      <geom name="torso" type="sphere" size="0.25"/>
      <body name="leg1" pos="0.2 0.2 0"><joint name="hip1" type="hinge" axis="0 0 1"/>
        <geom name="leg1" type="capsule" fromto="0 0 0 0.2 0.2 0" size="0.08"/></body>
      <body name="leg2" pos="-0.2 0.2 0"><joint name="hip2" type="hinge" axis="0 0 1"/>
        <geom name="leg2" type="capsule" fromto="0 0 0 -0.2 0.2 0" size="0.08"/></body>
    </body>
  </worldbody>
</mujoco>
"""

FIXED = WALKER.replace('<freejoint name="root"/>', "").replace('pos="0 0 1.3"', 'pos="0 0 1.3" euler="10 0 0"')


FORMS = {"world": lambda bodies, rec, poses, screws: crba_world(bodies, rec, poses, screws),
         "body": lambda bodies, rec, poses, screws: crba(bodies, rec)}


def _build(tmp_path, text, name, form=None):
    """The model built (form None: M as the compiler chooses; "world" or "body": that form)."""
    path = tmp_path / f"{name}.xml"
    path.write_text(text)
    shipped = lower.implicit_mass_matrix
    if form is not None:
        lower.implicit_mass_matrix = FORMS[form]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = eomc.compile(MjcfModel(path), name=name, functions=("rhs", "jac_x", "implicit", "mass_matrix"),
                                 cache_dir=tmp_path / name, progress=False)
    finally:
        lower.implicit_mass_matrix = shipped
    return path, model


def _implicit_M(model, x):
    out, at = implicit_terms_at(model, x)
    nu = model.nu
    return out[at["M"]:at["M"] + nu * nu].reshape(nu, nu)


def _states(model, rng, n=12):
    for _ in range(n):
        x = rng.uniform(-1.5, 1.5, model.nx)
        quats = list(getattr(model, "quaternions", ()))
        if quats:                       # a unit quaternion (w, x, y, z from each w's index)
            for w in quats:
                qv = rng.normal(size=4)
                x[w:w + 4] = qv / np.linalg.norm(qv)
        yield x


def test_the_form_with_fewer_operations_is_recorded(tmp_path, monkeypatch):
    """Three-axis hips (two massless frames each): the world form has fewer operations and is
    the one recorded (tried once on a fork, then once for real); a tree whose bodies all have
    mass and sit one joint deep (no massless frame): the body-frame form."""
    calls = []
    shipped = crba_module.crba_world

    def spy(*args):
        calls.append(args[1])
        return shipped(*args)
    monkeypatch.setattr(crba_module, "crba_world", spy)
    _build(tmp_path, WALKER, "spied")
    assert len(calls) == 2 and calls[0] is not calls[1]     # the fork's trial, then the recorder's
    calls.clear()
    _build(tmp_path, SHALLOW, "shallow")
    assert len(calls) == 1                                  # the trial only


def test_floating_branching_tree_against_the_body_frame_crba_and_the_loop_kernel(tmp_path):
    """Free joint (quaternion), three-axis hips (massless frames), armature: NAME_implicit's M
    (world form) equals the body-frame CRBA's (the same model built with it) and NAME_mass_matrix
    (the loop kernel) to 1e-13 of M's largest entry, and is symmetric."""
    _, world = _build(tmp_path, WALKER, "w_world", "world")
    _, body = _build(tmp_path, WALKER, "w_body", "body")
    # NAME_mass_matrix from the loop kernel NAME_dyn (with jac_x in the build), not M's straight-line code
    assert "w_world_dyn(" in next((tmp_path / "w_world").rglob("w_world.c")).read_text()
    rng = np.random.default_rng(3)
    for x in _states(world, rng):
        M = _implicit_M(world, x)
        scale = np.max(np.abs(M))
        assert np.max(np.abs(M - _implicit_M(body, x))) < 1e-13 * scale
        assert np.max(np.abs(M - world.mass_matrix(0.0, x))) < 1e-13 * scale
        assert np.array_equal(M, M.T)
        assert np.all(np.linalg.eigvalsh(M) > 0)


def test_fixed_base_tree_against_mujoco(tmp_path):
    """Hinges only (a tilted base, three-axis hips, armature on the shoulder): NAME_implicit's M
    against mj_fullM at random states, to 1e-12 of its largest entry."""
    path, model = _build(tmp_path, FIXED, "fixed", "world")
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    names = list(model.state_names)
    order = [names.index(f"q_{m.joint(j).name}") for j in range(m.njnt)]
    assert order == list(range(m.nq)) and m.nq == model.nq == m.nv
    rng = np.random.default_rng(8)
    for x in _states(model, rng):
        d.qpos[:] = x[:m.nq]
        mujoco.mj_forward(m, d)
        full = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, full)
        assert np.max(np.abs(_implicit_M(model, x) - full)) < 1e-12 * np.max(np.abs(full))
    assert m.dof_armature[m.joint("shoulder").dofadr[0]] == pytest.approx(0.05)
