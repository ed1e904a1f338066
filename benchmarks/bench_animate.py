"""Issue 20 speed: poses in C, writing an animation page, drawing it in headless Chromium.

  poses vs rhs     one call from Python of the generated NAME_poses against the model's rhs
                   (poses is its own C function: it must not make rhs slower), and Pinocchio's
                   forwardKinematics + updateFramePlacements (the same link placements) for UR5
  page             res.animate(path): 10 s at 60 frames per second (601 frames), wall time of
                   the whole write (poses in C, packing, JSON, the inlined three.js) and the
                   file's size, for the double pendulum, UR5 with its meshes, and a 35-dof
                   chain (the n-link cart with 34 links, a prescribed motion; built with
                   functions=["poses"] only); the 2-D GIF of the pendulum (matplotlib +
                   Pillow, 20 fps) for comparison; the first write of a page reads and packs
                   the meshes, later ones in the same process reuse them
  frame            headless Chromium (SwiftShader: software WebGL on the CPU, so an upper
                   bound for a machine with a GPU): the page's #bench=N mode draws N frames
                   back to back, each finished with gl.finish(); median and 90th percentile ms

Contestants are interleaved per repeat; medians.  Writes results/animate.md (unless --no-write).
"""
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import Timing, environment_header, format_table, parse_args, time_calls, write_results  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))


def _models(cache):
    import eomc
    from eomc.runtime.result import SimulationResult
    from helpers.robots import robot_path
    dp = eomc.compile(ROOT / "examples" / "double_pendulum.py", cache_dir=cache, progress=False)
    ur5 = eomc.compile(robot_path("ur5"), cache_dir=cache, progress=False)
    os.environ["EOMC_N_LINKS"] = "34"
    chain = eomc.compile(ROOT / "examples" / "n_link_cart.py", "chain34", cache_dir=cache, progress=False,
                         functions=["poses"])
    t = np.linspace(0, 10, 1001)
    runs = {}
    runs["double pendulum"] = (dp, dp.simulate(dp.initial_state, (0, 10)))
    x = np.zeros((len(t), ur5.nx))
    x[:, :6] = 0.8 * np.sin(np.outer(t, [0.5, 0.7, 0.9, 1.1, 1.3, 1.5]))
    runs["UR5 + meshes"] = (ur5, SimulationResult(t=t, x=x, state_names=ur5.state_names, stats={},
                                                  model=ur5, nq=ur5.nq))
    x = np.zeros((len(t), chain.nx))
    x[:, :chain.nq] = 0.3 * np.sin(np.outer(t, np.linspace(0.5, 2.0, chain.nq)))
    runs["35-dof chain"] = (chain, SimulationResult(t=t, x=x, state_names=chain.state_names, stats={},
                                                    model=chain, nq=chain.nq))
    return runs, robot_path("ur5")


def _frame_times(page, n):
    exe = shutil.which("chromium")
    if exe is None:
        return None
    with tempfile.TemporaryDirectory() as profile:
        out = subprocess.run([exe, "--headless", "--no-sandbox", "--use-gl=angle", "--use-angle=swiftshader",
                              "--enable-unsafe-swiftshader", f"--user-data-dir={profile}",
                              "--window-size=1280,720", "--timeout=20000", "--dump-dom",
                              f"{Path(page).as_uri()}#bench={n}"], capture_output=True, text=True, timeout=120)
    m = re.search(r'data-bench="([^"]*)"', out.stdout)
    return None if m is None else json.loads(m.group(1).replace("&quot;", '"'))


def main(argv=None):
    args = parse_args(__doc__.splitlines()[0], default_n=[0], default_repeat=5, argv=argv)
    import pinocchio as pin
    from eomc.runtime.animate import animate, animate_2d
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        runs, ur5_path = _models(tmp / "cache")
        rng = np.random.default_rng(1)
        # poses vs rhs, interleaved per repeat
        call_rows = []
        robot = pin.buildModelFromUrdf(str(ur5_path))
        data = robot.createData()
        for label in ("double pendulum", "UR5 + meshes"):
            model, _ = runs[label]
            x = rng.normal(size=model.nx)
            samples = {"poses": [], "rhs": [], "pin": []}
            for _ in range(args.repeat):
                samples["poses"] += time_calls(lambda: model.poses(0.0, x), 2000, 1).samples
                samples["rhs"] += time_calls(lambda: model.rhs(0.0, x), 2000, 1).samples
                if label.startswith("UR5"):
                    q = x[:6]
                    samples["pin"] += time_calls(lambda: (pin.forwardKinematics(robot, data, q),
                                                          pin.updateFramePlacements(robot, data)), 2000, 1).samples
            call_rows.append([label, f"{Timing(samples['poses']).median * 1e6:.2f}",
                              f"{Timing(samples['rhs']).median * 1e6:.2f}",
                              f"{Timing(samples['pin']).median * 1e6:.2f}" if samples["pin"] else "-",
                              str(runs[label][0].metadata["op_counts"]["poses"])])
        # writing the page (and the GIF), interleaved
        page_rows = []
        times = {label: [] for label in runs}
        gif = []
        for r in range(args.repeat):
            for label, (model, res) in runs.items():
                t0 = time.perf_counter()
                anim = animate(res, tmp / f"{r}-{label}.html", model=model, fps=60)
                times[label].append(time.perf_counter() - t0)
            if r < 2:
                model, res = runs["double pendulum"]
                t0 = time.perf_counter()
                animate_2d(res, tmp / "dp.gif", model=model, fps=20)
                gif.append(time.perf_counter() - t0)
        for label, (model, res) in runs.items():
            page = tmp / f"0-{label}.html"
            frames = _frame_times(page, 300)
            page_rows.append([label, str(model.nq), str(601), f"{times[label][0]:.3f}",
                              f"{Timing(times[label][1:] or times[label]).median:.3f}",
                              f"{page.stat().st_size / 1e6:.2f}",
                              "-" if frames is None else f"{frames['median_ms']:.1f}",
                              "-" if frames is None else f"{frames['p90_ms']:.1f}"])
        page_rows.append(["double pendulum, 2-D GIF at 20 fps (matplotlib + Pillow)", "2", "201",
                          f"{gif[0]:.3f}", f"{Timing(gif).median:.3f}", f"{(tmp / 'dp.gif').stat().st_size / 1e6:.2f}", "-", "-"])
    text = environment_header("Animation: poses in C, writing the page, drawing it", args,
                              notes=["poses/rhs from Python: one call each, medians of 2000-call blocks",
                                     "frame: headless Chromium with SwiftShader (software WebGL), 1280x720"])
    text += "\n## One call from Python (µs)\n\n" + format_table(
        ["model", "poses", "rhs", "Pinocchio FK + frame placements", "poses ops"], call_rows)
    text += "\n\n## 10 s at 60 fps written as one HTML page\n\n" + format_table(
        ["model", "dof", "frames", "write s (first)", "write s (median of later)", "file MB",
         "frame ms (median)", "frame ms (p90)"], page_rows)
    print(text)
    if not args.no_write:
        for p in write_results("animate", text):
            print(f"wrote {p}")


if __name__ == "__main__":
    main()
