"""MJCF files that are not regular files are refused unopened; errors in <include>d files
point at that file and line."""
import os
import threading

import pytest

pytest.importorskip("mujoco")

import eomc  # noqa: E402
from eomc.runtime.errors import ModelFileError  # noqa: E402

MAIN = """<mujoco model="main">
  <worldbody>
    <body name="a" pos="0 0 1">
      <joint name="h0" type="hinge"/>
      <geom type="sphere" size="0.1" mass="1"/>
      <include file="{include}"/>
    </body>
  </worldbody>
</mujoco>
"""
PART = """<mujoco>
  <body name="b" pos="0.2 0 0">

    <joint name="h1" type="hinge" frictionloss="-2"/>
    <geom type="sphere" size="0.1" mass="1"/>
  </body>
</mujoco>
"""


def _compile(path, tmp_path):
    done = {}

    def run():
        try:
            eomc.compile(str(path), functions=["rhs"], cache_dir=tmp_path / "c", progress=False)
        except Exception as exc:      # noqa: BLE001
            done["error"] = exc
    t = threading.Thread(target=run, daemon=True)
    t.start()
    t.join(60)
    assert not t.is_alive(), "the build blocked on a FIFO"
    return done.get("error")


def test_fifo_include_refused_with_its_line(tmp_path):
    os.mkfifo(tmp_path / "part.xml")
    main = tmp_path / "main.xml"
    main.write_text(MAIN.format(include="part.xml"))
    exc = _compile(main, tmp_path)
    assert isinstance(exc, ModelFileError)
    assert str(exc).startswith(f"{main}:6: the <include> file {tmp_path / 'part.xml'} is a FIFO")


def test_fifo_model_and_mesh_refused(tmp_path):
    os.mkfifo(tmp_path / "model.xml")
    exc = _compile(tmp_path / "model.xml", tmp_path)
    assert isinstance(exc, ModelFileError) and "is a FIFO (named pipe), not a regular file" in str(exc)
    os.mkfifo(tmp_path / "shape.stl")
    main = tmp_path / "m.xml"
    main.write_text('<mujoco><asset>\n<mesh name="s" file="shape.stl"/></asset><worldbody><body><freejoint/>'
                    '<geom type="mesh" mesh="s"/></body></worldbody></mujoco>')
    exc = _compile(main, tmp_path)
    assert isinstance(exc, ModelFileError) and str(exc).startswith(f"{main}:2: the <mesh> file")


def test_error_in_included_file_names_that_file(tmp_path):
    (tmp_path / "part.xml").write_text(PART)
    main = tmp_path / "main.xml"
    main.write_text(MAIN.format(include="part.xml"))
    exc = _compile(main, tmp_path)
    assert isinstance(exc, ModelFileError)
    assert str(exc).startswith(f"{tmp_path / 'part.xml'}:4: <joint>: joint h1: frictionloss")


def test_mujocos_own_error_in_included_file_names_that_file(tmp_path):
    """MuJoCo reports an element of an included file at "line 0" of the main file: eomc finds it."""
    (tmp_path / "part.xml").write_text(PART.replace('frictionloss="-2"', 'bogus="3"'))
    main = tmp_path / "main.xml"
    main.write_text(MAIN.format(include="part.xml"))
    exc = _compile(main, tmp_path)
    assert isinstance(exc, ModelFileError)
    assert str(exc).startswith(f"{tmp_path / 'part.xml'}:4: MuJoCo could not compile the model")
    assert "'bogus'" in str(exc) and "line 0" not in str(exc)
    # in the main file MuJoCo's own line stands (the included file mended first: MuJoCo reports an
    # included file's error before the main file's, at "line 0", and that one would be found)
    (tmp_path / "part.xml").write_text(PART.replace('frictionloss="-2"', ""))
    main.write_text(MAIN.format(include="part.xml").replace('type="hinge"/>', 'type="hinge" bogus="1"/>'))
    exc = _compile(main, tmp_path)
    assert str(exc).startswith(f"{main}:4: MuJoCo could not compile the model")


@pytest.mark.parametrize("change, line", [
    (('<geom type="sphere" size="0.1" mass="1"/>', '<geom type="sphere" size="0.1" mass="1"/><unknown/>'), 5),
    (('frictionloss="-2"', 'axis="0 0 0"'), 4),                        # compiler's "Element name 'h1', id 1"
    (('<body name="b" pos="0.2 0 0">', '<body name="b" pos="0.2 0 0" pos="1 0 0">'), 2),   # does not parse
])
def test_mujocos_other_errors_in_included_file_name_that_file(tmp_path, change, line):
    """An unrecognized element (MuJoCo names its tag only), an error of the compiled model (its
    name only) and a file that does not parse (MuJoCo names the main file's <include>) are found
    at the included file's line, also one include deeper."""
    (tmp_path / "part.xml").write_text(PART.replace(*change).replace('frictionloss="-2"', ""))
    (tmp_path / "middle.xml").write_text('<mujoco>\n  <include file="part.xml"/>\n</mujoco>\n')
    main = tmp_path / "main.xml"
    main.write_text(MAIN.format(include="middle.xml"))
    exc = _compile(main, tmp_path)
    assert isinstance(exc, ModelFileError)
    assert str(exc).startswith(f"{tmp_path / 'part.xml'}:{line}: MuJoCo could not compile the model"), str(exc)
    assert "line 0" not in str(exc)
