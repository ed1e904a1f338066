"""A singular mass matrix names the speeds that meet no inertia (eomc.runtime.diagnose)."""
import numpy as np
import pytest
import sympy as sm

import eomc
import eomc.mechanics as em
from eomc.errors import SimulationError


def _arm_system(m1, m2, l, g=None):
    """Two point masses on pins, shoulder then elbow (tip mass m2); gravity along -y when g is given."""
    q1, q2, u1, u2 = em.dynamicsymbols("q1 q2 u1 u2")
    ground = em.RigidBody("ground")
    upper = em.RigidBody("upper", mass=m1)
    upper.inertia = (em.inertia(upper.frame, 0, 0, 0), upper.masscenter)
    tip = em.RigidBody("tip", mass=m2)
    tip.inertia = (em.inertia(tip.frame, 0, 0, 0), tip.masscenter)
    system = em.System.from_newtonian(ground)
    system.add_joints(
        em.PinJoint("shoulder", ground, upper, q1, u1, child_point=l * upper.frame.y,
                    joint_axis=ground.frame.z),
        em.PinJoint("elbow", upper, tip, q2, u2, parent_point=-l * upper.frame.y,
                    child_point=l * tip.frame.y, joint_axis=upper.frame.z))
    if g is not None:
        system.apply_uniform_gravity(-g * ground.frame.y)
    return system


@pytest.fixture(scope="module")
def arm(tmp_path_factory):
    """The arm with its tip mass m2 a parameter."""
    m1, m2, l, g = sm.symbols("m1 m2 l g", positive=True)
    return eomc.compile(_arm_system(m1, m2, l, g), "arm", functions=["rhs", "mass_matrix"], progress=False,
                        parameters={m1: 1.0, m2: 0.5, l: 0.7, g: 9.81},
                        cache_dir=str(tmp_path_factory.mktemp("cache")))


def _p(model, **values):
    base = dict(zip(model.metadata["param_names"], model.param_defaults))
    base.update(values)
    return np.array([base[k] for k in model.metadata["param_names"]])


def test_a_call_names_the_speed_without_inertia(arm):
    x = np.array([0.3, -0.4, 0.1, 0.2])
    with pytest.raises(SimulationError, match=r"singular at t=0, state .*u2=0.2; nothing resists motion along u2 \(1\)"):
        arm.rhs(0.0, x, p=_p(arm, m2=0.0))
    assert np.all(np.isfinite(arm.rhs(0.0, x, p=_p(arm))))


def test_a_simulation_names_it_too(arm):
    """simulate diagnoses a singular mass matrix as a call does: here every speed (l = 0 puts both
    point masses on the shoulder).  A body's mass of 0 given at run time is refused before the run
    since session 21, naming the parameter and the body (runtime/law_parameters.check_body_parameters),
    so m2 = 0 no longer reaches the integrator (the call-level test above still diagnoses it)."""
    with pytest.raises(SimulationError, match=r"singular.*M is zero there: no speed meets any mass or inertia"):
        arm.simulate([0.3, -0.4, 0.1, 0.2], (0.0, 1.0), p=_p(arm, l=0.0))
    with pytest.raises(ValueError, match=r"parameter m2 = 0 gives body tip the mass 0"):
        arm.simulate([0.3, -0.4, 0.1, 0.2], (0.0, 1.0), p=_p(arm, m2=0.0))


def test_no_diagnosis_without_a_compiled_mass_matrix(arm, monkeypatch):
    """A model built without mass_matrix keeps the plain status: no guess."""
    from eomc.runtime.diagnose import singular_direction
    x = np.array([0.3, -0.4, 0.1, 0.2])
    assert singular_direction(arm, 0.0, x, _p(arm, m2=0.0)).startswith("; nothing resists")
    assert singular_direction(arm, 0.0, x, _p(arm)) == ""      # M regular: nothing to say
    monkeypatch.setattr(arm, "functions", ("rhs",))
    assert singular_direction(arm, 0.0, x, _p(arm, m2=0.0)) == ""


# ---- the recursive formulation at a singular configuration (reliability report r3, N9) ----------

def _mixed_tree():
    """The report's tree: a SphericalJoint (XYZ body angles), a prismatic child, a skew pin.
    (A ball joint alone already rounds D to <= 0 in the lock; with this tree D stayed > 0.)"""
    ground = em.RigidBody("ground")
    s = em.System.from_newtonian(ground)
    a = em.RigidBody("a", mass=sm.Symbol("ma"))
    a.inertia = (em.inertia(a.frame, 1, 2, 3, 0.1, 0.2, 0.3), a.masscenter)
    b = em.RigidBody("b", mass=sm.Symbol("mb"))
    b.inertia = (em.inertia(b.frame, 2, 1, 2.5), b.masscenter)
    c = em.RigidBody("c", mass=1)
    c.inertia = (em.inertia(c.frame, 1, 1, 1), c.masscenter)
    qa, ua = em.dynamicsymbols("qa1:4"), em.dynamicsymbols("ua1:4")
    qb, ub = em.dynamicsymbols("qb ub")
    qc, uc = em.dynamicsymbols("qc uc")
    s.add_joints(em.SphericalJoint("S", ground, a, qa, ua, parent_point=0.1 * ground.x, child_point=-0.5 * a.z),
                 em.PrismaticJoint("P", a, b, qb, ub, parent_point=0.5 * a.z, joint_axis=a.x),
                 em.PinJoint("R", a, c, qc, uc, parent_point=0.3 * a.y, child_point=-0.2 * c.x,
                             joint_axis=a.y + a.z))
    s.apply_uniform_gravity(-9.81 * ground.z)
    return s


