"""dm_control's suite (the models its wheel ships) against MuJoCo's own mj_forward, and what is refused.

The oracle is MuJoCo with contacts, constraints and limits off on both sides (eomc built with
``limits=False, geoms=False``): qacc at random states, eomc's states mapped to MuJoCo's
(eomc.compiler.mjcf.compare).  Models with ``<equality><tendon>`` couplings (manipulator,
stacker, quadruped) are closed trees in eomc: the oracle is MuJoCo's own M, forces and tendon
Jacobians with the coupling as an exact constraint (``coupled_qacc``), at states on the
coupling.  Actuators with activation dynamics (quadruped's filters) add MuJoCo's ``act`` as
states: their rates are compared with ``act_dot``.  The largest models (humanoid_CMU, humanoid,
quadruped) are in ``benchmarks/bench_dm_suite.py``'s full run; this file takes the rest.
"""
import warnings
from pathlib import Path

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")
dm_control = pytest.importorskip("dm_control")

import eomc  # noqa: E402
from eomc.compiler.mjcf import MjcfModel  # noqa: E402
from eomc.compiler.mjcf.compare import coupled_qacc, prepared, qacc_of, rhs_error, to_mujoco, tree_of  # noqa: E402
from eomc.compiler.mjcf.model import check_model, load_mjmodel  # noqa: E402
from eomc.runtime.errors import ModelFileError  # noqa: E402

SUITE = Path(dm_control.__file__).parent / "suite"
FAST = ["acrobot", "cartpole", "pendulum", "point_mass", "reacher", "finger", "fish", "swimmer", "cheetah",
        "hopper", "walker", "manipulator", "stacker"]
SLOW = ["quadruped", "humanoid", "humanoid_CMU"]


def _build(name, cache):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return eomc.compile(MjcfModel(SUITE / f"{name}.xml", limits=False, geoms=False),
                            functions=["rhs", "constraints", "constraints_jac"], cache_dir=cache, progress=False)


@pytest.mark.parametrize("name", FAST)
def test_suite_model_matches_mj_forward(name, tmp_path):
    model = _build(name, tmp_path)
    assert rhs_error(SUITE / f"{name}.xml", model) < 1e-12


@pytest.mark.slow
def test_quadruped_filters_and_couplings_match_mj_forward(tmp_path):
    """Quadruped: 12 actuators with first-order filters (act' = (ctrl - act)/0.1), 8 of them on
    fixed tendons, four tendon couplings: act_dot and qacc to 1e-12; the inputs stay the
    controls in MuJoCo's actuator order, the activations are states after q and u."""
    model = _build("quadruped", tmp_path)
    m = load_mjmodel(SUITE / "quadruped.xml")
    assert model.input_names == tuple(f"ctrl_{mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, k)}"
                                      for k in range(m.nu))
    assert model.state_names[-12:] == tuple(f"act_{mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, k)}"
                                            for k in range(m.nu))
    assert rhs_error(SUITE / "quadruped.xml", model) < 1e-12


def test_coupling_oracle_is_sharp(tmp_path):
    """Without the coupling the oracle's answer differs from eomc's: the test can fail."""
    model = _build("manipulator", tmp_path)
    path = SUITE / "manipulator.xml"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m0 = load_mjmodel(path)
        built = tree_of(m0, model, actuators=check_model(m0, path), limits=False, friction=False)
        m = prepared(load_mjmodel(path))
    d = mujoco.MjData(m)
    nq = len(built.coordinates)
    x = model.consistent_state(np.full(model.nx, 0.3), fixed=list(model.state_names[:nq - 1]))
    d.qpos[:], d.qvel[:] = to_mujoco(m, built, x[:nq], x[nq:])
    mujoco.mj_forward(m, d)
    mine = qacc_of(m, built, x[:nq], x[nq:], model.rhs(0.0, x, r=np.zeros(model.ninput))[nq:])
    ref = coupled_qacc(m, d)
    scale = np.max(np.abs(ref))
    assert np.max(np.abs(mine - ref)) < 1e-12 * scale
    assert np.max(np.abs(mine - d.qacc)) > 1e-3 * scale    # MuJoCo unconstrained: not the same


def test_ball_in_cup_hangs_on_its_string(tmp_path):
    """ball_in_cup's string is a spatial tendon through two sites with a range limit (0, 0.3): the
    ball falls until the string is taut and hangs under the sprung cup, as in MuJoCo's mj_step
    (the string's length and the ball's height after 2 s within 1 cm: MuJoCo's limit is a soft
    constraint, eomc's a spring-damper, so they stretch differently)."""
    path = SUITE / "ball_in_cup.xml"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(path, cache_dir=tmp_path, progress=False)
        m = load_mjmodel(path)
        built = tree_of(m, model, actuators=check_model(m, path))
    res = model.simulate(model.initial_state, (0.0, 2.0))
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = to_mujoco(m, built, res.x[-1][:model.nq], res.x[-1][model.nq:])
    mujoco.mj_kinematics(m, d)
    site = {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_SITE, i): np.array(d.site_xpos[i]) for i in range(m.nsite)}
    length = np.linalg.norm(site["ball"] - site["cup"])
    ball = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "ball")
    mine = float(d.xpos[ball][2])
    ref = mujoco.MjData(m)
    for _ in range(int(round(2.0 / m.opt.timestep))):
        mujoco.mj_step(m, ref)
    assert 0.3 <= length < 0.31
    assert abs(mine - ref.xpos[ball][2]) < 0.01
    assert mine < 0.2 - 0.05                    # it fell: with no string it would rest on the floor


