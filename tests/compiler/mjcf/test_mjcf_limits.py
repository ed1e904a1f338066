"""MJCF range limits, damping and frictionloss (eomc.compiler.tree.joint_laws) against MuJoCo.

Inside the range eomc's limit exerts nothing and MuJoCo's limit constraint is
inactive, so qacc agrees with mj_forward with limits *on* on both sides (to 1e-10).
Past the range both are soft but differ in kind (MuJoCo: a constraint solved with
impedance and reference acceleration; eomc: a spring-damper that gives under a steady
load as MuJoCo's does), so a pendulum dropped onto its limit is compared by where it
comes to rest and how deep it first goes, with the differences stated.  frictionloss is eomc's
regularised Coulomb friction, not MuJoCo's dry-friction constraint: checked
against its formula, MuJoCo's own friction switched off.
"""
import math
import warnings

import numpy as np
import pytest
from scipy.optimize import brentq

mujoco = pytest.importorskip("mujoco")

import eomc  # noqa: E402
from eomc.compiler.contact.mujoco_law import HOLD_WIDTH  # noqa: E402
from eomc.compiler.mjcf.compare import qacc_of, to_mujoco, tree_of  # noqa: E402
from eomc.compiler.mjcf.model import MjcfModel, check_model, load_mjmodel  # noqa: E402
from eomc.compiler.mjcf.treeir import tree_ir  # noqa: E402
from eomc.runtime.errors import EomcWarning, ModelFileError  # noqa: E402
from eomc.runtime.simulate import simulate  # noqa: E402
from eomc.runtime.switching import PhysicsWarning  # noqa: E402

ARM = """<mujoco model="limited">
  <option gravity="0 0 -9.81" timestep="0.0002"/>
  <worldbody>
    <body name="cart">
      <joint name="slide" type="slide" axis="1 0 0" range="-0.5 0.5" damping="0.3" frictionloss="0.2"/>
      <geom type="box" size="0.1 0.1 0.05" mass="1.5"/>
      <body name="upper" pos="0 0 -0.05">
        <joint name="shoulder" type="hinge" axis="0 1 0" range="-60 45" damping="0.05"/>
        <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.03" mass="1"/>
        <body name="lower" pos="0.4 0 0">
          <joint name="elbow" type="hinge" axis="0 1 0" range="-30 80" damping="0.02" frictionloss="0.05"/>
          <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.025" mass="0.6"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

DROP = """<mujoco model="drop">
  <option gravity="0 0 -9.81" timestep="0.0001" integrator="RK4"/>
  <worldbody>
    <body name="arm">
      <joint name="hinge" type="hinge" axis="0 1 0" range="-60 0"/>
      <geom type="sphere" size="0.02" pos="0.5 0 0" mass="1"/>
    </body>
  </worldbody>
