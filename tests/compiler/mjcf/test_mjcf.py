"""MJCF models (eomc.compiler.mjcf) against MuJoCo's own mj_forward, and what is refused.

The oracle is MuJoCo itself with contacts, constraints and limits off: qacc at random
states, eomc's states mapped to MuJoCo's (quaternions for ball/free joints, world-frame
free-joint velocity; eomc.compiler.mjcf.compare).  Models are built once per module.
The models whose ball and free joints the oracle maps are built with orientation="euler"
(body-XYZ angles, the mapping these tests check); the default's quaternions have the same
tests in test_mjcf_quaternion.py.
"""
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

import eomc  # noqa: E402
from eomc.compiler.mjcf.compare import prepared, qacc_of, to_mujoco, tree_of  # noqa: E402
from eomc.compiler.mjcf.model import MjcfModel, check_model, load_mjmodel  # noqa: E402
from eomc.compiler.mjcf.treeir import tree_ir  # noqa: E402
from eomc.runtime.errors import EomcWarning, ModelError, ModelFileError  # noqa: E402

SMALL = """<mujoco model="small">
  <option gravity="0.3 -0.2 -9.81"/>
  <default><joint damping="0.05"/></default>
  <worldbody>
    <body name="base" pos="0.1 0.2 0.3" quat="0.9 0.1 0.2 0.3">
      <joint name="slider" type="slide" axis="1 0.2 0" ref="0.1" armature="0.3"/>
      <geom type="box" size="0.1 0.2 0.05" mass="2"/>
      <body name="link1" pos="0 0 -0.2" euler="10 20 30">
        <joint name="h1" type="hinge" axis="0 1 0.3" pos="0.05 0 0.1" stiffness="2" springref="0.3"
               armature="0.05"/>
        <joint name="h2" type="hinge" axis="1 0 0" pos="0 0.02 0" ref="0.2"/>
        <geom type="capsule" fromto="0 0 0 0.1 0.05 -0.4" size="0.03"/>
        <body name="link2" pos="0.1 0.05 -0.4">
          <joint name="ball" type="ball" pos="0 0 0.01" armature="0.02"/>
          <geom type="box" size="0.05 0.08 0.12" pos="0.02 0 -0.1" euler="5 10 15"/>
          <body name="welded" pos="0 0.1 -0.2" euler="0 0 40">
            <geom type="sphere" size="0.04" pos="0.01 0 0"/>
          </body>
        </body>
      </body>
    </body>
    <body name="floater" pos="1 0 1">
      <joint name="free" type="free" armature="0.15" damping="0"/>
      <geom type="ellipsoid" size="0.1 0.2 0.3" pos="0.05 0.02 0.01" euler="20 30 40"/>
      <body name="tip" pos="0.3 0 0">
        <joint name="h3" type="hinge" axis="0 0 1" range="-1 1"/>
        <geom type="box" size="0.1 0.05 0.02" pos="0.1 0 0"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor joint="slider" gear="3"/>
    <motor name="m1" joint="h1" gear="0.7"/>
    <motor joint="h3" gear="1.5" ctrlrange="-1 1" ctrllimited="true"/>
  </actuator>
</mujoco>
"""


def _worst(model, path, ignore=(), trials=6):
    """max |qacc_eomc - qacc_mujoco| / max(1, |qacc|) over random states and controls."""
    m = prepared(load_mjmodel(path))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EomcWarning)
        motors = check_model(m, path, ignore)
    built = tree_of(m, model, actuators=motors)
    d = mujoco.MjData(m)
    rng = np.random.default_rng(7)
    nq, nu = len(built.coordinates), len(built.speeds)
    assert model.nq == nq and model.nx == nq + nu and model.ninput == len(motors)
    worst = 0.0
    for _ in range(trials):
        q, u = rng.uniform(-1.2, 1.2, nq), rng.uniform(-2, 2, nu)
        r = rng.uniform(-1.5, 1.5, len(motors))       # beyond ctrlrange too: MuJoCo clamps, so must eomc
        xd = model.rhs(0.0, np.concatenate([q, u]), r=r)
        d.qpos[:], d.qvel[:] = to_mujoco(m, built, q, u)
        d.ctrl[:] = 0
        d.ctrl[motors] = r
        mujoco.mj_forward(m, d)
        assert np.max(np.abs(d.qacc)) > 1e-3          # a state that moves
        mine = qacc_of(m, built, q, u, xd[nq:])
        worst = max(worst, np.max(np.abs(mine - d.qacc)) / max(1.0, np.max(np.abs(d.qacc))))
    return worst


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    root = tmp_path_factory.mktemp("mjcf")
    path = root / "small.xml"
    path.write_text(SMALL)
    model = eomc.compile(MjcfModel(path, limits=False, orientation="euler"), cache_dir=root / "cache",
                         progress=False)
    return path, model


