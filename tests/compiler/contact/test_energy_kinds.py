"""The ``energy`` output for the kinds session 17 added (compiler/contact/tree.energy_blockers):
models with joint limits and no ground contact, a position servo's bias at zero control (its
spring kp/2 L² counted), and MuJoCo's fluid forces with no wind (dissipative: no term needed).

Why (issue 29 item 1): a run with limits must carry an honest verdict; before, a model without
ground contacts had no energy output, so a step that created energy through a limit ended with
status 0.  Oracles: MuJoCo's mj_energyPos + mj_energyVel plus the servos' potential by hand
(to 1e-12), a conservative Radau run (drift < 1e-9), a planted source (RK4 at 5 ms on an
undamped stiff limit: status 20), and MuJoCo's own fluid force doing no positive work."""
import warnings
from pathlib import Path

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

import eomc  # noqa: E402
from eomc.compiler.contact.tree import energy_blockers  # noqa: E402
from eomc.compiler.mjcf import MjcfModel  # noqa: E402
from eomc.compiler.mjcf.compare import to_mujoco, tree_of  # noqa: E402
from eomc.compiler.mjcf.model import load_mjmodel, read_model  # noqa: E402
from eomc.runtime.switching import STATUS_ENERGY, PhysicsWarning  # noqa: E402
from helpers.params import params_with  # noqa: E402

# no floor: a limited shoulder, an elbow held by a position servo (gear 2), a servo on a fixed
# tendon over both (its control range holds 0), a motor, in a fluid (the upper arm MuJoCo's
# inertia box, the lower its ellipsoid model: added mass, Magnus and Kutta lift, drag)
SERVO = """<mujoco model="servo">
  <compiler angle="radian"/>
  <option density="1000" viscosity="0.01" {wind}><flag energy="enable"/></option>
  <worldbody>
    <body name="upper" pos="0 0 1">
      <joint name="shoulder" type="hinge" axis="0 1 0" range="-1 1" limited="true"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="1"/>
      <body name="lower" pos="0.3 0 0">
        <joint name="elbow" type="hinge" axis="0 1 0" armature="0.01"/>
        <geom type="box" size="0.1 0.02 0.03" pos="0.1 0 0" mass="0.5" fluidshape="ellipsoid"/>
      </body>
    </body>
  </worldbody>
  <tendon><fixed name="sum"><joint joint="shoulder" coef="1"/><joint joint="elbow" coef="0.5"/></fixed></tendon>
  <actuator>
    <position name="hold" joint="elbow" kp="20" gear="2" {servo}/>
    <position name="pull" tendon="sum" kp="5" ctrlrange="-1 1" ctrllimited="true"/>
    <motor name="push" joint="shoulder"/>
  </actuator>
</mujoco>
"""


def _file(tmp, name, wind="", servo=""):
    path = tmp / f"{name}.xml"
    path.write_text(SERVO.format(wind=wind, servo=servo))
    return path


