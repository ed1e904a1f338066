"""Issue 23 item 1: MJCF ``<equality><joint joint1 joint2 polycoef>`` couplings as holonomic
constraints on the tree (compiler/mjcf/equality.py, through compiler/tree/constrained.py).

Oracles, none of them eomc's own constrained solve:
- MuJoCo's reading of the coupling: at a state built from MuJoCo's documented rule
  q1 - ref1 = p0 + p1 d + ... + p4 d⁴ (d = q2 - ref2), MuJoCo's own constraint residual
  (efc_pos) is zero and its constraint Jacobian rows are eomc's;
- the reduced dynamics by hand in numpy from the *unconstrained* model (the same file
  without <equality>): u' = N v' + c, v' = (NᵀMN)⁻¹ Nᵀ(f - M c), N the coupling's
  null-space basis, c the quadratic term -- to 1e-12;
- a simulation keeps the constraints (drift at the tolerance's level);
- mj_forward with a stiff solref/solimp: agreement to the softness MuJoCo leaves, stated.
MuJoCo's suites ship no joint equality (dm_control's quadruped/manipulator/stacker
couple through tendon equalities, refused here), so the model is written here.

Cheap: two small models compiled once (module fixture); refusals stop before any C.
"""
import re

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

import eomc  # noqa: E402
from eomc.compiler.mjcf import MjcfModel  # noqa: E402
from eomc.errors import EomcWarning, ModelError, ModelFileError  # noqa: E402

# shoulder free; elbow = lin(shoulder); wrist = quartic(elbow); slider locked (no joint2);
# spin free, after the dependent joints in MuJoCo's order (so the states are reordered)
EQUALITY = """  <equality>
    <joint name="lin" joint1="elbow" joint2="shoulder" polycoef="0.1 0.5 0 0 0"/>
    <joint name="quad" joint1="wrist" joint2="elbow" polycoef="-0.05 0.3 0.8 0.2 0.1"/>
    <joint name="lock" joint1="slider" polycoef="0.05 0 0 0 0"/>
  </equality>
"""
MODEL = """<mujoco model="coupled">
  <compiler angle="radian"/>
  <option gravity="0 0 -9.81"/>
  <worldbody>
    <body name="upper">
      <joint name="shoulder" type="hinge" axis="0 1 0" damping="0.1"/>
      <geom type="capsule" fromto="0 0 0 0.5 0 0" size="0.05" mass="1"/>
      <body name="lower" pos="0.5 0 0">
        <joint name="elbow" type="hinge" axis="0 1 0" ref="0.2"/>
        <geom type="capsule" fromto="0 0 0 0.4 0 0.1" size="0.04" mass="0.7"/>
        <body name="tip" pos="0.4 0 0.1">
          <joint name="wrist" type="hinge" axis="0 0 1"/>
          <geom type="box" size="0.1 0.05 0.02" mass="0.3"/>
          <body name="sled" pos="0.1 0 0">
            <joint name="slider" type="slide" axis="1 0 0" ref="0.1"/>
            <geom type="sphere" size="0.03" mass="0.2"/>
            <body name="rotor" pos="0 0 0.05">
              <joint name="spin" type="hinge" axis="1 1 0"/>
              <geom type="box" size="0.03 0.06 0.01" mass="0.15" pos="0.02 0 0"/>
            </body>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
%s  <actuator><motor name="m" joint="shoulder" gear="2"/></actuator>
</mujoco>
"""
COUPLINGS = {"elbow": ("shoulder", [0.1, 0.5, 0, 0, 0]), "wrist": ("elbow", [-0.05, 0.3, 0.8, 0.2, 0.1]),
             "slider": (None, [0.05, 0, 0, 0, 0])}
