"""What torsional and rolling friction (MJCF condim 4/6, docs/contact.md) cost: dm_control's quadruped
built with them (its ball, condim 6: six ground contacts and 19 body-body pairs) and without them
(the same build with the ball's condim read as 3), one run.

Each build is a fresh child process with a fresh cache (default function set, CPU of the child and
its compilers); then rhs and jac_x per call (thread CPU, interleaved rounds, medians) at states of
MuJoCo's own passive run (mj_step at the file's step, t = 1 ... 5 s: the ball falling, landing on the
back and resting there).  The spin moment leaves the analytic jac_x kernel (its contact block is a
force at a point) for the tangent path, and the ball's 19 pairs leave the pair table for inlined
code (the table's law has no moment): both show here.

    python benchmarks/bench_spin_cost.py [--rounds 5]
"""
import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import environment_header, format_table, thread_cpu_per_call, write_results  # noqa: E402

WITHOUT = "import eomc.compiler.mjcf.collision as _c\n_c.spin_parameters = lambda friction, condim: (None, None)\n"
BUILD = """
import sys, warnings
warnings.simplefilter("ignore")
import eomc
eomc.compile(sys.argv[1], cache_dir=sys.argv[2], progress=False)
"""


def build(path, cache, prelude):
    """CPU s (child and its compilers) and wall s of a fresh build into ``cache``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", prelude + BUILD, str(path), str(cache)], capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode:
        raise RuntimeError(proc.stderr)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), wall


def mujoco_states(path, model, times):
    import mujoco
    from eomc.compiler.mjcf.compare import from_mujoco, tree_of
    from eomc.compiler.mjcf.model import load_mjmodel
    m = load_mjmodel(path)
    built = tree_of(m, model)
    d = mujoco.MjData(m)
    out = []
    for t in times:
        while d.time < t - 1e-9:
            mujoco.mj_step(m, d)
        q, u = from_mujoco(m, built, d.qpos, d.qvel)
        out.append(np.concatenate([q, u, np.zeros(len(model.state_names) - len(q) - len(u))]))
    return out


def main():
    import dm_control
    import eomc
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    path = Path(dm_control.__file__).parent / "suite" / "quadruped.xml"
    rows, models = [], {}
    with tempfile.TemporaryDirectory(prefix="bench_spin_") as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for label, prelude in (("without (condim 3)", WITHOUT), ("with (condim 6)", "")):
            cache = Path(tmp) / label.split()[0]
            cpu, wall = build(path, cache, prelude)
            if prelude:
                exec(prelude, {})
            else:
                import importlib
                import eomc.compiler.mjcf.collision as c
                importlib.reload(c)
            models[label] = (eomc.compile(str(path), cache_dir=cache, progress=False), cpu, wall)
        model = models["with (condim 6)"][0]
        states = mujoco_states(path, model, (1.0, 2.0, 3.0, 4.0, 5.0))
        times = {label: {"rhs": [], "jac_x": []} for label in models}
        for _ in range(args.rounds):
            for label, (m, _, _) in models.items():
                p = np.array(m.param_defaults, dtype=float)
                for x in states:
                    times[label]["rhs"].append(thread_cpu_per_call(lambda: m.rhs(0.0, x, p), 200))
                    times[label]["jac_x"].append(thread_cpu_per_call(lambda: m.jacobian(0.0, x, p), 20))
        base = models["without (condim 3)"]
        for label, (m, cpu, wall) in models.items():
            rhs, jac = (float(np.median(times[label][k])) for k in ("rhs", "jac_x"))
            rhs0, jac0 = (float(np.median(times["without (condim 3)"][k])) for k in ("rhs", "jac_x"))
            rows.append([label, f"{cpu:.1f}", f"{cpu / base[1]:.2f}", f"{1e6 * rhs:.2f}", f"{rhs / rhs0:.2f}",
                         f"{1e6 * jac:.1f}", f"{jac / jac0:.2f}"])
            print(rows[-1], flush=True)
    headers = ["quadruped.xml", "build CPU s", "ratio", "rhs us", "ratio", "jac_x us", "ratio"]
    load = os.getloadavg()
    text = environment_header("Torsional and rolling friction's cost on dm_control's quadruped (its ball, condim 6)",
                              notes=(f"load average at end {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}",
                                     f"{args.rounds} interleaved rounds x 5 MuJoCo states; medians of thread CPU per call"))
    text += "\n" + format_table(headers, rows) + "\n\n" + (__doc__ or "")
    print(format_table(headers, rows))
    write_results("spin_cost", text, keep_notes=True)


if __name__ == "__main__":
    main()