def test_small_model_matches_mj_forward(small):
    """Hinge chain with two joints on one body (refs, anchor, spring, damping), slide, ball,
    a welded body, a free body with a child, general gravity and motors, armature on a slide,
    a hinge, a ball and a free joint (MuJoCo's dof_armature kept; the free joint's on MuJoCo's
    world-frame linear dofs): qacc to 1e-10."""
    path, model = small
    assert model.state_names[:3] == ("q_slider", "q_h1", "q_h2")
    assert model.input_names == ("ctrl_actuator0", "ctrl_m1", "ctrl_actuator2")
    assert _worst(model, path) < 1e-10


def test_wrong_state_mapping_is_detected(small):
    """The oracle is sharp: the free body's rotation mapped the wrong way round is caught."""
    path, model = small
    m = prepared(load_mjmodel(path))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EomcWarning)
        built = tree_of(m, model, actuators=check_model(m, path))
    q, u = np.full(model.nq, 0.4), np.linspace(-1, 1, model.nx - model.nq)
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = to_mujoco(m, built, q, u)
    a = m.jnt_qposadr[[j for j in built.joints if j[1] == 0][0][0]]
    d.qpos[a + 4:a + 7] *= -1              # the inverse rotation: Euler angles read the wrong way round
    mujoco.mj_forward(m, d)
    xd = model.rhs(0.0, np.concatenate([q, u]))
    assert np.max(np.abs(qacc_of(m, built, q, u, xd[model.nq:]) - d.qacc)) > 1e-3


def _gym_asset(name):
    gym = pytest.importorskip("gymnasium")
    return Path(gym.__file__).parent / "envs" / "mujoco" / "assets" / name


def test_small_model_jacobian_has_the_armature(small):
    """jac_x of a model with armature (slide, hinge, ball, free) against central differences of its rhs;
    and the armature matters: without it the rhs differs."""
    path, model = small
    rng = np.random.default_rng(3)
    x = np.concatenate([rng.uniform(-1, 1, model.nq), rng.uniform(-1, 1, model.nx - model.nq)])
    r = rng.uniform(-1, 1, model.ninput)
    J = model.jacobian(0.0, x, r=r)
    h = 1e-6
    fd = np.column_stack([(model.rhs(0.0, x + h * e, r=r) - model.rhs(0.0, x - h * e, r=r)) / (2 * h)
                          for e in np.eye(model.nx)])
    assert np.max(np.abs(J - fd)) < 1e-6 * max(1.0, np.max(np.abs(J)))
    names = model.param_names
    p = np.array(model.param_defaults, dtype=float)
    assert {"arm_slider", "arm_h1", "arm_ball_x", "arm_ball_y", "arm_ball_z", "arm_free_vx",
            "arm_free_wz"} <= set(names)
    p0 = p.copy()
    p0[[names.index(k) for k in names if k.startswith("arm_")]] = 0
    assert np.max(np.abs(model.rhs(0.0, x, p=p0, r=r) - model.rhs(0.0, x, p=p, r=r))) > 1e-3


def _full_mass_matrix(m, d):
    """mj_fullM across MuJoCo versions (4.x takes the MjData, 3.x the sparse qM)."""
    M = np.zeros((m.nv, m.nv))
    try:
        mujoco.mj_fullM(m, d, M)
    except TypeError:
        mujoco.mj_fullM(m, M, d.qM)
    return M


@pytest.fixture(scope="module")
def hopper(tmp_path_factory):
    path = _gym_asset("hopper.xml")
    model = eomc.compile(MjcfModel(path, ignore=("limits",), geoms=False),   # MuJoCo's contacts off too
                         functions=["rhs", "mass_matrix", "inverse_dynamics"],
                         cache_dir=tmp_path_factory.mktemp("hopper"), progress=False)
    return path, model


