"""Frame outputs (eomc.compiler.tree.frames): poses, velocities, Jacobians, centre of mass.

Oracles: Pinocchio for URDF robots (``framesForwardKinematics``' ``oMf``,
``getFrameVelocity`` and ``getFrameJacobian`` in LOCAL_WORLD_ALIGNED, ``centerOfMass``
and ``vcom``) at random states -- UR5 (tool0, welded to the last link; base_link, welded
to the ground), Panda (the hand, welded; a finger, prismatic), Solo12 with a floating base
(feet, welded: the free joint's speeds are body-frame twists in both); a small URDF under
both formulations; MuJoCo's ``xpos``/``xmat``/``mj_jacBody``/``subtree_com`` for an MJCF
model with every joint type; SymPy's own kinematics for a System model under both.
Models are built once per module with only the ``outputs`` function (what frames add).
"""
import re
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import eomc
from eomc.compiler.urdf import build_tree, read_urdf
from eomc.compiler.urdf.model import UrdfModel
from eomc.runtime.errors import ModelError
from helpers.robots import PinRef, robot_path

TOL = 1e-12
ROBOTS = {"ur5": (False, ["tool0", "wrist_3_link", "base_link", "shoulder_link"]),
          "panda": (False, ["panda_hand", "panda_leftfinger", "panda_link3"]),
          "solo12": (True, ["FL_FOOT", "HR_FOOT", "base_link"])}

SMALL_URDF = """<robot name="small">
  <link name="base"/>
  <link name="arm"><inertial><origin xyz="0.1 0.02 0.3" rpy="0.1 0.2 0.3"/><mass value="1.5"/>
    <inertia ixx="0.02" ixy="0.001" ixz="0.002" iyy="0.03" iyz="0.003" izz="0.025"/></inertial></link>
  <link name="slide"><inertial><origin xyz="0.05 0 -0.1"/><mass value="0.7"/>
    <inertia ixx="0.004" ixy="0" ixz="0" iyy="0.005" iyz="0" izz="0.006"/></inertial></link>
  <link name="wheel"><inertial><origin xyz="0 0.01 0"/><mass value="0.3"/>
    <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.001"/></inertial></link>
  <link name="tip"/>
  <link name="sensor"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="arm"/>
    <origin xyz="0 0 0.2" rpy="0.3 0 0"/><axis xyz="0 0.6 0.8"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="j2" type="prismatic"><parent link="arm"/><child link="slide"/>
    <origin xyz="0.3 0 0.1" rpy="0 0.4 0.1"/><axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="j3" type="continuous"><parent link="slide"/><child link="wheel"/>
    <origin xyz="0 0.1 -0.2" rpy="0.2 0.1 0"/><axis xyz="0 1 0"/></joint>
  <joint name="weld" type="fixed"><parent link="wheel"/><child link="tip"/>
    <origin xyz="0.1 0.2 0.3" rpy="0.5 -0.4 1.2"/></joint>
  <joint name="weld2" type="fixed"><parent link="tip"/><child link="sensor"/>
    <origin xyz="-0.05 0.02 0.01" rpy="0 0 0.7"/></joint>
</robot>
"""
SMALL_FRAMES = ["tip", "sensor", "arm", "base"]


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("cache")


def _pinocchio_frame(ref, name, q, u):
    """(p, R, (v; w), J, com, vcom) of Pinocchio at eomc's state, J's columns in eomc's order."""
    m, d = ref.model, ref.data
    qp, vp = ref.q(q), ref.v(u)
    pin.forwardKinematics(m, d, qp, vp)
    pin.computeJointJacobians(m, d, qp)
    pin.updateFramePlacements(m, d)
    fid = m.getFrameId(name)
    assert fid < m.nframes, name
    J = pin.getFrameJacobian(m, d, fid, pin.LOCAL_WORLD_ALIGNED)[:, ref.iv]
    twist = pin.getFrameVelocity(m, d, fid, pin.LOCAL_WORLD_ALIGNED).vector
    com = pin.centerOfMass(m, d, qp, vp)
    return d.oMf[fid].translation, d.oMf[fid].rotation, twist, J, com, d.vcom[0].copy()


def _random_state(rng, model, floating):
    q = rng.uniform(-np.pi, np.pi, model.nq)
    if floating:
        q[:3], q[3:6] = rng.normal(size=3), rng.uniform(-1.2, 1.2, 3)
    return q, rng.normal(size=model.nu)


