"""Robots' animation pages in a real browser: one base mesh (no ghost at the origin), no frame
axes by default, and a camera that keeps the robot large on the canvas while it travels.

Go2 and G1 from example-robot-data with a floating base, built with only rhs and poses (a few
seconds each), moved along a prescribed path of 3 m: a camera that fitted the whole path would
show the robot small; the page must follow it.
"""
import json
import re
import sys
from pathlib import Path

import numpy as np
import pytest

import eomc
from eomc.compiler.urdf.model import UrdfModel
from eomc.runtime.animate import MIN_SHORT_SIDE, animate_2d
from eomc.runtime.result import SimulationResult
from helpers.robots import robot_path

from .test_animate import MAGENTA, _magenta, _open, _project

ROBOTS = {"go2": ("go2_description/urdf/go2.urdf", 0.45), "g1": ("g1_description/urdf/g1_29dof_rev_1_0.urdf", 0.8)}
# the robot's pixels (the grid hidden) cover at least this share of the scene's canvas, and
# its pixels span at least 40 % of the canvas's height (a humanoid is thin: 3-4 % of the area)
MIN_COVER = 0.03


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("cache")


def _walk(model, height):
    """A prescribed run: the base travels 3 m along x at a constant height while it turns."""
    t = np.linspace(0.0, 2.0, 121)
    x = np.zeros((len(t), model.nx))
    x[:, 0] = 1.0 + 1.5 * t
    x[:, 2] = height
    x[:, 5] = 0.3 * t
    return SimulationResult(t=t, x=x, state_names=model.state_names, stats={}, model_name=model.name,
                            nq=model.nq, model=model)


@pytest.mark.parametrize("robot", sorted(ROBOTS))
def test_floating_robot_page(robot, cache, tmp_path):
    path, height = ROBOTS[robot]
    # the poses only: the run is prescribed (_walk), no rhs is called, and the page is drawn from
    # the poses function and its geometry metadata, the same C with or without rhs (G1's build
    # 3.3 -> 1.0 s CPU)
    model = eomc.compile(UrdfModel(robot_path(path), floating_base=True), functions=["poses"],
                         cache_dir=cache, progress=False)
    base = model.state_names[0][2:].split("_floating")[0]
    geometry = model.metadata["poses"]["geometry"]
    assert "world" not in geometry, "the floating base's visuals are also drawn at the world origin"
    elsewhere = [k for k, shapes in geometry.items() for s in shapes if s.get("link") == base and k != base]
    assert base in geometry and not elsewhere, f"the base link's mesh is drawn under {elsewhere} too"
    res = _walk(model, height)
    page = tmp_path / f"{robot}.html"
    anim = res.animate(page, colors={base: MAGENTA})
    data = json.loads(re.search(r'id="eomc-data">(.*?)</script>', anim.html, re.S).group(1))
    assert data["axes"] is False and data["camera"]["follow"]
    assert not any(0 in line for line in data["lines"]), "a line from the world origin to the base"
    shape = data["geometry"][base][0]      # where the base's (first) mesh has its centre
    mesh = data["meshes"][shape["mesh"]]
    local = (np.reshape(shape["origin"], (4, 4)) @ np.append((np.array(mesh["lo"]) + mesh["hi"]) / 2, 1.0))[:3]
    for t in (0.0, 2.0):
        i = int(round(t * 60))
        pixels, attrs = _open(page, f"{t}&grid=0", tmp_path)   # the grid hidden: the rest is the robot
        assert attrs.get("ready") == "1" and "errors" not in attrs, attrs.get("errors")
        assert attrs.get("axes") == "0"
        view = json.loads(attrs["view"])
        centre, count = _magenta(pixels)
        expected = _project(view, anim.poses[base][i] + anim.poses.rotation(base)[i] @ local)
        assert np.linalg.norm(centre - expected) < 30, (t, centre, expected)
        origin = _project(view, np.zeros(3))
        r, g, b = pixels[..., 0], pixels[..., 1], pixels[..., 2]
        ys, xs = np.nonzero((r > 150) & (b > 150) & (g < 90))
        assert not np.any(np.hypot(xs - origin[0], ys - origin[1]) < 40), "a magenta base at the origin"
        top, left = int(view["top"]), int(view["left"])
        canvas = pixels[top:top + int(view["height"]), left:left + int(view["width"])]
        drawn = np.abs(canvas - np.array([0xf4, 0xf5, 0xf7])).max(axis=2) > 24
        cover = drawn.mean()
        ys, xs = np.nonzero(drawn)
        tall = (ys.max() - ys.min()) / canvas.shape[0]
        print(f"{robot} t={t}: cover {cover:.3f}, height share {tall:.2f}")
        assert cover >= MIN_COVER and tall >= 0.4, (robot, t, cover, tall)