def test_hopper_mass_matrix_and_inverse_dynamics_with_armature(hopper):
    """Hopper (hinges and slides, armature 1 on its leg joints): M against mj_fullM and inverse
    dynamics against mj_rne + armature·qacc - qfrc_passive (MuJoCo's mj_rne leaves the armature
    out; mj_inverse adds it), to 1e-12 relative."""
    path, model = hopper
    m = prepared(load_mjmodel(path))
    assert np.any(m.dof_armature)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EomcWarning)
        built = tree_of(m, model, actuators=check_model(m, path, ("limits",)))
    d, rng = mujoco.MjData(m), np.random.default_rng(5)
    for _ in range(3):
        q, u, w = rng.uniform(-1, 1, m.nq), rng.uniform(-2, 2, m.nv), rng.uniform(-3, 3, m.nv)
        x = np.concatenate([q, u])
        d.qpos[:], d.qvel[:] = to_mujoco(m, built, q, u)
        mujoco.mj_forward(m, d)
        M = _full_mass_matrix(m, d)
        assert np.max(np.abs(model.mass_matrix(0.0, x) - M)) < 1e-12 * np.max(np.abs(M))
        d.qacc[:] = w
        res = np.zeros(m.nv)
        mujoco.mj_rne(m, d, 1, res)
        tau = model.inverse_dynamics(0.0, x, w)
        expected = res + m.dof_armature * w - d.qfrc_passive
        assert np.max(np.abs(tau - expected)) < 1e-12 * max(1.0, np.max(np.abs(expected)))
        assert np.max(np.abs(tau - (res - d.qfrc_passive))) > 1e-2     # the armature term is there


@pytest.mark.parametrize("asset, ignore", [("inverted_double_pendulum.xml", ("limits",)),
                                           ("hopper.xml", ("limits",)),
                                           ("walker2d.xml", ("limits",)),
                                           ("half_cheetah.xml", ("limits",)),
                                           ("ant.xml", ("limits",)),
                                           ("humanoid.xml", ("limits",))])
def test_gymnasium_model_matches_mj_forward(asset, ignore, tmp_path):
    """Shipped models (gymnasium's wheel), their armature kept on both sides, with no ignore but
    the limits warning (humanoid's two fixed tendons apply no force: accepted as they are).
    Ground contacts off on both sides (tests/compiler/mjcf/test_ground_drops.py has them)."""
    path = _gym_asset(asset)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EomcWarning)
        model = eomc.compile(MjcfModel(path, ignore=ignore, geoms=False, orientation="euler"), functions=["rhs"],
                             cache_dir=tmp_path, progress=False)
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always", EomcWarning)
        assert _worst(model, path, ignore) < 1e-10
    # reloading for mj_forward repeats MuJoCo's one compiler warning: half cheetah's deprecated attribute
    expected = ["settotalmass"] if asset == "half_cheetah.xml" else []
    assert [m for m in expected if any(m in str(w.message) for w in seen)] == expected
    assert all("settotalmass" in str(w.message) for w in seen), [str(w.message) for w in seen]


def _refused(tmp_path, body, match, *, actuator="", extra="", ignore=()):
    path = tmp_path / "bad.xml"
    path.write_text(f"""<mujoco>
  {extra}
  <worldbody>
    <body name="a"><joint name="j" type="hinge" {body}/><geom size="0.1"/>
      <body name="b" pos="0 0 -1"><joint name="k" type="hinge"/><geom size="0.1"/></body>
    </body>
  </worldbody>
  {actuator}
</mujoco>""")
    with pytest.raises(ModelFileError, match=match) as info:
        eomc.compile(MjcfModel(path, ignore=ignore), functions=["rhs"], cache_dir=tmp_path / "c",
                     progress=False)
    return info.value


