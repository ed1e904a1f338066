"""MuJoCo's fixed tendons: springs (with a dead band), dampers and tendon actuators as joint-space
forces, against mj_forward (1e-12); limits and frictionloss by eomc's joint laws on the length."""
import warnings

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

import eomc  # noqa: E402
from eomc.compiler.mjcf import MjcfModel  # noqa: E402
from eomc.compiler.mjcf.compare import prepared, qacc_of, to_mujoco, tree_of  # noqa: E402
from eomc.compiler.mjcf.model import load_mjmodel  # noqa: E402
from eomc.runtime.errors import ModelFileError  # noqa: E402

XML = """<mujoco model="tendons">
  <worldbody>
    <body name="a" pos="0 0 1">
      <joint name="h1" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="1"/>
      <body name="b" pos="0.3 0 0">
        <joint name="h2" type="hinge" axis="0 1 0" ref="0.2"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="0.5"/>
        <body name="c" pos="0.3 0 0">
          <joint name="s3" type="slide" axis="1 0 0"/>
          <geom type="sphere" size="0.05" mass="0.2"/>
        </body>
      </body>
    </body>
  </worldbody>
  <tendon>
    <fixed name="couple" stiffness="4" damping="0.3" springlength="0.1">
      <joint joint="h1" coef="1"/><joint joint="h2" coef="-0.7"/>
    </fixed>
    <fixed name="band" stiffness="9" springlength="-0.1 0.2" range="-0.5 0.5" limited="true">
      <joint joint="h2" coef="0.5"/><joint joint="s3" coef="2"/>
    </fixed>
    <fixed name="free_len"><joint joint="h1" coef="1"/><joint joint="s3" coef="1"/></fixed>
  </tendon>
  <actuator>
    <motor name="pull" tendon="free_len" gear="3" ctrlrange="-1 1" ctrllimited="true"/>
    <position name="servo" tendon="couple" kp="5"/>
  </actuator>
</mujoco>
"""


def test_fixed_tendons_match_mj_forward(tmp_path):
    path = tmp_path / "t.xml"
    path.write_text(XML)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(MjcfModel(path, limits=False), functions=["rhs"], cache_dir=tmp_path / "c",
                             progress=False)
    assert model.ninput == 2 and "k_tendon_couple" in model.param_names
    m = prepared(load_mjmodel(path))
    built = tree_of(m, model)
    d = mujoco.MjData(m)
    rng = np.random.default_rng(2)
    for _ in range(8):
        q, u, r = rng.uniform(-0.6, 0.6, 3), rng.uniform(-2, 2, 3), rng.uniform(-1.5, 1.5, 2)
        xd = model.rhs(0.0, np.concatenate([q, u]), r=r)
        d.qpos[:], d.qvel[:] = to_mujoco(m, built, q, u)
        d.ctrl[:] = r
        mujoco.mj_forward(m, d)
        assert np.max(np.abs(d.qfrc_passive)) > 0.1
        mine = qacc_of(m, built, q, u, xd[3:])
        assert np.max(np.abs(mine - d.qacc)) < 1e-12 * max(1.0, np.max(np.abs(d.qacc)))


def test_tendon_limit_acts_on_the_length(tmp_path):
    path = tmp_path / "t.xml"
    path.write_text(XML)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        on = eomc.compile(str(path), functions=["rhs"], cache_dir=tmp_path / "c", progress=False)
    assert {"limit_lo_tendon_band", "limit_hi_tendon_band"} <= set(on.param_names)
    # past the upper end (0.5 h2 + 2 s3 = 0.9 > 0.5) the limit pushes s3 back; inside it does nothing
    names = list(on.state_names)
    x_out, x_in = np.zeros(6), np.zeros(6)
    x_out[names.index("q_s3")] = 0.45
    x_in[names.index("q_s3")] = 0.05
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        off = eomc.compile(MjcfModel(path, limits=False), functions=["rhs"], cache_dir=tmp_path / "c2", progress=False)
    k = names.index("u_s3")
    assert on.rhs(0.0, x_out, r=[0, 0])[k] < off.rhs(0.0, x_out, r=[0, 0])[k] - 1.0
    assert on.rhs(0.0, x_in, r=[0, 0])[k] == pytest.approx(off.rhs(0.0, x_in, r=[0, 0])[k], abs=1e-12)


def _with_sites(tendon):
    return (XML.replace("<tendon>", "<tendon>" + tendon)
            .replace('<geom type="sphere"', '<site name="s2" pos="0.02 0.03 0"/><geom type="sphere"')
            .replace('<joint name="h1"', '<site name="s1" pos="0.1 0 0.05"/><joint name="h1"')
            .replace("<worldbody>", '<worldbody><site name="s0" pos="0.2 0.1 1.3"/>'))


def test_wrapping_spatial_tendon_refused_by_name(tmp_path):
    """A spatial tendon with a pulley (or wrapping geoms): refused, naming it."""
    path = tmp_path / "s.xml"
    path.write_text(_with_sites('<spatial name="rope" stiffness="2"><site site="s1"/><site site="s2"/>'
                                '<pulley divisor="2"/><site site="s1"/><site site="s0"/></spatial>'))
    with pytest.raises(ModelFileError, match="<tendon>: tendon rope: a spatial tendon that wraps"):
        eomc.compile(str(path), functions=["rhs"], cache_dir=tmp_path / "c", progress=False)


def test_site_tendon_spring_and_damper_match_mj_forward(tmp_path):
    """A spatial tendon through three sites (one in the world, two on moving bodies), with a spring
    and a damper: MuJoCo applies them as passive forces Jᵀτ, so qacc matches mj_forward (1e-12)."""
    path = tmp_path / "s.xml"
    path.write_text(_with_sites('<spatial name="rope" stiffness="7" damping="0.4" springlength="0.3">'
                                '<site site="s0"/><site site="s1"/><site site="s2"/></spatial>'))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(MjcfModel(path, limits=False), functions=["rhs"], cache_dir=tmp_path / "c",
                             progress=False)
    m = prepared(load_mjmodel(path))
    built = tree_of(m, model, actuators=[0, 1], limits=False, friction=False)
    d = mujoco.MjData(m)
    rng = np.random.default_rng(4)
    for _ in range(6):
        q, u = rng.uniform(-1, 1, 3), rng.uniform(-2, 2, 3)
        d.qpos[:], d.qvel[:] = to_mujoco(m, built, q, u)
        d.ctrl[:] = 0
        mujoco.mj_forward(m, d)
        assert abs(d.qfrc_passive @ d.qvel) > 0        # the tendon acts
        mine = qacc_of(m, built, q, u, model.rhs(0.0, np.concatenate([q, u]), r=[0, 0])[3:])
        assert np.max(np.abs(mine - d.qacc)) < 1e-12 * max(1.0, np.max(np.abs(d.qacc)))
