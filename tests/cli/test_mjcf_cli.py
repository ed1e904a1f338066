"""MuJoCo models (.xml) on the command line: build, inspect, simulate, animate, --ignore.

Models are compiled in process (eomc.cli.main) into the session's temporary cache; the
model is a two-link arm with armature, a limit and a fixed tendon, so --ignore matters.
"""
import numpy as np
import re

import pytest

pytest.importorskip("mujoco")

from eomc.cli import main  # noqa: E402
from eomc.errors import EomcWarning  # noqa: E402

ARM = """<mujoco model="arm">
  <worldbody>
    <body name="upper" pos="0 0 1">
      <joint name="shoulder" type="hinge" axis="0 1 0" armature="0.1" damping="0.2"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.04"/>
      <body name="lower" pos="0.3 0 0">
        <joint name="elbow" type="hinge" axis="0 1 0" range="-2 2"/>
        <geom type="box" size="0.15 0.03 0.03" pos="0.15 0 0"/>
      </body>
    </body>
  </worldbody>
  <tendon><fixed name="coupling" stiffness="5" armature="0.1"><joint joint="shoulder" coef="1"/><joint joint="elbow" coef="-1"/></fixed></tendon>
  <actuator><motor name="m" joint="shoulder" gear="2"/></actuator>
</mujoco>
"""


@pytest.fixture(scope="module")
def arm(tmp_path_factory):
    path = tmp_path_factory.mktemp("arm") / "arm.xml"
    path.write_text(ARM)
    return path


def _ignoring(argv):
    """main(argv) with --ignore tendons: the warnings that say what was dropped, expected (the
    tendon's stiffness, and its armature, which eomc does not model), and no other."""
    dropped = r"ignored: (1 tendon\(s\) with stiffness|tendon coupling: armature)"
    with pytest.warns(EomcWarning) as caught:
        status = main(argv)
    messages = [str(w.message) for w in caught if issubclass(w.category, EomcWarning)]
    assert messages and all(re.search(dropped, m) for m in messages), messages
    return status


def test_build_and_inspect_with_ignore(arm, tmp_path, capsys):
    out = tmp_path / "out"
    assert _ignoring(["build", str(arm), "-o", str(out), "--ignore", "tendons,limits"]) == 0    # no -q: the summary
    assert (out / "arm.c").is_file() and (out / "libarm.so").is_file()
    assert "built model 'arm' (nq=2, nu=2" in capsys.readouterr().out
    assert _ignoring(["inspect", str(arm), "--ignore", "tendons", "--ignore", "limits", "-q"]) == 0
    text = capsys.readouterr().out
    assert "parameters:" in text and "arm_shoulder" in text and "inputs: ctrl_m" in text


def test_simulate_refuses_the_tendon_unless_ignored(arm, tmp_path, capsys):
    traj = tmp_path / "traj.csv"
    assert main(["simulate", str(arm), "--t-final", "0.2", "-o", str(traj), "-q"]) != 0
    assert "<tendon>: tendon coupling: armature" in capsys.readouterr().err    # fixed tendons are modelled, not their armature
    assert not traj.exists()
    assert _ignoring(["simulate", str(arm), "--t-final", "0.2", "-o", str(traj), "--ignore", "tendons,limits",
                 "--x0", "q_shoulder=0.3", "-q"]) == 0
    data = np.genfromtxt(traj, delimiter=",", names=True)
    assert data["t"][-1] == pytest.approx(0.2) and data["q_shoulder"][0] == 0.3
    assert abs(data["q_shoulder"][-1] - 0.3) > 1e-3          # it falls


@pytest.mark.parametrize("argv, message", [
    (["build", "{py}", "-o", "{tmp}/o", "--ignore", "tendons"], "--ignore applies to MuJoCo models (.xml)"),
    (["simulate", "{py}", "--t-final", "1", "--ignore", "tendons"], "--ignore applies to MuJoCo models (.xml)"),
    (["build", "{xml}", "-o", "{tmp}/o", "--ignore", "tendon"],
     "ignore tendon: unknown; what may be ignored: tendons, equality"),
])
def test_ignore_mistakes_are_one_line_errors(arm, tmp_path, capsys, argv, message):
    py = tmp_path / "m.py"
    py.write_text("raise SystemExit('never read')\n")
    argv = [a.format(py=py, xml=arm, tmp=tmp_path) for a in argv]
    assert main(argv) != 0
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_animate_an_mjcf_model(arm, tmp_path, capsys):
    """`eomc animate model.xml`: a page with MuJoCo's bodies and the geoms as shapes."""
    page = tmp_path / "arm.html"
    assert _ignoring(["animate", str(arm), "--t-final", "0.3", "-o", str(page), "--ignore", "tendons,limits",
                 "-q"]) == 0
    text = page.read_text()
    assert '"upper"' in text and '"lower"' in text and '"cylinder"' in text