@pytest.fixture(scope="module")
def mixed(tmp_path_factory):
    # recursive only: Kane's derivation of a SphericalJoint costs ~12 s; its rhs (LDLᵀ of M)
    # is the reference the singular test follows, and CRBA's M and f are the oracle below
    return eomc.compile(_mixed_tree(), "mixed", progress=False, formulation="recursive",
                        cache_dir=str(tmp_path_factory.mktemp("cache")), parameters={"ma": 2.0, "mb": 1.5},
                        functions=["rhs", "mass_matrix", "forcing"])


def _gimbal_state(model, offset):
    x = np.zeros(model.nx)
    x[1], x[model.nq:] = np.pi / 2 + offset, 0.3
    return x


@pytest.mark.parametrize("offset", [0.0, 1e-14, -1e-9, 1e-9])
def test_recursive_rhs_in_gimbal_lock_is_singular_naming_the_speeds(mixed, offset):
    """It used to return status 0 and one of infinitely many u' (up to 2e5 at -1e-9)."""
    with pytest.raises(SimulationError, match=r"singular.*nothing resists motion along "
                                              r"(ua1 \(1\), ua3 \(-1\)|ua3 \(1\), ua1 \(-1\))"):
        mixed.rhs(0.0, _gimbal_state(mixed, offset))


def test_recursive_rhs_near_gimbal_lock_and_elsewhere_is_not_refused(mixed):
    """No misfire: regular states, and 1e-6 / 1e-3 from the lock (cond M ~ 1e12, 1e6), solve
    M u' = f (CRBA's M and f, an algorithm independent of ABA)."""
    rng = np.random.default_rng(7)
    states = [rng.uniform(-1.4, 1.4, mixed.nx) for _ in range(20)]
    states += [_gimbal_state(mixed, -1e-6), _gimbal_state(mixed, -1e-3)]
    for x in states:
        ud = mixed.rhs(0.0, x)[mixed.nq:]
        M, f = mixed.mass_matrix(0.0, x), mixed.forcing(0.0, x)
        assert np.linalg.norm(M @ ud - f) <= 1e-10 * max(1.0, np.linalg.norm(f)) * np.linalg.norm(M), x


@pytest.mark.parametrize("status, reason", [(5, "the step size became too small"),
                                            (6, "the maximum number of steps was reached")])
def test_a_collapsed_step_names_a_mass_matrix_singular_to_rounding(arm, status, reason):
    """icub.urdf (example-robot-data) stopped with 'the step size became too small' and no why:
    its head has next to no inertia about the two neck joints (M's smallest eigenvalue 4e-18).
    A failure of that kind now carries the diagnosis; a regular M adds nothing."""
    from eomc.runtime.simulate import failure_message
    x = np.array([0.3, -0.4, 0.1, 0.2])
    stats = {"status": status, "t": 0.25, "t_fail": 0.25, "h": 1e-18, "steps": 100000}
    msg = failure_message(arm, "radau", stats, x, _p(arm, m2=1e-14))
    assert reason in msg and "nothing resists motion along u2 (1)" in msg and "gimbal lock" in msg
    assert "nothing resists" not in failure_message(arm, "radau", stats, x, _p(arm))


def test_a_build_whose_start_has_a_singular_mass_matrix_warns(tmp_path):
    """eomc.compile says at the build when nothing resists some motion at the default start
    (icub.urdf's head), naming the speed; a regular model builds without that warning."""
    from eomc.errors import EomcWarning
    system = _arm_system(1.0, sm.Symbol("m2"), 0.7)
    for m2, warned in ((1e-16, True), (0.5, False)):
        with pytest.warns() as record:
            import warnings
            warnings.warn("marker", UserWarning)            # pytest.warns needs one warning at least
            eomc.compile(system, f"tipmass{int(warned)}", functions=["rhs", "mass_matrix"], progress=False,
                         parameters={"m2": m2}, cache_dir=str(tmp_path / "cache"))
        hits = [str(w.message) for w in record if issubclass(w.category, EomcWarning)
                and "at the default start" in str(w.message)]
        assert bool(hits) == warned, hits
        if warned:
            assert "nothing resists motion along u2 (1)" in hits[0] and "very stiff" in hits[0]


