"""The animation page draws what touches (the contact spheres and points the model computes
with) and each contact's force as an arrow: the page's numbers against the run's outputs, and
the toggles in a real browser.

One MJCF ball (radius 0.1 m, 2 kg, a free joint) dropped from 0.3 m onto the plane: it touches
down at t ≈ 0.2 s and rests on its contact, whose normal force is then m·g.
"""
import json
import re
import warnings

import numpy as np
import pytest

import eomc
from eomc.compiler.mjcf.model import MjcfModel
from eomc.runtime.animate import FORCE_SCALE

from .test_animate import _open, _project

BALL = """<mujoco><option gravity="0 0 -9.81"/><worldbody><geom type="plane" size="5 5 .1"/>
<body name="ball" pos="0 0 0.3"><freejoint/><geom name="foot" type="sphere" size="0.1" mass="2"/></body>
</worldbody></mujoco>"""
MASS, RADIUS, G = 2.0, 0.1, 9.81


@pytest.fixture(scope="module")
def ball(tmp_path_factory):
    where = tmp_path_factory.mktemp("ball")
    (where / "ball.xml").write_text(BALL)
    model = eomc.compile(MjcfModel(where / "ball.xml"), functions=["rhs", "jac_x", "outputs", "events", "poses"],
                         cache_dir=where / "cache", progress=False)
    res = model.simulate(None, (0, 1.0), method="radau")
    assert res.status == 0
    return model, res


def _data(anim):
    return json.loads(re.search(r'id="eomc-data">(.*?)</script>', anim.html, re.S).group(1))


def _f32(b64, cols):
    import base64
    return np.frombuffer(base64.b64decode(b64), dtype="<f4").reshape(-1, cols).astype(float)


def test_the_compiler_records_the_contacts_for_the_page(ball):
    model, _ = ball
    meta = model.metadata["poses"]
    assert meta["contacts"] == [{"name": "foot", "frame": "ball", "point": [0.0, 0.0, 0.0], "radius": RADIUS,
                                 "radius_parameter": "r_foot", "normal": [0.0, 0.0, 1.0],
                                 "height": 0.0}]
    assert meta["weight"] == pytest.approx(MASS * G, rel=1e-12)


def test_arrows_are_the_runs_contact_forces(ball):
    model, res = ball
    anim = res.animate(fps=20)
    data = _data(anim)
    shape, = data["collision"]["ball"]
    assert shape["kind"] == "sphere" and shape["size"] == [RADIUS] and shape["contact"] == "foot"
    assert data["show_collision"] is False, "a model drawn by its own shapes hides them by default"
    assert data["show_forces"] is True
    arrow, = data["arrows"]
    values = _f32(arrow["values"], 6)
    times = _f32(data["t"], 1)[:, 0]
    per_newton = FORCE_SCALE * data["scale"] / (MASS * G)
    assert data["newtons_per_metre"] == pytest.approx(1 / per_newton, rel=1e-12)
    centre = anim.poses["ball"]
    for i in range(len(times)):
        fn, ftx, fty, ftz = (np.interp(times[i], res.t, res.outputs[f"{k}_foot"]) for k in ("Fn", "Ftx", "Fty", "Ftz"))
        force = np.array([ftx, fty, fn + ftz]) if fn > 0 else np.zeros(3)
        np.testing.assert_allclose(values[i, 3:], force * per_newton, rtol=1e-5, atol=1e-6 * per_newton * MASS * G)
        np.testing.assert_allclose(values[i, :3], centre[i] - [0, 0, RADIUS], atol=1e-6)
    assert not values[times < 0.15, 3:].any(), "an arrow while the ball is still in the air"
    rest = values[-1, 3:] / per_newton          # at rest the contact carries the weight, straight up
    np.testing.assert_allclose(rest, [0, 0, MASS * G], rtol=1e-4, atol=1e-4)


def _green(pixels, view):
    """The arrows' green pixels in the scene's canvas (the plots beside it have green too)."""
    r, g, b = pixels[..., 0], pixels[..., 1], pixels[..., 2]
    mask = (g > 120) & (r < 80) & (b < 80)
    inside = np.zeros_like(mask)
    top, left = int(view["top"]), int(view["left"])
    inside[top:top + int(view["height"]), left:left + int(view["width"])] = True
    return mask & inside


