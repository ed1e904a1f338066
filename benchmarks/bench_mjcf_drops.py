"""Issue 33: passive drops of gymnasium models with the file's contacts, eomc vs MuJoCo's mj_step.

Per model (all 11 of the gymnasium wheel's envs/mujoco/assets; humanoid again with its
self-collision pairs, which eomc leaves out by default and MuJoCo has), both start at the
model's initial state (MuJoCo's qpos0) with no control and run T seconds (15 s: long enough
for MuJoCo's ant, whose feet slide out under its soft friction for about 12 s, to come to
rest; at 3 s, the length this table had before, MuJoCo's ant was still 173 mm above its rest):

- MuJoCo: ``mj_step`` at the file's time step and integrator (its own contacts, limits,
  constraints);
- eomc: ``eomc.compile(path)`` with no flags (the file's contacts mapped to eomc's law,
  limits and frictionloss as eomc models them), ``model.simulate(..., method="radau")``,
  2000 output points per second.

Columns: first touch-down (the lowest contact distance minus the pair's margin reaching
zero, interpolated between samples; MuJoCo's from ``mj_geomDistance``; "-": none in the
run), the root body's height at T and MuJoCo's largest |qvel| there (at rest or not), the
deepest contact penetration over the run (eomc: beyond the law's surface, i.e. below the
margin; MuJoCo: -min dist + margin over its contacts), wall and CPU time of each simulation
(MuJoCo's Python loop of mj_step: its cost is mostly the loop's).

"statics": eomc started at MuJoCo's state at T with zero speeds and run 5 s more: the root's
height then minus MuJoCo's.  It compares the two models' resting laws (contact penetration,
the give of limits under load) on the same pose, apart from the path a fall takes: a model
that topples from an unstable stance (walker2d on its straight legs) can come to rest in
another pose than MuJoCo's, while MuJoCo's rest is also eomc's.
"""
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import environment_header, format_table, write_results  # noqa: E402

# (file stem, T, row label, eomc's self-collision pairs: MjcfModel(pairs=True))
T = 15.0
MODELS = [(stem, T, stem, None) for stem in ("hopper", "walker2d", "ant", "humanoid")] + [
    ("humanoid", T, "humanoid, pairs=True", True)] + [
    (stem, T, stem, None) for stem in ("half_cheetah", "humanoidstandup", "inverted_pendulum",
                                       "inverted_double_pendulum", "pusher", "reacher", "swimmer")]
STATICS = 5.0


def _touchdown(times, lowest):
    lowest = np.asarray(lowest)
    if lowest.size == 0:
        return float("nan")
    k = int(np.argmax(lowest <= 0))
    if lowest[k] > 0 or k == 0:
        return float("nan")
    return times[k - 1] + (times[k] - times[k - 1]) * lowest[k - 1] / (lowest[k - 1] - lowest[k])


def mujoco_drop(path, T):
    import mujoco
    from eomc.compiler.mjcf.collision import ground_geoms
    from eomc.compiler.mjcf.model import load_mjmodel
    m = load_mjmodel(path)
    d = mujoco.MjData(m)
    pairs = [(g.geom, g.height, mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, g.plane)) for g in ground_geoms(m)]
    times, lowest, deepest = [], [], 0.0
    t0, c0 = time.perf_counter(), time.process_time()
    while d.time < T - 1e-9:
        mujoco.mj_step(m, d)
        if pairs:
            times.append(d.time)
            low = min(mujoco.mj_geomDistance(m, d, p, g, 10.0, None) - h for g, h, p in pairs)
            lowest.append(low)
            deepest = max(deepest, -low)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return (_touchdown(times, lowest), float(d.xpos[1][2]), deepest, wall, cpu, float(np.abs(d.qvel).max()),
            d.qpos.copy())


