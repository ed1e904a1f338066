"""Bad URDF input: one clear line naming the file, the line and the link or joint; no traceback.

Each case edits a small two-link arm (tests/helpers/urdf_arm.py; no third-party file).
"""
import re
import subprocess
import sys

import pytest

from eomc.compiler.urdf import from_urdf
from eomc.errors import ModelFileError
from eomc.runtime.errors import EomcNote, EomcWarning
from helpers.urdf_arm import ARM



def _line(text, pattern):
    """1-based line of the first line of ``text`` containing ``pattern``."""
    return next(i for i, line in enumerate(text.splitlines(), 1) if pattern in line)


def _write(tmp_path, text, name="arm.urdf"):
    path = tmp_path / name
    path.write_text(text)
    return path


def _error(tmp_path, text):
    path = _write(tmp_path, text)
    with pytest.raises(ModelFileError) as info:
        from_urdf(path)
    message = str(info.value)
    assert message.startswith(f"{path}:"), message
    assert "Traceback" not in message
    return message, info.value


def test_the_unedited_arm_builds(tmp_path):
    system = from_urdf(_write(tmp_path, ARM))
    assert [str(q) for q in system.q] == ["q_shoulder(t)", "q_elbow(t)"]


def test_malformed_xml_gives_the_line(tmp_path):
    text = ARM.replace('<axis xyz="0 1 0"/>\n  </joint>\n  <joint name="elbow"',
                       '<axis xyz="0 1 0">\n  </joint>\n  <joint name="elbow"')
    message, error = _error(tmp_path, text)
    assert "malformed XML" in message
    assert error.lineno == _line(text, '<joint name="shoulder"') + 5   # where the mismatch shows


def _warned(tmp_path, text, *needles):
    """from_urdf(text) builds, warning once per link as ``file:line: ...`` with ``needles``."""
    path = _write(tmp_path, text)
    with pytest.warns(EomcWarning) as caught:
        system = from_urdf(path)
    messages = [str(w.message) for w in caught if issubclass(w.category, EomcWarning)]
    assert any(m.startswith(f"{path}:") and all(n in m for n in needles) for m in messages), messages
    return system, messages


def test_massless_moving_leaf_is_merged_with_a_warning(tmp_path):
    """No <inertial> (or zero mass) on the last link: it carries nothing, so its joint is
    locked and it is merged into its parent, and the warning says so."""
    start, end = ARM.index("    <inertial>\n      <origin xyz=\"0 0 0.15\""), ARM.index("  </link>\n  <joint")
    text = ARM[:start] + ARM[end:]
    system, _ = _warned(tmp_path, text, "link 'lower'", "joint 'elbow'", "carries no mass", "merged into 'upper'")
    assert [str(q) for q in system.q] == ["q_shoulder(t)"]
    massless = ARM.replace('<mass value="1.0"/>', '<mass value="0"/>')
    system, _ = _warned(tmp_path, massless.replace('ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.0005"',
                                                   'ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"'),
                        "link 'lower'", "carries no mass")
    assert len(system.q) == 1
    # zero mass but a rotational inertia (Bolt's feet): kept, as Pinocchio keeps it
    assert len(from_urdf(_write(tmp_path, massless)).q) == 2


def test_mesh_only_leaf_says_meshes_are_not_used(tmp_path):
    start, end = ARM.index("    <inertial>\n      <origin xyz=\"0 0 0.15\""), ARM.index("  </link>\n  <joint")
    mesh = ('    <visual><geometry><mesh filename="package://arm/lower.stl"/></geometry></visual>\n'
            '    <collision><geometry><mesh filename="package://arm/lower.stl"/></geometry></collision>\n')
    _warned(tmp_path, ARM[:start] + mesh + ARM[end:], "link 'lower'", "mesh", "carries no mass")


def test_massless_link_carrying_mass_moves_it(tmp_path):
    """A massless middle link (a 'virtual' link between two joints, as in human.urdf) is kept:
    the mass beyond it resists its joint."""
    start = ARM.index("    <inertial>\n      <origin xyz=\"0 0 0.2\"")
    end = ARM.index("  </link>\n  <link name=\"lower\">")
    system = from_urdf(_write(tmp_path, ARM[:start] + ARM[end:]))
    assert len(system.q) == 2


def test_a_joint_that_moves_no_inertia_is_refused(tmp_path):
    """A point mass on its own joint's axis: nothing resists that joint (M singular)."""
    text = ARM.replace('<origin xyz="0 0 0.15"/>', '<origin xyz="0 0 0"/>').replace(
        'ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.0005"',
        'ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"')
    message, error = _error(tmp_path, text)
    assert "joint 'elbow'" in message and "moves no inertia" in message
    assert error.lineno == _line(text, '<joint name="elbow"')


def test_joint_loop_two_parents(tmp_path):
    extra = ('  <joint name="strut" type="revolute">\n    <parent link="base"/>\n'
             '    <child link="lower"/>\n    <axis xyz="1 0 0"/>\n  </joint>\n</robot>')
    text = ARM.replace("</robot>", extra)
    message, error = _error(tmp_path, text)
    assert "joint loop" in message and "'lower'" in message and "'elbow'" in message and "'strut'" in message
    assert error.lineno == _line(text, '<joint name="strut"')