def test_actuator_refusal_points_at_the_actuator_not_the_joint_of_its_name(tmp_path):
    """dm_control names actuators as the joints they drive: the refusal's line is the actuator's."""
    path = tmp_path / "m.xml"
    path.write_text("""<mujoco>
  <worldbody>
    <body name="a"><joint name="yaw" type="hinge"/><geom size="0.1"/></body>
  </worldbody>
  <actuator>
    <general name="yaw" joint="yaw" dyntype="muscle"/>
  </actuator>
</mujoco>""")
    with pytest.raises(ModelFileError, match=r"actuator yaw: it has muscle") as info:
        eomc.compile(path, functions=["rhs"], cache_dir=tmp_path / "c", progress=False)
    assert "m.xml:6:" in str(info.value)


def test_varying_height_field_refused_flat_one_is_a_plane(tmp_path):
    """A height field a moving geom can touch: refused at its line unless flat (then a plane at its top)."""
    def write(data):
        path = tmp_path / "h.xml"
        path.write_text(f"""<mujoco>
  <asset><hfield name="terrain" nrow="2" ncol="2" size="1 1 0.5 0.1" elevation="{data}"/></asset>
  <worldbody>
    <geom name="ground" type="hfield" hfield="terrain" pos="0 0 -0.2"/>
    <body name="ball" pos="0 0 1"><freejoint/><geom type="sphere" size="0.1" mass="1"/></body>
  </worldbody>
</mujoco>""")
        return path
    with pytest.raises(ModelFileError, match=r"<geom>: geom ground: a height field") as info:
        eomc.compile(write("0 1 0 1"), functions=["rhs"], cache_dir=tmp_path / "c", progress=False)
    assert "h.xml:4:" in str(info.value)
    path = write("1 1 1 1")
    model = eomc.compile(path, cache_dir=tmp_path / "c", progress=False)
    res = model.simulate(model.initial_state, (0.0, 2.0))
    m = load_mjmodel(path)
    d = mujoco.MjData(m)
    for _ in range(int(round(2.0 / m.opt.timestep))):
        mujoco.mj_step(m, d)
    # MuJoCo normalises the elevation data (a flat field is all zeros): the top is at its pos, z = -0.2
    assert m.hfield_data.tolist() == [0.0] * 4
    z = res.x[-1][model.state_names.index("q_ball_joint_z") if "q_ball_joint_z" in model.state_names else 2]
    assert abs(z - d.qpos[2]) < 1e-3 and abs(z - (-0.1)) < 1e-3


def test_filter_and_integrator_activations_match_mj_forward(tmp_path):
    """Activation states of a filter (on a tendon), a filterexact servo and an integrator, with
    ctrlrange clamping before the dynamics: qacc and act_dot against mj_forward to 1e-12."""
    path = tmp_path / "act.xml"
    path.write_text("""<mujoco>
  <worldbody>
    <body name="a"><joint name="h1" type="hinge" axis="0 1 0"/><geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
      <body name="b" pos="0.3 0 0"><joint name="h2" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/></body></body>
  </worldbody>
  <tendon><fixed name="t"><joint joint="h1" coef="1"/><joint joint="h2" coef="-0.5"/></fixed></tendon>
  <actuator>
    <general name="f" tendon="t" dyntype="filter" dynprm="0.2" gainprm="3" ctrllimited="true" ctrlrange="-1 1"/>
    <general name="x" joint="h2" dyntype="filterexact" dynprm="0.05" gainprm="5" biastype="affine" biasprm="0 -5 -0.3"/>
    <general name="i" joint="h1" dyntype="integrator" gainprm="0.7"/>
  </actuator>
</mujoco>""")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(path, functions=["rhs"], cache_dir=tmp_path / "c", progress=False)
    assert model.state_names[-3:] == ("act_f", "act_x", "act_i")
    assert model.input_names == ("ctrl_f", "ctrl_x", "ctrl_i")
    assert rhs_error(path, model, trials=6) < 1e-12


@pytest.mark.parametrize("name", ["finger", "cartpole", "point_mass", "swimmer"])
def test_suite_model_simulates_with_no_flags(name, tmp_path):
    """Built as a user would (no flags: ground contacts, body–body pairs, limits) and run 5 s with
    the default method: it finishes with finite states.  finger's capsules start exactly parallel
    to the spinner's (the pair's nearest points must stay finite, with their Jacobian)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(SUITE / f"{name}.xml", cache_dir=tmp_path, progress=False)
    assert np.isfinite(model.jacobian(0.0, model.initial_state)).all()
    res = model.simulate(model.initial_state, (0.0, 5.0))
    assert res.t[-1] == pytest.approx(5.0) and np.isfinite(res.x).all()


@pytest.mark.slow
def test_manipulator_runs_under_radau_past_its_peg_landing(tmp_path):
    """dm_control's manipulator, default build (its body-body pairs on), under method="radau":
    its peg lands on the slot at t ~ 0.18-0.22 s.  Before body-body pairs had switching functions
    (contact_/clip_<pair> events) Radau stepped across the pair law's kinks and stopped at
    t = 0.2212 s with a 2e-16 step (status != 0); it must run past 0.3 s with status 0, and the
    pairs' outputs must be there (Fn_/depth_<pair>)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(SUITE / "manipulator.xml", functions=["rhs", "jac_x", "events", "outputs"],
                             cache_dir=tmp_path, progress=False)
    events = [e["name"] for e in model.metadata["events"]]
    assert "contact_pommel__slot_1" in events and "clip_pommel__slot_1" in events
    assert {"Fn_pommel__slot_1", "depth_pommel__slot_1"} <= set(model.output_names)
    result = model.simulate(model.initial_state, (0.0, 0.35), method="radau")
    assert result.status == 0, result.message
    assert result.t[-1] == pytest.approx(0.35)