</mujoco>
"""


@pytest.fixture(scope="module")
def arm(tmp_path_factory):
    root = tmp_path_factory.mktemp("limited")
    path = root / "limited.xml"
    path.write_text(ARM)
    model = eomc.compile(MjcfModel(path), functions=["rhs", "mass_matrix"], cache_dir=root / "cache",
                         progress=False)
    return path, model


def test_inside_the_range_qacc_matches_mj_forward_with_limits_on(arm):
    path, model = arm
    m = load_mjmodel(path)
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_FRICTIONLOSS)    # MuJoCo's is a constraint
    built = tree_of(m, model, actuators=check_model(m, path))
    p = model.param_defaults.copy()
    p[[i for i, n in enumerate(model.param_names) if n.startswith("friction_")
       and not n.startswith("friction_v")]] = 0.0
    d = mujoco.MjData(m)
    rng = np.random.default_rng(3)
    lo, hi = m.jnt_range[:, 0], m.jnt_range[:, 1]
    worst, seen = 0.0, 0
    for _ in range(20):
        q = rng.uniform(lo + 0.01, hi - 0.01)
        u = rng.uniform(-2, 2, 3)
        d.qpos[:], d.qvel[:] = to_mujoco(m, built, q, u)
        mujoco.mj_forward(m, d)
        assert d.nefc == 0                     # no constraint row: the limits are inactive in MuJoCo too
        xd = model.rhs(0.0, np.concatenate([q, u]), p=p)
        mine = qacc_of(m, built, q, u, xd[3:])
        worst = max(worst, np.max(np.abs(mine - d.qacc)) / max(1.0, np.max(np.abs(d.qacc))))
        seen += 1
    assert seen == 20 and worst < 1e-10, worst
    # and the damping is in it: without eomc's damping the two differ
    nodamp = p.copy()
    nodamp[[i for i, n in enumerate(model.param_names) if n.startswith("d_")]] = 0.0
    q, u = (lo + hi) / 2, np.array([1.0, -1.0, 2.0])
    d.qpos[:], d.qvel[:] = to_mujoco(m, built, q, u)
    mujoco.mj_forward(m, d)
    assert np.max(np.abs(model.rhs(0.0, np.concatenate([q, u]), p=nodamp)[3:] - d.qacc)) > 1e-2


def test_frictionloss_is_the_regularised_coulomb_law(arm):
    """rhs with frictionloss = rhs without it + M⁻¹ (-f tanh(u / v)) on each joint that has one."""
    path, model = arm
    names = list(model.param_names)
    p = model.param_defaults.copy()
    assert p[names.index("friction_slide")] == 0.2 and p[names.index("friction_elbow")] == 0.05
    assert "friction_shoulder" not in names
    none = p.copy()
    none[[names.index("friction_slide"), names.index("friction_elbow")]] = 0.0
    x = np.array([0.1, 0.2, 0.3, 0.004, -0.5, 0.02])
    v = p[names.index("friction_v_slide")]
    tau = np.array([-0.2 * math.tanh(0.004 / v), 0.0, -0.05 * math.tanh(0.02 / v)])
    direct = model.rhs(0.0, x, p=p)[3:] - model.rhs(0.0, x, p=none)[3:]
    expected = np.linalg.solve(model.mass_matrix(0.0, x, p=p), tau)
    assert np.max(np.abs(direct - expected)) < 1e-12 * max(1.0, np.max(np.abs(expected)))
    assert np.max(np.abs(expected)) > 0.01


def _mujoco_drop(path, t_final):
    m = load_mjmodel(path)
    d = mujoco.MjData(m)
    d.qpos[0] = -0.5
    deepest, n = 0.0, int(round(t_final / m.opt.timestep))
    for _ in range(n):
        mujoco.mj_step(m, d)
        deepest = max(deepest, d.qpos[0])
    return deepest, float(d.qpos[0])


def test_past_the_limit_compared_with_mujoco(tmp_path):
    """A 0.5 m pendulum falls 0.5 rad onto its upper limit 0 and rests against it.  eomc's
    spring-damper (mujoco_law.limit_spring) is MuJoCo's reference acceleration, K = m̃ k,
    k = 1/(dmax tc z)², C = 2 m̃/(dmax tc), stiffened G = dmax/(1 - dmax) times within a few
    mrad of the limit (the stretch r + (G - 1) w tanh(r/w)) and rests at K s(d) = m g l;
    MuJoCo's soft constraint rests at (1 - d)/d of the deflection of its reference stiffness,
    d between dmin and dmax (solimp) -- eomc's where d reaches dmax; here, under 1 mrad deep,
    the law's smoothing widths add to eomc's.  The first give at the impact, 30 mrad, is set by
    MuJoCo's reference acceleration, as eomc's is past the stiffened millirad."""
    path = tmp_path / "drop.xml"
    path.write_text(DROP)
    model = eomc.compile(MjcfModel(path), functions=["rhs", "jac_x"], cache_dir=tmp_path / "c", progress=False)
    p = dict(zip(model.param_names, model.param_defaults))
    m = load_mjmodel(path)
    inertia = 1.0 / m.dof_invweight0[0]
    tc, z, dmax = m.jnt_solref[0][0], m.jnt_solref[0][1], m.jnt_solimp[0][1]
    kref = 1 / (dmax * tc * z) ** 2            # MuJoCo's reference stiffness (per unit inertia)
    assert p["limit_k_hinge"] == pytest.approx(inertia * kref, rel=1e-12)
    assert p["limit_c_hinge"] == pytest.approx(2 * inertia / (dmax * tc), rel=1e-12)
    G, w = dmax / (1 - dmax), HOLD_WIDTH
    res = simulate(model, np.array([-0.5, 0.0]), (0.0, 2.0), method="radau", rtol=1e-9, atol=1e-11,
                   n_points=20001)
    ours_deep, ours_rest = res.x[:, 0].max(), res.x[-1, 0]
    k, e, F = p["limit_k_hinge"], p["limit_e_hinge"], 1.0 * 9.81 * 0.5
    # the limit only pushes: its force (k d + sqrt((k d)² + (k e/10)²))/2 at rest, times (d/(d+e))²
    def spring(d):
        s = d + (G - 1) * w * math.tanh(d / w)
        return (k * s + math.hypot(k * s, k * e / 10)) / 2 * d ** 2 / (d + e) ** 2
    static = brentq(lambda d: spring(d) - F * math.cos(d), 1e-9, 0.5, xtol=1e-15)
    assert ours_rest == pytest.approx(static, rel=1e-6)
    theirs_deep, theirs_rest = _mujoco_drop(path, 2.0)
    print(f"\ndrop onto a limit: deepest eomc {ours_deep:.4g} MuJoCo {theirs_deep:.4g} rad; "
          f"rest eomc {ours_rest:.4g} MuJoCo {theirs_rest:.4g} rad")
    # at rest MuJoCo's constraint balances the load F with d kref r = (1 - d) F/m̃, d in [dmin, dmax]
    dmin = m.jnt_solimp[0][0]
    mj_low, mj_high = (F / (inertia * kref) * (1 - d) / d for d in (dmax, dmin))
    assert 0.95 * mj_low < theirs_rest < 1.05 * mj_high           # the oracle is what we say it is
    # measured 0.83 vs 0.56 mrad: this close to the limit the stiffened region (1 mrad) and the
    # law's smoothing width (0.3 mrad) are what it rests in; the reference stiffness alone (the
    # rule before) rested at F/k, 13 times deeper than MuJoCo
    assert 0.7 * theirs_rest < ours_rest < 1.6 * theirs_rest
    assert ours_rest < 0.2 * F / k
    # the impact (first give 32 mrad) is the reference acceleration's: within 10 %
    assert ours_deep == pytest.approx(theirs_deep, rel=0.1)


def test_limits_off_and_bad_numbers(tmp_path):
    path = tmp_path / "limited.xml"
    path.write_text(ARM)
    m = load_mjmodel(path)
    on = {str(s) for s in tree_ir(m).parameters}
    off = {str(s) for s in tree_ir(m, limits=False, friction=False).parameters}
    assert on - off == {f"{k}_{j}" for j in ("slide", "shoulder", "elbow") for k in
                        ("limit_k", "limit_c", "limit_e", "limit_lo", "limit_hi")} | {
        "friction_slide", "friction_v_slide", "friction_elbow", "friction_v_elbow"}
    ball = tmp_path / "ball.xml"
    ball.write_text("""<mujoco>
  <worldbody>
    <body name="a"><joint name="socket" type="ball" frictionloss="0.1"/><geom size="0.1" pos="0 0 -0.3"/></body>
  </worldbody>
