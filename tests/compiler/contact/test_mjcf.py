"""Ground contacts named on an MJCF model's bodies (the file's geoms left out: naming contacts
replaces them): depths, forces and the dynamics against MuJoCo's own kinematics and mj_forward
with the same forces applied (MuJoCo's contacts off: its contact model is not this law)."""
import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

import eomc  # noqa: E402
from eomc.compiler.mjcf import MjcfModel  # noqa: E402
from eomc.compiler.mjcf.compare import prepared, qacc_of, to_mujoco, tree_of  # noqa: E402
from eomc.runtime.errors import ModelError  # noqa: E402

XML = """<mujoco model="hopper1">
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="torso" pos="0 0 0.5">
      <freejoint/>
      <geom type="box" size="0.1 0.05 0.04" mass="2"/>
      <geom name="nose" type="sphere" size="0.02" pos="0.1 0 0" mass="0.1"/>
      <body name="leg" pos="0 0 -0.05" euler="0 20 0">
        <joint name="hip" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.015" mass="0.3"/>
        <geom name="foot" type="sphere" size="0.03" pos="0.01 0.02 -0.3" mass="0.05"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


@pytest.fixture(scope="module")
def hopper(tmp_path_factory):
    path = tmp_path_factory.mktemp("mjcf") / "hopper1.xml"
    path.write_text(XML)
    spheres = [{"link": "torso", "point": (0.1, 0, 0), "radius": 0.02, "name": "nose"},
               {"link": "leg", "point": (0.01, 0.02, -0.3), "radius": 0.03, "name": "foot"}]
    model = eomc.compile(MjcfModel(path), contacts=spheres, functions=("rhs", "outputs"),
                         cache_dir=tmp_path_factory.mktemp("cache"))
    return path, model


def test_mjcf_contacts_match_mujoco(hopper):
    from eomc.compiler.mjcf.model import load_mjmodel
    path, model = hopper
    assert {"Fn_nose", "Fn_foot", "depth_foot"} <= set(model.output_names)
    m = prepared(load_mjmodel(path))
    d = mujoco.MjData(m)
    built = tree_of(m, model)
    p = dict(zip(model.param_names, model.param_defaults))
    assert p["r_foot"] == 0.03 and p["r_nose"] == 0.02
    nq = model.nq
    geoms = {name: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, name) for name in ("nose", "foot")}
    rng = np.random.default_rng(7)
    touching = 0
    for trial in range(8):
        q = rng.uniform(-0.3, 0.3, nq)
        for w in model.quaternions:        # the free joint's quaternion: a tilt of the same size
            q[w] += 1.0
            q[w:w + 4] /= np.linalg.norm(q[w:w + 4])
        u = rng.uniform(-1, 1, model.nu)
        d.qpos[:], d.qvel[:] = to_mujoco(m, built, q, u)
        mujoco.mj_kinematics(m, d)
        q[2] -= min(d.geom_xpos[g][2] - p[f"r_{n}"] for n, g in geoms.items()) + 0.003   # 3 mm in
        d.qpos[:], d.qvel[:] = to_mujoco(m, built, q, u)
        mujoco.mj_forward(m, d)
        x = np.concatenate([q, u])
        out = model.outputs(0.0, x)
        d.qfrc_applied[:] = 0
        for name, g in geoms.items():
            r = p[f"r_{name}"]
            centre = d.geom_xpos[g].copy()
            assert out[f"depth_{name}"] == pytest.approx(r - centre[2], abs=1e-12)
            b = int(m.geom_bodyid[g])
            vel = np.zeros(6)
            mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_GEOM, g, vel, 0)   # [w; v] world
            w, v = vel[:3], vel[3:]
            vp = v + np.cross(w, [0, 0, -r])
            vt = vp - vp[2] * np.array([0, 0, 1.0])
            depth = r - centre[2]
            fn = p[f"k_{name}"] * max(depth, 0) ** 1.5 * (1 + 1.5 * p[f"c_{name}"] * -v[2]) if depth > 0 else 0.0
            fn = max(fn, 0.0)
            ft = -p[f"mu_{name}"] * fn * vt / np.sqrt(vt @ vt + p[f"vs_{name}"] ** 2)
            assert out[f"Fn_{name}"] == pytest.approx(fn, rel=1e-10, abs=1e-10)
            assert [out[f"Ft{a}_{name}"] for a in "xyz"] == pytest.approx(ft, rel=1e-10, abs=1e-10)
            touching += fn > 0
            F = np.array([ft[0], ft[1], fn + ft[2]])
            mujoco.mj_applyFT(m, d, F, np.zeros(3), centre - [0, 0, r], b, d.qfrc_applied)
        mujoco.mj_forward(m, d)
        mine = qacc_of(m, built, q, u, model.rhs(0.0, x)[nq:])
        assert np.max(np.abs(mine - d.qacc)) < 1e-9 * max(1.0, np.max(np.abs(d.qacc)))
    assert touching >= 6       # the lowest sphere is 3 mm in (its force clipped to 0 when it leaves fast)


def test_mjcf_contact_on_no_such_body(hopper, tmp_path):
    path, _ = hopper
    with pytest.raises(ModelError, match="contact on body 'shin': the model has no such body"):
        eomc.compile(path, contacts=["shin"], cache_dir=tmp_path)
