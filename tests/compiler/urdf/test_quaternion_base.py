"""A floating base with quaternion coordinates (floating_base="quaternion", --orientation quaternion).

The free joint is the same 6-speed joint as with Euler angles (body-frame twist,
one 6x6 articulated solve at the root); only its orientation coordinates differ:
(w, x, y, z) with q' = ½ q ⊗ (0, ω), and a rotation that does not depend on the
quaternion's length.  Checked against Pinocchio's JointModelFreeFlyer (the same
speeds): ABA, RNEA and CRBA at random states on Solo12, Go2, G1 and Talos full
body (1e-12); q' against pinocchio.integrate; jac_x and jvp against central differences;
frame outputs against Pinocchio's frame placement and velocity; the Euler build's
trajectory away from pitch ±90°; a torque-free body through pitch 90° against an
independent rotation-matrix integration (the Euler build cannot start there); the
integrators and rollout keep |q| = 1; the refusals name what is wrong.
"""
import numpy as np
import pinocchio as pin
import pytest
from scipy.integrate import solve_ivp

import eomc
from eomc.compiler.urdf import build_tree, read_urdf
from eomc.compiler.urdf.model import UrdfModel
from eomc.errors import ModelError
from helpers.robots import PinRef, relative_error, robot_path

ROBOTS = {"solo12": "solo12", "go2": "go2_description/urdf/go2.urdf",
          "g1": "g1_description/urdf/g1_29dof_rev_1_0.urdf", "talos": "talos_data/robots/talos_full_v2.urdf"}
TOL = 1e-12


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("cache")


def _build(cache, rel, name, floating="quaternion", functions=("rhs",), **kw):
    path = robot_path(rel)
    model = eomc.compile(UrdfModel(path, floating_base=floating, limits=False), name, functions=list(functions),
                         cache_dir=cache, progress=False, **kw)
    tree = build_tree(read_urdf(path), floating_base=floating)
    return model, PinRef(path, [(j.name, j.type) for j in tree.joints], floating=True, locked=tree.locked)


def _state(model, rng, unit=True):
    q = rng.uniform(-1, 1, model.nq)
    q[3:7] /= np.linalg.norm(q[3:7])
    if not unit:
        q[3:7] *= rng.uniform(0.3, 3.0)
    return q, rng.normal(size=model.nu)


@pytest.fixture(scope="module")
def solo(cache):
    return _build(cache, "solo12", "solo_quat", functions=("rhs", "jac_x", "jvp", "mass_matrix",
                                                             "inverse_dynamics", "outputs"), frames=["FL_FOOT"])


def test_layout_names_and_upright_start(solo):
    model, _ = solo
    assert (model.nq, model.nu) == (19, 18)
    assert model.state_names[3:7] == tuple(f"q_base_link_floating_{c}" for c in ("qw", "qx", "qy", "qz"))
    assert model.quaternions == (3,)
    assert model.metadata["quaternions"] == [3]
    x0 = model.initial_state
    assert x0[3] == 1.0 and not np.any(np.delete(x0, 3))


def test_solo12_rhs_inverse_dynamics_mass_matrix_match_pinocchio(solo):
    model, ref = solo
    rng = np.random.default_rng(5)
    worst = 0.0
    for k in range(8):
        q, v = _state(model, rng, unit=k % 2 == 0)       # the length of q never matters
        tau, a = rng.normal(size=model.ninput), rng.normal(size=model.nu)
        x = np.concatenate([q, v])
        worst = max(worst, relative_error(model.rhs(0.0, x, r=tau)[model.nq:], ref.aba(q, v, tau)),
                    relative_error(model.inverse_dynamics(0.0, x, a, r=np.zeros(model.ninput)), ref.rnea(q, v, a)),
                    relative_error(model.mass_matrix(0.0, x), ref.mass_matrix(q)))
    assert worst < TOL


