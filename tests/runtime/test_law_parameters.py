"""Run-time parameters meet the build's refusals (runtime/law_parameters.py; issue 29 R2, R4):
simulate(p=...), simulate_many and sweep rows refuse what the builder refuses, naming the
parameter, instead of running with status 0 (mu = -1 gained 1440 J) or ending in an
unnamed non-finite value (limit_e = 0)."""
import re
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import eomc

sys.path.insert(0, str(Path(__file__).parents[1] / "compiler" / "contact"))
sys.path.insert(0, str(Path(__file__).parent))
import bounce_grid as bg  # noqa: E402
from test_switching import LIMITED  # noqa: E402


@pytest.fixture(scope="module")
def ball(tmp_path_factory):
    return bg.build(tmp_path_factory.mktemp("cache"))


@pytest.fixture(scope="module")
def stop(tmp_path_factory):
    d = tmp_path_factory.mktemp("stop")
    (d / "stop.urdf").write_text(LIMITED)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return eomc.compile(d / "stop.urdf", "stop", cache_dir=d / "cache", progress=False)


X0 = np.r_[0, 0, 0.5, np.zeros(9)]


@pytest.mark.parametrize("name, value, says", [
    ("mu_ball", -1.0, r"mu_ball = -1 must be >= 0 \(friction coefficient of contact ball\)"),
    ("k_ball", -1e6, r"k_ball = -1e\+06 must be >= 0 \(contact stiffness"),
    ("c_ball", -5.0, r"c_ball = -5 must be >= 0 \(contact damping"),
    ("r_ball", -0.1, r"r_ball = -0.1 must be >= 0 \(contact radius"),
    ("vs_ball", 0.0, r"vs_ball = 0 must be > 0 \(friction regularisation speed of contact ball\): the law divides"),
])
def test_contact_parameters_are_checked_at_run_time(ball, name, value, says):
    with pytest.raises(ValueError, match=says):
        ball.simulate(X0, (0, 1), p={name: value})


@pytest.mark.parametrize("values, says", [
    ({"limit_k_elbow": -100.0}, r"limit_k_elbow = -100 must be >= 0 \(limit stiffness of joint elbow\)"),
    ({"limit_c_elbow": -1.0}, r"limit_c_elbow = -1 must be >= 0"),
    ({"limit_e_elbow": 0.0}, r"limit_e_elbow = 0 must be > 0 \(limit width of joint elbow\): the law divides"),
    ({"friction_v_elbow": 0.0}, r"friction_v_elbow = 0 must be > 0 \(friction speed of joint elbow\)"),
    ({"damping_elbow": -5.0}, r"damping_elbow = -5 must be >= 0 \(damping of joint elbow\)"),
    ({"friction_elbow": -1.0}, r"friction_elbow = -1 must be >= 0 \(friction of joint elbow\)"),
    ({"limit_lo_elbow": 1.0, "limit_hi_elbow": -1.0}, r"limit_lo_elbow = 1 > limit_hi_elbow = -1"),
])
def test_joint_law_parameters_are_checked_at_run_time(stop, values, says):
    with pytest.raises(ValueError, match=says):
        stop.simulate({"q_elbow": 0.0}, (0, 1), p=values)


def test_sweep_rows_name_the_case_and_the_parameter(stop):
    from eomc.runtime.batch import simulate_many
    with pytest.raises(ValueError, match=r"case 1\b.*limit_k_elbow = -1 must be >= 0"):
        simulate_many(stop, {"q_elbow": 0.0}, (0, 0.1), p=[{"limit_k_elbow": 1.0}, {"limit_k_elbow": -1.0}],
                      progress=False)


def test_good_values_still_run(stop, ball):
    assert stop.simulate({"q_elbow": 0.0}, (0, 0.2), p={"limit_k_elbow": 0.0, "damping_elbow": 0.0}).status == 0
    assert ball.simulate(X0, (0, 0.2), p={"mu_ball": 0.0, "c_ball": 0.0, "r_ball": 0.0}).status == 0


DAMPED = """<mujoco model="damped"><worldbody>
  <body name="arm" pos="0 0 1"><joint name="hinge" type="hinge" axis="0 1 0" damping="0.5"/>
    <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="1"/>
    <body name="tip" pos="0.3 0 0"><joint name="wrist" type="ball" damping="0.2"/>
      <geom type="sphere" size="0.05" mass="0.5"/></body></body>
</worldbody></mujoco>"""


@pytest.fixture(scope="module")
def damped(tmp_path_factory):
    from eomc.compiler.mjcf.model import MjcfModel
    d = tmp_path_factory.mktemp("damped")
    (d / "damped.xml").write_text(DAMPED)
    return eomc.compile(MjcfModel(d / "damped.xml"), name="damped", cache_dir=d / "cache", progress=False)


