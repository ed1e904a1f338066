"""Issue 33: passive drops of gymnasium models with the file's contacts, eomc vs MuJoCo's mj_step.

Per model (all 11 of the gymnasium wheel's envs/mujoco/assets; humanoid again
without its self-collision pairs, which eomc has by default since session 11 as MuJoCo has, and
which ``pairs="trees"`` / ``--pairs trees`` leaves out), both start at the
model's initial state (MuJoCo's qpos0) with no control and run T seconds (15 s: long enough
for MuJoCo's ant, whose feet slide out under its soft friction for about 12 s, to come to
rest; at 3 s, the length this table had before, MuJoCo's ant was still 173 mm above its rest):

- MuJoCo: ``mj_step`` at the file's time step and integrator (its own contacts, limits,
  constraints);
- eomc: ``eomc.compile(path)`` with no flags (the file's contacts mapped to eomc's law,
  limits and frictionloss as eomc models them), ``model.simulate(..., method="radau")``,
  2000 output points per second.

Columns: first touch-down (the lowest contact distance minus the pair's margin reaching
zero, interpolated between samples; MuJoCo's from ``mj_geomDistance`` at each step's end
state, a fresh ``mj_kinematics``: after ``mj_step`` with the Euler integrators the data's
geom poses are the step's start, and read from them, as this table did until 2026-11-29
14:50, half_cheetah's touch-down was one 10 ms step late, 0.1299 s; "-": none in the run),
MuJoCo's touch-down again with its time step divided by 10 (same integrator: where its
discrete fall converges), eomc's touch-down in its fixed-step run at the file's time step h
(implicitfast through bench_fixedstep's C call: no events, simulate's default residual check;
depths sampled at each step's end) with its difference from mj_step at h (the file's integrator),
and MuJoCo's touch-down with implicitfast at h (the same scheme as eomc's) and the difference from
it, the root body's height at T and MuJoCo's largest |qvel| there (at rest or not), the
deepest contact penetration over the run (eomc: beyond the law's surface, i.e. below the
margin; MuJoCo: -min dist + margin over its contacts), wall and CPU time of each simulation
(MuJoCo's Python loop of mj_step: its cost is mostly the loop's).

"statics": eomc started at MuJoCo's state at T with zero speeds and run 5 s more: the root's
height then minus MuJoCo's.  It compares the two models' resting laws (contact penetration,
the give of limits under load) on the same pose, apart from the path a fall takes: a model
that topples from an unstable stance (walker2d on its straight legs) can come to rest in
another pose than MuJoCo's, while MuJoCo's rest is also eomc's.

Findings (2026-11-29, helper drops; scripts' figures quoted here, the table's from this run):

- At the same time step (the issue's "compared with MuJoCo's mj_step at the same time step"),
  eomc's fixed-step run lands within 1.1 % of mj_step on every drop model, half_cheetah included
  (0.1199 s in both: implicitfast's implicit Euler update falls exactly as MuJoCo's semi-implicit
  Euler, x_n = x_0 - g t_n (t_n + h)/2), and within 0.0-2.7 % of MuJoCo's implicitfast at h
  (2026-12-01: ant +0.2 % / +2.7 %, was -0.7 % / +1.7 % before session 21 located a touch-down
  inside the fixed step instead of halving to it; the other rows unchanged to the table's digits).
  Against the file's RK4 (hopper, walker2d, ant, humanoid) the first-order fixed step lands up to
  about h/2 early (hopper -1.1 % at 2 ms).  The adaptive (radau) column lands at the exact fall,
  so it matches MuJoCo where MuJoCo's step converges (h/10, or RK4 at h).

- half_cheetah's touch-down is a free fall of its back foot (bfoot, the lower end sphere of
  its capsule: 0.076406 m above the plane at the start in both, eomc's depth output and
  ``mj_geomDistance`` equal to 1e-6; no margin, no gap).  The exact fall lands at
  sqrt(2D/g) = 0.1248 s, eomc's touch-down.  MuJoCo's file step is 10 ms with the Euler
  integrator, whose semi-implicit update falls ahead, x_n = x_0 - g t_n (t_n + h)/2, so it
  lands at -h/2 + sqrt(h^2/4 + 2D/g) = 0.1199 s (measured 0.1199), 4 % before the exact fall;
  at h/10 0.1243.  No contact mapping makes a continuous-time model land at 0.1199: the
  bar "within 2 % of mj_step at the same step" is out of reach at a 10 ms Euler step for any
  exact integration; eomc is within 0.4 % of MuJoCo at h/10 (the RK4 models, hopper,
  walker2d, ant, humanoid, land at the same time to 1.6 %).
- half_cheetah's resting height +6.6 mm at 15 s is friction creep not yet ended: MuJoCo rests
  at the same pose at h, h/4, h/16 (z 0.5676, joints equal to 1e-4); eomc is still moving at
  15 s (|qvel| up to 1.6e-3; the friction's regularisation, v_s = 0.01 m/s) toward that pose
  (z 0.5742 at 15 s, 0.5696 at 30 s with |qvel| 3.7e-4, joints closing on MuJoCo's: bthigh
  0.021 / 0.031 vs 0.034).  Statics (eomc from MuJoCo's rest) +0.6 mm: the laws agree.
- walker2d's +5.9 mm is another resting pose, not the contact law: MuJoCo lies with its root
  pitched -4.05 rad and thighs at -2.22 rad, eomc at -2.27 and -0.55 (statics -3.3 mm).
  MuJoCo's own rest does not move with its step (h/4, h/16: z 0.1729, joints equal to 1e-4),
  so it is no chaotic sensitivity of MuJoCo's fall.  The paths part while the walker topples
  from its straight-legged stance (0.3-0.6 s): MuJoCo's thighs give, eomc's stay at 0.000
  and its knees bend.  Both thigh and knee start at the upper end of their ranges
  (range -150..0 deg, qpos0 = 0): the limit law at the range's edge chooses the mode.  With
  ``<flag limit="disable"/>`` in the file, both fall the same way and lie at the same pose
  (root z 0.050 both, every joint within 0.002 rad at 15 s).  The limit rule is
  compiler/mjcf/carried.py's (helper dmlimit's this session), not the contact mapping.
"""
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import environment_header, format_table, write_results  # noqa: E402