def _worst(model, ref, frames, floating, seed, states=3):
    rng = np.random.default_rng(seed)
    worst = 0.0
    for _ in range(states):
        q, u = _random_state(rng, model, floating)
        x = np.concatenate([q, u])
        for name in frames:
            f = model.frame(name, 0.0, x)
            p, R, twist, J, com, vcom = _pinocchio_frame(ref, name, q, u)
            c = model.frame("com", 0.0, x)
            worst = max(worst, *(float(np.max(np.abs(a - b))) for a, b in (
                (f.p, p), (f.R, R), (f.twist, twist), (f.J, J), (f.J @ u, f.twist), (c.p, com), (c.v, vcom))))
    return worst


@pytest.fixture(scope="module")
def robots(cache):
    out = {}
    for name, (floating, frames) in ROBOTS.items():
        path = robot_path(name)
        tree = build_tree(read_urdf(path), floating_base=floating)
        model = eomc.compile(UrdfModel(path, floating_base=floating), f"{name}_frames", functions=["outputs"],
                             formulation="recursive", cache_dir=cache, progress=False, frames=frames + ["com"])
        out[name] = model, PinRef(path, [(j.name, j.type) for j in tree.joints], floating=floating,
                                  locked=tree.locked)
    return out


@pytest.mark.parametrize("name", list(ROBOTS))
def test_robot_frames_agree_with_pinocchio(robots, name):
    model, ref = robots[name]
    floating, frames = ROBOTS[name]
    assert model.frame_names == tuple(frames) + ("com",)
    assert _worst(model, ref, frames, floating, seed=len(name)) < TOL


def test_output_names_and_shapes(robots):
    model, _ = robots["solo12"]
    names = model.output_names
    # the robot's own outputs first: its limits give it the energy output (since session 17)
    assert names[:4] == ("energy", "FL_FOOT.p.x", "FL_FOOT.p.y", "FL_FOOT.p.z")
    assert "FL_FOOT.R[0][1]" in names and "FL_FOOT.w.z" in names and "FL_FOOT.J[5][17]" in names
    assert "FL_FOOT.J[6][0]" not in names and "FL_FOOT.J[0][18]" not in names
    assert names[-6:] == ("com.p.x", "com.p.y", "com.p.z", "com.v.x", "com.v.y", "com.v.z")
    assert all("," not in n for n in names)            # CSV headers stay one column per name
    x = np.zeros(model.nx)
    x[2] = 0.4
    f = model.frame("FL_FOOT", 0.0, x)
    assert f.p.shape == (3,) and f.R.shape == (3, 3) and f.J.shape == (6, 18) and f.twist.shape == (6,)
    assert np.allclose(f.T[:3, 3], f.p) and f.T[3, 3] == 1.0
    rows = model.frame("FL_FOOT", np.zeros(4), np.tile(x, (4, 1)))
    assert rows.J.shape == (4, 6, 18) and np.array_equal(rows.p[2], f.p)
    c = model.frame("com", 0.0, x)
    assert c.R is None and c.J is None and c.p.shape == (3,)
    with pytest.raises(AttributeError, match="centre of mass"):
        c.twist


def test_unknown_frame_at_run_time_names_the_frames(robots):
    model, _ = robots["ur5"]
    with pytest.raises(KeyError, match=r"'tool1' is no frame output of this model; frames: tool0, wrist_3_link"):
        model.frame("tool1", 0.0, np.zeros(12))


@pytest.fixture(scope="module")
def small(tmp_path_factory, cache):
    path = tmp_path_factory.mktemp("small") / "small.urdf"
    path.write_text(SMALL_URDF)
    tree = build_tree(read_urdf(path))
    ref = PinRef(path, [(j.name, j.type) for j in tree.joints])
    models = {form: eomc.compile(path, f"small_{form}", functions=fns, formulation=form, cache_dir=cache,
                                 progress=False, frames=SMALL_FRAMES + ["com"])
              for form, fns in (("kane", ["outputs"]), ("recursive", ["rhs", "outputs"]))}
    return path, models, ref


@pytest.mark.parametrize("formulation", ["kane", "recursive"])
def test_both_formulations_agree_with_pinocchio(small, formulation):
    _, models, ref = small
    model = models[formulation]
    assert model.metadata["formulation"] == formulation
    assert _worst(model, ref, SMALL_FRAMES, False, seed=7, states=4) < TOL