@pytest.mark.parametrize("kw, match, line", [
    (dict(body="", extra='<tendon><fixed name="t" armature="0.1"><joint joint="j" coef="1"/></fixed></tendon>'),
     r"<tendon>: tendon t: armature", 2),
    (dict(body="", extra='<equality><weld name="eq" body1="a" body2="b"/></equality>'),
     r"<weld>: equality eq: <weld> is a weld between bodies", 2),
    (dict(body="", actuator='<actuator><intvelocity name="mus" joint="j" kp="1" actrange="-1 1"/></actuator>'),
     r"<actuator>: actuator mus: its activation is limited", 8),
    (dict(body="", actuator='<actuator><general name="filt" joint="j" dyntype="muscle"/></actuator>'),
     r"actuator filt: it has muscle or user-defined activation dynamics", 8),
])
def test_refused_with_element_and_line(tmp_path, kw, match, line):
    error = _refused(tmp_path, match=match, **kw)
    assert error.lineno == line
    assert "ignore=(" in str(error)


def test_mujoco_errors_keep_their_line(tmp_path):
    """MuJoCo's own compiler refuses a free joint below the world: its message, at its line."""
    path = tmp_path / "nested.xml"
    path.write_text('<mujoco><worldbody><body><joint type="hinge"/><geom size="0.1"/>\n'
                    '<body pos="0 0 1"><freejoint name="loose"/><geom size="0.1"/></body></body>\n'
                    '</worldbody></mujoco>')
    with pytest.raises(ModelFileError, match="nested.xml:2: MuJoCo could not compile the model: .*free joint "
                                             "can only be used on top level") as info:
        eomc.compile(str(path), functions=["rhs"], cache_dir=tmp_path / "c", progress=False)
    assert info.value.lineno == 2


def test_ignored_on_request_with_a_warning(tmp_path):
    """A tendon and a muscle-activated actuator dropped on request: a warning each; the latter is no input."""
    path = tmp_path / "ok.xml"
    path.write_text("""<mujoco><worldbody><body><joint name="j" type="hinge"/><geom size="0.1"/>
      <body pos="0 0 -1"><joint name="k" type="hinge"/><geom size="0.1"/></body></body></worldbody>
      <tendon><fixed name="t" damping="0.5"><joint joint="j" coef="1"/></fixed></tendon>
      <actuator><general name="servo" joint="j" dyntype="muscle"/><motor name="mot" joint="k"/></actuator>
      </mujoco>""")
    with pytest.warns(EomcWarning) as record:
        model = eomc.compile(MjcfModel(path, ignore=("tendons", "actuators")), functions=["rhs"],
                             cache_dir=tmp_path / "c", progress=False)
    text = " ".join(str(w.message) for w in record)
    assert "ignored: 1 tendon(s)" in text and "ignored: actuator servo" in text
    assert model.input_names == ("ctrl_mot",)


def test_refusal_points_at_the_named_joint(tmp_path):
    """A negative armature from a default class: the line of the joint that has it, by name."""
    path = tmp_path / "cls.xml"
    path.write_text("""<mujoco>
  <default><default class="heavy"><joint armature="-0.5"/></default></default>
  <worldbody>
    <body><joint name="light" type="hinge"/><geom size="0.1"/>
      <body pos="0 0 1">
        <joint name="geared" class="heavy" type="hinge"/><geom size="0.1"/>
      </body>
    </body>
  </worldbody>
</mujoco>""")
    # MuJoCo itself warns that the negative armature leaves M singular; eomc then refuses the file
    with pytest.warns(EomcWarning, match="MuJoCo: Inertia matrix is too close to singular"), \
            pytest.raises(ModelFileError, match=r"cls.xml:6: <joint>: joint geared: negative armature -0.5"):
        eomc.compile(str(path), functions=["rhs"], cache_dir=tmp_path / "c", progress=False)