# (file stem, T, row label, eomc's body-body pairs: MjcfModel(pairs=...), None the default: all,
# self-collisions included; "trees": none within one tree, the default before session 11)
T = 15.0
# walker2d and half_cheetah 30 s: at 15 s eomc's were still creeping under the friction's
# regularisation (|qvel| up to 0.029 and 1.6e-3) while MuJoCo's were at rest
MODELS = [(stem, T, stem, None) for stem in ("hopper", "ant", "humanoid")] + [
    ("humanoid", T, "humanoid, pairs=trees", "trees")] + [("walker2d", 2 * T, "walker2d", None),
                                                      ("half_cheetah", 2 * T, "half_cheetah", None)] + [
    (stem, T, stem, None) for stem in ("humanoidstandup", "inverted_pendulum",
                                       "inverted_double_pendulum", "pusher", "reacher", "swimmer")]
STATICS = 5.0
FINE = 10          # MuJoCo again at timestep / FINE for the touch-down


def _touchdown(times, lowest):
    lowest = np.asarray(lowest)
    if lowest.size == 0:
        return float("nan")
    k = int(np.argmax(lowest <= 0))
    if lowest[k] > 0 or k == 0:
        return float("nan")
    return times[k - 1] + (times[k] - times[k - 1]) * lowest[k - 1] / (lowest[k - 1] - lowest[k])


def _mujoco_lowest(m):
    """lowest(d): the smallest contact distance minus margin at d's state, from a fresh
    ``mj_kinematics`` of d.qpos: after ``mj_step`` with the Euler integrators d.geom_xpos are
    still the step's start (its mj_forward ran before the update), one step late; read from them
    half_cheetah's touch-down (10 ms step) was 0.1299 s instead of 0.1199 s."""
    import mujoco
    from eomc.compiler.mjcf.collision import ground_geoms
    pairs = [(g.geom, g.height, mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, g.plane)) for g in ground_geoms(m)]
    end = mujoco.MjData(m)

    def lowest(d):
        end.qpos[:] = d.qpos
        mujoco.mj_kinematics(m, end)
        return min(mujoco.mj_geomDistance(m, end, p, g, 10.0, None) - h for g, h, p in pairs)
    return lowest if pairs else None


def mujoco_drop(path, T):
    import mujoco
    from eomc.compiler.mjcf.model import load_mjmodel
    m = load_mjmodel(path)
    d = mujoco.MjData(m)
    lowest_at = _mujoco_lowest(m)
    times, lowest = [0.0], [lowest_at(d)] if lowest_at else []
    wall = cpu = 0.0                     # of the mj_step calls only (not the sampling)
    while d.time < T - 1e-9:
        t0, c0 = time.perf_counter(), time.process_time()
        mujoco.mj_step(m, d)
        wall, cpu = wall + time.perf_counter() - t0, cpu + time.process_time() - c0
        if lowest_at:
            times.append(d.time)
            lowest.append(lowest_at(d))
    deepest = max(0.0, -min(lowest)) if lowest else 0.0
    return (_touchdown(times, lowest), float(d.xpos[1][2]), deepest, wall, cpu, float(np.abs(d.qvel).max()),
            d.qpos.copy())