REF = {"elbow": 0.2, "slider": 0.1}
R = [0.7]


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    d = tmp_path_factory.mktemp("eq")
    (d / "coupled.xml").write_text(MODEL % EQUALITY)
    (d / "open.xml").write_text(MODEL % "")
    cache = d / "cache"
    coupled = eomc.compile(str(d / "coupled.xml"), cache_dir=cache, progress=False)   # default functions
    opened = eomc.compile(str(d / "open.xml"), functions=["rhs", "mass_matrix", "forcing"],
                          cache_dir=cache, progress=False)
    return coupled, opened, d


def _poly(c, x):
    return sum(c[k] * x ** k for k in range(5)), sum(k * c[k] * x ** (k - 1) for k in range(1, 5)), \
        sum(k * (k - 1) * c[k] * x ** (k - 2) for k in range(2, 5))


def _consistent(q_ind, u_ind):
    """{joint: (q, u)} from MuJoCo's documented rule, in coupling order (elbow before wrist)."""
    q, u = dict(q_ind), dict(u_ind)
    for j1, (j2, c) in COUPLINGS.items():
        if j2 is None:
            q[j1], u[j1] = REF.get(j1, 0.0) + c[0], 0.0
        else:
            val, slope, _ = _poly(c, q[j2] - REF.get(j2, 0.0))
            q[j1], u[j1] = REF.get(j1, 0.0) + val, slope * u[j2]
    return q, u


def _state(model, q, u):
    nq = model.nq
    names = model.state_names
    return np.array([q[n[2:]] for n in names[:nq]] + [u[n[2:]] for n in names[nq:]])


def _states(rng, count, moving=True):
    for _ in range(count):
        q_ind = {"shoulder": rng.uniform(-1, 1), "spin": rng.uniform(-2, 2)}
        u_ind = {"shoulder": rng.uniform(-2, 2) * moving, "spin": rng.uniform(-3, 3) * moving}
        yield _consistent(q_ind, u_ind)


def _mujoco(path):
    m = mujoco.MjModel.from_xml_path(str(path))
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    return m, mujoco.MjData(m)


def _set(m, d, q, u):
    for j in range(m.njnt):
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j)
        d.qpos[m.jnt_qposadr[j]], d.qvel[m.jnt_dofadr[j]] = q[name], u[name]
    d.ctrl[:] = R
    mujoco.mj_forward(m, d)


def test_states_parameters_and_default_functions(models):
    coupled, opened, _ = models
    # independent first in MuJoCo's order, then the dependent ones (joint1s) in equality order
    assert coupled.state_names[:5] == ("q_shoulder", "q_spin", "q_elbow", "q_wrist", "q_slider")
    assert (coupled.nhol, coupled.nvel) == (3, 3)
    for k in range(5):
        assert f"eq_quad_p{k}" in coupled.param_names
    assert [f"eq_lin_p{k}" in coupled.param_names for k in range(5)] == [True, True, False, False, False]
    # no functions named: the whole default set, the derivatives of the constrained tree included
    fns = coupled.metadata["functions"]
    assert {"rhs", "constraints", "mass_matrix", "jac_x", "jac_r", "linearize"} <= set(fns)


def test_jac_x_and_jac_r_are_the_derivatives_of_the_rhs(models):
    """The constrained tree's jac_x/jac_r (KKT residual's tangents) against central differences."""
    coupled, _, _ = models
    rng = np.random.default_rng(7)
    for q, u in _states(rng, 3):
        x = _state(coupled, q, u)
        J = coupled.jacobian(0.0, x, r=R)
        h = 1e-6
        fd = np.column_stack([(coupled.rhs(0.0, x + h * e, r=R) - coupled.rhs(0.0, x - h * e, r=R)) / (2 * h)
                              for e in np.eye(coupled.nx)])
        assert np.max(np.abs(J - fd)) < 1e-6 * max(1.0, np.max(np.abs(J)))