def eomc_drop(path, T, cache, pairs=None, rest_qpos=None):
    import eomc
    from eomc.compiler.mjcf import MjcfModel
    import mujoco
    from eomc.compiler.mjcf.compare import to_mujoco
    from eomc.compiler.mjcf.model import load_mjmodel
    from eomc.compiler.mjcf.treeir import tree_ir
    # with the events function, as eomc.compile builds by default: the contacts' touch-downs are
    # the switching functions that end radau's steps at the onset; without it a grown free-fall
    # step carried half_cheetah's foot 80 mm into the floor (and the damping held it there)
    model = eomc.compile(MjcfModel(Path(path), pairs=pairs) if pairs else str(path),
                         functions=("rhs", "outputs", "jac_x", "events"), cache_dir=cache, progress=False)
    t0, c0 = time.perf_counter(), time.process_time()
    res = model.simulate(model.initial_state, (0.0, T), method="radau", n_points=int(T * 2000) + 1)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    depths = [k for k in model.output_names if k.startswith("depth_")]
    deep = np.array([max([model.outputs(t, x)[k] for k in depths] or [-1.0]) for t, x in zip(res.t, res.x)])
    m = load_mjmodel(path)
    built = tree_ir(m)
    d = mujoco.MjData(m)

    def root_z(x):
        d.qpos[:], d.qvel[:] = to_mujoco(m, built, x[:model.nq], x[model.nq:model.nq + model.nu])
        mujoco.mj_kinematics(m, d)
        return float(d.xpos[1][2])
    z = root_z(res.x[-1])
    statics = float("nan")
    if rest_qpos is not None:        # MuJoCo's rest, zero speeds (activations: none in these files)
        from eomc.compiler.mjcf.compare import from_mujoco
        q, u = from_mujoco(m, built, rest_qpos, np.zeros(m.nv))
        x0 = np.concatenate([q, 0 * np.asarray(u), np.zeros(len(model.state_names) - model.nq - model.nu)])
        again = model.simulate(x0, (0.0, STATICS), method="radau", n_points=11)
        statics = root_z(again.x[-1])
    return (_touchdown(res.t, -deep) if depths else float("nan"), z, float(max(deep.max(), 0.0)) if depths else 0.0,
            wall, cpu, len(depths), statics)


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
            td_e, z_e, deep_e, wall_e, cpu_e, points, z_s = eomc_drop(path, T, Path(tmp), pairs, rest)

            def when(t):
                return "-" if np.isnan(t) else f"{t:.4f}"
            rows.append([label, f"{T:g}", str(points), when(td_m), when(td_e),
                         "-" if np.isnan(td_m) or np.isnan(td_e) else f"{100 * (td_e / td_m - 1):+.1f} %",
                         f"{z_m:.4f}", f"{v_m:.0e}", f"{z_e:.4f}", f"{1e3 * (z_e - z_m):+.1f}",
                         f"{1e3 * (z_s - z_m):+.1f}", f"{1e3 * deep_m:.2f}",
                         f"{1e3 * deep_e:.2f}", f"{wall_m:.2f}/{cpu_m:.2f}", f"{wall_e:.2f}/{cpu_e:.2f}"])
            csv.append([label, T, points, td_m, td_e, z_m, v_m, z_e, z_s, deep_m, deep_e, wall_m, cpu_m, wall_e,
                        cpu_e])
            print(" | ".join(rows[-1]), flush=True)
    headers = ["model", "T s", "eomc points", "touch-down MuJoCo s", "touch-down eomc s", "diff", "root z MuJoCo m",
               "MuJoCo max abs qvel", "root z eomc m", "diff mm", "statics diff mm", "deepest MuJoCo mm",
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
    print(write_results("mjcf_drops", text, csv, ["model", "T", "points", "touchdown_mujoco", "touchdown_eomc",
                                                  "root_z_mujoco", "qvel_max_mujoco", "root_z_eomc",
                                                  "root_z_eomc_from_mujoco_rest", "deepest_mujoco", "deepest_eomc",
                                                  "wall_mujoco", "cpu_mujoco", "wall_eomc", "cpu_eomc"]))


if __name__ == "__main__":
    main()
