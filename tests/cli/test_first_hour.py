"""The first hour's traps (first-hour report, reliability report F8's CLI cases).

- ``eomc simulate -o`` onto a missing folder or a folder fails before simulating
- ``eomc show`` lists parameters in p[] order with defaults, and says "lambda" only with multipliers
"""
import re
import warnings

import numpy as np
import pytest

from helpers import model_files
from helpers.stand_in import get_model

import eomc.cli.common as cli_common
import eomc.runtime.simulate as simulate_module
from eomc.cli import main


@pytest.fixture
def pendulum(monkeypatch):
    model = get_model("pendulum")
    model.initial_state = np.array([0.5, 0.0])
    monkeypatch.setattr(cli_common, "load_model", lambda spec, quiet=True, **_: model)
    return model


@pytest.fixture
def no_simulation(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("simulated before checking the output path")
    monkeypatch.setattr(simulate_module, "simulate", refuse)


@pytest.mark.parametrize("target, message", [
    ("missing/dir/t.csv", "the directory {tmp}/missing/dir does not exist"),
    (".", "is a directory; give a file name"),
])
def test_bad_output_path_fails_before_simulating(pendulum, no_simulation, tmp_path, capsys, target, message):
    path = tmp_path / target
    assert main(["simulate", "pend", "--t-final", "1", "-o", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("eomc simulate: error: -o ")
    assert message.format(tmp=tmp_path) in err
    assert "Traceback" not in err


def test_bad_plot_path_fails_before_simulating(pendulum, no_simulation, tmp_path, capsys):
    assert main(["simulate", "pend", "--t-final", "1", "--plot", str(tmp_path / "no" / "p.png")]) == 2
    assert "eomc simulate: error: --plot " in capsys.readouterr().err


def test_good_output_path_still_writes(pendulum, tmp_path):
    out = tmp_path / "t.csv"
    assert main(["simulate", "pend", "--t-final", "1", "-o", str(out), "-q"]) == 0
    assert out.read_text().startswith("t,q1,u1")


def test_rk4_without_dt_names_the_cli_flag(pendulum, capsys):
    assert main(["simulate", "pend", "--t-final", "1", "--method", "rk4"]) == 2
    assert "--dt on the command line" in capsys.readouterr().err


def test_dt_without_a_fixed_step_method_names_the_cli_flag(pendulum, capsys):
    # first hour s21: `eomc simulate model --dt 0.1` answered "(pass method= one of them with dt)"
    assert main(["simulate", "pend", "--t-final", "1", "--dt", "0.1"]) == 2
    assert "pass one of them with it (method= in Python, --method on the command line)" in capsys.readouterr().err


def test_show_lists_parameters_in_p_order_and_no_lambda_without_multipliers(tmp_path, capsys):
    text = model_files.PENDULUM.replace("parameters = {m: 2.0, l: 0.5, g: 9.81}",
                                        "parameters = {m: 2.0, l: 0.5, g: 9.81}  # not alphabetical")
    path = model_files.write(tmp_path, text, "pend")
    assert main(["show", str(path), "-q"]) == 0
    out = capsys.readouterr().out
    assert "parameters:    m=2, l=0.5, g=9.81" in out
    assert "lambda" not in out and "mass matrix  (A in A u' = b)" in out


def test_show_says_lambda_with_multipliers(tmp_path, capsys):
    text = ("import sympy as sm\nfrom eomc.mechanics import *\n"
            "x, y = dynamicsymbols('x y')\nm, g, l = sm.symbols('m g l')\n"
            "L = m * (x.diff()**2 + y.diff()**2) / 2 - m * g * y\n"
            "lm = LagrangesMethod(L, [x, y], hol_coneqs=[x**2 + y**2 - l**2])\nlm.form_lagranges_equations()\n"
            "system = lm\nparameters = {m: 1.0, g: 9.81, l: 1.0}\n")
    path = model_files.write(tmp_path, text, "cartesian")
    assert main(["show", str(path), "-q"]) == 0
    assert "mass matrix  (A in A [u'; lambda] = b)" in capsys.readouterr().out


def test_report_output_onto_a_file_fails_before_running(pendulum, tmp_path, capsys):
    target = tmp_path / "taken"
    target.write_text("keep me")
    assert main(["report", "pend", "-o", str(target), "-q"]) == 2
    assert f"eomc report: error: -o {target} is a file" in capsys.readouterr().err
    assert target.read_text() == "keep me"


# ---- issue 24: the first hour of round 3 ---------------------------------------------------------
import os  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import textwrap  # noqa: E402
from pathlib import Path  # noqa: E402

import eomc  # noqa: E402

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"

BALL = textwrap.dedent('''\
    """A ball thrown with drag; its radius R is used only by the impact event and an output."""
    from sympy import symbols
    from eomc.mechanics import *

    x, y = dynamicsymbols('x y')
    vx, vy = dynamicsymbols('v_x v_y')
    m, c, g, R = symbols('m c g R', positive=True)
    N = ReferenceFrame('N')
    O = Point('O')
    O.set_vel(N, 0)
    P = O.locatenew('P', x * N.x + y * N.y)
    P.set_vel(N, vx * N.x + vy * N.y)
    kane = KanesMethod(N, q_ind=[x, y], u_ind=[vx, vy], kd_eqs=[x.diff() - vx, y.diff() - vy])
    kane.kanes_equations([Particle('ball', P, m)], [(P, -m * g * N.y - c * (vx * N.x + vy * N.y))])
    system = kane
    name = 'ball_r'
    parameters = {m: 0.2, c: 0.05, g: 9.81, R: 0.05}
    initial_state = {x: 0.0, y: 2.0, vx: 3.0, vy: 4.0}
    events = {'impact': {'expr': y - R, 'direction': -1, 'terminal': True}}
    outputs = {'radius': R}
    ''')


def test_a_parameter_used_only_in_an_event_or_output_is_accepted(tmp_path, capsys):
    """First hour #4: 'parameters not used by the system: R' (no file:line) before."""
    path = model_files.write(tmp_path, BALL, "ball")
    assert main(["simulate", str(path), "--t-final", "3", "--param", "R=0.25", "-q"]) == 0
    out = capsys.readouterr().out
    assert "radius: start 0.25, end 0.25" in out and "stopped by event impact" in out
    model = eomc.compile(str(path), progress=False)
    res = model.simulate(None, (0, 3), p={"R": 0.25}, rtol=1e-10, atol=1e-12)
    assert res.event_stop == "impact" and res.x_final[1] == pytest.approx(0.25, abs=1e-9)


@pytest.fixture(scope="module")
def fourbar(tmp_path_factory):
    directory = tmp_path_factory.mktemp("fourbar")
    eomc.compile(str(EXAMPLES / "four_bar_system.py"), output_dir=str(directory), progress=False)
    return directory, eomc.load(directory)


def test_an_inconsistent_start_is_completed_by_default_with_one_note(fourbar, tmp_path):
    """First hour #8, round 4: a start off the constraints was warned about and then run into a
    blow-up (the slider-crank reached u = 4e7); now it is completed on the constraints, holding
    the states given, with one note saying by how much it was off."""
    directory, model = fourbar
    out = tmp_path / "default.csv"
    run = subprocess.run([sys.executable, "-m", "eomc", "simulate", str(directory), "--t-final", "0.01",
                          "--x0", "q1=-0.9", "u1=1", "--points", "2", "-o", str(out)], capture_output=True,
                         text=True, timeout=300, env=os.environ)
    assert run.returncode == 0, run.stderr
    notes = [line for line in run.stderr.splitlines() if "note" in line or "warning" in line]
    assert len(notes) == 1 and notes[0].startswith("eomc simulate: note: the start was off the constraints "
                                                   "(position residual "), run.stderr
    assert "completed the start on the constraints" in notes[0]
    assert "warnings.warn" not in run.stderr and "simulate.py" not in run.stderr
    first = np.loadtxt(out, delimiter=",", skiprows=1)[0, 1:1 + model.nx]
    np.testing.assert_allclose(first, model.consistent_state({"q1": -0.9, "u1": 1.0}), rtol=0, atol=1e-10)


def test_cli_consistent_and_project_keep_the_coordinates_given(fourbar, tmp_path, capsys):
    """First hour #8: --consistent exists; --project no longer moves q1 = -0.9 (it moved 0.3 to 0.11)."""
    directory, model = fourbar
    want = model.consistent_state({"q1": -0.9, "u1": 1.0})
    for flag in ("--consistent", "--project"):
        out = tmp_path / f"{flag[2:]}.csv"
        assert main(["simulate", str(directory), "--t-final", "0.01", "--x0", "q1=-0.9", "u1=1", flag,
                     "--points", "2", "-o", str(out), "-q"]) == 0
        first = np.loadtxt(out, delimiter=",", skiprows=1)[0, 1:1 + model.nx]
        assert first[0] == -0.9 and first[3] == 1.0
        np.testing.assert_allclose(first, want, rtol=0, atol=1e-10)
        assert f"note: {flag}: completed the start on the constraints" in capsys.readouterr().err


def test_python_project_says_which_states_it_moved(fourbar):
    from eomc.runtime.consistent import ConstraintWarning
    _, model = fourbar
    with pytest.warns(ConstraintWarning, match=r"project=True moved the start onto them: q1 -0\.9 -> "):
        model.simulate({"q1": -0.9, "u1": 1.0}, (0, 0.01), project=True, n_points=2)


def test_the_suite_builds_into_its_own_cache(tmp_path_factory):
    """First hour #9: the suite left entries in the user's cache; tests/conftest.py points
    EOMC_CACHE_DIR into this session's temporary tree (a test may still set its own)."""
    cache = Path(os.environ["EOMC_CACHE_DIR"]).resolve()
    assert cache.is_relative_to(tmp_path_factory.getbasetemp().resolve())


# A block dropped on six ground contacts (one point each, as a URDF's --ground makes hundreds).
_SIX_FEET = '''\
import sympy as sm
import eomc.contact
from eomc.mechanics import KanesMethod, Particle, Point, ReferenceFrame, dynamicsymbols
x, z, vx, vz = dynamicsymbols("x z vx vz")
m, g = sm.symbols("m g")
N = ReferenceFrame("N")
O = Point("O"); O.set_vel(N, 0)
G = O.locatenew("G", x * N.x + z * N.z); G.set_vel(N, vx * N.x + vz * N.z)
feet = [eomc.contact.ground(G, None, world=(N, O), name=f"foot{i}") for i in range(6)]
system = KanesMethod(N, q_ind=[x, z], u_ind=[vx, vz], kd_eqs=[x.diff() - vx, z.diff() - vz])
system.kanes_equations([Particle("blk", G, m)], [(G, -m * g * N.z)] + [l for f in feet for l in f.loads])
parameters = {m: 1.0, g: 9.81, **{k: v for f in feet for k, v in f.parameters.items()}}
outputs = {k: v for f in feet for k, v in f.outputs.items()}
events = {k: v for f in feet for k, v in f.events.items()}
initial_state = {z: 0.05, vx: 0.5}
'''


def test_many_contacts_are_summarised_not_listed_five_lines_each(tmp_path, capsys):
    # first hour s20: go2.urdf --floating-base --ground printed 3,040 lines of Fn_/Ftx_/.../depth_
    model = model_files.write(tmp_path, _SIX_FEET, "six_feet")
    assert main(["simulate", str(model), "--t-final", "0.3", "-q", "-o", str(tmp_path / "t.csv")]) == 0
    out = capsys.readouterr().out
    assert "Fn_foot0: start" not in out and "depth_foot5: start" not in out
    assert "contacts: 6 points (Fn_, Ftx_, Fty_, Ftz_, depth_<point> in the CSV), 6 touched, " \
           "6 touching at the end" in out
    assert "contacts: largest normal force Fn_foot0 = " in out and "deepest depth_foot0 = " in out
    # s21: when (the gym humanoid's 35 kN row is its touch-down, docs/contact.md)
    assert re.search(r"largest normal force Fn_foot0 = [0-9.e+]+ at t = 0\.1[0-9]*, deepest depth_foot0 = "
                     r"[0-9.e+-]+ at t = 0\.[0-9]+ \(maxima over the run's rows", out), out
    assert "  event contact_foot0:" not in out
    assert re.search(r"contact events: \d+ at 6 points, the first contact_foot0 at t = 0\.1", out)
    assert "Fn_foot5" in (tmp_path / "t.csv").read_text().splitlines()[0]     # all still in the CSV
    # before the touch-down (0.1 s) nothing touched: no time for a force that stayed 0
    assert main(["simulate", str(model), "--t-final", "0.05", "-q"]) == 0
    out = capsys.readouterr().out
    assert "contacts: largest normal force Fn_foot0 = 0, deepest depth_foot0 = -0." in out, out
    assert " at t = " not in out


_BALLS = """<mujoco model="balls">
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="a" pos="0 0 0.3"><freejoint/><geom name="ga" type="sphere" size="0.1" mass="1"/></body>
    <body name="b" pos="0.15 0 0.55"><freejoint/><geom name="gb" type="sphere" size="0.1" mass="1"/></body>
    <body name="c" pos="0.6 0 0.3"><freejoint/><geom name="gc" type="sphere" size="0.1" mass="1"/></body>
  </worldbody>
</mujoco>
"""


def test_mjcf_pairs_points_are_summarised_with_the_contacts(tmp_path, capsys):
    # first hour s20: gymnasium's humanoid printed px_/py_/pz_ of its 109 self-pairs, 327 lines
    pytest.importorskip("mujoco")
    model = tmp_path / "balls.xml"
    model.write_text(_BALLS)
    assert main(["simulate", str(model), "--t-final", "1", "-q"]) == 0
    out = capsys.readouterr().out
    assert "px_ga__gb: start" not in out and "Fn_ga: start" not in out
    assert "contacts: 6 points (Fn_, Ftx_, Fty_, Ftz_, depth_<point>; px_, py_, pz_ of 3 pairs in the CSV)" in out


def test_simulate_and_build_run_with_no_flags(tmp_path, monkeypatch, capsys):
    # first hour s21: `eomc simulate model` stopped at "the following arguments are required:
    # --t-final" and `eomc build model` at "-o/--output"; check and animate already ran 10 s
    model = model_files.write(tmp_path, model_files.PENDULUM, "pend")
    monkeypatch.chdir(tmp_path)
    assert main(["simulate", str(model), "-q"]) == 0
    assert re.search(r"^pend: \S+ t=\[0, 10\]: ", capsys.readouterr().out, re.M)
    assert main(["build", str(model)]) == 0            # no -q: the summary is read
    assert f"in {tmp_path / 'pend'}:" in capsys.readouterr().out
    assert (tmp_path / "pend" / "pend.h").is_file() and (tmp_path / "pend" / "pend.json").is_file()


def test_a_missing_optional_package_names_the_extra_not_a_traceback(tmp_path, monkeypatch, capsys):
    # first hour s21: `eomc simulate cheetah.xml` after `pip install ".[plot]"` (README's quick
    # start) ended in a 20-line traceback "ModuleNotFoundError: No module named 'mujoco'"
    import sys
    model = tmp_path / "balls.xml"
    model.write_text(_BALLS)
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))     # not the build of the test above
    monkeypatch.setitem(sys.modules, "mujoco", None)     # import mujoco -> ModuleNotFoundError
    assert main(["simulate", str(model), "--t-final", "0.1"]) == 1
    err = capsys.readouterr().err
    assert err.strip().splitlines()[-1] == (
        f"eomc simulate: error: reading a MuJoCo model ({model}) needs mujoco, which is not "
        f"installed: pip install \"eomc[mujoco]\" (from a clone of eomc: pip install \".[mujoco]\")")
    assert "Traceback" not in err
    # and from Python (the same sentence, an ImportError)
    from eomc.errors import MissingExtraError
    with pytest.raises(MissingExtraError, match=r"reading a MuJoCo model \(.*balls\.xml\) needs mujoco"):
        eomc.compile(model, progress=False)
    # --plot without matplotlib: said before building and simulating, not after
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    monkeypatch.setattr(cli_common, "load_model", lambda *a, **k: pytest.fail("built before the check"))
    assert main(["simulate", "pend.py", "--t-final", "0.1", "-q", "--plot", str(tmp_path / "p.png")]) == 1
    assert capsys.readouterr().err.strip().splitlines()[-1] == (
        "eomc simulate: error: --plot needs matplotlib, which is not installed: pip install \"eomc[plot]\" "
        "(from a clone of eomc: pip install \".[plot]\")")


# A block on one low foot; two high points (a head, a hand) never touch the ground.
_HIGH_AND_LOW = _SIX_FEET.replace(
    'feet = [eomc.contact.ground(G, None, world=(N, O), name=f"foot{i}") for i in range(6)]',
    'feet = [eomc.contact.ground(G, None, world=(N, O), name="foot")] + [eomc.contact.ground('
    'G.locatenew(f"P{i}", (i + 1) * N.z), None, world=(N, O), name=f"head{i}") for i in range(2)]')


def test_plot_leaves_out_contacts_that_never_touched_and_says_so(tmp_path, capsys):
    # first hour s20 (L6): gymnasium's ant touched with 4 of its 25 contacts and --plot drew
    # 4 pages, most of them flat zeros of the other 21
    pytest.importorskip("matplotlib")
    from eomc.runtime.plotting import panels
    model = model_files.write(tmp_path, _HIGH_AND_LOW, "high_low")
    assert main(["simulate", str(model), "--t-final", "0.3", "-q", "--plot", str(tmp_path / "p.png"),
                 "-o", str(tmp_path / "t.csv")]) == 0
    out = capsys.readouterr().out
    assert ("  --plot: 2 contacts never touched (head0, head1): their outputs (all 0 but depth_) are not "
            "drawn; --plot-states names what to draw") in out
    assert "Fn_head1" in (tmp_path / "t.csv").read_text().splitlines()[0]     # still in the CSV
    built = eomc.compile(model, progress=False)
    res = built.simulate(built.initial_state, (0, 0.3))
    drawn = {n for _, group in panels(res) for n in group}
    assert {"Fn_foot", "depth_foot"} <= drawn
    assert not drawn & {f"{k}_head{i}" for k in ("Fn", "Ftx", "Fty", "Ftz", "depth") for i in range(2)}
    # named, they are drawn
    assert "Fn_head0" in {n for _, group in panels(res, ["Fn_head0", "z"]) for n in group}


def test_a_run_that_stays_at_an_equilibrium_says_so(tmp_path, capsys):
    # first hour s21: SymPy's rolling-disc example starts at rest upright and `eomc simulate`
    # printed "8 steps" and nothing else: was anything simulated?
    model = model_files.write(tmp_path, model_files.PENDULUM, "pend")
    assert main(["simulate", str(model), "--t-final", "1", "-q", "--param", "g=0"]) == 0     # at rest, no gravity
    # with g = 0 a turned pendulum stays put too: the hint names the speed (it named q, a loop; s24)
    assert ("  nothing moved: the start is an equilibrium (every state stayed at its start value); give --x0 to "
            "start elsewhere, e.g. --x0 u=0.1") in capsys.readouterr().out
    assert main(["simulate", str(model), "--t-final", "1", "-q", "--param", "g=0", "--x0", "u=0.1"]) == 0
    assert "nothing moved" not in capsys.readouterr().out
    assert main(["simulate", str(model), "--t-final", "1", "-q"]) == 0
    assert "nothing moved" not in capsys.readouterr().out


def test_check_says_its_runs_gave_physics_warnings(tmp_path, capsys):
    # first hour s21: `eomc check manipulator.xml` warned that two bodies passed into each other,
    # and romeo.urdf that wrists went past their limits, then printed "10 of 10 checks passed"
    model = model_files.write(tmp_path, _SIX_FEET, "six_feet")
    soft = [f"k_foot{i}=30" for i in range(6)]       # the block sinks through its soft contacts
    from eomc.runtime.switching import PhysicsWarning
    with pytest.warns(PhysicsWarning, match="contact foot0 penetrated"):     # still shown, as before
        assert main(["check", str(model), "--t-final", "0.3", "-q", "--methods", "radau", "--param", *soft]) == 0
    assert ("eomc check: the runs gave 1 physics warning (on stderr: limits, contacts, energy): the checks above "
            "judge the integration, not the model's laws") in capsys.readouterr().out
    assert main(["check", str(model), "--t-final", "0.3", "-q", "--methods", "radau"]) == 0
    assert "physics warning" not in capsys.readouterr().out


def test_welded_links_with_impossible_inertias_are_one_short_note(tmp_path):
    # first hour s21 (L5): ANYmal C's five cameras, welded to its fixed base with impossible
    # inertias, gave `eomc CMD: warning: ... (principal moments below) ...` -- 680 characters
    # on every command, about links that move nothing; now one `eomc: note:` naming them
    from helpers.urdf_arm import ARM
    cams = "".join(f'  <joint name="cam{k}_joint" type="fixed"><parent link="base"/><child link="cam{k}"/>'
                   f'</joint>\n  <link name="cam{k}"><inertial><mass value="0.1"/><inertia ixx="1e-6" ixy="0" '
                   f'ixz="0" iyy="1e-6" iyz="0" izz="1e-3"/></inertial></link>\n' for k in (1, 2))
    path = tmp_path / "arm.urdf"
    path.write_text(ARM.replace("</robot>", cams + "</robot>"))
    for _ in range(2):     # the build, then the reuse shortcut's replay
        run = subprocess.run([sys.executable, "-m", "eomc", "simulate", str(path), "--t-final", "0.1", "-q"],
                             capture_output=True, text=True, cwd=tmp_path)
        assert run.returncode == 0, run.stderr
        notes = [line for line in run.stderr.splitlines() if "welded to the ground" in line]
        assert len(notes) == 1 and notes[0].startswith(f"eomc: note: {path}:"), run.stderr
        assert "2 links welded to the ground" in notes[0] and "link 'cam1' (line" in notes[0] \
            and "link 'cam2' (line" in notes[0] and "warning" not in notes[0], notes
        assert len(notes[0]) - len(str(path)) < 200, notes[0]      # was 354 + the path


def test_build_says_the_moved_start_as_a_cli_note(tmp_path, capsys):
    # first hour s22: `eomc build hyq_no_sensors.urdf` gave the Python API's warning ("give x0 to
    # simulate from another start; the joints are in model.metadata['start_in_range']") where
    # simulate gives a note; build now gives the note, naming the joint and what to do
    import warnings
    from helpers.urdf_arm import ARM
    from eomc.errors import DefaultStartWarning
    path = tmp_path / "arm.urdf"
    path.write_text(ARM.replace('<axis xyz="0 1 0"/>\n  </joint>\n  <joint name="elbow"',
                                '<axis xyz="0 1 0"/>\n    <limit lower="0.2" upper="1" effort="1" velocity="1"/>\n'
                                '  </joint>\n  <joint name="elbow"', 1))
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        assert main(["build", str(path), "-o", str(tmp_path / "out"), "-q"]) == 0
    assert not [w for w in seen if issubclass(w.category, DefaultStartWarning)]
    err = capsys.readouterr().err
    assert "eomc: note: arm: the zero pose is outside the range of joint shoulder" in err, err
    assert "just inside the nearest limit (arm.json's initial_state; simulate --x0 chooses another)" in err
    assert "model.metadata" not in err


def test_a_run_without_outputs_says_what_moved(tmp_path, capsys):
    # first hour s22: bolt.urdf and borinot (no limits, no contacts: no energy output) printed
    # their step count only; now the coordinate that moved most, and where the states go
    from helpers.urdf_arm import ARM
    path = tmp_path / "arm.urdf"
    path.write_text(ARM)
    assert main(["simulate", str(path), "--t-final", "0.2", "-q", "--x0", "q_shoulder=0.5"]) == 0
    out = capsys.readouterr().out
    assert re.search(r"\n  no outputs \(the model defines none\); of its 2 coordinates q_elbow changed most: "
                     r"start 0, end -0\.57[0-9]+; -o FILE writes every state\n", out), out     # the elbow swings
    assert main(["simulate", str(path), "--t-final", "0.2", "-q", "--x0", "q_shoulder=0.5", "-o",
                 str(tmp_path / "t.csv")]) == 0
    out = capsys.readouterr().out
    assert "nothing moved" not in out and "no outputs" in out and "-o FILE" not in out


def _binary_stl(path, corners):
    """A binary STL of the tetrahedron on four ``corners`` (its 4 faces, as trimesh writes them)."""
    faces = [(0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)]
    rec = np.zeros(len(faces), dtype=np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")]))
    rec["v"] = np.asarray(corners, dtype=np.float32)[np.array(faces)]
    path.write_bytes(b"\0" * 80 + np.uint32(len(faces)).tobytes() + rec.tobytes())


_MESHED = """<robot name="meshed">
  <link name="base">
    <inertial><mass value="2"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><mesh filename="package://meshed_description/meshes/foot.stl"/></geometry></collision>
    <collision><origin xyz="0 0 0.3"/><geometry><mesh filename="package://meshed_description/meshes/head.dae"/></geometry></collision>
  </link>
</robot>
"""


def test_the_base_install_reads_stl_collision_meshes_and_names_the_extra_for_dae(tmp_path, monkeypatch, capsys):
    """The README's contact command on solo12 in a fresh `pip install .` (no trimesh, no
    yourdfpy): every collision mesh was 'package://... do not exist' (they do: the package://
    search was yourdfpy's) and could not be read without trimesh, so the robot fell 0.3 m through
    the floor with status 0.  Now package:// is found without yourdfpy and STL/OBJ are read
    without trimesh; a DAE, which needs them, is named with the extra that reads it."""
    import sys
    for name in ("trimesh", "yourdfpy", "collada"):
        monkeypatch.setitem(sys.modules, name, None)        # the base install
    package = tmp_path / "meshed_description"
    (package / "urdf").mkdir(parents=True)
    (package / "meshes").mkdir()
    _binary_stl(package / "meshes" / "foot.stl", [(-0.1, -0.1, -0.2), (0.1, -0.1, -0.2), (0, 0.1, -0.2), (0, 0, 0)])
    (package / "meshes" / "head.dae").write_text("<COLLADA/>")
    urdf = package / "urdf" / "meshed.urdf"
    urdf.write_text(_MESHED)
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    with warnings.catch_warnings(record=True) as caught:      # the CLI prints them (a subprocess shows)
        warnings.simplefilter("always")
        assert main(["simulate", str(urdf), "--floating-base", "--ground", "--t-final", "0.5",
                     "-o", str(tmp_path / "t.csv")]) == 0
    texts = [str(w.message) for w in caught]
    assert not any("not exist" in t for t in texts), texts
    assert [t for t in texts if "head.dae" in t] == [
        "1 collision mesh needs trimesh and pycollada to be read, which are not installed, so its link does not "
        "touch the ground: pip install \"eomc[mesh]\" (from a clone of eomc: pip install \".[mesh]\"): "
        f"package://meshed_description/meshes/head.dae ({urdf}:5: link 'base')"], texts
    header = (tmp_path / "t.csv").read_text().splitlines()[0].split(",")
    feet = [h for h in header if h.startswith("depth_base_col")]
    assert len(feet) == 4, header                        # the tetrahedron's 4 corners touch the ground
    rows = np.loadtxt(tmp_path / "t.csv", delimiter=",", skiprows=1)
    z = rows[:, header.index("q_base_floating_z")]
    assert z[-1] > 0.1, z[-1]                            # standing on its corners, not through the floor


def test_kept_impossible_inertias_are_said_in_one_short_line():
    """allegro_right_hand.urdf: its four fingertips' tensors miss the triangle inequality (kept as
    given, as Pinocchio does): the note gave each link's three principal moments and 'with the
    links welded to it', ~900 characters on every command (first hour s23), then each link's line
    and 'a + b < c' (595 characters, s26).  Now one line names the links, says there is nothing to
    do and where the numbers are: the note's details, which `eomc inspect` prints (s27)."""
    from helpers.robots import robot_path
    from eomc.compiler.urdf import from_urdf
    from eomc.runtime.errors import EomcWarning
    path = robot_path("allegro_hand_description/urdf/allegro_right_hand.urdf")
    with pytest.warns(EomcWarning) as caught:
        from_urdf(path)
    kept = [w.message for w in caught if "kept as given" in str(w.message)]
    assert len(kept) == 1, kept
    text = str(kept[0]).replace(str(path), "")
    assert text == (":6: 4 links' inertia tensors (link_3.0, link_7.0, link_11.0, link_15.0) miss the triangle "
                    "inequality; kept as given, as Pinocchio does (the dynamics need only each moving body's "
                    "moments to be non-negative, and they are): nothing to do; eomc inspect gives the moments"), text
    assert len(text) < 300, len(text)          # was 1,000, then 445
    assert kept[0].details[0] == ("link 'link_3.0' (line 127): principal moments 2.30064e-06, 3.48527e-06, "
                                  "7.2659e-06 (2.3e-06 + 3.49e-06 < 7.27e-06)"), kept[0].details
    assert len(kept[0].details) == 4 and kept[0].details[3].startswith("link 'link_15.0' (line 548): ")


def test_inspect_prints_the_kept_inertias_details(tmp_path, capsys):
    """The numbers the one-line note leaves out are in `eomc inspect FILE`, after its table."""
    from helpers.robots import robot_path
    path = robot_path("allegro_hand_description/urdf/allegro_right_hand.urdf")
    assert main(["inspect", str(path), "-q", "--outputs", "rhs"]) == 0
    captured = capsys.readouterr()
    out = captured.out.split("the build's notes in detail:\n", 1)[1].splitlines()
    assert out[:4] == [f"  link '{name}' (line {line}): principal moments " + moments for name, line, moments in (
        ("link_3.0", 127, "2.30064e-06, 3.48527e-06, 7.2659e-06 (2.3e-06 + 3.49e-06 < 7.27e-06)"),
        ("link_7.0", 265, "2.30064e-06, 3.48527e-06, 7.2659e-06 (2.3e-06 + 3.49e-06 < 7.27e-06)"),
        ("link_11.0", 403, "2.30064e-06, 3.48527e-06, 7.2659e-06 (2.3e-06 + 3.49e-06 < 7.27e-06)"),
        ("link_15.0", 548, "8.23673e-06, 2.78621e-05, 4.44951e-05 (8.24e-06 + 2.79e-05 < 4.45e-05)"))], out


def test_plot_and_summary_leave_out_contact_outputs_that_stay_zero(tmp_path, capsys):
    """Go2 on its four feet (--plot): a whole panel of Ftz_ lines at 0 (a flat ground's tangential
    force has no vertical part), and the summary printed 'Ftz_X: start 0, end 0, change 0' for
    each foot.  Now --plot leaves them out and says so, and the summary says them in one line;
    the CSV keeps them, and named they are drawn."""
    pytest.importorskip("matplotlib")
    from eomc.runtime.plotting import panels
    import eomc
    model = model_files.write(tmp_path, _HIGH_AND_LOW, "high_low")
    assert main(["simulate", str(model), "--t-final", "0.3", "-q", "--plot", str(tmp_path / "p.png"),
                 "-o", str(tmp_path / "t.csv")]) == 0
    out = capsys.readouterr().out
    assert "  --plot: 2 contact outputs 0 throughout (Fty_foot, Ftz_foot) not drawn" in out, out  # it slides in x
    assert "Ftz_foot: start" not in out and "Fn_head0: start" not in out, out
    zero = [line for line in out.splitlines() if line.startswith("  0 throughout: ")]
    assert len(zero) == 1 and "Ftz_foot" in zero[0] and "Fn_head0" in zero[0], out
    assert "Fn_foot: start" in out                                            # it moved: its own line
    assert "Ftz_foot" in (tmp_path / "t.csv").read_text().splitlines()[0]     # still in the CSV
    built = eomc.compile(model, progress=False)
    res = built.simulate(built.initial_state, (0, 0.3))
    drawn = {n for _, group in panels(res) for n in group}
    assert {"Fn_foot", "Ftx_foot", "depth_foot"} <= drawn and not {"Fty_foot", "Ftz_foot"} & drawn, drawn
    assert "Ftz_foot" in {n for _, group in panels(res, ["Ftz_foot"]) for n in group}


def test_report_on_a_contact_model_compares_the_implicit_methods(tmp_path, capsys):
    """`eomc report hopper.xml` (no flags) ran rk4, dopri5 and dop853 at every tolerance and 21 of
    its 40 runs stopped as stiff (or rk4, without DOPRI5's step count): on ground contacts the
    default is bdf and radau, said on stderr, as `eomc check` leaves the explicit ones out there;
    --methods still runs them."""
    pytest.importorskip("matplotlib")
    model = model_files.write(tmp_path, _HIGH_AND_LOW, "high_low")
    common = ["--t-final", "0.2", "--tolerances", "1e-3", "1e-4", "--repeats", "1", "--reference-tol", "1e-8"]
    assert main(["report", str(model), "-o", str(tmp_path / "r"), *common]) == 0
    captured = capsys.readouterr()
    assert ("eomc report: high_low has ground contacts: comparing bdf and radau (rk4, dopri5 and dop853 stop "
            "there as stiff; --methods runs them anyway)") in captured.err, captured.err
    methods = {line.split(",")[0] for line in (tmp_path / "r" / "report.csv").read_text().splitlines()[1:]}
    assert methods == {"bdf", "radau"}, methods
    assert "--methods bdf radau" in (tmp_path / "r" / "report.md").read_text()
    assert main(["report", str(model), "-o", str(tmp_path / "r2"), "--methods", "dopri5", "radau", "-q", *common]) == 0
    methods = {line.split(",")[0] for line in (tmp_path / "r2" / "report.csv").read_text().splitlines()[1:]}
    assert methods == {"dopri5", "radau"}, methods


_FOOT_BELOW = """<robot name="two">
  <link name="base">
    <inertial><mass value="2"/><inertia ixx="0.02" iyy="0.02" izz="0.02" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 -0.2"/><geometry><box size="0.1 0.1 0.1"/></geometry></collision>
  </link>
  <joint name="mast" type="revolute"><parent link="base"/><child link="top"/><origin xyz="0 0 0.2"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <link name="top">
    <inertial><mass value="0.5"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><sphere radius="0.05"/></geometry></collision>
  </link>
</robot>
"""


def test_a_contact_named_above_a_links_geometry_is_named_as_the_cause_of_sinking(tmp_path, monkeypatch):
    """G1 with `--contact left_ankle_roll_link` (a point at the ankle's origin, above the sole):
    the contact takes the place of the link's collision spheres, and the feet sank 0.088 m; the
    warning blamed --no-ground, a link without geometry or a soft contact.  Now it names the
    contact on that link and how to place it."""
    path = tmp_path / "two.urdf"
    path.write_text(_FOOT_BELOW)
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert main(["simulate", str(path), "--floating-base", "--contact", "base", "--t-final", "0.3", "-q"]) == 0
    sank = [str(w.message) for w in caught if "under the ground" in str(w.message)]
    assert len(sank) == 1 and sank[0].startswith("two: body base went 0.25"), sank
    assert sank[0].endswith("the robot passed through the floor there (the contact named on link base takes the "
                            "place of its <collision> geometry: put it where the link touches, --contact "
                            "base:x,y,z:radius, or --contact @collision for the file's collision spheres)"), sank


def test_a_failed_runs_diagnosis_comes_before_its_state(pendulum, tmp_path, monkeypatch, capsys):
    """human.urdf with no flags stops at its hip's gimbal lock: the error named the cause ('nothing
    resists motion along u_left_hip_Z ... gimbal lock') and the rows written after 88 state values
    (3.5 kB).  The command line now gives the diagnosis and the file first, the state last."""
    from eomc.cli.simulate import state_last
    message = ("human: radau stopped at t=0.45: the mass matrix is singular; state q_a=1, q_b=2, u_a=3; "
               "nothing resists motion along u_a (1): ... gimbal lock; wrote the 46 rows computed up to t=0.45 "
               "to t.csv (marked '# incomplete' on its last line)")
    assert state_last(message) == (
        "human: radau stopped at t=0.45: the mass matrix is singular; nothing resists motion along u_a (1): ... "
        "gimbal lock; wrote the 46 rows computed up to t=0.45 to t.csv (marked '# incomplete' on its last "
        "line); state q_a=1, q_b=2, u_a=3")
    plain = "pend: dop853 stopped at t=1: maximum number of steps; state q1=0.5, u1=0"
    assert state_last(plain) == plain                                  # nothing after the state: as it was
    # through the command: out of steps, the rows written are said before the state
    out = tmp_path / "t.csv"
    assert main(["simulate", "pend", "--t-final", "100", "--max-steps", "5", "-o", str(out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "; wrote the " in err and err.index("; wrote the ") < err.index("; state q1="), err


@pytest.mark.parametrize("command", ["simulate", "check", "report", "linearize", "animate"])
def test_repeated_x0_param_and_input_flags_add_up(command):
    """`--x0 q1=1.5 --x0 u1=1` (flags repeated, as --contact is) kept only the last one: the
    four-bar of SymPy's docs then started at q1 = 0 and was refused as singular there, and a
    repeated --param silently ran the file's value of the first one.  They add up now."""
    from eomc.cli import command_parser

    _, parser = command_parser(command)
    extra = ["--input", "F=1", "--input", "T=2"] if command in ("simulate", "linearize", "animate") else []
    args = parser.parse_args(["m.py", "--x0", "q1=0.5", "--x0", "u1=1,q2=2", "--param", "g=3",
                              "--param", "L=2", *extra])
    assert cli_common.parse_assignments(args.x0, "x0") == {"q1": 0.5, "u1": 1.0, "q2": 2.0}
    assert cli_common.parse_assignments(args.param, "param") == {"g": 3.0, "L": 2.0}
    if extra:
        assert args.input == ["F=1", "T=2"]
    assert parser.parse_args(["m.py"]).x0 == [] and parser.parse_args(["m.py"]).param == []


def test_repeated_x0_and_param_reach_the_run(pendulum, tmp_path):
    out = tmp_path / "t.csv"
    assert main(["simulate", "pendulum", "--t-final", "0.01", "--points", "2", "--x0", "q1=0.25",
                 "--x0", "u1=0.5", "--param", "g=2", "--param", "L=3", "-o", str(out), "-q"]) == 0
    first = np.loadtxt(out, delimiter=",", skiprows=1)[0]
    assert first[1] == 0.25 and first[2] == 0.5


def test_check_at_an_equilibrium_says_that_nothing_was_compared(pendulum, capsys):
    """`eomc check` on SymPy's multi-dof holonomic example (its zero start an equilibrium) read
    "10 of 10 checks passed", every method "0 x tolerance, 8 steps": it says now that nothing
    moved, and how to start elsewhere (as `eomc simulate` does); a start that moves gets no such line."""
    pendulum.initial_state = np.array([0.0, 0.0])
    assert main(["check", "pendulum", "--t-final", "0.5", "--methods", "dop853", "-q"]) == 0
    out = capsys.readouterr().out
    assert "eomc check: nothing moved: the start is an equilibrium (rhs = 0 there)" in out, out
    assert "--x0 q1=0.1" in out
    assert main(["check", "pendulum", "--t-final", "0.5", "--methods", "dop853", "-q", "--x0", "q1=0.3"]) == 0
    assert "nothing moved" not in capsys.readouterr().out


def test_a_warning_that_begins_with_blank_lines_starts_on_the_warnings_line():
    """SymPy's deprecation texts (a model file on sympy.physics.mechanics.Body, JointsMethod:
    SymPy's own multi-dof holonomic example), given again from the build cache, begin with two
    blank lines: the command printed "eomc simulate: warning: " and then the text two lines down."""
    import warnings

    import eomc.cli as cli
    from eomc.errors import EomcWarning

    old = cli._plain_warnings("simulate")
    try:
        text = warnings.formatwarning(EomcWarning("\n\nSupport for the Body class has been removed.\n\nSee ...\n"),
                                      EomcWarning, "m.py", 3)
    finally:
        warnings.formatwarning = old
    assert text == "eomc simulate: warning: Support for the Body class has been removed.\n\nSee ...\n", text


def test_a_floating_base_with_no_ground_says_it_fell_and_how_to_get_a_ground(tmp_path, monkeypatch, capsys):
    """`eomc simulate solo12.urdf --floating-base` (no --contact, no --ground) fell 490 m in 10 s and
    exited with status 0 and no word.  simulate, animate and check now warn, naming the fall and
    the options that give a ground; with --ground (a contact) they do not."""
    path = tmp_path / "two.urdf"
    path.write_text(_FOOT_BELOW)
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.chdir(tmp_path)

    def warned(argv):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            assert main(argv) == 0
        capsys.readouterr()
        return [str(w.message) for w in caught if str(w.message).startswith("no ground")]

    said = warned(["simulate", str(path), "--floating-base", "--t-final", "1", "-q"])
    assert len(said) == 1, said
    fell = re.match(r"no ground: two's base fell ([0-9.]+) m in 1 s \(q_base_floating_z 0 -> -[0-9.]+\): "
                    r"nothing touches the ground", said[0])
    assert fell and abs(float(fell.group(1)) - 0.5 * 9.81) < 0.1, said
    assert "--ground lets the robot's <collision> geometry touch the plane z = 0" in said[0], said
    assert "--contact LINK[:x,y,z[:radius]]" in said[0], said
    said = warned(["animate", str(path), "--floating-base", "--t-final", "0.5", "-q", "-o", "two.html"])
    assert len(said) == 1 and "base fell 1.2" in said[0], said
    said = warned(["check", str(path), "--floating-base", "--t-final", "2", "--methods", "dop853", "-q"])
    assert len(said) == 1 and "the centre of mass falls g t^2/2 = 19.62 m in 2 s" in said[0], said
    assert warned(["simulate", str(path), "--floating-base", "--ground", "--t-final", "0.3", "-q"]) == []


def test_x0_and_param_take_pi():
    """`eomc linearize examples/cartpole_lqr.py --x0 th=pi` (upright) said "--x0: expected
    NAME=VALUE, got 'th=pi'" (first hour s28): a value may be a number or an arithmetic of
    numbers and pi; anything else is refused naming the value, and no Python is evaluated."""
    import math

    got = cli_common.parse_assignments(["th=pi", "q1=-pi/2,q2=2*pi", "u=(pi/4)", "g=9.81", "c=1e-3"], "x0")
    assert got == {"th": math.pi, "q1": -math.pi / 2, "q2": 2 * math.pi, "u": math.pi / 4, "g": 9.81, "c": 1e-3}
    for bad, value in (("th=tau", "tau"), ("th=__import__('os')", "__import__('os')"), ("th=pi/0", "pi/0"),
                       ("th=", ""), ("th=2**1000", "2**1000")):
        with pytest.raises(ValueError, match=re.escape(f"--x0: {bad!r}: the value {value!r} is not a number")):
            cli_common.parse_assignments([bad], "x0")
    with pytest.raises(ValueError, match=r"--param: expected NAME=VALUE, got 'g'"):
        cli_common.parse_assignments(["g"], "param")