def test_a_simulation_carries_the_frames(small):
    _, models, _ = small
    model = models["recursive"]
    res = model.simulate(np.array([0.3, 0.1, 0.2, 0.5, -0.4, 1.0]), (0.0, 0.2), n_points=5,
                         r=np.zeros(model.ninput))
    along = res.frame("tip")
    assert along.p.shape == (5, 3) and along.J.shape == (5, 6, 3)
    at = model.frame("tip", res.t, res.x)
    assert np.array_equal(along.R, at.R) and np.array_equal(along.J, at.J)
    assert np.array_equal(res["tip.p.z"], along.p[:, 2])
    c = res.frame("com")
    assert c.p.shape == (5, 3) and c.R is None


def test_generated_code_is_deterministic(small, cache):
    path, _, _ = small
    from eomc.compiler.driver import generate
    a, b = (generate(path, "small_det", functions=["outputs"], frames=["tip", "com"], use_cache=False,
                     formulation="recursive")[1] for _ in range(2))
    assert a.c_source == b.c_source and "tip.J[5][2]" in a.c_source


def test_unknown_link_lists_the_nearest_names(small, cache):
    path, _, _ = small
    with pytest.raises(ModelError, match=r"no link named 'tpi' to output as a frame \(nearest: tip"):
        eomc.compile(path, "small_bad", functions=["outputs"], frames=["tpi"], cache_dir=cache, progress=False)
    with pytest.raises(ModelError, match="add 'outputs' to the functions"):
        eomc.compile(path, "small_bad", functions=["rhs"], frames=["tip"], cache_dir=cache, progress=False)
    with pytest.raises(ModelError, match="list of frame names"):
        eomc.compile(path, "small_bad", functions=["outputs"], frames=3, cache_dir=cache, progress=False)
    with pytest.raises(ModelError, match="its order is the outputs' order"):
        eomc.compile(path, "small_bad", functions=["outputs"], frames={"tip", "com"}, cache_dir=cache,
                     progress=False)


def test_command_line(small, tmp_path, cache, capsys):
    from eomc.cli import main
    path, _, _ = small
    out = tmp_path / "built"
    assert main(["build", str(path), "-o", str(out), "-q", "--outputs", "rhs,outputs", "--frame", "tip",
                 "--frame", "com", "--formulation", "recursive", "--cache-dir", str(cache)]) == 0
    capsys.readouterr()
    csv = tmp_path / "traj.csv"
    assert main(["simulate", str(out), "--t-final", "0.1", "--points", "3", "--frame", "tip", "-o", str(csv)]) == 0
    text = capsys.readouterr().out
    assert "tip: position start (" in text and "tip.J[" not in text
    header = csv.read_text().splitlines()[0].split(",")
    assert "tip.R[2][2]" in header and "com.v.z" in header
    assert main(["simulate", str(out), "--t-final", "0.1", "--frame", "sensor"]) != 0
    assert "built without the frame output(s) sensor (it has: tip, com)" in capsys.readouterr().err


SYSTEM = Path(__file__).resolve().parents[3] / "examples" / "cart_pole_system.py"


@pytest.mark.parametrize("formulation", ["kane", "recursive"])
def test_system_bodies_agree_with_sympy(formulation, cache):
    """A System's body by name: its mass centre and frame, against SymPy's own kinematics."""
    from eomc.compiler.model.modelfile import run_model_file
    ns = run_model_file(str(SYSTEM))[0]
    ground, pole, cart = ns["ground"], ns["pole"], ns["cart"]
    N, O = ground.frame, ground.masscenter
    q, u = [ns["q_cart"], ns["q_pole"]], [ns["u_cart"], ns["u_pole"]]
    model = eomc.compile(str(SYSTEM), f"cartpole_frames_{formulation}", functions=["outputs"],
                         formulation=formulation, cache_dir=cache, progress=False, frames=["pole", "com"])
    assert model.metadata["formulation"] == formulation
    rng = np.random.default_rng(5)
    for _ in range(2):
        x = rng.normal(size=4)
        values = {**ns["parameters"], **dict(zip(q + u, x))}

        def num(vec):
            return np.array(vec.to_matrix(N).subs(values), dtype=float).ravel()
        P = pole.masscenter
        f = model.frame("pole", 0.0, x, r=np.zeros(2))
        J = np.array([np.concatenate([num(P.vel(N).diff(s, N)), num(pole.frame.ang_vel_in(N).diff(s, N))])
                      for s in u]).T
        mp, mc = ns["parameters"][ns["m_pole"]], ns["parameters"][ns["m_cart"]]
        com = (mp * num(P.pos_from(O)) + mc * num(cart.masscenter.pos_from(O))) / (mp + mc)
        vcom = (mp * num(P.vel(N)) + mc * num(cart.masscenter.vel(N))) / (mp + mc)
        c = model.frame("com", 0.0, x, r=np.zeros(2))
        pairs = ((f.p, num(P.pos_from(O))), (f.R, np.array(N.dcm(pole.frame).subs(values), dtype=float)),
                 (f.v, num(P.vel(N))), (f.w, num(pole.frame.ang_vel_in(N))), (f.J, J), (c.p, com), (c.v, vcom))
        assert max(float(np.max(np.abs(a - b))) for a, b in pairs) < TOL
    with pytest.raises(ModelError, match=r"no body named 'pol' .*nearest: pole"):
        eomc.compile(str(SYSTEM), "cartpole_bad", functions=["outputs"], formulation=formulation,
                     cache_dir=cache, progress=False, frames=["pol"])