</mujoco>""")
    with pytest.raises(ModelFileError, match=r"ball.xml:3: <joint>: joint socket: frictionloss on a ball joint"):
        eomc.compile(MjcfModel(ball), functions=["rhs"], cache_dir=tmp_path / "c", progress=False)
    with pytest.warns(EomcWarning, match="ignored: joint socket: frictionloss on a ball joint"):
        eomc.compile(MjcfModel(ball, ignore=("frictionloss",)), functions=["rhs"], cache_dir=tmp_path / "c",
                     progress=False)


def test_a_range_that_starts_at_zero_keeps_its_bound_as_a_parameter(tmp_path):
    """range="0 90": the bound at 0 is a parameter (limit_lo_<joint>) like the other, so the
    runtime watches it (before, the exact zero became a literal in the C and the runtime, which
    finds limits by their parameters, never saw that side) and the MJCF's limit shape is in the
    model's metadata for the energy verdict (runtime/limit_energy.py)."""
    path = tmp_path / "zero.xml"
    path.write_text(ARM.replace('range="-30 80"', 'range="0 80"', 1))
    assert 'range="0 80"' in path.read_text()
    names = {str(s): v for s, v in tree_ir(load_mjmodel(path)).parameters.items()}
    assert names["limit_lo_elbow"] == 0.0
    model = eomc.compile(MjcfModel(path), functions=["rhs"], cache_dir=tmp_path / "c", progress=False)
    assert model.param_defaults[list(model.param_names).index("limit_lo_elbow")] == 0.0
    assert set(model.metadata["limit_laws"]) == {"slide", "shoulder", "elbow"}


