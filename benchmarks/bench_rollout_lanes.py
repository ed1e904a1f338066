"""eomc.rollout with lanes=True (RK4 stages as NAME_rhs_batch_p calls, in C) vs the scalar C rollout.

Per model (built with rhs, rhs_batch; the build picks the machine's lanes), 4096 random starts,
RK4, dt = 1e-3, 100 steps, record="final":
* one thread, pinned (taskset -c 1 for the whole script), process CPU time;
* both contestants alternate, 5 rounds, medians; the final states' max difference is reported
  (the lanes' sin/cos are within 1 ulp of libm's, so the rows agree to rounding, not bits).

Usage: taskset -c 1 python benchmarks/bench_rollout_lanes.py [--write]
"""
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))


def models():
    from helpers.robots import robot_path
    from eomc.compiler.urdf.model import UrdfModel
    cart = HERE / "tree_models" / "cart_rel_joints.py"
    return [("cart n=4", lambda: str(cart), {"EOMC_N_LINKS": "4"}),
            ("UR10", lambda: UrdfModel(robot_path("ur_description/urdf/ur10_robot.urdf"), limits=False), {}),
            ("Go2", lambda: UrdfModel(robot_path("go2_description/urdf/go2.urdf"), floating_base=True,
                                      limits=False), {})]


def main(argv):
    import numpy as np
    from eomc.compiler.driver import compile as compile_model
    from eomc.compiler.build.builder import machine_lanes
    from eomc.runtime.rollout import rollout
    warnings.simplefilter("ignore")
    rows = []
    cache = tempfile.mkdtemp(prefix="eomc_rl_")
    for label, make, env in models():
        os.environ.update(env)
        m = compile_model(make(), f"rl{len(rows)}", functions=("rhs", "rhs_batch"), cache_dir=cache, progress=False)
        X0 = np.random.default_rng(0).uniform(-0.5, 0.5, (4096, m.nx))
        P = np.asarray(m.param_defaults) * np.random.default_rng(1).uniform(0.9, 1.1, (4096, m.nparam))
        times = {(lanes, rows_p): [] for lanes in (False, True) for rows_p in (False, True)}
        out = {}
        for rnd in range(5):
            order = list(times) if rnd % 2 == 0 else list(times)[::-1]
            for lanes, rows_p in order:
                t0 = time.process_time()
                res = rollout(m, X0, dt=1e-3, steps=100, threads=1, lanes=lanes, p=P if rows_p else None)
                times[lanes, rows_p].append(time.process_time() - t0)
                out[lanes, rows_p] = res.x
        diff = max(float(np.abs(out[True, r] - out[False, r]).max() / max(np.abs(out[False, r]).max(), 1.0))
                   for r in (False, True))
        med = {k: statistics.median(v) for k, v in times.items()}
        rows.append((label, m.nx, med[False, False], med[True, False], med[False, True], med[True, True], diff))
        print(rows[-1], flush=True)
    head = ("| model | nx | scalar C rollout s | lanes rollout s | speed-up | scalar, one p per row s | "
            "lanes, one p per row s | speed-up | max rel. difference of final states |\n"
            "|--|--|--|--|--|--|--|--|--|")
    text = head + "\n" + "\n".join(f"| {a} | {b} | {c:.3f} | {d:.3f} | {c / d:.2f} | {e:.3f} | {f:.3f} | "
                                    f"{e / f:.2f} | {g:.1e} |" for a, b, c, d, e, f, g in rows)
    gcc = subprocess.run(["gcc", "--version"], capture_output=True, text=True).stdout.splitlines()[0]
    env = (f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; {machine_lanes()} lanes; {gcc}; "
           f"Python {platform.python_version()}; load average {os.getloadavg()[0]:.1f} (2 cores shared)")
    print(env)
    print(text)
    if "--write" in argv:
        (HERE / "results" / "rollout_lanes.md").write_text(
            "# rollout(lanes=True) vs the scalar C rollout (issue 31 items 1-2)\n\n"
            f"{env}.  benchmarks/bench_rollout_lanes.py: 4096 rows, RK4, dt 1e-3, 100 steps, one thread "
            "(taskset -c 1), process CPU time, contestants alternating, median of 5; the lanes loop in C "
            "(eomc_rollout_lanes, blocks of 64 rows); one p per row: the parameters x U(0.9, 1.1).\n\n" + text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
