"""Passive drops with the file's contacts against MuJoCo's mj_step at the model's time step.

From the model's initial state, both fall, touch down and come to rest: the time of the
first touch-down (a geom reaching its contact margin, interpolated between samples) within
2 %, the root body's resting height within 5 mm, and no contact point deeper than its
law's stated penetration (MuJoCo's resting depth, compiler/mjcf/collision.py) several
times over at any sample.  eomc integrates with radau (the contacts are stiff for an
explicit method at MuJoCo's step: the friction's regularisation)."""
import warnings

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

import eomc  # noqa: E402
from eomc.compiler.mjcf.collision import ground_geoms, resting_depth  # noqa: E402
from eomc.compiler.mjcf.compare import to_mujoco  # noqa: E402
from eomc.compiler.mjcf.model import load_mjmodel  # noqa: E402
from eomc.compiler.mjcf.treeir import tree_ir  # noqa: E402

BOX = """<mujoco model="{name}">
  <option timestep="0.002"/>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1" margin="0.002"/>
    <body name="thing" pos="0 0 0.6" euler="0.3 0.2 0.1">
      <freejoint/>
      {geom}
    </body>
  </worldbody>
</mujoco>
"""
GEOMS = {"box": '<geom type="box" size="0.2 0.15 0.05" mass="3"/>',
         "capsule": '<geom type="capsule" size="0.05 0.2" mass="1"/>',
         "sphere": '<geom type="sphere" size="0.1" mass="1" solref="0.01 1"/>',
         "ellipsoid": '<geom type="ellipsoid" size="0.2 0.12 0.05" mass="1"/>'}


def _gym(name):
    import gymnasium
    from pathlib import Path
    return Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / name


def _touchdown(times, lowest):
    """The first time ``lowest`` (the smallest distance minus margin) reaches 0, interpolated."""
    k = int(np.argmax(np.asarray(lowest) <= 0))
    assert lowest[k] <= 0 < lowest[0]
    return times[k - 1] + (times[k] - times[k - 1]) * lowest[k - 1] / (lowest[k - 1] - lowest[k])


def _mujoco_drop(path, T):
    m = load_mjmodel(path)
    d = mujoco.MjData(m)
    pairs = [(g.geom, g.height, mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, g.plane)) for g in ground_geoms(m)]
    times, lowest = [0.0], []

    def low():
        return min(mujoco.mj_geomDistance(m, d, p, g, 10.0, None) - h for g, h, p in pairs)
    mujoco.mj_forward(m, d)
    lowest.append(low())
    while d.time < T - 1e-9:
        mujoco.mj_step(m, d)
        times.append(d.time)
        lowest.append(low())
    return m, d, _touchdown(times, lowest), -min(lowest)


def _eomc_drop(path, T, tmp_path):
    # a function set without "events": the compiler keeps the contacts' gap events anyway
    # (their touch-downs end Radau's steps; without them the sphere's grown free-fall step
    # went through the floor with status 0, issue 29)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(str(path), functions=("rhs", "outputs", "jac_x"), cache_dir=tmp_path, progress=False)
    res = model.simulate(model.initial_state, (0.0, T), method="radau", events=False, n_points=int(T * 2000) + 1)
    depths = [k for k in model.output_names if k.startswith("depth_")]
    deepest = np.array([max(model.outputs(t, x)[k] for k in depths) for t, x in zip(res.t, res.x)])
    return model, res, _touchdown(res.t, -deepest), deepest


def _root_height(m, model, x):
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = to_mujoco(m, tree_ir(m), x[:model.nq], x[model.nq:])
    mujoco.mj_kinematics(m, d)
    return float(d.xpos[1][2])


def _check(path, T, tmp_path):
    m, d, t_mj, theirs_deepest = _mujoco_drop(path, T)
    model, res, t_eomc, deepest = _eomc_drop(path, T, tmp_path)
    assert t_eomc == pytest.approx(t_mj, rel=0.02)
    assert _root_height(m, model, res.x[-1]) == pytest.approx(float(d.xpos[1][2]), abs=0.005)
    # the stated penetration: MuJoCo's resting depth of the geom's contact (its law's k rests
    # there under the whole robot); an impact may go some times deeper, never through (and
    # never deeper than MuJoCo's own contact in the same drop)
    stated = max(resting_depth(m.geom_solref[g.geom], m.geom_solimp[g.geom], 9.81, m.opt.timestep)[0]
                 + g.height for g in ground_geoms(m))
    assert deepest.max() < 5 * stated
    assert deepest.max() < theirs_deepest
    return t_mj, t_eomc


@pytest.mark.parametrize("shape", list(GEOMS))
def test_primitive_drop_matches_mujoco(shape, tmp_path):
    path = tmp_path / f"{shape}.xml"
    path.write_text(BOX.format(name=shape, geom=GEOMS[shape]))
    _check(path, 2.0, tmp_path / "c")


def test_hopper_drop_matches_mujoco(tmp_path):
    """gymnasium's hopper: it lands on its foot, balances for a while, topples and lies still
    (at rest after 15 s on both sides; at 3 s eomc's was still settling)."""
    pytest.importorskip("gymnasium")
    _check(_gym("hopper.xml"), 15.0, tmp_path)