def test_couplings_read_as_mujoco_reads_them(models):
    """MuJoCo's own residual is zero at the states eomc calls consistent, and its Jacobian rows are eomc's."""
    coupled, _, d = models
    m, data = _mujoco(d / "coupled.xml")
    rng = np.random.default_rng(23)
    for q, u in _states(rng, 4):
        _set(m, data, q, u)
        rows = [i for i in range(data.nefc) if data.efc_type[i] == mujoco.mjtConstraint.mjCNSTR_EQUALITY]
        assert len(rows) == 3
        assert np.max(np.abs(data.efc_pos[rows])) < 1e-12
        x = _state(coupled, q, u)
        assert np.max(np.abs(coupled.constraints(0.0, x, r=R))) < 1e-12
        # eomc's velocity-constraint Jacobian rows (d f_v/du) against MuJoCo's efc_J (same dof order map)
        jac = np.asarray(coupled.constraints_jacobian(0.0, x, r=R))
        nq = coupled.nq
        names = [n[2:] for n in coupled.state_names[nq:]]
        dof = [int(m.jnt_dofadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n)]) for n in names]
        efc_J = np.asarray(data.efc_J).reshape(data.nefc, m.nv)[rows][:, dof]
        vel_rows = jac[3:, nq:] if jac.shape[0] == 6 else jac[:, nq:]
        assert np.max(np.abs(np.abs(vel_rows) - np.abs(efc_J))) < 1e-12


def _reduced(opened, q, u, quadratic=True):
    """u' of the coupled model by hand from the open model's M and f, in the open model's
    speed order, and that order's joint names: u = N v, u' = N v' + c with J N = 0 and
    J c = -γ (c = 0 and γ left out with ``quadratic=False``)."""
    xo = _state(opened, q, u)
    names = [n[2:] for n in opened.state_names[opened.nq:]]
    nu = len(names)
    ix = {n: k for k, n in enumerate(names)}
    M, f = np.asarray(opened.mass_matrix(0.0, xo, r=R)), np.asarray(opened.forcing(0.0, xo, r=R))
    assert np.allclose(np.linalg.solve(M, f), opened.rhs(0.0, xo, r=R)[opened.nq:], rtol=1e-12, atol=1e-12)
    # J u' = -γ by hand: rows d(f_v)/du and γ = d f_v/dt at u' = 0
    J, gamma = np.zeros((3, nu)), np.zeros(3)
    for i, (j1, (j2, c)) in enumerate(COUPLINGS.items()):
        J[i, ix[j1]] = 1.0
        if j2 is not None:
            _, slope, curve = _poly(c, q[j2] - REF.get(j2, 0.0))
            J[i, ix[j2]] = -slope
            gamma[i] = -curve * u[j2] ** 2 if quadratic else 0.0
    dep = [ix[j] for j in COUPLINGS]
    ind = [k for k in range(nu) if k not in dep]
    N = np.zeros((nu, len(ind)))
    N[ind, range(len(ind))] = 1.0
    N[dep] = -np.linalg.solve(J[:, dep], J[:, ind])
    c = np.zeros(nu)
    c[dep] = -np.linalg.solve(J[:, dep], gamma)
    vdot = np.linalg.solve(N.T @ M @ N, N.T @ (f - M @ c))
    expected = N @ vdot + c
    assert np.max(np.abs(J @ expected + gamma)) < 1e-10
    return dict(zip(names, expected))


def test_accelerations_are_the_reduced_dynamics_of_the_open_model(models):
    coupled, opened, _ = models
    rng = np.random.default_rng(7)
    for q, u in _states(rng, 5):
        expected = _reduced(opened, q, u)
        x = _state(coupled, q, u)
        got = np.asarray(coupled.rhs(0.0, x, r=R))[coupled.nq:]
        want = np.array([expected[n[2:]] for n in coupled.state_names[coupled.nq:]])
        assert np.max(np.abs(got - want) / np.maximum(1.0, np.abs(want))) < 1e-12, (got, want)


