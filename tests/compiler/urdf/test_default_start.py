"""Issue 29: a URDF robot's default start is a pose it can take.  A joint whose range
excludes 0 (Go2's knees: [-2.72, -0.84]) starts just inside its nearest limit, named in a
note; joints whose range holds 0 stay at 0; a start the caller gives (x0, --x0) is kept as
given (and warned about); with the limits off nothing moves.  The Python API says so with a
DefaultStartWarning (the command line with its note), and the Kane route starts where the
recursive one does."""
import warnings

import numpy as np
import pytest

import eomc
import eomc.cli.common as cli_common
from eomc.compiler.urdf.model import START_INSIDE
from eomc.errors import DefaultStartWarning
from eomc.runtime.switching import PhysicsWarning

ARM = """<?xml version="1.0"?>
<robot name="bent">
  <link name="base"/>
  <link name="upper"><inertial><origin xyz="0.3 0 0"/><mass value="1.0"/>
    <inertia ixx="0.001" iyy="0.002" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="lower"><inertial><origin xyz="0.3 0 0"/><mass value="1.0"/>
    <inertia ixx="0.001" iyy="0.002" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="upper"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <joint name="knee" type="revolute">
    <parent link="upper"/><child link="lower"/><origin xyz="0.6 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-2.5" upper="-0.8" effort="1" velocity="1"/>
  </joint>
</robot>
"""


@pytest.fixture(scope="module")
def arm(tmp_path_factory):
    d = tmp_path_factory.mktemp("bent")
    (d / "bent.urdf").write_text(ARM)
    return d


def test_the_default_start_puts_a_joint_whose_range_excludes_zero_just_inside(arm, capsys):
    model = eomc.compile(arm / "bent.urdf", "bent", cache_dir=arm / "cache", progress=False)
    x0 = dict(zip(model.state_names, model.initial_state))
    assert x0["q_shoulder"] == 0.0                          # its range holds 0: untouched
    assert x0["q_knee"] == pytest.approx(-0.8 - START_INSIDE)   # inside, not on the limit's onset
    assert [m["joint"] for m in model.metadata["start_in_range"]] == ["knee"]
    with warnings.catch_warnings():                     # the default start: no outside-the-range warning
        warnings.simplefilter("error", PhysicsWarning)
        res = model.simulate(None, (0, 0.05))
    assert res.x[0][model.state_names.index("q_knee")] == pytest.approx(-0.8 - START_INSIDE)
    # the command line's default start names the joint it moved
    start = cli_common.initial_state(model, {})
    assert start["q_knee"] == pytest.approx(-0.8 - START_INSIDE)
    err = capsys.readouterr().err
    assert "zero pose is outside the range of joint knee (range [-2.5, -0.8]; starts at q_knee = -0.81)" in err
    # a start the user gives is never changed; it gets the warning, and no note
    assert cli_common.initial_state(model, {"q_knee": 0.0})["q_knee"] == 0.0
    assert "zero pose" not in capsys.readouterr().err
    with pytest.warns(PhysicsWarning, match=r"outside the range of joint knee \(q_knee = 0, 0\.8 above"):
        model.simulate({"q_knee": 0.0}, (0, 0.01))


def test_with_the_limits_off_the_zero_pose_is_the_start(arm):
    from eomc.compiler.urdf.model import UrdfModel
    free = eomc.compile(UrdfModel(arm / "bent.urdf", limits=False), "bent_free", cache_dir=arm / "cache",
                        progress=False)
    assert free.initial_state is None or not np.any(free.initial_state)
    assert not free.metadata.get("start_in_range")


KNEE_MOVED = r"bent: the zero pose is outside the range of joint knee \(range \[-2\.5, -0\.8\]; starts at q_knee = -0\.81\)"


def test_the_python_api_warns_naming_the_joint_its_range_and_start(arm):
    with pytest.warns(DefaultStartWarning, match=KNEE_MOVED) as got:
        eomc.compile(arm / "bent.urdf", "bent", cache_dir=arm / "cache", progress=False)
    assert [w.filename for w in got if w.category is DefaultStartWarning] == [__file__]   # at the user's call
    with warnings.catch_warnings():            # filterable alone: nothing else is silenced
        warnings.simplefilter("error")
        warnings.filterwarnings("ignore", category=DefaultStartWarning)
        eomc.compile(arm / "bent.urdf", "bent", cache_dir=arm / "cache", progress=False)


def test_the_command_line_says_it_once_as_a_note_not_a_warning(arm, tmp_path, monkeypatch, capsys):
    from eomc.cli import main
    monkeypatch.setenv("EOMC_CACHE_DIR", str(arm / "cache"))
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        assert main(["simulate", str(arm / "bent.urdf"), "--t-final", "0.01", "-o", str(tmp_path / "x.csv")]) == 0
    assert not [w for w in got if issubclass(w.category, DefaultStartWarning)]
    err = capsys.readouterr().err
    assert err.count("zero pose is outside the range of joint knee") == 1
    assert "eomc: note: bent: the zero pose" in err


def test_the_kane_route_starts_where_the_recursive_one_does(arm):
    recursive = eomc.compile(arm / "bent.urdf", "bent", cache_dir=arm / "cache", progress=False)
    with pytest.warns(DefaultStartWarning, match=KNEE_MOVED):
        kane = eomc.compile(arm / "bent.urdf", "bent", formulation="kane", cache_dir=arm / "cache",
                            progress=False)
    assert kane.state_names == recursive.state_names
    np.testing.assert_array_equal(kane.initial_state, recursive.initial_state)
    assert kane.metadata["start_in_range"] == recursive.metadata["start_in_range"]


def test_joints_of_one_range_and_start_are_named_together():
    """A1's four knees (first hour s27) each repeated '(range [-2.69653, -0.916298]; starts at
    q_<knee> = -0.926298)': joints sharing a range and a start are named once together."""
    from eomc.runtime.switching import moved_start_text

    def knee(leg, lower=-2.69653, value=-0.926298):
        return {"joint": f"{leg}_calf_joint", "state": f"q_{leg}_calf_joint", "lower": lower,
                "upper": -0.916298, "value": value}
    text = moved_start_text("a1", [knee("FR"), knee("FL"), knee("RR", lower=-2.5), knee("RL")])
    assert text == ("a1: the zero pose is outside the range of joints FR_calf_joint, FL_calf_joint, RL_calf_joint "
                    "(range [-2.69653, -0.916298]; each starts at -0.926298); RR_calf_joint (range [-2.5, "
                    "-0.916298]; starts at q_RR_calf_joint = -0.926298)")
