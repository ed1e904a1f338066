"""The ``energy`` output of a passive robot with ground contacts (compiler/tree/contacts.py)
against MuJoCo's own energy (mj_energyPos + mj_energyVel: gravity's potential and
1/2 u'Mu with the joints' armature), plus the contacts' elastic energy k δ^(5/2) / (5/2).

Why it matters: the runtime fails a run whose passive robot gained energy
(runtime/switching.verdict); a tree robot had no energy to judge by (issue 29)."""
import warnings

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

import eomc  # noqa: E402
from eomc.compiler.mjcf import MjcfModel  # noqa: E402
from eomc.compiler.mjcf.compare import to_mujoco, tree_of  # noqa: E402
from eomc.compiler.mjcf.model import load_mjmodel  # noqa: E402
from eomc.runtime.switching import STATUS_ENERGY, PhysicsWarning, contact_parameter  # noqa: E402
from helpers.params import undamped  # noqa: E402

XML = """<mujoco model="{name}">
  <option><flag energy="enable"/></option>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="torso" pos="0 0 0.5" euler="0.2 0.1 0">
      <freejoint/>
      <geom type="box" size="0.1 0.05 0.04" mass="2"/>
      <geom name="nose" type="sphere" size="0.02" pos="0.1 0 0" mass="0.1"/>
      <body name="leg" pos="0 0 -0.05" euler="0 20 0">
        <joint name="hip" type="hinge" axis="0 1 0" armature="0.02" {spring}/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.015" mass="0.3"/>
        <geom name="foot" type="sphere" size="0.03" pos="0.01 0.02 -0.3" mass="0.05"/>
      </body>
    </body>
  </worldbody>
  {actuator}
</mujoco>
"""


def _build(tmp, name, spring="", actuator="", functions=("rhs", "jac_x", "outputs")):
    path = tmp / f"{name}.xml"
    path.write_text(XML.format(name=name, spring=spring, actuator=actuator))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(MjcfModel(path), functions=functions, cache_dir=tmp / "c", progress=False)
    return path, model


@pytest.fixture(scope="module")
def passive(tmp_path_factory):
    return _build(tmp_path_factory.mktemp("energy"), "passive")


def test_energy_is_mujocos_plus_the_contacts_elastic_energy(passive):
    path, model = passive
    m = load_mjmodel(path)
    d = mujoco.MjData(m)
    built = tree_of(m, model)
    rng = np.random.default_rng(29)
    p = np.array(model.param_defaults)
    names = model.param_names
    for _ in range(6):
        x = np.array(model.initial_state, dtype=float)
        x[:model.nq] += rng.normal(scale=0.3, size=model.nq)
        x[2] = rng.uniform(0.0, 0.5)        # some samples with a foot or the nose in the floor
        x[model.nq:] = rng.normal(size=model.nu)
        out = model.outputs(0.0, x)
        d.qpos[:], d.qvel[:] = to_mujoco(m, built, x[:model.nq], x[model.nq:])
        mujoco.mj_forward(m, d)
        mujoco.mj_energyPos(m, d)
        mujoco.mj_energyVel(m, d)
        index = {n: i for i, n in enumerate(names)}
        elastic = sum(p[contact_parameter(index, "k", c)] * max(out[f"depth_{c}"], 0.0) ** 2.5 / 2.5
                      for c in (n[len("depth_"):] for n in model.output_names if n.startswith("depth_")))
        assert out["energy"] == pytest.approx(d.energy[0] + d.energy[1] + elastic, rel=1e-12, abs=1e-12)


def test_a_passive_drop_keeps_its_energy_and_a_created_gain_fails_the_run(passive):
    """Dropped, it loses energy (damped contacts); with the switching points off at a stiff,
    undamped k, Radau's step over the impact creates energy: the run fails (status 20) where,
    without the energy output, it ended with status 0."""
    _, model = passive
    with warnings.catch_warnings():
        warnings.simplefilter("error", PhysicsWarning)
        res = model.simulate(model.initial_state, (0, 1.0), method="radau")
    E = res.outputs["energy"]
    assert res.status == 0 and E.max() - E[0] < 1e-6 * abs(E[0]) and E[-1] < E[0] - 1.0
    p = np.array(model.param_defaults)
    for n in model.param_names:
        if n.startswith("k_"):
            p[model.param_names.index(n)] = 1e7
        if n.startswith("c_"):
            p[model.param_names.index(n)] = 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhysicsWarning)
        bad = model.simulate(model.initial_state, (0, 1.0), p=p, method="radau", switching=False,
                             raise_on_failure=False, max_steps=20000)
        good = model.simulate(model.initial_state, (0, 1.0), p=p, method="radau")
    assert bad.status == STATUS_ENERGY and "energy rose" in bad.message     # 11.3 J -> 4e4 J
    assert good.status == 0 and good.outputs["energy"].max() <= good.outputs["energy"][0] * (1 + 1e-6)


