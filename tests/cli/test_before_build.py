"""Run options checked before a robot is built; what a build chose and why, in one line."""

import pytest

from eomc.cli import main
from helpers.robots import robot_path

GO2 = "go2_description/urdf/go2.urdf"


@pytest.fixture
def no_compiling(monkeypatch):
    """Reading the robot is allowed (the names come from the build's own reading), deriving
    it or compiling C is a failure here: the typo must be caught between."""
    import eomc.compiler.driver as driver

    def refuse(*args, **kwargs):
        raise AssertionError("a model was derived or compiled")
    monkeypatch.setattr(driver, "spec_of", refuse)
    monkeypatch.setattr(driver, "build_and_load", refuse)


@pytest.mark.parametrize("argv, words", [
    (["--x0", "q_floating_base_joint_z=0.4"], ["unknown state q_floating_base_joint_z in --x0",
                                                "did you mean q_base_floating_z"]),
    (["--input", "tau_FL_knee=1"], ["unknown input tau_FL_knee in --input", "tau_FL_"]),
    (["--frame", "FL_fot"], ["unknown frame FL_fot in --frame", "did you mean FL_foot"]),
    (["--contact", "FL_fot:0,0,0:0.02"], ["contact on link 'FL_fot'", "no such link", "did you mean FL_foot"]),
])
def test_a_typo_is_reported_before_anything_is_built(argv, words, no_compiling, tmp_path, capsys):
    code = main(["simulate", str(robot_path(GO2)), "--floating-base", "--t-final", "1", "-q", *argv])
    err = capsys.readouterr().err
    # the --contact link is refused by the robot reader itself (a ModelError, status 1)
    assert code == (1 if argv[0] == "--contact" else 2) and err.count("\n") == 1, err
    for w in words:
        assert w in err, err


def test_the_floating_coordinates_hint_without_floating_base(no_compiling, capsys):
    assert main(["animate", str(robot_path(GO2)), "-o", "x.html", "-q", "--x0", "q_base_floating_z=0.4"]) == 2
    assert "exist with --floating-base" in capsys.readouterr().err


def test_build_says_fixed_base_and_the_formulation(tmp_path, capsys):
    path = robot_path("ur5")
    assert main(["build", str(path), "--outputs", "rhs", "-o", str(tmp_path / "ur5")]) == 0
    captured = capsys.readouterr()
    notes = [line for line in captured.err.splitlines() if "fixed base" in line]
    assert len(notes) == 1 and "--floating-base" in notes[0]
    lines = [line for line in captured.out.splitlines() if line.startswith("formulation: ")]
    assert len(lines) == 1 and ("auto" in lines[0] or "fallback" in lines[0]), captured.out


def test_animate_from_a_csv_builds_the_poses_only(tmp_path, monkeypatch, capsys):
    """Drawing a saved run of a robot needs its poses: rhs and poses are built (seconds), not
    the Jacobians, outputs and events of a full build; the CSV's frame positions are still
    plotted (its rotation entries are not)."""
    import numpy as np

    import eomc.compiler.driver as driver
    from eomc.compiler.urdf.names import urdf_names
    names = urdf_names(str(robot_path(GO2)), floating_base=True)
    t = np.linspace(0, 0.5, 6)
    columns = {"t": t, **{n: 0 * t for n in names.states}, "FL_foot.p.x": t, "FL_foot.R[0][0]": 1 + 0 * t}
    columns["q_base_floating_z"] = 0.4 + 0 * t
    csv = tmp_path / "traj.csv"
    np.savetxt(csv, np.column_stack(list(columns.values())), delimiter=",", header=",".join(columns),
               comments="")
    seen = []
    real = driver.compile

    def spy(*args, **kwargs):
        seen.append(kwargs)
        return real(*args, **kwargs)
    monkeypatch.setattr(driver, "compile", spy)
    page = tmp_path / "go2.html"
    assert main(["animate", str(robot_path(GO2)), "--floating-base", "--from", str(csv),
                 "-o", str(page), "-q"]) == 0
    assert len(seen) == 1 and seen[0]["functions"] == ["rhs", "poses"]
    text = page.read_text()
    assert '"name":"FL_foot.p.x"' in text and "FL_foot.R[0][0]" not in text.split('"outputs"')[1][:2000]


def test_plot_states_are_checked_before_the_run(tmp_path, monkeypatch, capsys):
    from pathlib import Path

    import eomc.runtime.simulate as simulate_module
    examples = Path(__file__).resolve().parents[2] / "examples"

    def refuse(*args, **kwargs):
        raise AssertionError("the run started")
    monkeypatch.setattr(simulate_module, "simulate", refuse)
    code = main(["simulate", str(examples / "double_pendulum.py"), "--t-final", "1", "-q",
                 "--plot", str(tmp_path / "p.png"), "--plot-states", "q1,q9"])
    assert code == 2 and "--plot-states names q9" in capsys.readouterr().err


@pytest.fixture
def nothing_derived(monkeypatch):
    """The file may be read (once: the parameters are the reader's), but deriving the
    equations or compiling C fails the test: a --param mistake must be caught between."""
    import eomc.compiler.driver as driver

    def refuse(*args, **kwargs):
        raise AssertionError("the model was derived or compiled")
    monkeypatch.setattr(driver, "spec_of", refuse)
    monkeypatch.setattr(driver, "build_and_load", refuse)


MJCF_PENDULUM = """<mujoco><worldbody><body name="arm" pos="0 0 1">
  <joint name="hinge" type="hinge" axis="0 1 0" damping="0.1"/>
  <geom type="capsule" fromto="0 0 0 0 0 -0.5" size="0.05" mass="1"/></body></worldbody>
  <actuator><motor joint="hinge"/></actuator></mujoco>"""