def test_a_constrained_system_builds_without_the_singular_start_warning(tmp_path):
    """The four-bar's mass_matrix (a constrained system) is not a plain symmetric positive M
    (smallest eigenvalue -1.36): no guess about missing inertia from it."""
    import warnings
    from pathlib import Path
    from eomc.errors import EomcWarning
    example = Path(__file__).resolve().parents[2] / "examples" / "four_bar_system.py"
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        model = eomc.compile(str(example), progress=False, cache_dir=str(tmp_path / "cache"))
    assert "mass_matrix" in model.functions
    assert not [w for w in record if issubclass(w.category, EomcWarning) and "at the default start" in str(w.message)]


NECK = """<?xml version="1.0"?>
<robot name="neck">
  <link name="chest">
    <inertial><mass value="5"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial>
  </link>
  <joint name="neck_roll" type="revolute">
    <origin xyz="0 0 0.2"/><axis xyz="1 0 0"/><parent link="chest"/><child link="neck_2"/>
    <dynamics damping="1" friction="0"/><limit effort="20" velocity="100" lower="-1.2" upper="1.0"/>
  </joint>
  <link name="neck_2">
    <inertial><mass value="0.1"/><inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial>
  </link>
  <joint name="neck_yaw" type="revolute">
    <origin xyz="0 0 0"/><axis xyz="0 0 1"/><parent link="neck_2"/><child link="head"/>
    <dynamics damping="1" friction="0"/><limit effort="20" velocity="100" lower="-0.96" upper="0.96"/>
  </joint>
  <link name="head">
    <inertial><origin xyz="0.0185 0 0.1108"/><mass value="1.33687"/>
      <inertia ixx="0" ixy="0" ixz="2.40741e-35" iyy="0" iyz="0" izz="0"/></inertial>
  </link>
</robot>
"""


def test_a_point_mass_head_is_named_with_the_inertia_that_lets_the_run_finish(tmp_path):
    """icub.urdf's head (1.34 kg, inertia 1e-35, on neck joints whose axes meet): turning about
    the line through the joint and the head's centre moves nothing.  The build warning and the
    stopped run name the body and the --param inertia that resists it; with it the run finishes."""
    import re
    import warnings
    from eomc.errors import EomcWarning
    path = tmp_path / "neck.urdf"
    path.write_text(NECK)
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        model = eomc.compile(path, "neck", progress=False, cache_dir=str(tmp_path / "cache"))
    start = [str(w.message) for w in record if issubclass(w.category, EomcWarning)
             and "at the default start" in str(w.message)]
    assert len(start) == 1 and "body 'head' (1.34 kg) has no rotational inertia" in start[0], start
    assert "give those bodies inertia" not in start[0]         # the concrete remedy replaces it
    suggested = dict(re.findall(r"(I\w+_head)=([-\d.e]+)", start[0].split("--param", 1)[1]))
    assert set(suggested) == {"Ixx_head", "Iyy_head", "Izz_head", "Ixz_head"}
    assert float(suggested["Ixx_head"]) == pytest.approx(0.4 * 1.33687 * (0.0185 ** 2 + 0.1108 ** 2), rel=1e-2)
    with pytest.raises(SimulationError, match="body 'head'.*--param Ixx_head="):
        model.simulate({}, (0.0, 1.0))
    p = dict(zip(model.param_names, model.param_defaults))
    p.update({k: float(v) for k, v in suggested.items()})
    result = model.simulate({}, (0.0, 1.0), p=p)
    assert result.t[-1] == pytest.approx(1.0)


def test_the_command_line_given_the_advised_inertia_does_not_warn_of_the_singular_start_again(tmp_path, monkeypatch):
    """`eomc simulate neck.urdf --param Ixx_head=...` with the build warning's own values: the start
    is judged again with them and the warning, true of the file's parameters only, is not given --
    on the build and on the reused build; values that do not mend it keep it."""
    import re
    import warnings
    from eomc.cli import main
    from eomc.errors import SingularStartWarning
    path = tmp_path / "neck.urdf"
    path.write_text(NECK)
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    out = str(tmp_path / "t.csv")

    def said(*args):
        with warnings.catch_warnings(record=True) as record:
            warnings.simplefilter("always")
            status = main(["simulate", str(path), "-o", out, "-q", *args])
        return status, [str(w.message) for w in record if issubclass(w.category, SingularStartWarning)]

    _, start = said("--t-final", "0.01")
    assert len(start) == 1 and "at the default start nothing resists" in start[0], start
    advice = re.search(r"--param ((?:I\w+_head=[-\d.e]+ ?)+)", start[0]).group(1).split()
    for _ in range(2):          # built (its own build: --param is no build option), then reused
        status, start = said("--t-final", "0.2", "--param", *advice)
        assert status in (0, None) and start == [], start
    _, start = said("--t-final", "0.01", "--param", "Ixx_head=1e-9")
    assert len(start) == 1, start