@pytest.fixture(scope="module")
def hopper(cache):
    gym = pytest.importorskip("gymnasium")
    from eomc.compiler.mjcf import MjcfModel
    path = Path(gym.__file__).parent / "envs" / "mujoco" / "assets" / "hopper.xml"
    # no ground (geoms=False): the round-4 case, a hopper that falls 20 m
    model = eomc.compile(MjcfModel(path, geoms=False), functions=["rhs", "poses"], cache_dir=cache,
                         progress=False)
    return model, model.simulate(model.initial_state, (0.0, 2.0), n_points=81, method="dop853")


def test_hopper_gif_follows_the_fall(hopper, tmp_path):
    """The hopper falls about 20 m (its ground left out): a GIF fitted to the
    whole fall drew it as a 58x348 sliver; the view follows it at its own size instead."""
    from PIL import Image
    model, res = hopper
    gif = animate_2d(res, tmp_path / "hopper.gif", model=model)
    with Image.open(gif) as im:
        assert min(im.size) >= MIN_SHORT_SIDE and max(im.size) <= 2.3 * min(im.size), im.size
        frames = []
        for i in (0, im.n_frames - 1):
            im.seek(i)
            frames.append(np.asarray(im.convert("RGB"), dtype=int))
    for pixels in frames:   # the skeleton's dark lines are in the picture, and not as a sliver
        ys, xs = np.nonzero(pixels.max(axis=2) < 90)
        assert len(xs) > 200
        assert (ys.max() - ys.min()) > 0.3 * pixels.shape[0]


def test_mp4_through_the_bundled_ffmpeg(hopper, tmp_path, monkeypatch):
    """No ffmpeg on PATH: the imageio-ffmpeg wheel's binary writes the MP4; without that
    either, one line names the extra to install."""
    pytest.importorskip("imageio_ffmpeg")
    import eomc.runtime.animate as animate_module
    model, res = hopper
    monkeypatch.setattr(animate_module.shutil, "which", lambda name: None)
    out = animate_2d(res, tmp_path / "hopper.mp4", model=model, t_max=0.5)
    assert out.stat().st_size > 1000 and out.read_bytes()[4:8] == b"ftyp"
    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)
    with pytest.raises(ValueError, match=r'pip install "\.\[video\]" in eomc\'s clone'):
        animate_2d(res, tmp_path / "again.mp4", model=model)


def test_page_never_plots_rotations_or_jacobians():
    """A frame output is summed up by its position (one strip of three curves); R, J, v and w
    entries are left out; at most 8 strips, the rest counted."""
    from eomc.runtime.animate import _strips, page_outputs
    names = ["energy"] + [f"foot.p.{a}" for a in "xyz"] + [f"foot.R[{i}][{j}]" for i in range(3) for j in range(3)]
    names += [f"foot.{k}.{a}" for k in "vw" for a in "xyz"] + [f"foot.J[{i}][{j}]" for i in range(6) for j in range(18)]
    names += [f"com.p.{a}" for a in "xyz"] + [f"com.v.{a}" for a in "xyz"]
    shown = page_outputs(names)
    assert shown == ["energy", "foot.p.x", "foot.p.y", "foot.p.z", "com.p.x", "com.p.y", "com.p.z"]
    strips, left_off = _strips(shown)
    assert [s["label"] for s in strips] == ["energy", "foot.p", "com.p"] and left_off == 0
    strips, left_off = _strips([f"f{k}" for k in range(11)])
    assert len(strips) == 8 and left_off == 3
