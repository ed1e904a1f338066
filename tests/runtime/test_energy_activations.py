"""The energy verdict on a model whose servos have activation dynamics (MJCF ``timeconst`` /
``dyntype="filter"``: dm_control's quadruped and dog).

Why (issue 29 item 1): such a servo pushes with gain·act + bias.  With every activation at 0 and a
zero control the activation stays 0 (act' = (ctrl - act)/τ), so the servo is its bias, a spring
the energy output counts, and a run is judged; from a start with an activation not at 0 the servo
pushes with a state the energy does not hold, so the run is not judged (runtime/switching.
_activations_at_rest; the energy text says so, compiler/tree/lower.energy_text).  Before, such
a model had no energy output at all."""
import warnings

import numpy as np
import pytest

pytest.importorskip("mujoco")

import eomc  # noqa: E402
from eomc.compiler.mjcf import MjcfModel  # noqa: E402
from eomc.runtime.switching import ACTIVATIONS_AT_REST, STATUS_ENERGY, PhysicsWarning  # noqa: E402
from helpers.params import params_with  # noqa: E402

# a limited shoulder, an elbow held by a filtered position servo (its control range holds 0)
ARM = """<mujoco model="filtered">
  <compiler angle="radian"/>
  <worldbody>
    <body name="upper" pos="0 0 1">
      <joint name="shoulder" type="hinge" axis="0 1 0" range="-1 1" limited="true"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="1"/>
      <body name="lower" pos="0.3 0 0">
        <joint name="elbow" type="hinge" axis="0 1 0" armature="0.01"/>
        <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02" mass="0.5"/>
      </body>
    </body>
  </worldbody>
  <actuator><position name="hold" joint="elbow" kp="20" timeconst="0.05" ctrlrange="-1 1" ctrllimited="true"/></actuator>
</mujoco>
"""


@pytest.fixture(scope="module")
def filtered(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("acts")
    path = tmp / "filtered.xml"
    path.write_text(ARM)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return eomc.compile(MjcfModel(path), functions=("rhs", "jac_x", "outputs"), cache_dir=tmp / "c",
                            progress=False)


def test_the_energy_counts_the_bias_and_says_when_it_holds(filtered):
    model = filtered
    assert "energy" in model.output_names and model.nz == 1 and model.state_names[-1] == "act_hold"
    assert ACTIVATIONS_AT_REST in model.metadata["energy"] and "servos' bias" in model.metadata["energy"]
    x = np.array([0.3, -0.4, 1.0, -2.0, 0.0])
    # the servo's share: kp/2 q² (its bias -kp q at act = 0; MuJoCo's <position>: bias1 = -kp)
    unsprung = model.outputs(0.0, x, params_with(model, bias1_hold=0.0))["energy"]
    assert model.outputs(0.0, x)["energy"] - unsprung == pytest.approx(20.0 * x[1] ** 2 / 2, rel=1e-12)


def test_judged_from_activations_at_zero_and_not_judged_otherwise(filtered):
    """RK4 at 5 ms on an undamped stiff limit creates 4.8 J of 18.4 J at the impact: from act = 0 (zero
    control) the run fails (status 20); the same run from act = 0.3 is not judged (status 0: the
    servo pushes with its state); tight Radau from act = 0 keeps the energy (the bias counted)."""
    model = filtered
    p = params_with(model, limit_k_shoulder=1e4, limit_c_shoulder=0.0)
    x0 = np.array([0.5, -0.4, 8.0, 0.0, 0.0])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhysicsWarning)
        judged = model.simulate(x0, (0, 3), p=p, method="rk4", dt=5e-3, raise_on_failure=False)
        loose = model.simulate(np.r_[x0[:4], 0.3], (0, 3), p=p, method="rk4", dt=5e-3, raise_on_failure=False)
    assert judged.status == STATUS_ENERGY and "energy rose" in judged.message
    assert np.all(judged.x[:, -1] == 0.0)                   # the activation stayed 0
    assert loose.status == 0 and loose.outputs["energy"].max() > loose.outputs["energy"][0] + 0.1
    with warnings.catch_warnings():     # the default limit is soft: its overshoot's own warning
        warnings.simplefilter("ignore", PhysicsWarning)
        good = model.simulate(x0, (0, 3), p=params_with(model, limit_c_shoulder=0.0), method="radau", rtol=1e-10,
                              atol=1e-12)
    E = good.outputs["energy"]
    assert good.status == 0 and good.x[:, 0].max() > 1.0 and E.max() - E[0] < 1e-8 * E[0]