@pytest.mark.parametrize("joint, match", [
    ('<freejoint name="f"/>', None),
    ('<joint name="f" type="free" damping="0.1"/>', "joint f: damping on a free joint"),
    ('<joint name="b" type="ball" stiffness="2"/>', "joint b: stiffness on a ball joint"),
    ('<joint name="h" type="hinge" damping="-0.5"/>', r"xml:1: <joint>: joint h: negative damping"),
    ('<joint name="h" type="hinge" stiffness="-2"/>', "joint h: negative damping or stiffness"),
    ('<joint name="h" type="hinge" armature="-0.1"/>', r"xml:1: <joint>: joint h: negative armature -0.1"),
])
def test_joint_checks(tmp_path, joint, match):
    """What the joint-space loads cannot carry is refused (checked without building)."""
    path = tmp_path / "j.xml"
    path.write_text(f'<mujoco><worldbody><body>{joint}<geom size="0.1"/></body></worldbody></mujoco>')
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always", EomcWarning)
        m = load_mjmodel(path)
    # MuJoCo's compiler warns only where a negative armature leaves M singular
    singular = [w for w in seen if "too close to singular" in str(w.message)]
    assert len(singular) == len(seen) == ("armature=\"-" in joint), [str(w.message) for w in seen]
    if match is None:
        assert check_model(m, path) == []
        return
    with pytest.raises(ModelFileError, match=match):
        check_model(m, path)


def test_mujoco_warnings_become_ours(tmp_path, monkeypatch):
    """MuJoCo's compiler warnings come out as EomcWarnings, not as a MUJOCO_LOG.TXT in the cwd."""
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "old.xml"
    path.write_text('<mujoco><compiler settotalmass="3"/><worldbody><body><joint type="hinge"/>'
                    '<geom size="0.1"/></body></worldbody></mujoco>')
    with pytest.warns(EomcWarning, match="old.xml: MuJoCo: compiler attribute 'settotalmass' is deprecated"):
        load_mjmodel(path)
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()


def test_bad_input_messages(tmp_path):
    with pytest.raises(ModelError, match=r"unknown; what may be ignored: tendons"):
        eomc.compile(MjcfModel(tmp_path / "x.xml", ignore=("tendon",)), progress=False)
    broken = tmp_path / "broken.xml"
    broken.write_text("<mujoco><worldbody><body><joint type='hinge'/></body></worldbody>")
    with pytest.raises(ModelFileError, match="broken.xml: MuJoCo could not compile the model"):
        eomc.compile(str(broken), cache_dir=tmp_path / "c", progress=False)
    with pytest.raises(ModelFileError, match="missing.xml: no such file"):
        eomc.compile(str(tmp_path / "missing.xml"), progress=False)


def test_cli_build(small, tmp_path):
    """`python -m eomc build model.xml` builds it (through the same dispatch; the fixture's cache,
    so the child only exports what the fixture built)."""
    path, _ = small
    out = subprocess.run([sys.executable, "-m", "eomc", "build", str(path), "-o", str(tmp_path / "out"),
                          "--cache-dir", str(path.parent / "cache")],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert any((tmp_path / "out").rglob("*.c"))


def test_regressor_refuses_armature(small, tmp_path):
    """Y·pi has no column for the armature's a·u': asking for the regressor says so, naming the joint."""
    path, _ = small
    with pytest.raises(ModelError, match=r"regressor is not generated for a tree with armature \(body base, "
                                         r"joint slider\)"):
        eomc.compile(str(path), functions=["regressor"], cache_dir=tmp_path, progress=False)


def test_poses_are_mujocos_body_frames(small):
    """The animation's poses: every MuJoCo body frame's origin and rotation equal MuJoCo's xpos and
    xmat at random states (to 1e-12), welded and multi-joint bodies included; geoms as shapes."""
    path, model = small
    m = prepared(load_mjmodel(path))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EomcWarning)
        built = tree_of(m, model, actuators=check_model(m, path))
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(1, m.nbody)]
    d, rng = mujoco.MjData(m), np.random.default_rng(11)
    for _ in range(3):
        q, u = rng.uniform(-1.5, 1.5, model.nq), rng.uniform(-1, 1, model.nx - model.nq)
        poses = model.poses(0.0, np.concatenate([q, u]))
        assert list(poses.frame_names) == names
        d.qpos[:], d.qvel[:] = to_mujoco(m, built, q, u)
        mujoco.mj_kinematics(m, d)
        for b, name in enumerate(names, start=1):
            assert np.max(np.abs(poses[name] - d.xpos[b])) < 1e-12
            assert np.max(np.abs(poses.rotation(name) - d.xmat[b].reshape(3, 3))) < 1e-12
        placed = []           # every shape's pose in the world: body pose x its origin
        for name, items in model.metadata["poses"]["geometry"].items():
            T = np.eye(4)
            T[:3, :3], T[:3, 3] = poses.rotation(name), poses[name]
            placed += [T @ np.array(item["origin"]).reshape(4, 4) for item in items]
        for g in range(m.ngeom):          # each geom is drawn where MuJoCo has it
            assert min(np.max(np.abs(P[:3, 3] - d.geom_xpos[g])) + np.max(np.abs(P[:3, :3] - d.geom_xmat[g].reshape(3, 3)))
                       for P in placed) < 1e-12
    shapes = model.metadata["poses"]["geometry"]
    kinds = {k: sorted(s["kind"] for s in v) for k, v in shapes.items()}
    assert kinds["link1"] == ["cylinder", "sphere", "sphere"]          # the capsule
    assert kinds["floater"] == ["box"]                                 # the ellipsoid's bounding box
    assert kinds["welded"] == ["sphere"] and kinds["base"] == ["box"]
    assert shapes["base"][0]["size"] == [0.2, 0.4, 0.1]