def test_coordinate_rates_match_pinocchio_integrate(solo):
    """q' of the base (position' = R v, quat' = ½ q ⊗ ω) is the derivative of Pinocchio's
    integrate(q, v dt) at dt = 0 (its quaternion ordered x, y, z, w)."""
    model, ref = solo
    rng = np.random.default_rng(6)
    for _ in range(3):
        q, v = _state(model, rng)
        xd = model.rhs(0.0, np.concatenate([q, v]), r=np.zeros(model.ninput))
        h, pq = 1e-6, ref.q(q)
        dq = (pin.integrate(ref.model, pq, ref.v(v) * h) - pin.integrate(ref.model, pq, -ref.v(v) * h)) / (2 * h)
        assert np.max(np.abs(np.r_[xd[:3], xd[4:7], xd[3]] - dq[:7])) < 1e-9
        assert np.max(np.abs(xd[7:model.nq] - v[6:])) == 0.0


def test_jac_x_and_jvp_match_central_differences(solo):
    model, _ = solo
    rng = np.random.default_rng(7)
    q, v = _state(model, rng)
    x, r = np.concatenate([q, v]), rng.normal(size=model.ninput)
    J = model.jac_x(0.0, x, r=r)
    D = np.empty_like(J)
    for k in range(model.nx):
        e = np.zeros(model.nx)
        e[k] = 1e-6
        D[:, k] = (model.rhs(0.0, x + e, r=r) - model.rhs(0.0, x - e, r=r)) / 2e-6
    assert np.max(np.abs(J - D)) < 1e-6 * max(1.0, np.max(np.abs(J)))
    V = rng.normal(size=(2, model.nx))
    _, JV = model.jvp(0.0, x, V, r=r)
    assert np.max(np.abs(JV - V @ J.T)) < 1e-12 * np.max(np.abs(J)) * model.nx
    # the rhs does not depend on the quaternion's length: u' has no radial derivative
    assert np.max(np.abs(J[model.nq:, 3:7] @ q[3:7])) < 1e-9 * np.max(np.abs(J))


def test_frame_outputs_match_pinocchio(solo):
    model, ref = solo
    rng = np.random.default_rng(8)
    q, v = _state(model, rng)
    out = model.outputs(0.0, np.concatenate([q, v]), r=np.zeros(model.ninput))
    out = np.array([out[n] for n in model.output_names]) if isinstance(out, dict) else np.asarray(out)
    pin.forwardKinematics(ref.model, ref.data, ref.q(q), ref.v(v))
    pin.updateFramePlacements(ref.model, ref.data)
    fid = ref.model.getFrameId("FL_FOOT")
    at = {n: k for k, n in enumerate(model.output_names)}
    p = out[[at[f"FL_FOOT.p.{c}"] for c in "xyz"]]
    R = out[[at[f"FL_FOOT.R[{i}][{j}]"] for i in range(3) for j in range(3)]].reshape(3, 3)
    vel = pin.getFrameVelocity(ref.model, ref.data, fid, pin.LOCAL_WORLD_ALIGNED)
    assert np.max(np.abs(p - ref.data.oMf[fid].translation)) < 1e-13
    assert np.max(np.abs(R - ref.data.oMf[fid].rotation)) < 1e-13
    assert np.max(np.abs(out[[at[f"FL_FOOT.v.{c}"] for c in "xyz"]] - vel.linear)) < 1e-13
    assert np.max(np.abs(out[[at[f"FL_FOOT.w.{c}"] for c in "xyz"]] - vel.angular)) < 1e-13


@pytest.mark.parametrize("name", ["go2", "g1", "talos"])
def test_large_robots_rhs_match_pinocchio(cache, name):
    model, ref = _build(cache, ROBOTS[name], f"{name}_quat")
    rng = np.random.default_rng(9)
    worst = 0.0
    for k in range(6):
        q, v = _state(model, rng, unit=k % 2 == 0)
        tau = rng.normal(size=model.ninput)
        worst = max(worst, relative_error(model.rhs(0.0, np.concatenate([q, v]), r=tau)[model.nq:],
                                          ref.aba(q, v, tau)))
    assert worst < TOL


def _rotation(quat):
    w, x, y, z = np.asarray(quat) / np.linalg.norm(quat)
    return pin.Quaternion(w, x, y, z).toRotationMatrix()