MJCF_BODIES = ["base", "link1", "link2", "welded", "floater", "tip", "world"]


def _small_mjcf(tmp_path, edit=lambda text: text):
    """tests/compiler/mjcf/test_mjcf.py's SMALL model (``edit`` applied) written to tmp_path."""
    source = (Path(__file__).resolve().parents[1] / "mjcf" / "test_mjcf.py").read_text()
    path = tmp_path / "small.xml"
    path.write_text(edit(re.search(r'SMALL = """(.*?)"""', source, re.S).group(1)))
    return path


def _worst_against_mujoco(path, tag, cache, frames, seed):
    """The largest difference, at two random states, between the compiled frames ``frames``
    ((name, MuJoCo object kind) pairs: "body" or "site") plus ``com`` and MuJoCo's own
    (xpos/xmat and mj_jacBody, site_xpos/site_xmat and mj_jacSite, subtree_com/subtree_linvel;
    Jacobian columns mapped: a free joint's linear speeds are world components in MuJoCo)."""
    mujoco = pytest.importorskip("mujoco")
    from eomc.compiler.mjcf.compare import _rotation, prepared, to_mujoco, tree_of
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")        # its joint range is not modelled: said, not tested here
        model = eomc.compile(path, tag, functions=["outputs"], cache_dir=cache, progress=False,
                             frames=[name for name, _ in frames] + ["com"])
        m = prepared(mujoco.MjModel.from_xml_path(str(path)))
    built = tree_of(m, model)
    d = mujoco.MjData(m)
    rng = np.random.default_rng(seed)
    worst = 0.0
    for _ in range(2):
        q, u = rng.uniform(-1, 1, model.nq), rng.normal(size=model.nu)
        for w in model.quaternions:             # random orientations: each quaternion unit
            q[w:w + 4] /= np.linalg.norm(q[w:w + 4])
        d.qpos[:], d.qvel[:] = to_mujoco(m, built, q, u)
        mujoco.mj_forward(m, d)
        mujoco.mj_subtreeVel(m, d)
        P = np.zeros((m.nv, model.nu))          # qvel = P u
        for j, kind, iq, iu in built.joints:
            a, n = int(m.jnt_dofadr[j]), {0: 6, 1: 3, 2: 1, 3: 1}[kind]
            P[a:a + n, iu:iu + n] = np.eye(n)
            if kind == 0:
                P[a:a + 3, iu:iu + 3] = _rotation(built, q, iq + 3)
        x = np.concatenate([q, u])
        for name, kind in frames:
            jacp, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
            if kind == "site":
                i = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, name)
                mujoco.mj_jacSite(m, d, jacp, jacr, i)
                p, R = d.site_xpos[i], d.site_xmat[i]
            else:
                i = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name)
                mujoco.mj_jacBody(m, d, jacp, jacr, i)
                p, R = d.xpos[i], d.xmat[i]
            f = model.frame(name, 0.0, x, r=np.zeros(model.ninput))
            pairs = ((f.p, p), (f.R, R.reshape(3, 3)), (f.J, np.vstack([jacp, jacr]) @ P),
                     (f.v, jacp @ d.qvel), (f.w, jacr @ d.qvel))
            worst = max(worst, *(float(np.max(np.abs(a - b))) for a, b in pairs))
        c = model.frame("com", 0.0, x, r=np.zeros(model.ninput))
        worst = max(worst, float(np.max(np.abs(c.p - d.subtree_com[0]))),
                    float(np.max(np.abs(c.v - d.subtree_linvel[0]))))
    return worst


