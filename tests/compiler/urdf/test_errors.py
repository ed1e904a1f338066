"""Bad URDF input: one clear line naming the file, the line and the link or joint; no traceback.

Each case edits a small two-link arm (tests/helpers/urdf_arm.py; no third-party file).
"""
import re
import subprocess
import sys

import pytest

from eomc.compiler.urdf import from_urdf
from eomc.errors import ModelFileError
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


def test_missing_inertial_on_a_moving_link(tmp_path):
    start, end = ARM.index("    <inertial>\n      <origin xyz=\"0 0 0.15\""), ARM.index("  </link>\n  <joint")
    text = ARM[:start] + ARM[end:]
    message, error = _error(tmp_path, text)
    assert "link 'lower'" in message and "joint 'elbow'" in message and "<inertial>" in message
    assert error.lineno == _line(text, '<link name="lower">')


def test_zero_mass_moving_link(tmp_path):
    text = ARM.replace('<mass value="1.0"/>', '<mass value="0"/>')
    message, error = _error(tmp_path, text)
    assert "link 'lower'" in message and "zero mass" in message
    assert error.lineno == _line(text, '<link name="lower">')


def test_mesh_only_link_says_meshes_are_not_used(tmp_path):
    start, end = ARM.index("    <inertial>\n      <origin xyz=\"0 0 0.15\""), ARM.index("  </link>\n  <joint")
    mesh = ('    <visual><geometry><mesh filename="package://arm/lower.stl"/></geometry></visual>\n'
            '    <collision><geometry><mesh filename="package://arm/lower.stl"/></geometry></collision>\n')
    text = ARM[:start] + mesh + ARM[end:]
    message, error = _error(tmp_path, text)
    assert "link 'lower'" in message and "mesh" in message and "<inertial>" in message
    assert error.lineno == _line(text, '<link name="lower">')


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
    text = ARM.replace('ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.0005"',
                       'ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.05"')
    message, error = _error(tmp_path, text)
    assert "link 'lower'" in message and "inertia" in message and "triangle" in message


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