@pytest.mark.parametrize("name, joint", [("d_hinge", "hinge"), ("d_wrist_1", "wrist")])
def test_mjcf_damping_is_checked_at_run_time(damped, name, joint):
    """MJCF's joint damping is the parameter d_<joint> (d_<joint>_<axis> on a ball joint): a negative
    one pushes energy in, so it is refused by name like the URDF laws' damping_<joint>."""
    assert name in damped.param_names
    with pytest.raises(ValueError, match=rf"{name} = -1 must be >= 0 \(damping of joint {joint}\)"):
        damped.simulate(None, (0, 0.1), p={name: -1.0})
    assert damped.simulate(None, (0, 0.1), p={name: 0.0}).status == 0


@pytest.mark.parametrize("name, what", [("limit_kd_elbow", "limit entry stiffness"),
                                        ("limit_cd_elbow", "limit entry damping"),
                                        ("limit_d_elbow", "limit entry depth")])
def test_the_entry_spring_s_parameters_are_checked(stop, name, what):
    """The entry spring-damper's (compiler/tree/joint_laws.entry_gains) are refused below 0 by name:
    a negative stiffness or damping would feed energy in, a negative depth would put the entry
    spring inside the range."""
    assert name in stop.param_names
    with pytest.raises(ValueError, match=rf"{name} = -1 must be >= 0 \({what} of joint elbow\)"):
        stop.simulate({"q_elbow": 0.3}, (0, 0.05), p={name: -1.0})


def test_a_changed_parameter_after_cached_runs_is_still_checked(stop):
    """simulate keeps what depends only on the model and the last parameters seen (law index
    arrays, limit bounds keyed on p's bytes): after runs with the defaults,
    a changed parameter is still refused naming it, a moved limit still judges the start, and a
    changed stiffness is still named as the user's."""
    from eomc.runtime.switching import PhysicsWarning
    with warnings.catch_warnings():
        warnings.simplefilter("error", PhysicsWarning)
        for _ in range(2):
            assert stop.simulate({"q_elbow": 0.3}, (0, 0.05)).status == 0
    with pytest.raises(ValueError, match=r"limit_k_elbow = -1 must be >= 0 \(limit stiffness of joint elbow\)"):
        stop.simulate({"q_elbow": 0.3}, (0, 0.05), p={"limit_k_elbow": -1.0})
    with pytest.raises(ValueError, match=r"limit_lo_elbow = 0\.4 > limit_hi_elbow = 0\.2"):
        stop.simulate({"q_elbow": 0.3}, (0, 0.05), p={"limit_lo_elbow": 0.4, "limit_hi_elbow": 0.2})
    with pytest.warns(PhysicsWarning, match=r"outside the range of joint elbow \(q_elbow = 0\.3, 0\.1 above "
                                            r"its upper limit 0\.2\)"):
        stop.simulate({"q_elbow": 0.3}, (0, 0.01), p={"limit_hi_elbow": 0.2})
    # the limit's own spring and its entry spring (joint_laws.entry_gains) both a thousandth
    soft = {n: stop.param_defaults[stop.param_names.index(n)] * 1e-3 for n in ("limit_k_elbow", "limit_kd_elbow")}
    with pytest.warns(PhysicsWarning, match=r"joint elbow went .* past its upper limit 0\.5.*your limit "
                                            r"stiffness limit_k_elbow = [0-9.e+]+ \(the default is"):
        stop.simulate({"q_elbow": 0.0}, (0, 1.0), p=soft, method="dop853")


EXAMPLES = Path(__file__).parents[2] / "examples"


@pytest.fixture(scope="module")
def pendulum(tmp_path_factory):
    return eomc.compile(EXAMPLES / "double_pendulum.py", cache_dir=tmp_path_factory.mktemp("pend"), progress=False)


@pytest.fixture(scope="module")
def top(tmp_path_factory):
    return eomc.compile(EXAMPLES / "heavy_top.py", cache_dir=tmp_path_factory.mktemp("top"), progress=False)