def test_joint_loop_cycle(tmp_path):
    text = ARM.replace('<parent link="base"/>\n    <child link="upper"/>',
                       '<parent link="lower"/>\n    <child link="upper"/>')
    message, _ = _error(tmp_path, text)
    assert "joint loop" in message and "cycle" in message and "upper" in message


def test_unknown_joint_type(tmp_path):
    text = ARM.replace('type="continuous"', 'type="ball"')
    message, error = _error(tmp_path, text)
    assert "joint 'elbow'" in message and "unknown type 'ball'" in message and "revolute" in message
    assert error.lineno == _line(text, '<joint name="elbow"')


def test_bad_number_names_the_element(tmp_path):
    text = ARM.replace('<origin xyz="0 0 0.4" rpy="0 0 0"/>', '<origin xyz="0 0.4" rpy="0 0 0"/>')
    message, error = _error(tmp_path, text)
    assert "joint 'elbow'" in message and "3 finite numbers" in message
    assert error.lineno == _line(text, 'xyz="0 0.4"')


def test_undefined_link_and_missing_child(tmp_path):
    message, error = _error(tmp_path, ARM.replace('<child link="lower"/>', '<child link="forearm"/>'))
    assert "joint 'elbow'" in message and "'forearm'" in message
    message, _ = _error(tmp_path, ARM.replace('<child link="lower"/>', ''))
    assert "joint 'elbow'" in message and "<child" in message


def test_impossible_inertia(tmp_path):
    """A triangle inequality missed beyond rounding on a positive tensor: kept as given
    (Pinocchio's choice: the dynamics are defined) with a warning naming the link; a
    negative principal moment beyond rounding on a moving body: refused."""
    text = ARM.replace('ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.0005"',
                       'ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.05"')
    _warned(tmp_path, text, "link 'lower'", "triangle", "kept as given")
    text = ARM.replace('ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.0005"',
                       'ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="-0.001"')
    message, error = _error(tmp_path, text)
    assert "link 'lower'" in message and "negative" in message
    assert error.lineno == _line(text, '<link name="lower">')


def test_rounding_level_violations_are_repaired(tmp_path):
    """-2.5e-22 beside 3e-6 (HyQ's base), and a triangle missed by 1e-12 relative: one warning
    each naming the link; the repaired tensor is what the model uses."""
    text = ARM.replace('ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.0005"',
                       'ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="-2.5e-22"')
    system, _ = _warned(tmp_path, text, "link 'lower'", "repaired", "rounding")
    assert "Izz_lower" not in {str(k) for k in system.urdf.parameters}      # repaired to 0
    text = ARM.replace('ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.0005"',
                       'ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.02000000000002"')
    system, _ = _warned(tmp_path, text, "link 'lower'", "repaired")
    values = {str(k): v for k, v in system.urdf.parameters.items()}
    assert values["Ixx_lower"] + values["Iyy_lower"] >= values["Izz_lower"]


def test_not_a_urdf(tmp_path):
    message, error = _error(tmp_path, '<?xml version="1.0"?>\n<mujoco model="x"/>\n')
    assert "<mujoco>" in message and error.lineno == 2