def test_negative_frictionloss_names_the_joint(tmp_path):
    """MuJoCo accepts it (its constraint would clamp it); as a law it would feed energy in."""
    path = tmp_path / "neg.xml"
    path.write_text("""<mujoco>
  <worldbody>
    <body name="a"><joint name="pin" type="hinge" frictionloss="-0.1"/><geom size="0.1" pos="0 0 -0.3"/></body>
  </worldbody>
</mujoco>""")
    with pytest.raises(ModelFileError, match=r"neg.xml:3: <joint>: joint pin: frictionloss -0.1: it must be a "
                                             r"finite number >= 0"):
        eomc.compile(MjcfModel(path), functions=["rhs"], cache_dir=tmp_path / "c", progress=False)


SITTER = """<mujoco model="sitter">
  <option gravity="0 0 -9.81" timestep="0.002"/>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="torso" pos="0 0 0.521">
      <freejoint name="root"/>
      <geom type="box" size="0.1 0.1 0.05" pos="0.15 0 0.05" mass="8"/>
      <body name="leg">
        <joint name="knee" type="hinge" axis="0 1 0" range="-17 17"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.02" mass="1" contype="0" conaffinity="0"/>
        <geom name="f0" type="sphere" size="0.02" pos="0.25 0.1 -0.5" mass="0.1"/>
        <geom name="f1" type="sphere" size="0.02" pos="0.25 -0.1 -0.5" mass="0.1"/>
        <geom name="f2" type="sphere" size="0.02" pos="-0.25 0.1 -0.5" mass="0.1"/>
        <geom name="f3" type="sphere" size="0.02" pos="-0.25 -0.1 -0.5" mass="0.1"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def test_a_knee_that_catches_a_free_torso_goes_as_far_past_as_mujocos(tmp_path):
    """A free torso on one leg pivots onto the knee's limit (its centre of mass is ahead of the
    knee).  MuJoCo's soft limit stops what the joint moves within its time constant; eomc's
    spring-damper acts on the inertia the knee carries (compiler/mjcf/carried.py: the torso's
    about the knee) as MuJoCo's solver does, saturating (mujoco_law.limit_spring) -- with the
    leg's own inertia alone (1/dof_invweight0) the knee went 0.216 rad past, with the carried
    inertia as the scale 0.043, with the saturating scale 0.057, MuJoCo's 0.0446.  The largest excursion past the limit is MuJoCo's within a factor 1.5 (MuJoCo's
    is 0.045 rad here: an MJCF limit gives what the file's solref makes it give)."""
    from eomc.compiler.contact.mujoco_law import limit_spring
    path, m, knee, own, carried = _sitter_knee(tmp_path, SITTER)
    # the rest of the robot's inertia about the knee's axis: the torso box (8 kg, half sizes 0.1 and
    # 0.05 across the axis) with its centre 0.15 ahead of and 0.05 above the knee
    assert carried == pytest.approx(8.0 / 3 * (0.1 ** 2 + 0.05 ** 2) + 8.0 * (0.15 ** 2 + 0.05 ** 2), rel=1e-9)
    assert carried > 5 * own
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EomcWarning)
        model = eomc.compile(MjcfModel(path), functions=("rhs", "outputs", "jac_x", "events"),
                             cache_dir=tmp_path / "c", progress=False)
    p = dict(zip(model.param_names, model.param_defaults))
    K, C, _ = limit_spring(own, m.jnt_solref[knee], m.jnt_solimp[knee], m.opt.timestep, carried)
    assert (p["limit_k_knee"], p["limit_c_knee"]) == pytest.approx((K, C), rel=1e-12)
    # past the verdict's 0.03 rad, as MuJoCo's: the run says so, naming the joint
    with pytest.warns(PhysicsWarning, match=r"joint knee went 0\.0\d* past its lower limit"):
        res = model.simulate(None, (0.0, 0.6))
    ours = float(np.max(np.radians(-17) - res["q_knee"]))
    d = mujoco.MjData(m)
    theirs = 0.0
    while d.time < 0.6 - 1e-9:
        mujoco.mj_step(m, d)
        theirs = max(theirs, np.radians(-17) - d.qpos[7])
    print(f"\nknee past its limit: eomc {ours:.4g} rad, MuJoCo {theirs:.4g} rad")
    assert theirs > 0.005                    # MuJoCo's soft limit gives too: the comparison is not empty
    assert theirs / 1.5 < ours < 1.5 * theirs