SERVO = """<mujoco model="servo">
  <worldbody>
    <body name="a" pos="0 0 1">
      <joint name="j1" type="hinge" axis="0 1 0" armature="0.1"/>
      <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.04"/>
      <body name="b" pos="0.4 0 0">
        <joint name="j2" type="hinge" axis="0 1 0.2" ref="0.3"/>
        <geom type="box" size="0.15 0.03 0.03" pos="0.15 0 0"/>
        <body name="c" pos="0.3 0 0">
          <joint name="s3" type="slide" axis="1 0 0"/>
          <geom type="sphere" size="0.05"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <position name="p1" joint="j1" kp="20" kv="2" gear="1.5" ctrlrange="-0.5 0.5"/>
    <velocity name="v2" joint="j2" kv="3" gear="0.8"/>
    <motor name="m2" joint="j2" gear="2" ctrlrange="-1 1" ctrllimited="true"/>
    <position name="p3" joint="s3" kp="50" forcerange="-4 4"/>
    <general name="g3" joint="s3" gaintype="affine" gainprm="1 0.5 0.2" biastype="affine" biasprm="0.1 -2 -0.3"/>
  </actuator>
</mujoco>
"""


def test_servos_and_clamping_match_mj_forward(tmp_path):
    """Position and velocity servos (kp, kv, gear), an affine general actuator, ctrlrange and
    forcerange clamping: qacc against mj_forward with controls beyond their ranges (to 1e-10),
    and jac_x, jac_r, jac_p against central differences (the clamps' slopes included)."""
    path = tmp_path / "servo.xml"
    path.write_text(SERVO)
    # without the a-c self-pair (in by default since session 11): at these random states it is
    # pressed deep (rhs ~1e6), and the central differences' rounding, eps |rhs| / h ~ 4e-4, is
    # above the bar; this test is about the servos (the pair's own checks: tests/compiler/contact)
    model = eomc.compile(MjcfModel(path, pairs="trees"), "servo", functions=["rhs", "jac_x", "jac_r", "jac_p"],
                         cache_dir=tmp_path / "c", progress=False)
    assert model.input_names == ("ctrl_p1", "ctrl_v2", "ctrl_m2", "ctrl_p3", "ctrl_g3")
    assert {"arm_j1", "gain_p1", "bias1_p1", "bias2_p1", "bias2_v2", "gain2_g3", "bias0_g3"} <= set(model.param_names)
    assert _worst(model, path, trials=8) < 1e-10
    m = prepared(load_mjmodel(path))
    built = tree_of(m, model, actuators=check_model(m, path))
    d, rng = mujoco.MjData(m), np.random.default_rng(2)
    clamped = 0
    for _ in range(4):
        x = np.concatenate([rng.uniform(-1, 1, model.nq), rng.uniform(-1, 1, model.nx - model.nq)])
        r = rng.uniform(-2, 2, model.ninput)
        d.qpos[:], d.qvel[:] = to_mujoco(m, built, x[:model.nq], x[model.nq:])
        d.ctrl[:] = r
        mujoco.mj_forward(m, d)
        clamped += int(abs(d.actuator_force[3]) == 4.0) + int(abs(r[0]) > 0.5)
        h = 1e-6
        fd = np.column_stack([(model.rhs(0.0, x + h * e, r=r) - model.rhs(0.0, x - h * e, r=r)) / (2 * h)
                              for e in np.eye(model.nx)])
        J = model.jacobian(0.0, x, r=r)
        assert np.max(np.abs(J - fd)) < 1e-6 * max(1.0, np.max(np.abs(J)))
        fd = np.column_stack([(model.rhs(0.0, x, r=r + h * e) - model.rhs(0.0, x, r=r - h * e)) / (2 * h)
                              for e in np.eye(model.ninput)])
        B = model.input_jacobian(0.0, x, r=r)
        assert np.max(np.abs(B - fd)) < 1e-6 * max(1.0, np.max(np.abs(B)))
        p = model.param_defaults
        fd = np.column_stack([(model.rhs(0.0, x, p=p + h * e, r=r) - model.rhs(0.0, x, p=p - h * e, r=r)) / (2 * h)
                              for e in np.eye(model.nparam)])
        P = model.jac_p(0.0, x, r=r)          # the armature, gains and biases as parameters
        assert np.max(np.abs(P - fd)) < 1e-6 * max(1.0, np.max(np.abs(P)))
    assert clamped >= 2                                   # the clamps were exercised