def test_a_simulation_keeps_the_couplings(models):
    coupled, _, d = models
    q, u = next(_states(np.random.default_rng(3), 1))
    x0 = dict(zip(coupled.state_names, _state(coupled, q, u)))
    res = coupled.simulate(x0, (0.0, 2.0), rtol=1e-10, atol=1e-10, n_points=21, r=R)
    assert res.status == 0
    assert res.constraint_residual is not None and np.max(res.constraint_residual) < 1e-7
    assert np.ptp(res.x[:, 0]) > 0.1          # it moved
    # and MuJoCo agrees the final state is on its couplings
    m, data = _mujoco(d / "coupled.xml")
    xf = res.x[-1]
    names = [n[2:] for n in coupled.state_names[:coupled.nq]]
    _set(m, data, dict(zip(names, xf[:coupled.nq])), dict(zip(names, xf[coupled.nq:])))
    rows = [i for i in range(data.nefc) if data.efc_type[i] == mujoco.mjtConstraint.mjCNSTR_EQUALITY]
    assert np.max(np.abs(data.efc_pos[rows])) < 1e-6


def test_mj_forward_with_a_stiff_coupling_comes_close(models):
    """MuJoCo's coupling is soft: even stiff (solimp 0.9999) its impedance leaves about 1e-4
    of the constraint force out, and its constraint acts on J qacc alone (the J̇ v term is
    left to the reference acceleration's correction of the drift it makes).  So at rest
    qacc agrees with eomc's to about 1e-4; moving, it agrees to that with the hand-made
    reduced dynamics *without* the quadratic term, and differs from eomc's (exact, with
    it) by a few per cent here."""
    coupled, opened, d = models
    m, data = _mujoco(d / "coupled.xml")
    m.eq_solref[:] = [0.002, 1.0]
    m.eq_solimp[:] = [0.9999, 0.9999, 0.001, 0.5, 2]
    names = [n[2:] for n in coupled.state_names[coupled.nq:]]
    dof = [int(m.jnt_dofadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n)]) for n in names]
    worst = {}
    for moving in (False, True):
        rng = np.random.default_rng(11)
        eomc_err, plain_err = [], []
        for q, u in _states(rng, 4, moving):
            _set(m, data, q, u)
            ud = np.asarray(coupled.rhs(0.0, _state(coupled, q, u), r=R))[coupled.nq:]
            plain = _reduced(opened, q, u, quadratic=False)
            plain = np.array([plain[n] for n in names])
            qacc = data.qacc[dof]
            scale = max(1.0, np.max(np.abs(ud)))
            eomc_err.append(np.max(np.abs(qacc - ud)) / scale)
            plain_err.append(np.max(np.abs(qacc - plain)) / scale)
        worst[moving] = (max(eomc_err), max(plain_err))
    print("\nrelative qacc difference to mj_forward (solref 0.002 1, solimp 0.9999): at rest %.2e; "
          "moving %.2e (to the reduced dynamics without J̇v: %.2e)" % (worst[False][0], *worst[True]))
    assert worst[False][0] < 1e-3
    assert worst[True][1] < 1e-3 < worst[True][0]


def _file(tmp_path, equality, name="m.xml"):
    path = tmp_path / name
    path.write_text(f"""<mujoco>
  <worldbody>
    <body name="a"><joint name="j" type="hinge"/><geom size="0.1"/>
      <body name="b" pos="0 0 -1"><joint name="k" type="hinge"/><geom size="0.1"/>
        <body name="c" pos="0 0 -1"><joint name="s" type="slide"/><geom size="0.1"/></body>
      </body>
    </body>
  </worldbody>
  <equality>
{equality}
  </equality>
</mujoco>""")
    return path