def mujoco_touchdown_fine(path, until, divide=FINE, integrator=None):
    """MuJoCo's first touch-down with its time step divided by ``divide`` (same integrator, or the
    mjtIntegrator named, e.g. "IMPLICITFAST"): where its discrete fall converges to (the
    semi-implicit Euler of a 10 ms step lands h/2 early in a free fall: t(t + h) = 2D/g).  Runs
    until the touch-down or ``until``."""
    import mujoco
    from eomc.compiler.mjcf.model import load_mjmodel
    m = load_mjmodel(path)
    m.opt.timestep /= divide
    if integrator is not None:
        m.opt.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator}")
    d = mujoco.MjData(m)
    lowest_at = _mujoco_lowest(m)
    times, lowest = [0.0], [lowest_at(d)]
    while d.time < until - 1e-9 and lowest[-1] > 0:
        mujoco.mj_step(m, d)
        times.append(d.time)
        lowest.append(lowest_at(d))
    return _touchdown(times, lowest)


def eomc_touchdown_fixed(model, dt, until):
    """eomc's first touch-down in its fixed-step run at ``dt`` (the file's time step): implicitfast
    through bench_fixedstep's C call (what a control loop runs: no events, simulate's default
    residual check), the depth outputs sampled at every step's end and interpolated as MuJoCo's.
    Its update is implicit Euler, which in a free fall is MuJoCo's semi-implicit Euler: both land
    at t(t + h) = 2D/g."""
    from bench_fixedstep import eomc_call
    n = int(np.ceil(until / dt))
    grid = dt * np.arange(n + 1)
    call, x_out, _, stats = eomc_call(model, model.initial_state, dt, t1=grid[-1], t_eval=grid)
    call()
    deep = [max(v for k, v in model.outputs(t, x).items() if k.startswith("depth_")) for t, x in zip(grid, x_out)]
    return _touchdown(grid, -np.asarray(deep))


def eomc_drop(path, T, cache, pairs=None, rest_qpos=None, fixed_until=None):
    import eomc
    from eomc.compiler.mjcf import MjcfModel
    import mujoco
    from eomc.compiler.mjcf.compare import to_mujoco, tree_of
    from eomc.compiler.mjcf.model import load_mjmodel
    # with the events function, as eomc.compile builds by default: the contacts' touch-downs are
    # the switching functions that end radau's steps at the onset; without it a grown free-fall
    # step carried half_cheetah's foot 80 mm into the floor (and the damping held it there)
    # and, for a model that touches down, NAME_implicit: the fixed-step touch-down's implicitfast
    # path (bench_fixedstep's; generated for models with ground contacts only)
    model = eomc.compile(MjcfModel(Path(path), pairs=pairs) if pairs else str(path),
                         functions=("rhs", "outputs", "jac_x", "events") + (("implicit",) if fixed_until else ()),
                         cache_dir=cache, progress=False)
    m = load_mjmodel(path)
    td_fixed = float("nan") if fixed_until is None else eomc_touchdown_fixed(model, m.opt.timestep, fixed_until)
    t0, c0 = time.perf_counter(), time.process_time()
    res = model.simulate(model.initial_state, (0.0, T), method="radau", n_points=int(T * 2000) + 1)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    depths = [k for k in model.output_names if k.startswith("depth_")]
    deep = np.max([res.outputs[k] for k in depths], axis=0) if depths else np.full(len(res.t), -1.0)
    built = tree_of(m, model)
    d = mujoco.MjData(m)

    def root_z(x):
        d.qpos[:], d.qvel[:] = to_mujoco(m, built, x[:model.nq], x[model.nq:model.nq + model.nu])
        mujoco.mj_kinematics(m, d)
        return float(d.xpos[1][2])
    z = root_z(res.x[-1])
    v = float(np.abs(d.qvel).max())     # at T (root_z set it): still moving or at rest
    statics = float("nan")
    if rest_qpos is not None:        # MuJoCo's rest, zero speeds (activations: none in these files)
        from eomc.compiler.mjcf.compare import from_mujoco
        q, u = from_mujoco(m, built, rest_qpos, np.zeros(m.nv))
        x0 = np.concatenate([q, 0 * np.asarray(u), np.zeros(len(model.state_names) - model.nq - model.nu)])
        again = model.simulate(x0, (0.0, STATICS), method="radau", n_points=11)
        statics = root_z(again.x[-1])
    return (_touchdown(res.t, -deep) if depths else float("nan"), z, float(max(deep.max(), 0.0)) if depths else 0.0,
            wall, cpu, len(depths), statics, v, td_fixed)