def test_no_energy_output_with_a_servo_that_pushes_at_zero_control_and_no_verdict_while_an_input_acts(tmp_path):
    """A position servo with activation dynamics (timeconst) whose control range holds no 0
    drives its activation away from 0 at zero control, then pushes with it, a source the output
    cannot hold: no energy output, no false verdict (a plain servo's bias -kp q is a spring whose
    potential is counted since session 17, test_energy_kinds.py, and one with activation dynamics
    and a range holding 0 since session 18, tests/runtime/test_energy_activations.py; joint and
    tendon springs: test_springs_and_pairs_energy_is_mujocos_plus_the_elastic_energy).
    An actuator is a source only while its input is not zero: judged at r = 0, not at r != 0."""
    # only its output names are read: the outputs function decides them (2.4 -> 0.5 s CPU)
    servo = '<actuator><position joint="hip" kp="10" timeconst="0.05" ctrlrange="0.2 1" ctrllimited="true"/></actuator>'
    _, sprung = _build(tmp_path, "sprung", actuator=servo, functions=("outputs",))
    assert "energy" not in sprung.output_names
    _, plain = _build(tmp_path, "plain", actuator='<actuator><position joint="hip" kp="10"/></actuator>',
                      functions=("outputs",))
    assert "energy" in plain.output_names
    _, driven = _build(tmp_path, "driven", actuator='<actuator><motor joint="hip" gear="5"/></actuator>')
    assert "energy" in driven.output_names and driven.ninput == 1
    p = np.array(driven.param_defaults)
    for n in driven.param_names:
        if n.startswith("k_"):
            p[driven.param_names.index(n)] = 1e7
        if n.startswith("c_"):
            p[driven.param_names.index(n)] = 0.0
    kw = dict(p=p, method="radau", switching=False, raise_on_failure=False, max_steps=20000)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhysicsWarning)
        assert driven.simulate(driven.initial_state, (0, 1.0), **kw).status == STATUS_ENERGY
        pushed = driven.simulate(driven.initial_state, (0, 0.3), r=[1.0], **{**kw, "switching": True})
    assert pushed.status == 0 and pushed.outputs["energy"].max() > pushed.outputs["energy"][0] + 0.01


# Two free bodies (a ball resting on the floor, a ball with a sprung arm dropped onto it): a joint
# spring with its rest position, a fixed tendon's spring on it, and body-body pairs (sphere-sphere, sphere-capsule) besides the
# ground's contacts.  Their potentials are in the energy output (issue 29 item 1: gymnasium's
# humanoid, with self-pairs and joint springs, had none).
PAIRED = """<mujoco model="paired">
  <compiler angle="radian"/>
  <option><flag energy="enable"/></option>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="low" pos="0 0 0.12">
      <freejoint/>
      <geom name="lowball" type="sphere" size="0.1" mass="1"/>
    </body>
    <body name="high" pos="0.03 0.01 0.45" euler="0.3 0.2 0">
      <freejoint/>
      <geom name="head" type="sphere" size="0.08" mass="0.5"/>
      <body name="arm">
        <joint name="elbow" type="hinge" axis="0 1 0" stiffness="3" springref="0.4" armature="0.01"/>
        <geom name="bar" type="capsule" fromto="0 0 0 0.2 0 0" size="0.02" mass="0.2"/>
      </body>
    </body>
  </worldbody>
  <tendon><fixed name="tie" stiffness="2" springlength="0.1"><joint joint="elbow" coef="2"/></fixed></tendon>
</mujoco>
"""


def _paired(tmp, functions=("rhs", "jac_x", "outputs")):
    path = tmp / "paired.xml"
    path.write_text(PAIRED)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return path, eomc.compile(MjcfModel(path), functions=functions, cache_dir=tmp / "c", progress=False)