def _mujoco_deepest(m, joint, t_final):
    """MuJoCo's largest excursion of ``joint`` past its limit in an mj_step run, and the scale its
    solver put on the limit row's reference acceleration at that step, 1/(A_s + R) over dmax:
    A_s the row's effective inverse inertia with the other rows (contacts) as the solver has
    them (J M⁻¹ Jᵀ, Schur complement with A + R of the others), R its regulariser."""
    d = mujoco.MjData(m)
    deepest, scale = 0.0, None
    while d.time < t_final - 1e-9:
        mujoco.mj_step(m, d)
        for i in range(d.nefc):
            if d.efc_type[i] != mujoco.mjtConstraint.mjCNSTR_LIMIT_JOINT or d.efc_id[i] != joint:
                continue
            if -d.efc_pos[i] <= deepest:
                continue
            J = np.array(d.efc_J).reshape(d.nefc, m.nv)
            Minv = np.zeros((m.nv, m.nv))
            mujoco.mj_solveM(m, d, Minv, np.eye(m.nv))
            A, R = J @ Minv @ J.T, np.array(d.efc_R)
            o = [k for k in range(d.nefc) if k != i]
            schur = A[i, i] - A[i, o] @ np.linalg.solve(A[np.ix_(o, o)] + np.diag(R[o]), A[o, i])
            deepest, scale = -d.efc_pos[i], 1.0 / (schur + R[i]) / m.jnt_solimp[joint][1]
    return deepest, scale