def test_kane_formulation_is_refused_saying_why(small, tmp_path):
    path, _ = small
    with pytest.raises(ModelError, match="an MJCF model has the recursive formulation only"):
        eomc.compile(str(path), functions=["rhs"], formulation="kane", cache_dir=tmp_path, progress=False)


def test_initial_state_is_mujocos_qpos0(small, tmp_path):
    """A model starts where mj_resetData puts it: refs, and a free body where (and as turned as)
    the file puts it, in eomc's coordinates (mapped back, the same qpos0; quaternions compared as
    rotations)."""
    path, model = small
    m = load_mjmodel(path)
    built = tree_of(m, model, actuators=check_model(m, path, ("limits",)))
    x0 = np.asarray(model.initial_state)
    assert x0[model.state_names.index("q_slider")] == pytest.approx(0.1)
    qpos, _ = to_mujoco(m, built, x0[:model.nq], x0[model.nq:])
    assert np.max(np.abs(qpos - m.qpos0)) < 1e-15
    turned = tmp_path / "turned.xml"
    turned.write_text('<mujoco><worldbody><body pos="0.5 -1 2" euler="30 -70 120"><freejoint name="f"/>'
                      '<geom size="0.1"/></body></worldbody></mujoco>')
    from eomc.compiler.mjcf.model import reference_state
    from eomc.compiler.mjcf.treeir import quat_matrix
    m = load_mjmodel(turned)
    built = tree_ir(m, actuators=[])
    state = reference_state(m, built)
    q = np.array([state.get(str(c).replace("(t)", ""), 0.0) for c in built.coordinates])
    qpos, _ = to_mujoco(m, built, q, np.zeros(6))
    assert np.max(np.abs(qpos[:3] - [0.5, -1, 2])) < 1e-15
    assert np.max(np.abs(quat_matrix(qpos[3:]) - quat_matrix(m.qpos0[3:]))) < 1e-14


def test_fixed_tendons_are_accepted(tmp_path):
    """Fixed tendons are modelled (tests/compiler/mjcf/test_mjcf_tendon.py): with or without
    stiffness, limits, friction, accepted with no warning; one with armature is refused."""
    def tendon(attrs):
        path = tmp_path / "t.xml"
        path.write_text(f"""<mujoco><worldbody><body><joint name="j" type="hinge"/><geom size="0.1"/>
          <body pos="0 0 -1"><joint name="k" type="hinge"/><geom size="0.1"/></body></body></worldbody>
          <tendon><fixed name="t" {attrs}><joint joint="j" coef="1"/><joint joint="k" coef="-1"/></fixed></tendon>
          </mujoco>""")
        return load_mjmodel(path), path
    for attrs in ("", 'limited="true" range="-0.1 0.1"', 'stiffness="2" frictionloss="0.1"'):
        m, path = tendon(attrs)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            assert check_model(m, path) == []
    m, path = tendon('armature="0.2"')
    with pytest.raises(ModelFileError, match=r"t.xml:3: <tendon>: tendon t: armature"):
        check_model(m, path)
