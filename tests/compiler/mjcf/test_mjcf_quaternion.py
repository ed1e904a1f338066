"""MJCF ball and free joints with MuJoCo's own quaternion coordinates (orientation="quaternion").

The same joints as with body-XYZ angles (body-frame angular speeds; a free joint's
linear speed in body components, mapped to MuJoCo's world-frame one by
eomc.compiler.mjcf.compare), with MuJoCo's (w, x, y, z) as coordinates: qacc
against mj_forward at random states (unit and non-unit quaternions: the rhs does
not depend on their length), the animation's poses against MuJoCo's xpos/xmat, qpos0
as the initial state, gymnasium's ant and humanoid (free joints) to 1e-10.
"""
import warnings
from pathlib import Path

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

import eomc  # noqa: E402
from eomc.compiler.mjcf.compare import from_mujoco, prepared, qacc_of, to_mujoco  # noqa: E402
from eomc.compiler.mjcf.model import MjcfModel, check_model, load_mjmodel  # noqa: E402
from eomc.compiler.mjcf.treeir import tree_ir  # noqa: E402
from eomc.runtime.errors import EomcWarning, ModelError  # noqa: E402

from .test_mjcf import SMALL, _gym_asset  # noqa: E402


def _built(path, ignore=()):
    m = prepared(load_mjmodel(path))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EomcWarning)
        motors = check_model(m, path, ignore)
    return m, tree_ir(m, actuators=motors, quaternion=True), motors


def _state(model, rng):
    q, u = rng.uniform(-1.2, 1.2, model.nq), rng.uniform(-2, 2, model.nu)
    for k, i in enumerate(model.quaternions):
        q[i:i + 4] *= (1.0 if k % 2 == 0 else 2.5) / np.linalg.norm(q[i:i + 4])
    return q, u


def _worst(model, path, ignore=(), trials=6):
    m, built, motors = _built(path, ignore)
    assert model.nq == len(built.coordinates) and model.quaternions == built.tree.quaternions
    d, rng, worst = mujoco.MjData(m), np.random.default_rng(17), 0.0
    for _ in range(trials):
        q, u = _state(model, rng)
        r = rng.uniform(-1.5, 1.5, len(motors))
        xd = model.rhs(0.0, np.concatenate([q, u]), r=r)
        d.qpos[:], d.qvel[:] = to_mujoco(m, built, q, u)
        d.ctrl[:] = 0
        d.ctrl[motors] = r
        mujoco.mj_forward(m, d)
        assert np.max(np.abs(d.qacc)) > 1e-3
        worst = max(worst, np.max(np.abs(qacc_of(m, built, q, u, xd[model.nq:]) - d.qacc))
                    / max(1.0, np.max(np.abs(d.qacc))))
    return worst


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    root = tmp_path_factory.mktemp("mjcfq")
    path = root / "small.xml"
    path.write_text(SMALL)
    model = eomc.compile(MjcfModel(path, limits=False, orientation="quaternion"), cache_dir=root / "cache",
                         progress=False, functions=["rhs", "jac_x", "poses"])
    return path, model


def test_small_model_matches_mj_forward(small):
    path, model = small
    names = model.state_names
    assert [names[i] for i in model.quaternions] == ["q_ball_qw", "q_free_qw"]
    assert names[model.quaternions[1] - 3:model.quaternions[1] + 4] == tuple(
        f"q_free_{c}" for c in ("x", "y", "z", "qw", "qx", "qy", "qz"))
    assert _worst(model, path) < 1e-10


def test_qpos0_is_the_initial_state_and_round_trips(small):
    path, model = small
    m, built, _ = _built(path)
    q0 = model.initial_state[:model.nq]
    qpos, _ = to_mujoco(m, built, q0, np.zeros(model.nu))
    assert np.max(np.abs(qpos - m.qpos0)) < 1e-15 * 10
    i = model.quaternions[1]
    assert np.allclose(q0[i:i + 4], m.qpos0[m.jnt_qposadr[m.joint("free").id] + 3:][:4] /
                       np.linalg.norm(m.qpos0[m.jnt_qposadr[m.joint("free").id] + 3:][:4]))
    q, u = from_mujoco(m, built, qpos, np.zeros(m.nv))
    assert np.max(np.abs(q - q0)) < 1e-15 * 10


def test_poses_are_mujocos_body_frames(small):
    path, model = small
    m, built, _ = _built(path)
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(1, m.nbody)]
    d, rng = mujoco.MjData(m), np.random.default_rng(3)
    for _ in range(3):
        q, u = _state(model, rng)
        poses = model.poses(0.0, np.concatenate([q, u]))
        d.qpos[:], d.qvel[:] = to_mujoco(m, built, q, u)
        mujoco.mj_kinematics(m, d)
        for b, name in enumerate(names, start=1):
            assert np.max(np.abs(poses[name] - d.xpos[b])) < 1e-12
            assert np.max(np.abs(poses.rotation(name) - d.xmat[b].reshape(3, 3))) < 1e-12