@pytest.fixture
def arm_urdf(tmp_path):
    from helpers.urdf_arm import ARM
    path = tmp_path / "arm.urdf"
    path.write_text(ARM)
    return path


@pytest.mark.parametrize("command", ["simulate", "animate", "check", "report", "linearize"])
def test_a_misspelt_param_on_a_urdf_robot_is_reported_before_deriving(command, nothing_derived, tmp_path,
                                                                        capsys):
    options = {"simulate": ["--t-final", "1"], "animate": ["-o", str(tmp_path / "go2.html")],
               "report": ["-o", str(tmp_path / "report")]}.get(command, [])
    code = main([command, str(robot_path(GO2)), "--floating-base", "-q", *options, "--param", "m_FL_thgh=2"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1, err
    assert "go2: unknown parameter m_FL_thgh in --param (did you mean m_FL_thigh" in err, err


def test_a_misspelt_param_on_an_mjcf_model_is_reported_before_deriving(nothing_derived, tmp_path, capsys):
    pytest.importorskip("mujoco")
    path = tmp_path / "pendulum.xml"
    path.write_text(MJCF_PENDULUM)
    assert main(["simulate", str(path), "--t-final", "1", "-q", "--param", "d_hinje=0.2"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "unknown parameter d_hinje in --param (did you mean d_hinge?)" in err, err


def test_a_refused_param_value_is_reported_before_deriving(arm_urdf, nothing_derived, capsys):
    """The run-time law check (eomc.runtime.law_parameters) on the reader's names: a negative
    contact stiffness is refused before the build, naming the parameter and the contact."""
    code = main(["simulate", str(arm_urdf), "--t-final", "1", "-q", "--contact", "lower:0,0,0.3:0.05",
                 "--param", "k_lower=-5"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1, err
    assert "parameter k_lower = -5 must be >= 0 (contact stiffness of contact lower)" in err, err


@pytest.mark.parametrize("command, options", [
    ("simulate", ["--method", "dopri8"]),
    ("animate", ["-o", "a.html", "--method", "dopri8"]),
    ("check", ["--methods", "radau,dopri8"]),
    ("report", ["-o", "report", "--methods", "radau", "dopri8"]),
    ("sweep", ["--cases", "cases.csv", "-o", "s.csv", "--t-final", "1", "--method", "dopri8"]),
])
def test_a_misspelt_method_is_refused_before_the_model_is_read(command, options, arm_urdf, monkeypatch,
                                                                 tmp_path, capsys):
    """An unknown --method (--methods) cost a full build before the run refused it (s26's
    noticed list): now it is refused first, with the nearest names, and nothing is read."""
    import eomc.cli.common as cli_common

    def refuse(*args, **kwargs):
        raise AssertionError("the model was read")
    monkeypatch.setattr(cli_common, "with_options", refuse)
    monkeypatch.setattr(cli_common, "_reused", refuse)
    monkeypatch.chdir(tmp_path)
    (tmp_path / "cases.csv").write_text("q_shoulder\n0.1\n")
    assert main([command, str(arm_urdf), "-q", *options]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert "unknown integration method 'dopri8' (did you mean dopri5 or dop853?); valid methods: auto" in err, err


def test_correct_params_still_run(arm_urdf, tmp_path, capsys):
    """The early check passes what the build has: the run takes the values (a heavier lower
    link and a softer contact change the trajectory)."""
    import numpy as np
    runs = {}
    for label, params in (("default", []), ("changed", ["--param", "m_lower=3", "k_lower=2e5"])):
        out = tmp_path / f"{label}.csv"
        assert main(["simulate", str(arm_urdf), "--t-final", "0.3", "-q", "--x0", "q_shoulder=0.5",
                     "--contact", "lower:0,0,0.3:0.05", "-o", str(out), *params]) == 0, capsys.readouterr().err
        runs[label] = np.genfromtxt(out, delimiter=",", names=True)
    assert not np.allclose(runs["default"]["q_shoulder"], runs["changed"]["q_shoulder"])


@pytest.mark.parametrize("argv, words", [
    (["--x0", "q_hinje=0.3"], "unknown state q_hinje in --x0 (did you mean q_hinge"),
    (["--input", "ctrl_actuator=1"], "unknown input ctrl_actuator in --input (did you mean ctrl_actuator0?)"),
    (["--frame", "ram"], "unknown frame ram in --frame (did you mean arm?)"),
])
def test_mjcf_run_option_typos_are_reported_before_deriving(argv, words, nothing_derived, tmp_path, capsys):
    pytest.importorskip("mujoco")
    path = tmp_path / "pendulum.xml"
    path.write_text(MJCF_PENDULUM)
    assert main(["simulate", str(path), "--t-final", "1", "-q", *argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and words in err, err


def test_correct_mjcf_options_still_run(tmp_path, capsys):
    pytest.importorskip("mujoco")
    path = tmp_path / "pendulum.xml"
    path.write_text(MJCF_PENDULUM)
    out = tmp_path / "run.csv"
    assert main(["simulate", str(path), "--t-final", "0.2", "-q", "--x0", "q_hinge=0.3", "--input",
                 "ctrl_actuator0=0.5", "--frame", "arm", "--param", "d_hinge=0.2", "-o", str(out)]) == 0, \
        capsys.readouterr().err
    header = out.read_text().splitlines()[0]
    assert "q_hinge" in header and "arm.p.x" in header, header