@pytest.mark.parametrize("equality, match, line", [
    ('    <connect name="pin" body1="a" body2="c" anchor="0 0 0"/>',
     r"m.xml:10: <connect>: equality pin: <connect> is a ball-joint loop closure between bodies: only "
     r"joint couplings", 10),
    ('    <joint joint1="k" joint2="j"/>\n    <weld name="glue" body1="b" body2="c"/>',
     r"<weld>: equality glue: <weld> is a weld", 11),
    ('    <joint name="one" joint1="k" joint2="j"/>\n    <joint name="two" joint1="k" joint2="s"/>',
     r"equality two: joint k is already joint1 of equality one", 11),
    # dm_control's quadruped names each tendon equality as its tendon: the equality's line
    ('  </equality>\n  <tendon>\n    <fixed name="t"><joint joint="j" coef="1"/><joint joint="k" '
     'coef="-1"/></fixed><fixed name="u"><joint joint="k" coef="2"/><joint joint="j" coef="1"/></fixed>\n'
     '  </tendon>\n  <equality>\n    <tendon name="t" tendon1="t" tendon2="u"/>',
     r"<equality><tendon>: equality t: every joint of tendon t is in tendon2", 15),
])
def test_what_is_not_a_coupling_is_refused_with_element_and_line(tmp_path, equality, match, line):
    with pytest.raises(ModelFileError, match=match) as info:
        eomc.compile(str(_file(tmp_path, equality)), functions=["rhs"], cache_dir=tmp_path / "c",
                     progress=False)
    assert info.value.lineno == line


def test_ignore_drops_other_kinds_and_keeps_the_coupling_and_inactive_ones_are_left_out(tmp_path):
    path = _file(tmp_path, '    <joint name="c1" joint1="s" joint2="k" polycoef="0 0.2 0 0 0"/>\n'
                           '    <joint name="off" joint1="j" active="false"/>\n'
                           '    <connect name="pin" body1="a" body2="c" anchor="0 0 0"/>')
    with pytest.warns(EomcWarning) as record:
        model = eomc.compile(MjcfModel(path, ignore=("equality",)), functions=["rhs", "constraints"],
                             cache_dir=tmp_path / "c", progress=False)
    text = " ".join(str(w.message) for w in record)
    assert "ignored: equality pin" in text and "equality off: inactive" in text
    assert (model.nhol, model.state_names[:3]) == (1, ("q_j", "q_k", "q_s"))
    x = np.array([0.3, 0.5, 0.2 * 0.5, 0.0, 1.0, 0.2])
    assert np.max(np.abs(model.constraints(0.0, x))) < 1e-15
    # the polycoef number is a parameter: changing it moves the constraint
    assert np.isclose(model.constraints(0.0, x, p={"eq_c1_p1": 0.3})[0], -0.1 * 0.5)


def test_the_default_initial_state_is_on_the_couplings(models):
    """MuJoCo's qpos0 is not on a coupling with p0 != 0: eomc's start is (joint1 set from joint2)."""
    coupled, _, _ = models
    x0 = coupled.initial_state
    assert x0[coupled.state_names.index("q_elbow")] == pytest.approx(0.2 + 0.1)
    assert np.max(np.abs(coupled.constraints(0.0, x0, r=R))) < 1e-14


def test_ground_contacts_keep_the_couplings(tmp_path):
    """The contact reader makes a new Tree: the couplings ride along on it too."""
    path = _file(tmp_path, '    <joint name="c1" joint1="s" joint2="k" polycoef="0 0.2 0 0 0"/>')
    model = eomc.compile(str(path), contacts=["c"], functions=["rhs", "constraints"],
                         cache_dir=tmp_path / "c", progress=False)
    assert model.nhol == 1 and model.state_names[2] == "q_s"


def test_poses_follow_the_reordered_states(models):
    """The animation's body frames at a coupled state are MuJoCo's xpos/xmat (states reordered)."""
    coupled, _, d = models
    m, data = _mujoco(d / "coupled.xml")
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(1, m.nbody)]
    for q, u in _states(np.random.default_rng(5), 2):
        poses = coupled.poses(0.0, _state(coupled, q, u))
        _set(m, data, q, u)
        for b, name in enumerate(names, start=1):
            assert np.max(np.abs(poses[name] - data.xpos[b])) < 1e-12
            assert np.max(np.abs(poses.rotation(name) - data.xmat[b].reshape(3, 3))) < 1e-12