def test_the_oracles_tree_follows_the_models_layout_and_refuses_the_other(small):
    """compare.tree_of builds MuJoCo's tree in the model's layout (the default build's quaternions,
    or an Euler build's angles); a tree in the other layout is refused by to_mujoco and qacc_of.
    Before, tree_ir(m) (body-XYZ angles by default) mapped a quaternion build's states silently
    wrong: the free body's rotation read from (x, qw, qx), its position still right."""
    from eomc.compiler.mjcf.compare import tree_of
    path, model = small
    m = prepared(load_mjmodel(path))
    built = tree_of(m, model)
    assert len(built.coordinates) == model.nq and built.tree.quaternions == model.quaternions
    euler = tree_of(m, MjcfModel(path, orientation="euler"))
    assert len(euler.coordinates) == model.nq - 2 and not getattr(euler.tree, "quaternions", ())
    assert len(tree_of(m, MjcfModel(path)).coordinates) == model.nq        # the default: quaternions
    q, u = _state(model, np.random.default_rng(9))
    with pytest.raises(ValueError, match=r"coordinates given, the tree has .* tree_of\(m, model\)"):
        to_mujoco(m, tree_ir(m), q, u)
    with pytest.raises(ValueError, match="coordinates given"):
        qacc_of(m, tree_ir(m), q, u, np.zeros(model.nu))
    to_mujoco(m, built, q, u)


def test_simulation_keeps_the_quaternions_unit_and_follows_mujoco(small):
    """A short run against MuJoCo's own RK4 at a small step (contacts, limits off on both)."""
    path, model = small
    m, built, _ = _built(path)
    rng = np.random.default_rng(4)
    q, u = _state(model, rng)
    res = model.simulate(np.concatenate([q, u]), (0, 0.2), method="dop853", rtol=1e-11, atol=1e-11)
    for i in model.quaternions:
        assert abs(np.linalg.norm(res.x[-1, i:i + 4]) - 1) < 1e-14
    m.opt.integrator = int(mujoco.mjtIntegrator.mjINT_RK4)
    m.opt.timestep = 1e-4
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = to_mujoco(m, built, q, u)
    for _ in range(2000):
        mujoco.mj_step(m, d)
    mq, mu = from_mujoco(m, built, d.qpos, d.qvel)
    end = res.x[-1]
    for i in model.quaternions:           # q and -q are the same rotation
        if np.dot(mq[i:i + 4], end[i:i + 4]) < 0:
            mq[i:i + 4] *= -1
    assert np.max(np.abs(mq - end[:model.nq])) < 1e-8
    assert np.max(np.abs(mu - end[model.nq:])) < 1e-7


def test_a_bound_call_keeps_its_quaternion_indices_alive(small):
    """bind_call's call (what timing harnesses keep: bench_fixedstep) holds the quaternions' C
    index array its options point to: with only the call kept, the prepared args and that array
    were collected, and in bench_fixedstep (its memory reused by the MuJoCo models built next) a
    quaternion build's bound runs ended at once with status 4, bad argument.  (Here for this
    module's quaternion model; the call's keeping of the model is tested in runtime/test_simulate.)"""
    import gc
    import weakref

    from eomc.runtime.simulate import bind_call, prepare
    path, model = small
    q, u = _state(model, np.random.default_rng(5))
    x0 = np.concatenate([q, u])
    a = prepare(model, x0, (0.0, 0.05), method="rk4", dt=0.005, t_eval=[0.05])
    indices = weakref.ref(a["quat"])
    call, _, x_last, stats = bind_call(model, a)
    del a
    gc.collect()
    assert indices() is not None
    assert call() == 0 and stats.status == 0 and stats.nfev > 0
    np.testing.assert_array_equal(x_last, model.simulate(x0, (0.0, 0.05), method="rk4", dt=0.005).x[-1])


@pytest.mark.parametrize("asset", ["ant.xml", "humanoid.xml"])
def test_gymnasium_free_joint_models_match_mj_forward(asset, tmp_path):
    path = _gym_asset(asset)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EomcWarning)
        model = eomc.compile(MjcfModel(path, ignore=("limits",), geoms=False, orientation="quaternion"),
                             functions=["rhs"], cache_dir=tmp_path, progress=False)
    assert len(model.quaternions) == 1
    assert _worst(model, path, ("limits",)) < 1e-10


def test_bad_orientation_is_refused(tmp_path):
    with pytest.raises(ModelError, match="orientation='quat'.*'quaternion'"):
        MjcfModel(Path(tmp_path / "x.xml"), orientation="quat")