def test_collision_and_force_toggles_in_the_browser(ball, tmp_path):
    """At rest (t = 0.9): with forces on, the arrow's green pixels run up from the ball's
    bottom; with both toggles set by the link, the page reports them, and no JS errors."""
    model, res = ball
    page = tmp_path / "ball.html"
    anim = res.animate(page, up="z")
    i = int(round(0.9 * 60))
    pixels, attrs = _open(page, "0.9&collision=1&forces=1", tmp_path)
    assert attrs.get("ready") == "1" and "errors" not in attrs, attrs.get("errors")
    assert attrs["collision"] == "1" and attrs["forces"] == "1"
    view = json.loads(attrs["view"])
    ys, xs = np.nonzero(_green(pixels, view))
    assert len(xs) > 20, "no arrow on the screenshot"
    top = anim.poses["ball"][i] + [0, 0, -RADIUS + FORCE_SCALE * _data(anim)["scale"]]
    tip = _project(view, top)
    assert np.min(np.hypot(xs - tip[0], ys - tip[1])) < 15, "the arrow does not reach m·g's length"
    pixels, attrs = _open(page, "0.9&collision=0&forces=0", tmp_path / "off")
    assert attrs.get("ready") == "1" and "errors" not in attrs, attrs.get("errors")
    assert attrs["collision"] == "0" and attrs["forces"] == "0"
    assert _green(pixels, json.loads(attrs["view"])).sum() < 5, "the arrow is drawn with forces off"


def _figures_drawn(monkeypatch):
    """The matplotlib figures animate_2d closes (read after it has written the file)."""
    import matplotlib.pyplot as plt
    closed, close = [], plt.close
    monkeypatch.setattr(plt, "close", lambda fig=None: (closed.append(fig), close(fig))[1])
    return closed


def _ground_lines(fig):
    return [ln for ax in fig.axes for ln in ax.get_lines() if ln.get_gid() == "ground"]


RAISED = BALL.replace('<geom type="plane" size="5 5 .1"/>', '<geom type="plane" pos="0 0 0.05" size="5 5 .1"/>')


@pytest.fixture(scope="module")
def raised(tmp_path_factory):
    """The ball dropped onto a plane 5 cm up: the ground is neither at z = 0 nor at the run's
    lowest point (the resting ball sinks into it), and the motion keeps x = y = 0 (planar)."""
    where = tmp_path_factory.mktemp("raised")
    (where / "ball.xml").write_text(RAISED)
    model = eomc.compile(MjcfModel(where / "ball.xml"), functions=["rhs", "jac_x", "outputs", "events", "poses"],
                         cache_dir=where / "cache", progress=False)
    res = model.simulate(None, (0, 0.8), method="radau")
    assert res.status == 0
    return model, res


def test_the_2d_drawing_has_the_ground_at_the_planes_height(raised, monkeypatch, tmp_path):
    """The GIF's figure holds one line marked "ground": horizontal at z = 0.05 (the plane's
    height, the contact's recorded one; this ball's pair has no margin) in the (y, z) view of
    a ball that only falls, and the contact sphere (radius 0.1) resting on it, both in view;
    before, no floor and no sphere were drawn and contact could not be seen."""
    from eomc.runtime.animate import animate_2d, ground_plane
    model, res = raised
    normal, height = ground_plane(model)
    np.testing.assert_array_equal(normal, [0, 0, 1])
    assert height == pytest.approx(0.05, abs=1e-12)
    closed = _figures_drawn(monkeypatch)
    animate_2d(res, tmp_path / "b.gif", model=model, fps=5, dpi=30)
    line, = _ground_lines(closed[-1])
    (y1, z1), (y2, z2) = line.get_xy1(), line.get_xy2()
    assert y1 != y2 and z1 == pytest.approx(0.05, abs=1e-12) and z2 == pytest.approx(0.05, abs=1e-12)
    ax = closed[-1].axes[0]
    assert ax.get_ylim()[0] < 0.05 < ax.get_ylim()[1]       # in view: the ball rests on it
    # the contact sphere, at the last frame (t = 0.8 s: resting), touches the line
    sphere, = [p for p in ax.patches if p.get_gid() == "contact"]
    assert sphere.get_radius() == pytest.approx(RADIUS, rel=1e-12)
    assert sphere.get_center()[1] - RADIUS == pytest.approx(0.05, abs=2e-3)
    assert ax.get_ylim()[0] < sphere.get_center()[1] - RADIUS and sphere.get_center()[1] + RADIUS < ax.get_ylim()[1]


