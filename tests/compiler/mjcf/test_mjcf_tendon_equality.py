"""<equality><tendon> couplings between fixed tendons: exact constraints on the closed tree."""
import warnings

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

import eomc  # noqa: E402
from eomc.compiler.mjcf import MjcfModel  # noqa: E402
from eomc.compiler.mjcf.compare import prepared, qacc_of, to_mujoco, tree_of  # noqa: E402
from eomc.compiler.mjcf.model import load_mjmodel  # noqa: E402

XML = """<mujoco model="tied">
  <compiler angle="radian"/>
  <worldbody>
    <body name="a" pos="0 0 1">
      <joint name="h1" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="1"/>
      <body name="b" pos="0.3 0 0">
        <joint name="h2" type="hinge" axis="0 1 0" ref="0.1"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="0.5"/>
        <body name="c" pos="0.3 0 0">
          <joint name="h3" type="hinge" axis="0 0 1"/>
          <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.03" mass="0.3"/>
        </body>
      </body>
    </body>
  </worldbody>
  <tendon>
    <fixed name="t1"><joint joint="h2" coef="1"/><joint joint="h3" coef="0.5"/></fixed>
    <fixed name="t2"><joint joint="h1" coef="2"/></fixed>
  </tendon>
  <equality>
    <tendon name="tie" tendon1="t1" tendon2="t2" polycoef="0.05 0.7 0.3 0 0" solimp="0.9999 0.9999 0.001"
            solref="0.002 1"/>
  </equality>
</mujoco>
"""


@pytest.fixture(scope="module")
def tied(tmp_path_factory):
    root = tmp_path_factory.mktemp("tied")
    path = root / "tied.xml"
    path.write_text(XML)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(MjcfModel(path, limits=False), functions=["rhs", "constraints", "constraints_jac", "jac_x"],
                             cache_dir=root / "c", progress=False)
    return path, model


def _lengths(q):      # eomc's state order: h1, h3, h2 (the dependent h2 last)
    h1, h3, h2 = q
    return h2 + 0.5 * h3, 2 * h1          # absolute: at qpos0 (h2 = ref = 0.1) L1_0 = 0.1, L2_0 = 0


def test_initial_state_on_the_coupling_and_drift(tied):
    path, model = tied
    assert model.state_names[:3] == ("q_h1", "q_h3", "q_h2")
    x0 = model.initial_state.copy()
    L1, L2 = _lengths(x0[:3])
    # MuJoCo's L_0: lengths at qpos0 (h2 = ref = 0.1): L1_0 = 0.1, L2_0 = 0
    d = L2
    assert L1 - 0.1 == pytest.approx(0.05 + 0.7 * d + 0.3 * d * d, abs=1e-14)
    x0[0] = 0.2
    x0 = model.consistent_state(x0, fixed=["q_h1", "q_h3"])
    res = model.simulate(x0, (0.0, 1.0), method="radau", rtol=1e-10, atol=1e-12)
    for x in res.x[::100]:
        L1, L2 = _lengths(x[:3])
        assert L1 - 0.1 == pytest.approx(0.05 + 0.7 * L2 + 0.3 * L2 * L2, abs=1e-7)


def test_against_mujocos_stiff_coupling(tied):
    """At rest on the coupling, MuJoCo's near-hard equality (solimp 0.9999) gives eomc's qacc."""
    path, model = tied
    m = load_mjmodel(path)
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT) | int(mujoco.mjtDisableBit.mjDSBL_LIMIT)
    built = tree_of(m, model)
    d = mujoco.MjData(m)
    x0 = model.initial_state.copy()
    x0[0] = 0.3
    x0[1] = -0.2
    x0 = model.consistent_state(x0, fixed=["q_h1", "q_h3"])
    q, u = x0[:3], x0[3:]
    d.qpos[:], d.qvel[:] = to_mujoco(m, built, q, u)
    mujoco.mj_forward(m, d)
    mine = qacc_of(m, built, q, u, model.rhs(0.0, x0)[3:])
    assert np.max(np.abs(mine - d.qacc)) < 2e-3 * np.max(np.abs(d.qacc))