@pytest.mark.parametrize("leg, dmax", [(1.0, 0.95), (0.2, 0.95), (0.2, 0.99)])
def test_the_limits_scale_is_the_one_mujocos_solver_applies(tmp_path, leg, dmax):
    """The rule of mujoco_law.limit_spring's ``carried`` against MuJoCo's solver on a free torso
    (8 kg) pivoting onto its knee limit, the leg 1 or 0.2 kg, MuJoCo's default dmax 0.95 and
    dm_control's humanoid's 0.99: at MuJoCo's deepest step, the scale its solver put on the
    limit's reference acceleration (1/(A_s + R), the row's effective inverse inertia A_s with
    the feet's contact rows, R = (1 - d)/d·dof_invweight0, over dmax) is the rule's
    m·m_c/(d·m + (1 - d)·m_c) within 25 % (m_c the carried inertia, the torso rigid about the
    knee), and eomc's excursion past the limit is MuJoCo's within a factor 1.5.  Measured
    (scale / own inertia): rule 4.84, 8.43, 12.3; MuJoCo's solver 4.63, 7.24, 10.5; the carried
    inertia itself (last rule's scale) 6.07, 13.9, 13.9.  Lighter legs still (carried 26 and 53
    times the own inertia) put the rule 1.6 and 1.9 times above the solver (its feet's soft,
    lifting contacts leave the knee less than the rigid torso): not asserted; docs say so."""
    from eomc.compiler.contact.mujoco_law import limit_spring
    xml = SITTER.replace('mass="1"', f'mass="{leg}"').replace('mass="0.1"', f'mass="{leg / 10}"').replace(
        'range="-17 17"', f'range="-17 17" solimplimit="0.9 {dmax} 0.001"')
    path, m, knee, own, carried = _sitter_knee(tmp_path, xml)
    K, C, hold = limit_spring(own, m.jnt_solref[knee], m.jnt_solimp[knee], m.opt.timestep, carried)
    K_own, _, (G, _) = limit_spring(own, m.jnt_solref[knee], m.jnt_solimp[knee], m.opt.timestep)
    rule = K / K_own * own
    theirs, solver = _mujoco_deepest(m, knee, 0.6)
    print(f"\nleg {leg} kg, dmax {m.jnt_solimp[knee][1]}: scale / own inertia: rule {rule / own:.3g}, MuJoCo's "
          f"solver {solver / own:.3g}, carried {carried / own:.3g}")
    assert theirs > 0.005 and solver > 2 * own        # the knee carries the torso in MuJoCo's run too
    assert solver / 1.25 < rule < 1.25 * solver
    # MuJoCo's give under a steady load is its own inertia's whatever the joint carries: so is eomc's
    assert hold[0] * K == pytest.approx(G * K_own, rel=1e-12)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", (EomcWarning, PhysicsWarning))
        model = eomc.compile(MjcfModel(path), functions=("rhs", "outputs", "jac_x", "events"),
                             cache_dir=tmp_path / "c", progress=False)
        res = model.simulate(None, (0.0, 0.6))
    p = dict(zip(model.param_names, model.param_defaults))
    assert (p["limit_k_knee"], p["limit_c_knee"]) == pytest.approx((K, C), rel=1e-12)
    ours = float(np.max(np.radians(-17) - res["q_knee"]))
    print(f"knee past its limit: eomc {ours:.4g} rad, MuJoCo {theirs:.4g} rad")
    assert theirs / 1.5 < ours < 1.5 * theirs


def _sitter_knee(tmp_path, xml):
    """The sitter model written and loaded: (path, MjModel, knee id, the knee's own inertia
    1/dof_invweight0, the inertia it carries)."""
    from eomc.compiler.mjcf.carried import carried_inertias
    path = tmp_path / "sitter.xml"
    path.write_text(xml)
    m = load_mjmodel(path)
    knee = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "knee")
    return path, m, knee, 1.0 / m.dof_invweight0[m.jnt_dofadr[knee]], carried_inertias(m)[knee]


PLANAR_ROOT = ('<joint name="rootx" type="slide" axis="1 0 0"/><joint name="rootz" type="slide" axis="0 0 1"/>'
               '<joint name="rooty" type="hinge" axis="0 1 0"/>')