def test_cli_prints_one_line(tmp_path):
    path = _write(tmp_path, ARM.replace('type="continuous"', 'type="ball"'))
    out = subprocess.run([sys.executable, "-m", "eomc", "build", str(path), "-o", str(tmp_path / "out"), "-q"],
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 1
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and re.search(rf"{re.escape(str(path))}:\d+: joint 'elbow' has unknown type", lines[0])


def test_a_nameless_robot_builds_named_after_its_file(tmp_path):
    """urdfdom refuses <robot> without a name; the robot is fully described without it, so it
    builds with a warning and the file's stem names the model (as --name would)."""
    text = ARM.replace('<robot name="arm">', "<robot>")
    path = _write(tmp_path, text, name="two_link.urdf")
    with pytest.warns(EomcWarning) as caught:
        system = from_urdf(path)
    messages = [str(w.message) for w in caught if issubclass(w.category, EomcWarning)]
    assert any(m.startswith(f"{path}:{_line(text, '<robot>')}:") and "no name attribute" in m
               and "named 'two_link' after the file" in m for m in messages), messages
    assert [str(q) for q in system.q] == ["q_shoulder(t)", "q_elbow(t)"]
    from eomc.compiler.urdf.reader import read_urdf
    with pytest.warns(EomcWarning):
        assert read_urdf(path).name == "two_link"


def test_a_robot_without_links_names_the_files_beside_it(tmp_path):
    """example-robot-data's ur3.urdf is an empty xacro output (no name, no link) next to
    ur3_robot.urdf: the refusal says the file describes no robot and names its neighbours."""
    empty = '<?xml version="1.0"?>\n<robot xmlns:xacro="http://wiki.ros.org/xacro">\n  <!-- nothing -->\n</robot>\n'
    path = _write(tmp_path, empty, name="ur3.urdf")
    _write(tmp_path, ARM, name="ur3_robot.urdf")
    _write(tmp_path, ARM, name="ur5_robot.urdf")
    with pytest.raises(ModelFileError) as info:
        from_urdf(path)
    message = str(info.value)
    assert message.startswith(f"{path}:2: ") and "has no <link>" in message and "no name" not in message
    assert "ur3_robot.urdf" in message and "ur5_robot.urdf" not in message


def test_several_rounding_repairs_share_one_warning(tmp_path):
    """icub.urdf repairs seven links' moments like -1.4e-20: one warning naming each link with
    its line, not seven."""
    text = ARM.replace('ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.0005"',
                       'ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="-2.5e-22"')
    start = text.index('<link name="upper">')
    end = text.index("</link>", start)
    upper = text[start:end]
    moments = re.search(r'izz="[^"]*"', upper).group(0)
    text = text[:start] + upper.replace(moments, 'izz="-1e-21"') + text[end:]
    path = _write(tmp_path, text)
    with pytest.warns(EomcWarning) as caught:
        from_urdf(path)
    repaired = [str(w.message) for w in caught if "repaired" in str(w.message)]
    assert len(repaired) == 1, repaired
    assert "2 links' principal moments" in repaired[0]
    for link in ("upper", "lower"):
        line = _line(text, f'<link name="{link}">')
        assert f"'{link}' (line {line}): " in repaired[0], repaired


def test_several_kept_tensors_share_one_warning(tmp_path):
    """Two moving links whose tensors miss the triangle inequality (kept as given, as Pinocchio
    does; HyQ's feet, Allegro's fingers: five lines each) and two links welded to the ground
    with impossible tensors (ANYmal C's cameras): one warning each kind, naming every link
    with its line."""
    bad = 'ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.05"'
    text = ARM.replace('ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.0005"', bad)
    text = text.replace('ixx="0.02" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.001"',
                        'ixx="0.02" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.1"')
    cams = "".join(f'  <joint name="cam{k}_joint" type="fixed"><parent link="base"/><child link="cam{k}"/>'
                   f'</joint>\n  <link name="cam{k}"><inertial><mass value="0.1"/><inertia ixx="1e-6" ixy="0" '
                   f'ixz="0" iyy="1e-6" iyz="0" izz="1e-3"/></inertial></link>\n' for k in (1, 2))
    text = text.replace("</robot>", cams + "</robot>")
    path = _write(tmp_path, text)
    with pytest.warns(EomcWarning) as caught:
        from_urdf(path)
    messages = [str(w.message) for w in caught]
    kept = [m for m in messages if "kept as given" in m]
    assert len(kept) == 1 and "2 links' inertia tensors (upper, lower)" in kept[0], messages
    details = [w.message for w in caught if "kept as given" in str(w.message)][0].details   # eomc inspect's
    for name, each in zip(("upper", "lower"), details):
        line = _line(text, f'<link name="{name}">')
        assert each.startswith(f"link '{name}' (line {line}): principal moments "), details
    grounded = [m for m in messages if "welded to the ground" in m]
    assert len(grounded) == 1 and "2 links welded to the ground" in grounded[0], messages
    for k in (1, 2):
        line = _line(text, f'<link name="cam{k}">')
        assert f"link 'cam{k}' (line {line})" in grounded[0], grounded
    # nothing to act on: a note (the CLI prints `eomc: note: ...`), short -- no moments (first hour
    # s21: ANYmal C's five cameras gave a 680-character warning on every command)
    note = [w for w in caught if "welded to the ground" in str(w.message)][0]
    assert issubclass(note.category, EomcNote) and "principal moments" not in grounded[0]
    # the kept tensors too (the dynamics are fine): a BuildNote, said when built, not on a reuse
    # (first hour s26: ANYmal's 840 characters on every simulate/check/animate)
    from eomc.errors import BuildNote
    said = [w for w in caught if "kept as given" in str(w.message)][0]
    assert issubclass(said.category, BuildNote)
    assert not any(issubclass(w.category, EomcNote) for w in caught if w is not note and w is not said)


def test_several_massless_moving_links_share_one_warning(tmp_path):
    """romeo.urdf merges eight massless finger chains: one warning naming each link, its joint
    and line and what it is merged into, not eight."""
    fingers = "".join(f'  <joint name="finger{k}" type="revolute"><parent link="lower"/><child link="tip{k}"/>'
                      f'<axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>\n'
                      f'  <link name="tip{k}"/>\n' for k in (1, 2))
    text = ARM.replace("</robot>", fingers + "</robot>")
    path = _write(tmp_path, text)
    with pytest.warns(EomcWarning) as caught:
        system = from_urdf(path)
    merged = [str(w.message) for w in caught if "carr" in str(w.message) and "no mass" in str(w.message)]
    assert len(merged) == 1 and "2 moving links carry no mass" in merged[0], merged
    for k in (1, 2):
        line = _line(text, f'<joint name="finger{k}"')
        assert f"link 'tip{k}' (moved by joint 'finger{k}', line {line}) carries no mass: merged into 'lower'" \
            in merged[0], merged
    assert [str(q) for q in system.q] == ["q_shoulder(t)", "q_elbow(t)"]
