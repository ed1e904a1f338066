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
from eomc.compiler.mjcf.compare import to_mujoco  # noqa: E402
from eomc.compiler.mjcf.model import load_mjmodel  # noqa: E402
from eomc.compiler.mjcf.treeir import tree_ir  # noqa: E402
from eomc.runtime.switching import STATUS_ENERGY, PhysicsWarning, contact_parameter  # noqa: E402

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
    built = tree_ir(m)
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


def test_no_energy_output_with_a_spring_and_no_verdict_while_an_input_acts(tmp_path):
    """A joint spring's start energy is not in the output: no energy output, no false verdict.
    An actuator is a source only while its input is not zero: judged at r = 0, not at r != 0."""
    # only its output names are read: the outputs function decides them (2.4 -> 0.5 s CPU)
    _, sprung = _build(tmp_path, "sprung", spring='stiffness="3"', functions=("outputs",))
    assert "energy" not in sprung.output_names
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