def test_a_knee_that_catches_a_planar_torso_goes_as_far_past_as_mujocos(tmp_path):
    """The sitter with a planar root (slide x, slide z, hinge y, unactuated: how gymnasium's and
    dm_control's walker, hopper and cheetah hang from the world) instead of a free joint: the knee
    carries the torso as it does on the free sitter (compiler/mjcf/carried.py), so the knee goes
    0.057 rad past where MuJoCo's goes 0.045; with the leg's own inertia (1/dof_invweight0, the
    rule planar roots had until session 9) it goes more than 1.5 times as far."""
    from eomc.compiler.contact.mujoco_law import limit_spring
    path, m, knee, own, carried = _sitter_knee(tmp_path, SITTER.replace('<freejoint name="root"/>', PLANAR_ROOT))
    # with one joint below the root, the held inertia is the torso's rigid about the knee's axis
    assert carried == pytest.approx(8.0 / 3 * (0.1 ** 2 + 0.05 ** 2) + 8.0 * (0.15 ** 2 + 0.05 ** 2), rel=1e-9)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", (EomcWarning, PhysicsWarning))
        model = eomc.compile(MjcfModel(path), functions=("rhs", "outputs", "jac_x", "events"),
                             cache_dir=tmp_path / "c", progress=False)
        p = dict(zip(model.param_names, model.param_defaults))
        K, C, _ = limit_spring(own, m.jnt_solref[knee], m.jnt_solimp[knee], m.opt.timestep, carried)
        assert (p["limit_k_knee"], p["limit_c_knee"]) == pytest.approx((K, C), rel=1e-12)
        ours = float(np.max(np.radians(-17) - model.simulate(None, (0.0, 0.6))["q_knee"]))
        K0, C0, _ = limit_spring(own, m.jnt_solref[knee], m.jnt_solimp[knee], m.opt.timestep)
        p0 = model.param_defaults.copy()
        p0[list(model.param_names).index("limit_k_knee")] = K0
        p0[list(model.param_names).index("limit_c_knee")] = C0
        old = float(np.max(np.radians(-17) - model.simulate(None, (0.0, 0.6), p=p0)["q_knee"]))
    theirs = _mujoco_excursions(m, ["knee"], 0.6)["knee"]
    print(f"\nplanar knee past its limit: eomc {ours:.4g} rad (own inertia {old:.4g}), MuJoCo {theirs:.4g}")
    assert theirs > 0.005
    assert theirs / 1.5 < ours < 1.5 * theirs
    assert old > 1.5 * theirs           # the test tells the rules apart


def _mujoco_excursions(m, joints, t_final):
    """joint name -> MuJoCo's (mj_step, the file's step and integrator) largest excursion past a
    limit of the joint, from the file's qpos0 (a side the start is already outside of left out:
    that excursion is the start's)."""
    ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n) for n in joints]
    adr = [int(m.jnt_qposadr[j]) for j in ids]
    d = mujoco.MjData(m)
    qs = [d.qpos[adr].copy()]
    while d.time < t_final - 1e-9:
        mujoco.mj_step(m, d)
        qs.append(d.qpos[adr].copy())
    return {n: _excursion(np.array(qs)[:, i], *m.jnt_range[j]) for i, (n, j) in enumerate(zip(joints, ids))}


def _excursion(q, lo, hi):
    """the largest excursion of the path q past lo or hi, on the sides q[0] is inside of"""
    past = [side for side in (lo - q, q - hi) if side[0] <= 0]
    return float(max((np.max(side) for side in past), default=0.0))


def _suite_file(which, stem):
    if which == "gym":
        gymnasium = pytest.importorskip("gymnasium")
        from pathlib import Path
        return Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / f"{stem}.xml"
    dm_control = pytest.importorskip("dm_control")
    from pathlib import Path
    return Path(dm_control.__file__).parent / "suite" / f"{stem}.xml"


@pytest.fixture(scope="module")
def suite_drop(tmp_path_factory):
    """(which, stem) -> {joint: (eomc's largest excursion past a limit, MuJoCo's)} over the 5 s
    no-flag passive drop from the file's qpos0 (eomc: eomc.compile(path), the default method;
    MuJoCo: mj_step at the file's step), every limited hinge and slide; each model built and run
    once per module."""
    runs = {}

    def drop(which, stem):
        if (which, stem) not in runs:
            path = _suite_file(which, stem)
            m = load_mjmodel(path)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", (EomcWarning, PhysicsWarning))
                model = eomc.compile(str(path), cache_dir=tmp_path_factory.mktemp(stem), progress=False)
                res = model.simulate(None, (0.0, 5.0))
            p = dict(zip(model.param_names, model.param_defaults))
            joints = [n[len("limit_k_"):] for n in model.param_names if n.startswith("limit_k_")]
            theirs = _mujoco_excursions(m, joints, 5.0)
            runs[(which, stem)] = {j: (_excursion(np.asarray(res[f"q_{j}"]), p.get(f"limit_lo_{j}", 0.0),
                                                  p.get(f"limit_hi_{j}", 0.0)), theirs[j]) for j in joints}
        return runs[(which, stem)]
    return drop


