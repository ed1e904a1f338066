"""The multibody Model (eomc.compiler.multibody): a reader fills it once, nothing after it reads files.

Counted, not assumed: parses of a URDF (lxml: the reader's, and the visuals' and welded
links' reader's, which read the file again before the Model existed) and executions of a model file during a default (``auto``)
build with a frame output and the animation's poses; MuJoCo compilations of an MJCF
file the same way.  And the defect the Model removes by construction: a URDF robot
given an extra first-order state kept its welded links and its poses (they used to ride
on Kane's record as private attributes that the states step did not copy).
"""
import dataclasses
import typing
from pathlib import Path

import numpy as np
import pytest
from sympy.physics.mechanics import dynamicsymbols

import eomc
from eomc.compiler.driver import generate
from eomc.compiler.multibody import Frame, Model, Provenance
from eomc.compiler.model import spec as spec_module
from helpers.urdf_arm import ARM

EXAMPLES = Path(__file__).resolve().parents[3] / "examples"
TOOL0 = """  <link name="tool0"/>
  <joint name="flange" type="fixed">
    <parent link="lower"/>
    <child link="tool0"/>
    <origin xyz="0 0 0.3" rpy="0 0 0"/>
  </joint>
  <link name="upper_mark"/>
  <joint name="mark" type="fixed">
    <parent link="upper"/>
    <child link="upper_mark"/>
    <origin xyz="0.05 0 0.2" rpy="0 0.3 0"/>
  </joint>
</robot>"""
VISUAL = '<visual><geometry><box size="0.1 0.1 0.4"/></geometry></visual>\n  </link>\n  <link name="lower">'


@pytest.fixture
def arm(tmp_path):
    path = tmp_path / "arm.urdf"
    path.write_text(ARM.replace("</robot>", TOOL0).replace('</link>\n  <link name="lower">', VISUAL, 1))
    return path


@pytest.fixture
def counted(monkeypatch):
    """{"xml": n, "model file": n, "mujoco": n}: reads of a file, by kind (every URDF reader,
    eomc's, eomc.runtime.urdf_scene's or yourdfpy's, parses through lxml.etree.parse)."""
    from lxml import etree
    from eomc.compiler.mjcf import model as mjcf_model
    counts = {"xml": 0, "model file": 0, "mujoco": 0}

    def wrap(key, real):
        def counting(*args, **kwargs):
            counts[key] += 1
            return real(*args, **kwargs)
        return counting
    monkeypatch.setattr(etree, "parse", wrap("xml", etree.parse))
    monkeypatch.setattr(spec_module, "run_model_file", wrap("model file", spec_module.run_model_file))
    monkeypatch.setattr(mjcf_model, "load_mjmodel", wrap("mujoco", mjcf_model.load_mjmodel))
    return counts


@pytest.mark.parametrize("formulation", ["auto", "recursive", "kane"])
def test_a_urdf_is_parsed_once(arm, counted, formulation):
    _, generated = generate(str(arm), frames=["tool0"], formulation=formulation, use_cache=False,
                            progress=False)
    assert counted["xml"] == 1
    assert "poses" in generated.metadata["functions"] and "outputs" in generated.metadata["functions"]
    poses = generated.metadata["poses"]
    assert "tool0" in str(poses) and "box" in str(poses)    # the welded link and the visual, from the one read


COLLIDING = ('<link name="tool0">\n    <collision><origin xyz="0 0 0.3" rpy="0 0.2 0"/><geometry><box '
             'size="0.05 0.05 0.1"/></geometry></collision>\n    <collision><origin xyz="0 0 0.3"/><geometry>'
             '<sphere radius="0.03"/></geometry></collision>\n  </link>')


@pytest.mark.parametrize("contact", ["--contact", "--ground", "@collision"])
def test_contacts_and_the_ground_take_the_collision_geometry_from_the_one_read(arm, counted, contact):
    """Contact spheres on a welded link (tool0), @collision spheres and --ground's <collision>
    shapes come from the reader's Model (its collisions and welded links): the file is parsed
    once, and the geometry is where the file puts it (a box and a sphere on the welded tool0)."""
    from eomc.compiler.urdf.model import UrdfModel
    path = arm.with_name("colliding.urdf")
    path.write_text(arm.read_text().replace('<link name="tool0"/>', COLLIDING, 1))
    model = {"--contact": UrdfModel(path, contacts=("tool0:0,0,0.1:0.02",)),
             "--ground": UrdfModel(path, ground=True),
             "@collision": UrdfModel(path, contacts=("@collision",))}[contact]
    _, generated = generate(model, frames=["tool0"], use_cache=False, progress=False)
    assert counted["xml"] == 1
    depths = [n for n in generated.metadata["output_names"] if n.startswith("depth_")]
    box = [f"depth_tool0_col0_{k}" for k in range(8)]      # a box touches by its corners
    assert depths == {"--contact": ["depth_tool0"], "--ground": box + ["depth_tool0_col1"],
                      "@collision": ["depth_tool0"]}[contact]


@pytest.mark.parametrize("formulation", ["kane", "auto"])
def test_a_from_urdf_system_is_not_read_again(arm, counted, formulation):
    """A System from_urdf made (the file read there, once) builds with its welded links as
    frames and its poses from that reading: no parse during the build."""
    from eomc.compiler.urdf import from_urdf
    system = from_urdf(arm)
    assert counted["xml"] == 1
    _, generated = generate(system, name="arm", frames=["tool0"], formulation=formulation, use_cache=False,
                            progress=False)
    assert counted["xml"] == 1
    assert "tool0.p.z" in generated.metadata["output_names"] and "tool0" in str(generated.metadata["poses"])