def _euler(a, b, c):
    return pin.utils.rotate("x", a) @ pin.utils.rotate("y", b) @ pin.utils.rotate("z", c)


def test_trajectory_agrees_with_the_euler_build_away_from_the_singularity(cache, solo):
    model, _ = solo
    euler, _ = _build(cache, "solo12", "solo_euler", floating=True)
    rng = np.random.default_rng(10)
    angles = np.array([0.2, -0.3, 0.4])
    joints, u = rng.uniform(-0.5, 0.5, 12), rng.normal(scale=0.5, size=18)
    xq = np.r_[[0, 0, 1], pin.Quaternion(_euler(*angles)).coeffs()[[3, 0, 1, 2]], joints, u]
    xe = np.r_[[0, 0, 1], angles, joints, u]
    kw = dict(rtol=1e-11, atol=1e-11, t_eval=np.linspace(0, 0.4, 5))
    rq = model.simulate(xq, (0, 0.4), method="dop853", **kw)
    re = euler.simulate(xe, (0, 0.4), method="dop853", **kw)
    assert np.max(np.abs(re.x[:, 6:] - rq.x[:, 7:])) < 1e-8          # joints and every speed
    assert np.max(np.abs(re.x[:, :3] - rq.x[:, :3])) < 1e-8
    for a, b in zip(re.x, rq.x):
        assert np.max(np.abs(_euler(*a[3:6]) - _rotation(b[3:7]))) < 1e-8
    assert abs(np.linalg.norm(rq.x[-1, 3:7]) - 1) < 1e-14


FREE_BODY = """<?xml version="1.0"?>
<robot name="brick"><link name="brick"><inertial><origin xyz="0 0 0" rpy="0 0 0"/><mass value="2"/>
<inertia ixx="0.3" ixy="0" ixz="0" iyy="0.5" iyz="0" izz="0.7"/></inertial></link></robot>
"""


def _torque_free(I, w0, R0, t):
    """R(t), ω(t) of a torque-free rigid body by an independent integration (R' = R [ω]×)."""
    def f(_, y):
        R, w = y[:9].reshape(3, 3), y[9:]
        W = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
        return np.r_[(R @ W).ravel(), np.linalg.solve(I, -np.cross(w, I @ w))]
    sol = solve_ivp(f, (0, t), np.r_[R0.ravel(), w0], rtol=1e-12, atol=1e-12, method="DOP853")
    return sol.y[:9, -1].reshape(3, 3), sol.y[9:, -1]


@pytest.mark.parametrize("method", ["dop853", "radau"])
def test_through_pitch_90_degrees(cache, tmp_path, method):
    """A brick tumbling from pitch exactly 90° (the Euler angles' singularity: their build
    cannot even start there) and through it again, against an independent integration."""
    path = tmp_path / "brick.urdf"
    path.write_text(FREE_BODY)
    functions = ["rhs", "jac_x"]
    quat = eomc.compile(UrdfModel(path, floating_base="quaternion"), "brick_q", functions=functions,
                        cache_dir=cache, progress=False)
    euler = eomc.compile(UrdfModel(path, floating_base=True), "brick_e", functions=functions, cache_dir=cache,
                         progress=False)
    w0 = np.array([0.4, 3.0, 0.3])
    R0 = pin.utils.rotate("y", np.pi / 2)
    x0 = np.r_[[0, 0, 0], pin.Quaternion(R0).coeffs()[[3, 0, 1, 2]], [0, 0, 0], w0]
    res = quat.simulate(x0, (0, 3.0), method=method, rtol=1e-10, atol=1e-10)
    R, w = _torque_free(np.diag([0.3, 0.5, 0.7]), w0, R0, 3.0)
    assert np.max(np.abs(_rotation(res.x[-1, 3:7]) - R)) < 1e-6
    assert np.max(np.abs(res.x[-1, 10:] - w)) < 1e-6
    assert abs(np.linalg.norm(res.x[-1, 3:7]) - 1) < 1e-14
    # the Euler build at the same state: its angle rates divide by cos(pitch) = 6e-17
    rates = euler.rhs(0.0, np.r_[[0, 0, 0], [0, np.pi / 2, 0], [0, 0, 0], w0])[3:6]
    assert np.max(np.abs(rates)) > 1e15


