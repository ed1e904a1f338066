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
from eomc.compiler.mjcf.compare import to_mujoco, tree_of  # noqa: E402
from eomc.compiler.mjcf.model import load_mjmodel  # noqa: E402

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


def _mujoco_drop(path, T, until_touch=False):
    """MuJoCo's run: (m, d, touch-down time, deepest distance below the margins).  The distances
    are read at each step's end state (a fresh mj_kinematics): after mj_step with the Euler
    integrators d.geom_xpos are still the step's start, one step late."""
    m = load_mjmodel(path)
    d, end = mujoco.MjData(m), mujoco.MjData(m)
    pairs = [(g.geom, g.height, mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, g.plane)) for g in ground_geoms(m)]
    times, lowest = [0.0], []

    def low():
        end.qpos[:] = d.qpos
        mujoco.mj_kinematics(m, end)
        return min(mujoco.mj_geomDistance(m, end, p, g, 10.0, None) - h for g, h, p in pairs)
    lowest.append(low())
    while d.time < T - 1e-9 and not (until_touch and lowest[-1] <= 0):
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
    d.qpos[:], d.qvel[:] = to_mujoco(m, tree_of(m, model), x[:model.nq], x[model.nq:])
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


CAPSULE = """<mujoco model="capsule_margin">
  <option timestep="{h}" integrator="{integrator}"/>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1" margin="0.004"/>
    <body name="thing" pos="0 0 0.4" euler="0.4 0.3 0">
      <freejoint/>
      <geom type="capsule" size="0.05 0.2" mass="1" margin="0.01"/>
    </body>
  </worldbody>
</mujoco>
"""


@pytest.mark.parametrize("h, integrator", [(0.01, "Euler"), (0.01, "RK4"), (0.001, "Euler")])
def test_capsule_with_margin_touches_down_at_the_free_fall_time(h, integrator, tmp_path):
    """A tilted capsule with margins (geom 10 mm + plane 4 mm) falls freely until its lower end
    sphere is the summed margin above the plane.  eomc's touch-down is the exact fall's,
    sqrt(2 D / g) with D MuJoCo's distance at the start minus the margin; MuJoCo's at its own
    step is its integrator's: semi-implicit Euler lands h/2 early (t (t + h) = 2 D / g: 0.1199
    instead of 0.1248 s for half_cheetah at 10 ms), RK4 exactly.  Both within 1 % of the exact
    fall at 1 ms (and with RK4 at 10 ms)."""
    path = tmp_path / "capsule.xml"
    path.write_text(CAPSULE.format(h=h, integrator=integrator))
    m, _, t_mj, _ = _mujoco_drop(path, 1.0, until_touch=True)
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    (geom,) = ground_geoms(m)
    assert geom.height == pytest.approx(0.014, abs=1e-15)                 # the plane raised by both margins
    D = mujoco.mj_geomDistance(m, d, 0, geom.geom, 10.0, None) - geom.height
    g = 9.81
    exact = np.sqrt(2 * D / g)
    model, res, t_eomc, _ = _eomc_drop(path, 0.4, tmp_path / "c")
    assert t_eomc == pytest.approx(exact, rel=1e-3)
    euler = -h / 2 + np.sqrt(h * h / 4 + 2 * D / g)
    assert t_mj == pytest.approx(euler if integrator == "Euler" else exact, rel=2e-3)
    if integrator == "RK4" or h <= 0.001:
        assert t_eomc == pytest.approx(t_mj, rel=0.01)


def test_fixed_step_at_mujocos_step_touches_down_with_mj_step(tmp_path):
    """The issue's "compared with mj_step at the same time step": eomc's fixed step (implicitfast
    at the file's 10 ms) updates as implicit Euler, which in a free fall is MuJoCo's semi-implicit
    Euler, x_n = x_0 - g t_n (t_n + h)/2: every sample before the touch-down is MuJoCo's and both
    reach the floor in the same step.  Since session 21 the fixed step locates a touch-down inside
    its step (runtime/c/eomc_fixedstep.c fs_onset_cell) and the contact acts from there, so the
    sample after it is the located landing's: the touch-down interpolated between samples is
    within 1 % of the exact fall's (measured 0.35 %), while MuJoCo's, whose contact acts from a
    step's start, lands 3 % early at this step (0.1616 s against 0.1665 s exact; eomc 0.1671 s,
    3.4 % after mj_step: the 2 % against mj_step that this test asserted before session 21 holds
    at 5 ms (0.19 %) and 2 ms (0.03 %), where MuJoCo's own error is small)."""
    h = 0.01
    path = tmp_path / "capsule.xml"
    path.write_text(CAPSULE.format(h=h, integrator="Euler"))
    m, _, t_mj, _ = _mujoco_drop(path, 1.0, until_touch=True)
    (geom,) = ground_geoms(m)
    d = mujoco.MjData(m)
    z_mj, lowest_mj = [], []
    while not lowest_mj or lowest_mj[-1] > 0:
        z_mj.append(float(d.qpos[2]))
        mujoco.mj_kinematics(m, d)
        lowest_mj.append(mujoco.mj_geomDistance(m, d, 0, geom.geom, 10.0, None) - geom.height)
        mujoco.mj_step(m, d)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(str(path), functions=("rhs", "outputs", "jac_x", "implicit"), cache_dir=tmp_path / "c",
                             progress=False)
    grid = h * np.arange(41)
    res = model.simulate(model.initial_state, (0.0, grid[-1]), method="implicitfast", dt=h, t_eval=grid,
                         events=False)
    assert res.status == 0
    depths = [k for k in model.output_names if k.startswith("depth_")]
    lowest = [-max(model.outputs(t, x)[k] for k in depths) for t, x in zip(res.t, res.x)]
    landed = int(np.argmax(np.asarray(lowest) <= 0))
    assert landed == len(lowest_mj) - 1                             # the same step
    z = res.x[:landed, model.state_names.index("q_joint0_z")]
    assert np.max(np.abs(z - z_mj[:landed])) < 1e-12
    assert np.max(np.abs(z - (0.4 - 9.81 * grid[:landed] * (grid[:landed] + h) / 2))) < 1e-12
    t_fixed = _touchdown(res.t, lowest)
    exact = np.sqrt(2 * lowest_mj[0] / 9.81)
    assert t_fixed == pytest.approx(exact, rel=0.01)
    assert exact / t_mj - 1 > 0.02