def test_the_pages_floor_is_the_ground(raised):
    """The 3-D page's floor grid lies in the plane (z = 0.05, grid in x-y, z up), with the
    view straight onto the planar motion and with up='z' alike; before, it was the run's lowest
    point less the shapes' reach (a planar view: a grid behind the motion)."""
    model, res = raised
    for up in (None, "z"):
        camera = _data(res.animate(fps=10, up=up))["camera"]
        assert camera["grid"] == "xy" and camera["up"] == [0.0, 0.0, 1.0], up
        assert camera["floor"][2] == pytest.approx(0.05, abs=1e-12), up


def test_a_model_without_contacts_draws_no_ground(monkeypatch, tmp_path):
    """A pendulum (no contact, no ground_check) keeps today's drawing: no ground line in its
    GIF, and its page's floor is the run's lowest point."""
    from eomc.runtime.animate import animate_2d, ground_plane
    where = tmp_path
    (where / "p.xml").write_text("""<mujoco><option gravity="0 0 -9.81"/><worldbody>
<body name="arm" pos="0.3 0 1"><joint name="hinge" type="hinge" pos="-0.3 0 0" axis="0 1 0"/>
<geom type="capsule" fromto="-0.3 0 0 0 0 0" size="0.02" mass="1"/></body></worldbody></mujoco>""")
    model = eomc.compile(MjcfModel(where / "p.xml"), functions=["rhs", "outputs", "poses"],
                         cache_dir=where / "cache", progress=False)
    res = model.simulate(None, (0, 0.5))
    assert ground_plane(model) is None
    closed = _figures_drawn(monkeypatch)
    animate_2d(res, tmp_path / "p.gif", model=model, fps=5, dpi=30)
    assert closed and not _ground_lines(closed[-1])
    camera = _data(res.animate(fps=10, up="z"))["camera"]
    assert camera["floor"][2] < 1.0


@pytest.fixture(scope="module")
def hopper(tmp_path_factory):
    """gymnasium's hopper after a passive drop of 1.2 s (radau)."""
    gymnasium = pytest.importorskip("gymnasium")
    from pathlib import Path
    path = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / "hopper.xml"
    with warnings.catch_warnings(record=True) as caught:       # self-pairs in: no "left out" note
        warnings.simplefilter("always")
        model = eomc.compile(MjcfModel(path), functions=["rhs", "jac_x", "outputs", "events", "poses"],
                             cache_dir=tmp_path_factory.mktemp("hopper"), progress=False)
    assert not [w for w in caught if "self-collision" in str(w.message)], [str(w.message) for w in caught]
    res = model.simulate(None, (0, 1.2), method="radau")
    assert res.status == 0
    return model, res


def test_hopper_arrows_start_on_the_ground(hopper):
    """gymnasium's hopper (MJCF: each body's frame is its mass centre less an offset, a capsule's
    contacts are its end spheres) after a passive drop: every closed contact's arrow starts on
    the ground (z = the plane's height − depth), and the arrows together carry the weight the compiler recorded."""
    model, res = hopper
    anim = res.animate(fps=20)
    data = _data(anim)
    weight = model.metadata["poses"]["weight"]
    per_newton = FORCE_SCALE * data["scale"] / weight
    total = np.zeros(3)
    closed = 0
    height = {c["name"]: c["height"] for c in model.metadata["poses"]["contacts"]}
    for arrow in data["arrows"]:
        last = _f32(arrow["values"], 6)[-1]
        depth = np.interp(_f32(data["t"], 1)[-1, 0], res.t, res.outputs[f"depth_{arrow['name']}"])
        if last[3:].any():
            closed += 1
            # the plane is raised by the pair's margin (docs/contact.md)
            assert last[2] == pytest.approx(height[arrow["name"]] - depth, abs=1e-5), arrow["name"]
        total += last[3:] / per_newton
    assert closed >= 2
    np.testing.assert_allclose(total, [0, 0, weight], rtol=0, atol=1e-2 * weight)