@pytest.fixture(scope="module")
def paired(tmp_path_factory):
    return _paired(tmp_path_factory.mktemp("paired"))


def _elastic(model, p, out):
    """Σ k δ₊^(5/2) / (5/2) over the ground contacts and the pairs, from their depth outputs."""
    index = {n: i for i, n in enumerate(model.param_names)}
    total = 0.0
    for c in (n[len("depth_"):] for n in model.output_names if n.startswith("depth_")):
        k = p[index["k_" + c]] if "__" in c else p[contact_parameter(index, "k", c)]
        total += k * max(out[f"depth_{c}"], 0.0) ** 2.5 / 2.5
    return total


def _unit(model, x):
    """x with each quaternion (the MJCF default's free joints) scaled to unit length: a pose."""
    for w in model.quaternions:
        x[w:w + 4] /= np.linalg.norm(x[w:w + 4])
    return x


def _states(model, rng, n):
    """Random states, the high ball pushed into the low one in some (pairs in contact)."""
    names = list(model.state_names)
    hx, hy, hz = (names.index(f"q_joint1_{a}") for a in "xyz")       # high's free joint
    for j in range(n):
        x = np.array(model.initial_state, dtype=float)
        x[:model.nq] += rng.normal(scale=0.05, size=model.nq)
        if j % 2:
            x[hz] = 0.12 + 0.17 - rng.uniform(0.0, 0.01)    # high's z: the balls overlap
            x[[hx, hy]] = x[0:2]
        x[model.nq:] = rng.normal(size=model.nu)
        yield _unit(model, x)


def test_springs_and_pairs_energy_is_mujocos_plus_the_elastic_energy(paired):
    """MuJoCo's mj_energyPos holds the joint spring's 1/2 k (q - springref)² and the tendon's
    1/2 k (L - springlength)²; the pairs' and the
    ground's elastic energy is k δ₊^(5/2) / (5/2) from their own depth outputs."""
    path, model = paired
    m = load_mjmodel(path)
    d = mujoco.MjData(m)
    built = tree_of(m, model)
    p = np.array(model.param_defaults)
    touched = 0
    for x in _states(model, np.random.default_rng(29), 6):
        out = model.outputs(0.0, x)
        d.qpos[:], d.qvel[:] = to_mujoco(m, built, x[:model.nq], x[model.nq:])
        mujoco.mj_forward(m, d)
        mujoco.mj_energyPos(m, d)
        mujoco.mj_energyVel(m, d)
        elastic = _elastic(model, p, out)
        touched += out["depth_lowball__head"] > 0
        assert out["energy"] == pytest.approx(d.energy[0] + d.energy[1] + elastic, rel=1e-12, abs=1e-12)
    assert touched >= 2


def test_a_conservative_run_with_springs_and_pairs_keeps_its_energy(paired):
    """c = 0, no friction, no damping: tight Radau keeps the energy through the balls' impact
    (the pair's elastic energy counted) to 1e-9 of it; at a hopeless fixed step (RK4 at 2 ms on
    pairs of k = 1e9) the energy created fails the run (status 20)."""
    _, model = paired
    p = undamped(model)
    res = model.simulate(model.initial_state, (0, 1.5), p=p, method="radau", rtol=1e-10, atol=1e-12)
    E = res.outputs["energy"]
    assert res.status == 0 and res.outputs["depth_lowball__head"].max() > 1e-3
    assert np.abs(E - E[0]).max() < 1e-9 * abs(E[0])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhysicsWarning)
        bad = model.simulate(model.initial_state, (0, 1.5), p=undamped(model, 1e9), method="rk4", dt=2e-3,
                             raise_on_failure=False)
    assert bad.status == STATUS_ENERGY and "energy rose" in bad.message


def test_the_pairs_table_holds_the_same_energy(paired, tmp_path, monkeypatch):
    """Through the pairs' table (pairs.TABLE_FROM = 1: gymnasium's humanoid's 109 pairs take it)
    the energy reads the table's depths: the same values as the inlined pairs'."""
    from eomc.compiler.contact import pairs
    monkeypatch.setattr(pairs, "TABLE_FROM", 1)
    _, table = _paired(tmp_path, functions=("outputs",))
    _, model = paired
    for x in _states(model, np.random.default_rng(3), 4):
        assert table.outputs(0.0, x)["energy"] == pytest.approx(model.outputs(0.0, x)["energy"], rel=1e-13)