@pytest.fixture(scope="module")
def servo(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("kinds")
    path = _file(tmp, "servo")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return path, eomc.compile(MjcfModel(path), functions=("rhs", "jac_x", "outputs"), cache_dir=tmp / "c",
                                  progress=False)


def test_energy_is_mujocos_plus_the_servos_springs(servo):
    """mj_energyPos (gravity) + mj_energyVel (armature included) + kp/2 L² of each servo, L the
    actuator's length (gear·q; the tendon's length): the output to 1e-12, at states past the
    limit too (MuJoCo's energy has no limit term; neither has the MJCF energy output)."""
    path, model = servo
    assert "energy" in model.output_names and "servos' bias" in model.metadata["energy"]
    m = load_mjmodel(path)
    d = mujoco.MjData(m)
    built = tree_of(m, model)
    rng = np.random.default_rng(17)
    for _ in range(6):
        x = rng.normal(scale=1.0, size=model.nx)
        out = model.outputs(0.0, x)
        d.qpos[:], d.qvel[:] = to_mujoco(m, built, x[:model.nq], x[model.nq:])
        mujoco.mj_forward(m, d)
        mujoco.mj_energyPos(m, d)
        mujoco.mj_energyVel(m, d)
        springs = 20.0 * (2.0 * d.qpos[1]) ** 2 / 2 + 5.0 * d.ten_length[0] ** 2 / 2
        assert out["energy"] == pytest.approx(d.energy[0] + d.energy[1] + springs, rel=1e-12, abs=1e-12)


def test_a_conservative_run_keeps_its_energy_and_the_fluid_only_takes_it(servo):
    """No fluid, inside the range: Radau at 1e-11 keeps the energy to 1e-9; in the fluid the
    energy only falls (status 0); through the limit it falls (the limit's damping)."""
    _, model = servo
    dry = params_with(model, fluid_density=0.0, fluid_viscosity=0.0)
    x0 = np.array([0.3, -0.4, 0.0, 0.0])
    res = model.simulate(x0, (0, 3), p=dry, method="radau", rtol=1e-11, atol=1e-12)
    E = res.outputs["energy"]
    assert res.status == 0 and np.abs(E - E[0]).max() < 1e-9 * abs(E[0])
    wet = model.simulate(x0, (0, 3), method="radau")
    E = wet.outputs["energy"]
    assert wet.status == 0 and np.diff(E).max() < 0.0 and E[-1] < E[0] - 1.0     # falls at every point
    with warnings.catch_warnings():     # 0.036 past the limit: the overshoot's own warning
        warnings.simplefilter("ignore", PhysicsWarning)
        hit = model.simulate(np.array([0.5, -0.4, 4.0, 0.0]), (0, 3), p=dry, method="radau")
    E = hit.outputs["energy"]
    assert hit.status == 0 and hit.x[:, 0].max() > 1.0 and E.max() - E[0] < 1e-6 * E[0] and E[-1] < E[0] - 1.0


def test_a_step_that_creates_energy_at_the_limit_fails_the_run(servo):
    """RK4 at 5 ms on an undamped stiff limit (limit_k 1e4, limit_c 0) gains 3.5 J of 20.8 J at
    the impact: status 20 (before, with no energy output, status 0); Radau at 1e-10: no gain."""
    _, model = servo
    p = params_with(model, fluid_density=0.0, fluid_viscosity=0.0, limit_k_shoulder=1e4, limit_c_shoulder=0.0)
    x0 = np.array([0.5, -0.4, 4.0, 0.0])
    bad = model.simulate(x0, (0, 3), p=p, method="rk4", dt=5e-3, raise_on_failure=False)
    assert bad.status == STATUS_ENERGY and "energy rose" in bad.message
    good = model.simulate(x0, (0, 3), p=p, method="radau", rtol=1e-10, atol=1e-12)
    E = good.outputs["energy"]
    assert good.status == 0 and good.x[:, 0].max() > 1.0 and E.max() - E[0] < 1e-9 * E[0]


def test_a_negative_fluid_density_is_refused(servo):
    _, model = servo
    with pytest.raises(ValueError, match="fluid_density"):
        model.simulate(np.zeros(4), (0, 0.1), p=params_with(model, fluid_density=-1.0))


def test_what_still_keeps_the_energy_out(tmp_path):
    """A wind pushes energy in; a servo with activation dynamics whose control range holds no 0
    moves its activation from 0 at zero control (with a range holding 0 its bias is counted, the
    run judged from act = 0: tests/runtime/test_energy_activations.py); a clamped force clamps
    spring and damper together: no energy output, named."""
    def blockers(**kw):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return "; ".join(energy_blockers(read_model(_file(tmp_path, "b", **kw))))
    assert blockers() == ""
    assert "a wind" in blockers(wind='wind="1 0 0"')
    assert blockers(servo='timeconst="0.1"') == ""
    assert "the activation act_hold moves from 0" in blockers(servo='timeconst="0.1" ctrlrange="0.2 1" ctrllimited="true"')
    assert "bias1_hold" in blockers(servo='forcerange="-1 1" forcelimited="true"')


def _fluid_power(path, seed):
    """max over random states of MuJoCo's qfrc_fluid·qvel over |qfrc_fluid|·|qvel|."""
    m = load_mjmodel(path)
    d = mujoco.MjData(m)
    rng = np.random.default_rng(seed)
    worst = -np.inf
    for _ in range(200):
        d.qpos[:] = m.qpos0 + rng.normal(scale=0.5, size=m.nq)
        d.qvel[:] = rng.normal(scale=3.0, size=m.nv)
        mujoco.mj_forward(m, d)
        f = d.qfrc_fluid
        worst = max(worst, float(f @ d.qvel) / max(np.linalg.norm(f) * np.linalg.norm(d.qvel), 1e-300))
    return worst


def test_mujocos_fluid_forces_do_no_positive_work():
    """The claim energy_blockers rests on (fluid.FluidLoad/EllipsoidFluidLoad.passive_fluid),
    measured on MuJoCo's own forces: gymnasium's swimmer (inertia box) and dm_control's fish
    (ellipsoids, with added mass, Magnus and Kutta lift) never do positive work with no wind."""
    gymnasium = pytest.importorskip("gymnasium")
    dm_control = pytest.importorskip("dm_control")
    swimmer = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / "swimmer.xml"
    fish = Path(dm_control.__file__).parent / "suite" / "fish.xml"
    for path in (swimmer, fish):
        assert _fluid_power(path, 1) <= 1e-12
    assert energy_blockers(read_model(swimmer)) == []
    # the fish: its fluid and servos pass; it has no limit or contact to judge a run by
    assert energy_blockers(read_model(fish)) == ["no ground contact and no joint limit"]