def test_the_hopper_is_drawn_on_its_floor_not_the_margin_above_it(hopper, monkeypatch, tmp_path):
    """hopper.xml's floor is the plane z = 0, and each of its pairs has MuJoCo's margin 2 mm
    (the geoms' 1 mm each): the law acts from z = 0.002 (the recorded height) and the metadata
    says by how much that is above the floor, so the GIF's ground line and the page's floor
    are at z = 0; before, both were drawn 2 mm high (the margin was not recorded)."""
    from eomc.runtime.animate import animate_2d, ground_plane
    model, res = hopper
    contacts = model.metadata["poses"]["contacts"]
    assert contacts and all(c["height"] == pytest.approx(0.002, abs=1e-15) for c in contacts), contacts
    assert all(c["margin"] == pytest.approx(0.002, abs=1e-15) for c in contacts), contacts
    normal, height = ground_plane(model)
    np.testing.assert_array_equal(normal, [0, 0, 1])
    assert height == pytest.approx(0.0, abs=1e-15)
    assert _data(res.animate(fps=10))["camera"]["floor"][2] == pytest.approx(0.0, abs=1e-15)
    closed = _figures_drawn(monkeypatch)
    animate_2d(res, tmp_path / "h.gif", model=model, fps=2, dpi=30)
    line, = _ground_lines(closed[-1])
    assert line.get_xy1()[1] == pytest.approx(0.0, abs=1e-15) and line.get_xy2()[1] == pytest.approx(0.0, abs=1e-15)


TRIPOD = """<robot name="tripod">
<link name="base"><inertial><mass value="3"/><origin xyz="0 0 0"/>
<inertia ixx="0.02" iyy="0.02" izz="0.02" ixy="0" ixz="0" iyz="0"/></inertial></link>
<joint name="weld" type="fixed"><parent link="base"/><child link="foot"/><origin xyz="0.01 0 -0.1" rpy="0 0 0.5"/></joint>
<link name="foot"/>
</robot>"""
LEGS = {"a": (0.08, 0.0, 0.0), "b": (-0.04, 0.0693, 0.0), "c": (-0.04, -0.0693, 0.0)}


def test_urdf_contacts_on_a_welded_link(tmp_path):
    """A URDF body standing on three contact spheres named on a link welded to it (turned and
    moved): each arrow starts at the sphere's bottom placed through the weld, on the ground
    after the landing, and the three carry m·g."""
    from eomc.compiler.urdf.model import UrdfModel
    (tmp_path / "tripod.urdf").write_text(TRIPOD)
    contacts = [dict(link="foot", point=p, radius=0.02, name=n) for n, p in LEGS.items()]
    model = eomc.compile(UrdfModel(tmp_path / "tripod.urdf", floating_base=True), contacts=contacts,
                         functions=["rhs", "jac_x", "outputs", "events", "poses"],
                         cache_dir=tmp_path / "cache", progress=False)
    x0 = np.zeros(model.nx)
    x0[model.state_names.index(next(n for n in model.state_names if n.endswith("_z")))] = 0.125
    res = model.simulate(x0, (0, 0.8), method="radau")
    assert res.status == 0
    anim = res.animate(fps=20)
    data = _data(anim)
    frame = data["arrows"][0]["frame"]
    weight = model.metadata["poses"]["weight"]
    assert weight == pytest.approx(3 * 9.81, rel=1e-9)
    per_newton = FORCE_SCALE * data["scale"] / weight
    yaw = np.array([[np.cos(0.5), -np.sin(0.5), 0], [np.sin(0.5), np.cos(0.5), 0], [0, 0, 1]])
    R, p = anim.poses.rotation(frame)[-1], anim.poses[frame][-1]
    t_end = _f32(data["t"], 1)[-1, 0]
    total = np.zeros(3)
    for arrow in data["arrows"]:
        last = _f32(arrow["values"], 6)[-1]
        centre = p + R @ (np.array([0.01, 0, -0.1]) + yaw @ LEGS[arrow["name"]])
        np.testing.assert_allclose(last[:3], centre - [0, 0, 0.02], atol=1e-6)
        depth = np.interp(t_end, res.t, res.outputs[f"depth_{arrow['name']}"])
        assert depth > 0 and last[2] == pytest.approx(-depth, abs=1e-6)
        total += last[3:] / per_newton
    # vertical only: 0.8 s after a 5 mm drop the regularised friction still pulls (0.6 N)
    assert total[2] == pytest.approx(weight, rel=1e-2)
    shapes = data["collision"][frame]
    assert sorted(s["contact"] for s in shapes) == sorted(LEGS) and all(s["size"] == [0.02] for s in shapes)


IDLE = """<mujoco><option gravity="0 0 -9.81"/><worldbody><geom type="plane" size="5 5 .1"/>
<body name="lamp" pos="1 0 2"><joint name="slide" type="slide" axis="1 0 0"/>
<geom name="lamp" type="sphere" size="0.1" mass="1"/></body>
<body name="ball" pos="0 0 0.3"><freejoint/><geom name="foot" type="sphere" size="0.1" mass="2"/></body>
</worldbody></mujoco>"""