def test_a_sympy_bodys_mass_parameter_is_refused_naming_it_and_the_body(pendulum, tmp_path, capsys):
    """first hour s21 L3: --param m1=-1 on the double pendulum ended at t = 0 in "the mass matrix is
    singular ... a body with no mass", naming no parameter.  The build records which parameter is
    whose mass (NAME.json body_parameters); simulate, rollout rows and sweep rows refuse it by name."""
    assert {"body": "Bob1", "mass": [1.0, [["m1", 1.0]]]} in pendulum.metadata["body_parameters"]
    says = r"parameter m1 = -1 gives body Bob1 the mass -1: a body's mass must be > 0"
    with pytest.raises(ValueError, match=says):
        pendulum.simulate(None, (0, 1), p={"m1": -1.0})
    with pytest.raises(ValueError, match=r"parameter m2 = 0 \(p row 2\) gives body Bob2 the mass 0"):
        P = np.tile(pendulum.param_defaults, (3, 1))
        P[2, 1] = 0.0
        eomc.rollout(pendulum, np.tile(pendulum.initial_state, (3, 1)), dt=0.01, steps=2, p=P)
    from eomc.runtime.batch import simulate_many
    with pytest.raises(ValueError, match=r"case 1\b.*" + says):
        simulate_many(pendulum, None, (0, 0.1), p=[{"m1": 1.0}, {"m1": -1.0}], progress=False)
    from eomc.cli import main
    cases = tmp_path / "cases.csv"
    cases.write_text("m1,m2\n1,1\n-1,1\n")
    assert main(["sweep", str(EXAMPLES / "double_pendulum.py"), "--cases", str(cases), "--t-final", "0.1",
                 "-o", str(tmp_path / "out.csv"), "-q"]) != 0
    assert re.search(r"cases\.csv:3: double_pendulum: " + says, capsys.readouterr().err)
    assert pendulum.simulate(None, (0, 0.1), p={"m1": 0.5}).status == 0


def test_a_sympy_bodys_inertia_parameters_are_refused_as_the_build_refuses_a_links(top):
    """The heavy top's central inertia diag(I1, I1, I3): a negative moment, or I3 > 2 I1 (no mass
    distribution has it), is refused naming the parameters and the body."""
    with pytest.raises(ValueError, match=r"parameters I1 = 0\.01, I3 = 5 give body Top a central inertia with "
                                         r"principal moments 0\.01, 0\.01, 5, which miss the triangle inequality"):
        top.simulate(None, (0, 0.1), p={"I3": 5.0})
    with pytest.raises(ValueError, match=r"I1 = -1, I3 = .* give body Top a central inertia .* a negative moment"):
        top.simulate(None, (0, 0.1), p={"I1": -1.0})
    with pytest.raises(ValueError, match=r"parameter m = -2 gives body Top the mass -2"):
        top.simulate(None, (0, 0.1), p={"m": -2.0})
    assert top.simulate(None, (0, 0.1), p={"I3": 0.015}).status == 0


def test_a_urdf_links_mass_and_inertia_parameters_are_refused_naming_them(tmp_path):
    """A URDF link's m_<link> and I.._<link> are run-time parameters, but the robot's tree IR had
    no SymPy bodies for NAME.json body_parameters to read, so p={"m_upper": -1} ran unchecked.
    Now the tree's bodies are read: a mass <= 0 and an impossible central inertia are refused,
    naming the parameters and the link, as the URDF reader refuses them in the file.  The upper
    link turns about one axis, so the tree keeps only its moment about it (not its tensor): only
    its mass is judged.  A build with all_inertial_parameters (identification's: its fits pass
    unphysical vectors through simulate on purpose) is not checked."""
    from helpers.urdf_arm import ARM
    from eomc.compiler.urdf.model import UrdfModel
    path = tmp_path / "arm.urdf"
    elbow = ARM.index('<joint name="elbow"')
    path.write_text(ARM[:elbow] + ARM[elbow:].replace('<axis xyz="0 1 0"/>', '<axis xyz="1 0 0"/>', 1))
    arm = eomc.compile(path, cache_dir=tmp_path / "cache", progress=False)
    rows = {row["body"]: row for row in arm.metadata["body_parameters"]}
    assert rows["upper"]["mass"] == [1.0, [["m_upper", 1.0]]] and rows["lower"]["mass"] == [1.0, [["m_lower", 1.0]]]
    assert "inertia" not in rows["upper"] and rows["lower"]["inertia"][2][2] == [1.0, [["Izz_lower", 1.0]]]
    with pytest.raises(ValueError, match=r"arm: parameter m_upper = -1 gives body upper the mass -1: a body's "
                                         r"mass must be > 0"):
        arm.simulate(np.zeros(4), (0, 0.1), p={"m_upper": -1.0})
    with pytest.raises(ValueError, match=r"Izz_lower = 0\.5 give body lower a central inertia with principal "
                                         r"moments 0\.01, 0\.01, 0\.5, which miss the triangle inequality"):
        arm.simulate(np.zeros(4), (0, 0.1), p={"Izz_lower": 0.5})
    assert arm.simulate(np.zeros(4), (0, 0.1), p={"m_upper": 2.0, "Izz_lower": 0.015}).status == 0
    fit = eomc.compile(UrdfModel(path, all_inertial_parameters=True), cache_dir=tmp_path / "cache",
                       progress=False)
    assert "body_parameters" not in fit.metadata
    fit.simulate(np.zeros(4), (0, 0.1), p={"m_upper": -1.0}, raise_on_failure=False)     # not refused