def main():
    import gymnasium
    import mujoco
    import tempfile
    folder = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets"
    rows, csv = [], []
    with tempfile.TemporaryDirectory(prefix="bench_drops_") as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        only = [a for a in sys.argv[1:] if not a.startswith("-")]     # model names: only these (not written)
        for stem, T, label, pairs in MODELS:
            if only and stem not in only:
                continue
            path = folder / f"{stem}.xml"
            td_m, z_m, deep_m, wall_m, cpu_m, v_m, rest = mujoco_drop(path, T)
            td_f = float("nan") if np.isnan(td_m) else mujoco_touchdown_fine(path, 2 * td_m)
            td_i = float("nan") if np.isnan(td_m) else mujoco_touchdown_fine(path, 2 * td_m, 1, "IMPLICITFAST")
            td_e, z_e, deep_e, wall_e, cpu_e, points, z_s, v_e, td_x = eomc_drop(
                path, T, Path(tmp), pairs, rest, None if np.isnan(td_m) else 2 * td_m)

            def when(t):
                return "-" if np.isnan(t) else f"{t:.4f}"
            def rel(a, b):
                return "-" if np.isnan(a) or np.isnan(b) else f"{100 * (a / b - 1):+.1f} %"
            rows.append([label, f"{T:g}", str(points), when(td_m), when(td_e), rel(td_e, td_m), when(td_f),
                         rel(td_e, td_f), when(td_x), rel(td_x, td_m), when(td_i), rel(td_x, td_i),
                         f"{z_m:.4f}", f"{v_m:.0e}", f"{z_e:.4f}", f"{v_e:.0e}", f"{1e3 * (z_e - z_m):+.1f}",
                         f"{1e3 * (z_s - z_m):+.1f}", f"{1e3 * deep_m:.2f}",
                         f"{1e3 * deep_e:.2f}", f"{wall_m:.2f}/{cpu_m:.2f}", f"{wall_e:.2f}/{cpu_e:.2f}"])
            csv.append([label, T, points, td_m, td_e, td_f, td_x, td_i, z_m, v_m, z_e, v_e, z_s, deep_m, deep_e, wall_m, cpu_m, wall_e,
                        cpu_e])
            print(" | ".join(rows[-1]), flush=True)
    headers = ["model", "T s", "eomc points", "touch-down MuJoCo s", "touch-down eomc s", "diff",
               f"touch-down MuJoCo h/{FINE} s", f"diff vs h/{FINE}", "touch-down eomc implicitfast h s",
               "diff vs mj_step h", "touch-down mj_step implicitfast h s", "diff vs it", "root z MuJoCo m",
               "MuJoCo max abs qvel", "root z eomc m",
               "eomc max abs qvel", "diff mm", "statics diff mm", "deepest MuJoCo mm",
               "deepest eomc mm", "MuJoCo wall/CPU s", "eomc radau wall/CPU s"]
    load = os.getloadavg()
    text = environment_header("Passive drops with the file's contacts: eomc (radau) vs MuJoCo mj_step",
                              notes=(f"load average at end {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} on a shared "
                                     f"2-core machine",
                                     f"models from gymnasium {gymnasium.__version__}'s wheel; mujoco {mujoco.__version__}"))
    text += "\n" + format_table(headers, rows) + "\n\n" + (__doc__ or "")
    if only:
        print(format_table(headers, rows))
        return
    headers_csv = ["model", "T", "points", "touchdown_mujoco", "touchdown_eomc", "touchdown_mujoco_fine",
                   "touchdown_eomc_implicitfast_h", "touchdown_mujoco_implicitfast_h",
                   "root_z_mujoco", "qvel_max_mujoco", "root_z_eomc", "qvel_max_eomc",
                   "root_z_eomc_from_mujoco_rest", "deepest_mujoco", "deepest_eomc",
                   "wall_mujoco", "cpu_mujoco", "wall_eomc", "cpu_eomc"]
    print(write_results("mjcf_drops", text, csv, headers_csv, keep_notes=True))


if __name__ == "__main__":
    main()