def test_cli_ignorable_list_is_the_compilers():
    """The CLI writes the list out (it must not import the compiler to build its parsers)."""
    from eomc.cli.common import IGNORABLE as cli
    from eomc.compiler.mjcf.model import IGNORABLE
    assert cli == IGNORABLE


def test_check_an_mjcf_model(arm, capsys):
    """`eomc check model.xml --ignore ...` runs its checks on the MuJoCo model."""
    assert _ignoring(["check", str(arm), "--ignore", "tendons,limits", "-q"]) == 0
    assert "checks passed" in capsys.readouterr().out


def test_show_says_an_mjcf_model_has_no_formed_equations(tmp_path, capsys):
    """`eomc show model.xml` prints what it has and says M and f are not formed (never zeros)."""
    path = tmp_path / "pend.xml"
    path.write_text('<mujoco><worldbody><body><joint name="j" type="hinge" armature="0.2"/>'
                    '<geom type="capsule" fromto="0 0 0 0 0 -1" size="0.05"/></body></worldbody></mujoco>')
    assert main(["show", str(path), "-q"]) == 0
    text = capsys.readouterr().out
    assert "coordinates q: q_j" in text and "arm_j=0.2" in text
    assert "mass matrix and forcing: not formed" in text and "mass matrix  (A" not in text


CHAIN = """<mujoco model="chain">
  <worldbody>
    <body name="a" pos="0 0 1"><joint name="ja" type="hinge" axis="0 1 0"/>
      <geom name="ga" type="sphere" size="0.05" mass="1"/>
      <body name="b" pos="0.2 0 0"><joint name="jb" type="hinge" axis="0 1 0"/>
        <geom name="gb" type="capsule" fromto="0 0 0 0.2 0 0" size="0.03" mass="1"/>
        <body name="c" pos="0.2 0 0"><joint name="jc" type="hinge" axis="0 1 0"/>
          <geom name="gc" type="sphere" size="0.05" mass="1"/></body></body></body>
  </worldbody>
</mujoco>
"""


def test_pairs_flag_chooses_self_collisions(tmp_path, capsys):
    """The default and --pairs all add the one self-collision pair MuJoCo has (ga–gc: grandparent
    and grandchild; the parent–child pairs are filtered), without a note (nothing is left out);
    --pairs trees and --pairs none leave it out, silently (asked for); --pairs on a URDF is refused."""
    path = tmp_path / "chain.xml"
    path.write_text(CHAIN)

    def inspect(*flags):
        with _quiet():
            assert main(["inspect", str(path), "-q", *flags]) == 0
        text = capsys.readouterr()
        return set(re.findall(r"\bk_(\w+)", text.out)), text.err
    assert inspect()[0] == {"ga__gc"}
    assert inspect("--pairs", "all")[0] == {"ga__gc"}
    assert inspect("--pairs", "trees")[0] == set()
    assert inspect("--pairs", "none")[0] == set()
    urdf = tmp_path / "r.urdf"
    urdf.write_text('<robot name="r"><link name="base"/></robot>')
    assert main(["inspect", str(urdf), "--pairs", "all", "-q"]) != 0
    assert "--pairs applies to MuJoCo models" in capsys.readouterr().err


def _quiet():
    import contextlib
    import warnings

    @contextlib.contextmanager
    def ctx():
        with warnings.catch_warnings():
            warnings.simplefilter("error", EomcWarning)      # no note: nothing left out unasked
            yield
    return ctx()


DEPRECATED = """<mujoco model="weight"><compiler settotalmass="2"/><worldbody>
  <body name="bob" pos="0 0 1"><joint name="swing" type="hinge" axis="0 1 0"/>
    <geom type="sphere" size="0.05" pos="0.3 0 0"/></body>
</worldbody></mujoco>
"""


def test_a_mujoco_deprecation_is_said_when_built_not_on_every_command(tmp_path, monkeypatch):
    """gymnasium's half_cheetah.xml repeated MuJoCo's 'settotalmass is deprecated' (260
    characters about the file, nothing to do in a run) as a warning on every simulate, animate,
    check and report (first hour s27): a BuildNote, said when the model is built."""
    import warnings
    from eomc.errors import BuildNote
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    path = tmp_path / "weight.xml"
    path.write_text(DEPRECATED)
    argv = ["simulate", str(path), "--t-final", "0.1", "-q", "-o", str(tmp_path / "t.csv")]
    with warnings.catch_warnings(record=True) as first:
        warnings.simplefilter("always")
        assert main(argv) == 0
    said = [w for w in first if "deprecated" in str(w.message)]
    assert len(said) == 1 and said[0].category is BuildNote and "MuJoCo: " in str(said[0].message), \
        [str(w.message) for w in first]
    with warnings.catch_warnings(record=True) as again:
        warnings.simplefilter("always")
        assert main(argv) == 0
    assert not [w for w in again if "deprecated" in str(w.message)], [str(w.message) for w in again]
