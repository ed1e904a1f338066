"""MJCF models (eomc.compiler.mjcf) against MuJoCo's own mj_forward, and what is refused.

The oracle is MuJoCo itself with contacts, constraints and limits off: qacc at random
states, eomc's states mapped to MuJoCo's (quaternions for ball/free joints, world-frame
free-joint velocity; eomc.compiler.mjcf.compare).  Models are built once per module.
"""
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

import eomc  # noqa: E402
from eomc.compiler.mjcf.compare import prepared, qacc_of, to_mujoco  # noqa: E402
from eomc.compiler.mjcf.model import MjcfModel, check_model, load_mjmodel  # noqa: E402
from eomc.compiler.mjcf.treeir import tree_ir  # noqa: E402
from eomc.runtime.errors import EomcWarning, ModelError, ModelFileError  # noqa: E402

SMALL = """<mujoco model="small">
  <option gravity="0.3 -0.2 -9.81"/>
  <default><joint damping="0.05"/></default>
  <worldbody>
    <body name="base" pos="0.1 0.2 0.3" quat="0.9 0.1 0.2 0.3">
      <joint name="slider" type="slide" axis="1 0.2 0" ref="0.1"/>
      <geom type="box" size="0.1 0.2 0.05" mass="2"/>
      <body name="link1" pos="0 0 -0.2" euler="10 20 30">
        <joint name="h1" type="hinge" axis="0 1 0.3" pos="0.05 0 0.1" stiffness="2" springref="0.3"/>
        <joint name="h2" type="hinge" axis="1 0 0" pos="0 0.02 0" ref="0.2"/>
        <geom type="capsule" fromto="0 0 0 0.1 0.05 -0.4" size="0.03"/>
        <body name="link2" pos="0.1 0.05 -0.4">
          <joint name="ball" type="ball" pos="0 0 0.01"/>
          <geom type="box" size="0.05 0.08 0.12" pos="0.02 0 -0.1" euler="5 10 15"/>
          <body name="welded" pos="0 0.1 -0.2" euler="0 0 40">
            <geom type="sphere" size="0.04" pos="0.01 0 0"/>
          </body>
        </body>
      </body>
    </body>
    <body name="floater" pos="1 0 1">
      <freejoint name="free"/>
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
    if "armature" in ignore:
        m.dof_armature[:] = 0
    built = tree_ir(m, actuators=motors)
    d = mujoco.MjData(m)
    rng = np.random.default_rng(7)
    nq, nu = len(built.coordinates), len(built.speeds)
    assert model.nq == nq and model.nx == nq + nu and model.ninput == len(motors)
    worst = 0.0
    for _ in range(trials):
        q, u = rng.uniform(-1.2, 1.2, nq), rng.uniform(-2, 2, nu)
        r = rng.uniform(-1, 1, len(motors))
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
    model = eomc.compile(MjcfModel(path, limits=False), cache_dir=root / "cache", progress=False)
    return path, model


def test_small_model_matches_mj_forward(small):
    """Hinge chain with two joints on one body (refs, anchor, spring, damping), slide, ball,
    a welded body, a free body with a child, general gravity and motors: qacc to 1e-10."""
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
        built = tree_ir(m, actuators=check_model(m, path))
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


@pytest.mark.parametrize("asset, ignore", [("inverted_double_pendulum.xml", ("limits",)),
                                           ("hopper.xml", ("armature", "limits"))])
def test_gymnasium_model_matches_mj_forward(asset, ignore, tmp_path):
    """Shipped models (gymnasium's wheel); hopper's armature is dropped on both sides."""
    path = _gym_asset(asset)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EomcWarning)
        model = eomc.compile(MjcfModel(path, ignore=ignore), functions=["rhs"], cache_dir=tmp_path,
                             progress=False)
    assert _worst(model, path, ignore) < 1e-10


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
    (dict(body='armature="0.1"'), r"bad.xml:4: <joint>: joint j: armature 0.1", 4),
    (dict(body="", extra='<tendon><fixed name="t"><joint joint="j" coef="1"/></fixed></tendon>'),
     r"<tendon>: 1 tendon\(s\) \(e.g. t\)", 2),
    (dict(body="", extra='<equality><joint name="eq" joint1="j" joint2="k"/></equality>'),
     r"<equality>: 1 equality constraint\(s\) \(e.g. eq\)", 2),
    (dict(body="", actuator='<actuator><position name="servo" joint="j" kp="10"/></actuator>'),
     r"<actuator>: actuator servo: it is not a plain motor", 8),
    (dict(body="", actuator='<actuator><general name="filt" joint="j" dyntype="filter"/></actuator>'),
     r"actuator filt: it is not a plain motor", 8),
    (dict(body="", extra='<option density="1.2"/>'), r"<option>: fluid forces", 2),
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
    """A tendon and a servo dropped on request: a warning each; the servo is no input."""
    path = tmp_path / "ok.xml"
    path.write_text("""<mujoco><worldbody><body><joint name="j" type="hinge"/><geom size="0.1"/>
      <body pos="0 0 -1"><joint name="k" type="hinge"/><geom size="0.1"/></body></body></worldbody>
      <tendon><fixed name="t"><joint joint="j" coef="1"/></fixed></tendon>
      <actuator><position name="servo" joint="j"/><motor name="mot" joint="k"/></actuator></mujoco>""")
    with pytest.warns(EomcWarning) as record:
        model = eomc.compile(MjcfModel(path, ignore=("tendons", "actuators")), functions=["rhs"],
                             cache_dir=tmp_path / "c", progress=False)
    text = " ".join(str(w.message) for w in record)
    assert "ignored: 1 tendon(s)" in text and "ignored: actuator servo" in text
    assert model.input_names == ("ctrl_mot",)


def test_refusal_points_at_the_named_joint(tmp_path):
    """Armature from a default class: the line of the first joint that has it, by name."""
    path = tmp_path / "cls.xml"
    path.write_text("""<mujoco>
  <default><default class="heavy"><joint armature="0.5"/></default></default>
  <worldbody>
    <body><joint name="light" type="hinge"/><geom size="0.1"/>
      <body pos="0 0 1">
        <joint name="geared" class="heavy" type="hinge"/><geom size="0.1"/>
      </body>
    </body>
  </worldbody>
</mujoco>""")
    with pytest.raises(ModelFileError, match=r"cls.xml:6: <joint>: joint geared: armature 0.5"):
        eomc.compile(str(path), functions=["rhs"], cache_dir=tmp_path / "c", progress=False)


@pytest.mark.parametrize("joint, match", [
    ('<freejoint name="f"/>', None),
    ('<joint name="f" type="free" damping="0.1"/>', "joint f: damping on a free joint"),
    ('<joint name="b" type="ball" stiffness="2"/>', "joint b: stiffness on a ball joint"),
    ('<joint name="h" type="hinge" damping="-0.5"/>', r"xml:1: <joint>: joint h: negative damping"),
    ('<joint name="h" type="hinge" stiffness="-2"/>', "joint h: negative damping or stiffness"),
])
def test_joint_checks(tmp_path, joint, match):
    """What the joint-space loads cannot carry is refused (checked without building)."""
    path = tmp_path / "j.xml"
    path.write_text(f'<mujoco><worldbody><body>{joint}<geom size="0.1"/></body></worldbody></mujoco>')
    m = load_mjmodel(path)
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
    """`eomc build model.xml` builds it (through the same dispatch)."""
    path, _ = small
    out = subprocess.run([sys.executable, "-m", "eomc", "build", str(path), "-o", str(tmp_path / "out"),
                          "--cache-dir", str(tmp_path / "cache")],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert any((tmp_path / "out").rglob("*.c"))
