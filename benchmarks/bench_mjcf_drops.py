"""Issue 33: passive drops of gymnasium models with the file's contacts, eomc vs MuJoCo's mj_step.

Per model (hopper, walker2d, ant, humanoid from the gymnasium wheel; humanoid again with its
self-collision pairs, which eomc leaves out by default and MuJoCo has), both start at the
model's initial state (MuJoCo's qpos0) with no control and run T seconds:

- MuJoCo: ``mj_step`` at the file's time step and integrator (its own contacts, limits,
  constraints);
- eomc: ``eomc.compile(path)`` with no flags (the file's contacts mapped to eomc's law,
  limits and frictionloss as eomc models them), ``model.simulate(..., method="radau")``,
  2000 output points per second.

Columns: first touch-down (the lowest contact distance minus the pair's margin reaching
zero, interpolated between samples; MuJoCo's from ``mj_geomDistance``), the root body's
height at T, the deepest contact penetration over the run (eomc: beyond the law's surface,
i.e. below the margin; MuJoCo: -min dist + margin over its contacts), wall and CPU time of
each simulation (MuJoCo's Python loop of mj_step: its cost is mostly the loop's).
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
MODELS = [("hopper", 3.0, "hopper", None), ("walker2d", 3.0, "walker2d", None), ("ant", 3.0, "ant", None),
          ("humanoid", 3.0, "humanoid", None), ("humanoid", 3.0, "humanoid, pairs=True", True)]


def _touchdown(times, lowest):
    lowest = np.asarray(lowest)
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
        times.append(d.time)
        low = min(mujoco.mj_geomDistance(m, d, p, g, 10.0, None) - h for g, h, p in pairs)
        lowest.append(low)
        deepest = max(deepest, -low)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return _touchdown(times, lowest), float(d.xpos[1][2]), deepest, wall, cpu


def eomc_drop(path, T, cache, pairs=None):
    import eomc
    from eomc.compiler.mjcf import MjcfModel
    import mujoco
    from eomc.compiler.mjcf.compare import to_mujoco
    from eomc.compiler.mjcf.model import load_mjmodel
    from eomc.compiler.mjcf.treeir import tree_ir
    model = eomc.compile(MjcfModel(Path(path), pairs=pairs) if pairs else str(path),
                         functions=("rhs", "outputs", "jac_x"), cache_dir=cache, progress=False)
    t0, c0 = time.perf_counter(), time.process_time()
    res = model.simulate(model.initial_state, (0.0, T), method="radau", n_points=int(T * 2000) + 1)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    depths = [k for k in model.output_names if k.startswith("depth_")]
    deep = np.array([max(model.outputs(t, x)[k] for k in depths) for t, x in zip(res.t, res.x)])
    m = load_mjmodel(path)
    d = mujoco.MjData(m)
    x = res.x[-1]
    d.qpos[:], d.qvel[:] = to_mujoco(m, tree_ir(m), x[:model.nq], x[model.nq:])
    mujoco.mj_kinematics(m, d)
    return _touchdown(res.t, -deep), float(d.xpos[1][2]), float(deep.max()), wall, cpu, len(depths)


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
            td_m, z_m, deep_m, wall_m, cpu_m = mujoco_drop(path, T)
            td_e, z_e, deep_e, wall_e, cpu_e, points = eomc_drop(path, T, Path(tmp), pairs)
            rows.append([label, f"{T:g}", str(points), f"{td_m:.4f}", f"{td_e:.4f}", f"{100 * (td_e / td_m - 1):+.1f} %",
                         f"{z_m:.4f}", f"{z_e:.4f}", f"{1e3 * (z_e - z_m):+.1f}", f"{1e3 * deep_m:.2f}",
                         f"{1e3 * deep_e:.2f}", f"{wall_m:.2f}/{cpu_m:.2f}", f"{wall_e:.2f}/{cpu_e:.2f}"])
            csv.append([label, T, points, td_m, td_e, z_m, z_e, deep_m, deep_e, wall_m, cpu_m, wall_e, cpu_e])
            print(" | ".join(rows[-1]), flush=True)
    headers = ["model", "T s", "eomc points", "touch-down MuJoCo s", "touch-down eomc s", "diff", "root z MuJoCo m",
               "root z eomc m", "diff mm", "deepest MuJoCo mm", "deepest eomc mm", "MuJoCo wall/CPU s",
               "eomc radau wall/CPU s"]
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
                                                  "root_z_mujoco", "root_z_eomc", "deepest_mujoco", "deepest_eomc",
                                                  "wall_mujoco", "cpu_mujoco", "wall_eomc", "cpu_eomc"]))


if __name__ == "__main__":
    main()