def test_a_from_urdf_systems_frames_are_its_links_under_every_formulation(arm, tmp_path):
    """The frame 'upper' of a from_urdf System is the link's frame (at its joint) under auto as
    under kane; before, auto took the bodies of the tree recognized from the System (at their
    mass centres) and did not know the welded tool0."""
    from eomc.compiler.urdf import from_urdf
    built = {form: eomc.compile(from_urdf(arm), name=f"arm_{form}", frames=["upper", "tool0"],
                                formulation=form, cache_dir=tmp_path, progress=False)
             for form in ("kane", "auto")}
    x = np.array([0.3, -0.7, 0.2, 0.5])
    for frame in ("upper", "tool0"):
        a, b = (built[form].frame(frame, 0.0, x) for form in ("kane", "auto"))
        for key in ("p", "R", "v", "w", "J"):
            assert np.allclose(getattr(a, key), getattr(b, key), atol=1e-13, rtol=0), (frame, key)
    assert abs(built["auto"].frame("upper", 0.0, x).p[2] - 0.1) < 1e-14     # the shoulder, not the mass centre


def test_a_model_file_is_executed_once(counted):
    _, generated = generate(str(EXAMPLES / "cart_pole_system.py"), frames=["com"], use_cache=False,
                            progress=False)
    assert counted["model file"] == 1
    assert generated.metadata.get("formulation_costs")      # auto compared both, from the one run


def test_an_mjcf_file_is_compiled_once(tmp_path, counted):
    pytest.importorskip("mujoco")
    path = tmp_path / "pendulum.xml"
    path.write_text("""<mujoco><worldbody><body name="arm" pos="0 0 1">
      <joint name="hinge" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.5" size="0.05" mass="1"/>
      <site name="tip" pos="0 0 -0.5"/></body></worldbody>
      <actuator><motor joint="hinge"/></actuator></mujoco>""")
    _, generated = generate(str(path), frames=["arm"], use_cache=False, progress=False)
    assert counted["mujoco"] == 1
    assert "poses" in generated.metadata["functions"]


@pytest.mark.parametrize("formulation", ["auto", "recursive"])
def test_extra_states_keep_the_robots_frames_and_poses(arm, formulation, tmp_path):
    """Issue 28's defect: an extra first-order state dropped the URDF's welded links (tool0 was
    "no body") and, silently, its poses.  Checked against the same robot without the state:
    tool0's outputs agree where q and u are the same."""
    i_m = dynamicsymbols("i_m")
    tau = dynamicsymbols("tau_elbow")
    options = dict(frames=["tool0"], formulation=formulation, cache_dir=tmp_path, progress=False)
    with_state = eomc.compile(str(arm), states={i_m: -i_m + tau}, **options)
    plain = eomc.compile(str(arm), **options)
    assert "poses" in with_state.functions and "poses" in plain.functions
    assert with_state.state_names[-1] == "i_m" and len(with_state.state_names) == len(plain.state_names) + 1
    x = np.array([0.3, -0.7, 0.2, 0.5])
    frame, frame_plain = with_state.frame("tool0", 0.0, np.append(x, 0.1)), plain.frame("tool0", 0.0, x)
    for key in ("p", "R", "v", "w", "J"):
        assert np.allclose(getattr(frame, key), getattr(frame_plain, key), atol=1e-14, rtol=0), key
    assert abs(frame.p[2] - (0.1 + 0.4 * np.cos(0.3) + 0.3 * np.cos(0.3 - 0.7))) < 1e-12
    posed, posed_plain = with_state.poses(0.0, np.append(x, 0.1)), plain.poses(0.0, x)
    assert "tool0" in posed.frame_names and posed.frame_names == posed_plain.frame_names
    assert np.allclose(posed.positions, posed_plain.positions, atol=1e-14, rtol=0)
    assert np.allclose(posed.positions[posed.frame_names.index("tool0")], frame.p, atol=1e-14, rtol=0)


def test_every_link_is_a_frame_welded_ones_at_their_offsets(arm):
    read = spec_module.read_model(str(arm)).model
    assert isinstance(read, Model) and read.source == Provenance("urdf", str(arm), 2)
    assert [f.name for f in read.frames] == ["base", "upper", "lower", "tool0", "upper_mark"]
    mark = read.frame("upper_mark")
    assert mark.body == 0 and float(mark.offset[0]) == 0.05
    assert np.allclose(np.array(mark.rotation, dtype=float),
                       [[np.cos(0.3), 0, np.sin(0.3)], [0, 1, 0], [-np.sin(0.3), 0, np.cos(0.3)]], atol=1e-15)
    assert read.frame("base").body == -1


def test_the_model_is_typed():
    """Frozen dataclasses whose fields say what they hold (no `object`/Any fields)."""
    for record in (Model, Frame, Provenance):
        assert record.__dataclass_params__.frozen
        hints = typing.get_type_hints(record)
        for f in dataclasses.fields(record):
            assert hints[f.name] not in (object, typing.Any), f"{record.__name__}.{f.name}"
            assert "Any" not in str(hints[f.name]), f"{record.__name__}.{f.name}: {hints[f.name]}"