def test_the_pages_strips_leave_out_contacts_that_never_touched(tmp_path):
    """As --plot: a contact that never touched draws no strips of zeros (first hour s27: the
    pages of a1 --floating-base --ground and gymnasium's half_cheetah spent seven of their eight
    strips on a trunk contact that never touched); the footnote counts it, and outputs= still
    draws it when named."""
    (tmp_path / "idle.xml").write_text(IDLE)
    model = eomc.compile(MjcfModel(tmp_path / "idle.xml"), functions=["rhs", "jac_x", "outputs", "events", "poses"],
                         cache_dir=tmp_path / "cache", progress=False)
    res = model.simulate(None, (0, 0.5), method="radau")
    assert res.status == 0 and "Fn_lamp" in res.outputs and not np.any(res.outputs["Fn_lamp"])
    assert np.max(res.outputs["Fn_foot"]) > 0
    data = _data(res.animate(fps=20))
    drawn = [data["outputs"][k]["name"] for strip in data["strips"] for k in strip["series"]]
    assert not [n for n in drawn if "lamp" in n], drawn      # lamp's ground contact, lamp__foot's pair
    assert drawn[:3] == ["energy", "Fn_foot", "depth_foot"]     # Ftx_foot: 0 throughout
    assert data["idle_contacts"] == 2
    named = _data(res.animate(fps=20, outputs=["Fn_lamp", "Fn_foot"]))
    assert [o["name"] for o in named["outputs"]] == ["Fn_lamp", "Fn_foot"] and named["idle_contacts"] == 0


STOOL = """<mujoco><option gravity="0 0 -9.81"/><worldbody><geom type="plane" size="5 5 .1"/>
<body name="stool" pos="0 0 0.12"><freejoint/>
<geom name="leg_a" type="sphere" size="0.1" pos="0.3 0.3 0" mass="1"/>
<geom name="leg_b" type="sphere" size="0.1" pos="-0.3 0.3 0" mass="1"/>
<geom name="leg_c" type="sphere" size="0.1" pos="-0.3 -0.3 0" mass="1"/>
<geom name="leg_d" type="sphere" size="0.1" pos="0.3 -0.3 0" mass="1"/></body>
</worldbody></mujoco>"""


@pytest.fixture(scope="module")
def stool(tmp_path_factory):
    where = tmp_path_factory.mktemp("stool")
    (where / "stool.xml").write_text(STOOL)
    model = eomc.compile(MjcfModel(where / "stool.xml"), functions=["rhs", "jac_x", "outputs", "events", "poses"],
                         cache_dir=where / "cache", progress=False)
    names = list(model.output_names)
    assert names.index("energy") > 8      # after the legs' outputs in the model's order
    res = model.simulate(None, (0, 0.3), method="radau")
    assert res.status == 0 and all(np.max(res.outputs[f"Fn_leg_{leg}"]) > 0 for leg in "abcd")
    return res


def test_the_pages_strips_show_the_energy_before_the_contacts(stool):
    """A1 with --floating-base --ground (first hour s28): its page's 8 strips were the first two
    contacts' Fn, Ftx, Fty and depth, and the energy, after 32 contact outputs in the model's
    order, was left off.  The model's own outputs come first, then every contact's normal force,
    then the rest: a four-legged stool's page draws its energy and its four legs' Fn (its Fn and
    depth alone fill the 8 strips)."""
    res = stool
    data = _data(res.animate(fps=20))
    drawn = [data["outputs"][k]["name"] for strip in data["strips"] for k in strip["series"]]
    assert drawn[:5] == ["energy", "Fn_leg_a", "Fn_leg_b", "Fn_leg_c", "Fn_leg_d"], drawn
    assert len(data["strips"]) == 8 and data["strips_left_off"] > 0


def test_plot_panels_hold_one_kind_each_the_energy_first(stool):
    """A1's --plot (first hour s28) drew its energy as the 8th curve of a panel of friction
    forces, and normal and friction forces shared panels by their scale.  The model's own
    outputs come first, then one panel kind each: normal forces, friction forces, depths."""
    from eomc.runtime.plotting import panels
    chosen = [(label, group) for label, group in panels(stool) if label not in ("coordinates", "speeds")]
    assert chosen[0] == ("outputs", ["energy"]), chosen
    assert chosen[1:] == [("contact normal forces", [f"Fn_leg_{leg}" for leg in "abcd"]),
                          ("contact depths", [f"depth_leg_{leg}" for leg in "abcd"])], chosen   # Ftx, Fty: 0