@pytest.mark.parametrize("which, stem, joints, factor", [
    ("gym", "walker2d", ("foot_joint", "foot_left_joint"), 1.5),
    ("dm", "hopper", ("knee", "ankle"), 1.5),
    ("dm", "walker", ("right_ankle", "left_ankle"), 2.5),
])
def test_planar_robots_limits_hold_as_mujocos(suite_drop, which, stem, joints, factor):
    """No-flag 5 s falls of the planar-rooted robots (compiler/mjcf/carried.py's held inertia):
    the joints that go past their limits in both runs go as far as in MuJoCo's mj_step run
    within ``factor``.  Measured eomc / MuJoCo: walker2d feet 0.037 / 0.028 (1.3), dm hopper knee
    0.054 / 0.060 and ankle 0.021 / 0.026, dm walker ankles 0.052 / 0.022 (2.3: not within 1.5;
    MuJoCo's limit holds the load of the walker's crash onto its folded knees, which no spring
    does: docs/joint-laws.md; its knees 0.062 / 0.073, hips 0.011 / 0.042, walker2d's legs
    0.041 / 0.091, benchmarks/results/limit_overshoot.md).  With 1/dof_invweight0 (before
    session 9): 0.229, 0.149 / 0.052, 0.533 rad past."""
    got = suite_drop(which, stem)
    for joint in joints:
        ours, theirs = got[joint]
        print(f"\n{stem} {joint} past its limit: eomc {ours:.4g} rad, MuJoCo {theirs:.4g}")
        assert theirs > 0.005
        assert theirs / factor < ours < factor * theirs


# The stated overshoot (docs/joint-laws.md, benchmarks/bench_limit_overshoot.BOUND_FACTOR/_SLACK)
BOUND_FACTOR, BOUND_SLACK = 1.35, 0.005


@pytest.mark.parametrize("which, stem, held", [
    ("gym", "walker2d", ()),
    ("dm", "hopper", ()),
    ("dm", "walker", ("right_ankle", "left_ankle")),
])
def test_planar_robots_stay_within_the_stated_overshoot(suite_drop, which, stem, held):
    """Every limited joint of the no-flag 5 s drop goes at most 1.35 times as far past its limits
    as MuJoCo's does (mj_step at the file's step) plus 5 mrad: the stated overshoot of an MJCF
    limit.  ``held``: the joints MuJoCo's limit holds by cancelling the load (the dm walker's
    ankles, dmax 0.99, under the crash onto the folded knees: MuJoCo's own ankles go 0.060 rad
    past with dmax 0.95), bounded by 2.5 times MuJoCo's instead (measured 2.32; the spring's
    hold factor G there is 5.3, the ratio a steady load would reach).  Measured
    (limit_overshoot.md): walker2d feet 1.34x, dm hopper waist 0.0223 vs 0.0135 (1.65x, within
    the slack; 1.10x MuJoCo's at a tenth of its step), everything else at most MuJoCo's."""
    got = suite_drop(which, stem)
    assert any(theirs > 0.005 for _, theirs in got.values())        # the drop reaches the limits
    for joint, (ours, theirs) in got.items():
        print(f"\n{stem} {joint}: eomc {ours:.4g} rad, MuJoCo {theirs:.4g}")
        if joint in held:
            assert ours < 2.5 * theirs, joint
        else:
            assert ours <= BOUND_FACTOR * theirs + BOUND_SLACK, joint
