"""The animation of an MJCF model whose free and ball joints are quaternions (the MJCF default).

The page's poses come from the generated NAME_poses at the run's states (interpolated between
rows, which a quaternion's R(q) = R(cq) tolerates); here the frames fall on the run's rows, so
each body's drawn rotation and position must be MuJoCo's xmat/xpos at that state.  The box
tumbles through pitch 90 deg (where body-XYZ angles lock) and its arm swings on a ball joint.
"""
import warnings

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

import eomc  # noqa: E402
from eomc.compiler.mjcf.compare import prepared, to_mujoco, tree_of  # noqa: E402
from eomc.compiler.mjcf.model import MjcfModel, load_mjmodel  # noqa: E402

TUMBLER = """<mujoco model="qtumbler">
  <option gravity="0 0 0"/>
  <worldbody>
    <body name="box" pos="0 0 1">
      <freejoint name="root"/>
      <geom type="box" size="0.3 0.1 0.05" mass="1"/>
      <body name="arm" pos="0.3 0 0">
        <joint name="shoulder" type="ball"/>
        <geom type="capsule" fromto="0 0 0 0.25 0 0" size="0.02" mass="0.2"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def test_a_tumbling_quaternion_model_is_drawn_where_mujoco_places_it(tmp_path):
    path = tmp_path / "qtumbler.xml"
    path.write_text(TUMBLER)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(MjcfModel(path), functions=["rhs", "poses"], cache_dir=tmp_path / "cache",
                             progress=False)
    names = list(model.state_names)
    assert len(model.quaternions) == 2 and "q_root_qw" in names and "q_shoulder_qz" in names
    x0 = np.array(model.initial_state, dtype=float)
    x0[[names.index(f"u_root_w{a}") for a in "xyz"]] = (0.3, 4.0, 0.2)
    x0[names.index("u_shoulder_wz")] = 1.5
    res = model.simulate(x0, (0.0, 1.0), t_eval=np.arange(21) / 20, method="dop853", rtol=1e-10, atol=1e-10)
    assert res.status == 0
    anim = res.animate(fps=20)
    m = prepared(load_mjmodel(path))
    d, tree = mujoco.MjData(m), tree_of(m, model)
    pitched = 0.0
    for i, x in enumerate(res.x):
        d.qpos[:], d.qvel[:] = to_mujoco(m, tree, x[:model.nq], x[model.nq:])
        mujoco.mj_kinematics(m, d)
        for body in ("box", "arm"):
            k = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, body)
            np.testing.assert_allclose(anim.poses.rotation(body)[i], d.xmat[k].reshape(3, 3), rtol=0, atol=1e-12)
            np.testing.assert_allclose(anim.poses[body][i], d.xpos[k], rtol=0, atol=1e-12)
        pitched = max(pitched, abs(d.xmat[1].reshape(3, 3)[2, 0]))
    assert pitched > 0.99                      # near pitch 90 deg (within 8 deg), where the angles lock
    for i in model.quaternions:       # rows between steps are interpolated: unit within the step's error
        assert np.abs(np.linalg.norm(res.x[:, i:i + 4], axis=1) - 1).max() < 1e-10