def test_mjcf_bodies_agree_with_mujoco(tmp_path, cache):
    """Every joint type (slide, two hinges on one body, ball, a welded body, free) against
    MuJoCo's body frames, mj_jacBody and the whole model's subtree_com / subtree_linvel."""
    path = _small_mjcf(tmp_path)
    assert _worst_against_mujoco(path, "small_mjcf_frames", cache, [(b, "body") for b in MJCF_BODIES], 11) < TOL


def _with_sites(text):
    """SMALL with a site on a moving body (turned by its own quat), two on a welded body (one named
    like the body "tip") and one on the world."""
    text = text.replace('<body name="link2" pos="0.1 0.05 -0.4">',
                        '<site name="knee_site" pos="0.02 -0.03 0.05" quat="0.7 0.1 -0.3 0.2"/>\n'
                        '        <body name="link2" pos="0.1 0.05 -0.4">')
    text = text.replace('<geom type="sphere" size="0.04" pos="0.01 0 0"/>',
                        '<geom type="sphere" size="0.04" pos="0.01 0 0"/><site name="weld-site" pos="0.1 0 0"/>'
                        '<site name="tip" pos="0 0 0.3"/>')
    return text.replace('<body name="floater" pos="1 0 1">',
                        '<site name="marker" pos="0.5 -0.2 0.1" euler="0 90 0"/>\n    <body name="floater" pos="1 0 1">')


def test_mjcf_sites_agree_with_mujoco(tmp_path, cache):
    """A named <site> is a frame: on a moving body, on a welded body and on the world, against
    MuJoCo's site_xpos/site_xmat and mj_jacSite; a site named like a body ("tip") leaves the name
    to the body, and an unknown name lists the sites among the candidates."""
    path = _small_mjcf(tmp_path, _with_sites)
    frames = [("knee_site", "site"), ("weld-site", "site"), ("marker", "site"), ("tip", "body")]
    assert _worst_against_mujoco(path, "small_mjcf_sites", cache, frames, 12) < TOL
    with pytest.raises(ModelError, match=r"no body or site named 'knee_sit' .*nearest: knee_site"):
        eomc.compile(path, "small_mjcf_sites_bad", functions=["outputs"], cache_dir=cache, progress=False,
                     frames=["knee_sit"])


def _chain(n):
    inertial = ('<inertial><origin xyz="0.1 0.01 0.2"/><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" '
                'iyy="0.02" iyz="0" izz="0.03"/></inertial>')
    links = ['<link name="base"/>'] + [f'<link name="l{i}">{inertial}</link>' for i in range(n)] + ['<link name="tool"/>']
    joints = [f'<joint name="j{i}" type="revolute"><parent link="{"base" if i == 0 else f"l{i - 1}"}"/>'
              f'<child link="l{i}"/><origin xyz="0 0 0.3" rpy="0.1 0 0"/><axis xyz="{"1 0 0" if i % 2 else "0 1 0"}"/>'
              f'<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>' for i in range(n)]
    joints.append(f'<joint name="jt" type="fixed"><parent link="l{n - 1}"/><child link="tool"/>'
                  f'<origin xyz="0 0.1 0.1"/></joint>')
    return '<robot name="chain">' + "".join(links + joints) + "</robot>"


def test_code_grows_linearly_with_depth(tmp_path):
    """The tip of an n-link chain and the centre of mass: O(n) operations, not O(n^2)."""
    from eomc.compiler.driver import generate
    ops = {}
    for n in (6, 12, 24):
        path = tmp_path / f"chain{n}.urdf"
        path.write_text(_chain(n))
        meta = generate(path, f"chain{n}", functions=["outputs"], formulation="recursive", use_cache=False,
                        frames=["tool", "com"])[1].metadata
        ops[n] = sum(meta["op_counts"]["outputs"].values())
    per_link = [(ops[b] - ops[a]) / (b - a) for a, b in ((6, 12), (12, 24))]
    assert per_link[1] < 1.1 * per_link[0], ops


def test_a_system_the_tree_reader_refuses_says_why(cache):
    """Absolute angles (the double pendulum): no joint tree, so no frames -- refused with the reason."""
    path = Path(__file__).resolve().parents[3] / "examples" / "double_pendulum.py"
    with pytest.raises(ModelError, match=r"double_pendulum.py: frame outputs are computed along the joint tree.*"
                                         r"body Bob2 .*depends on more than its own coordinate"):
        eomc.compile(str(path), "dp_frames", functions=["outputs"], cache_dir=cache, progress=False,
                     frames=["Bob2"])