@pytest.mark.parametrize("method", ["rk4", "dopri5", "radau", "implicitfast"])
def test_integrators_keep_the_quaternion_unit(solo, method):
    model, _ = solo
    rng = np.random.default_rng(11)
    q, v = _state(model, rng)
    q[3:7] *= 1.5                     # x0's is normalised at the start too
    kw = dict(dt=2e-3) if method in ("rk4", "implicitfast") else dict(rtol=1e-8, atol=1e-8)
    if method in ("radau", "implicitfast"):
        pytest.skip("solo_quat has jac_x") if model.c_model.jac_x == model.ffi.NULL else None
    res = model.simulate(np.r_[q, v], (0, 0.2), method=method, **kw)
    norms = np.linalg.norm(res.x[:, 3:7], axis=1)
    assert abs(norms[-1] - 1) < 1e-14 and abs(norms[0] - 1) < 1e-14
    if method in ("rk4", "implicitfast"):            # every row is a step's end
        assert np.max(np.abs(norms - 1)) < 1e-14


def test_rollout_rows_are_unit_and_equal_simulate(solo):
    model, _ = solo
    rng = np.random.default_rng(12)
    X0 = np.array([np.r_[_state(model, rng)] for _ in range(3)])
    X0[1, 3:7] *= 2.0
    out = eomc.rollout(model, X0, dt=1e-3, steps=100, method="rk4", threads=2)
    assert np.all(np.abs(np.linalg.norm(out.x[:, 3:7], axis=1) - 1) < 1e-14)
    for k in range(3):
        one = model.simulate(X0[k], (0, 0.1), method="rk4", dt=1e-3)
        assert np.array_equal(one.x[-1], out.x[k])


def test_zero_quaternion_is_refused_naming_it(solo):
    model, _ = solo
    x0 = np.zeros(model.nx)
    with pytest.raises(ValueError, match=r"quaternion \(q_base_link_floating_qw, .*\) is zero"):
        model.simulate(x0, (0, 0.1))
    with pytest.raises(ValueError, match=r"row 1.*zero"):
        eomc.rollout(model, np.array([model.initial_state, x0]), dt=1e-3, steps=10)


def test_kane_and_bad_values_are_refused(cache):
    path = robot_path("solo12")
    with pytest.raises(ModelError, match="recursive formulation only"):
        eomc.compile(UrdfModel(path, floating_base="quaternion"), "solo_kane", functions=["rhs"],
                     formulation="kane", cache_dir=cache, progress=False)
    with pytest.raises(ModelError, match="'quaternion'"):
        UrdfModel(path, floating_base="quaternions")


def test_initial_state_given_without_the_quaternion_still_starts_upright():
    from eomc.compiler.model.spec import model_spec
    spec = model_spec(UrdfModel(robot_path("solo12"), floating_base="quaternion"), "solo_x0",
                      initial_state={"q_base_link_floating_z": 0.4}, formulation="recursive")
    assert spec.initial_state[2] == 0.4 and spec.initial_state[3] == 1.0
    assert not np.any(np.delete(spec.initial_state, [2, 3]))


def test_the_header_tells_c_users_to_keep_the_quaternions_unit(cache, solo):
    """A C user's own integrator (examples/embed_c) must normalise the quaternion rows as eomc's
    integrators do; the header said nothing of it before session 29.  An Euler build's header has
    no such paragraph."""
    model, _ = solo
    header = (model.directory / f"{model.name}.h").read_text()
    assert "Unit quaternions (w, x, y, z) in x, at x[i] .. x[i + 3] for i = 3." in header
    assert "scale each of these quaternions back to length 1 after" in header
    euler, _ = _build(cache, "solo12", "solo_euler", floating=True)
    assert "quaternion" not in (euler.directory / f"{euler.name}.h").read_text().lower()
