"""Where dm_control's cheetah and quadruped come to rest: root height over a long passive run.

dm_suite.md compares the root body's height at 5 s (cheetah +5.0 mm, quadruped +4.1 mm against
MuJoCo's mj_step, the issue's bar 5 mm).  This table asks whether 5 s is rest at all: both models
run passively from the file's initial state (no control; MuJoCo ``mj_step`` at the file's step
and integrator, eomc ``eomc.compile(path)`` with no flags and simulate's default method), and the
root's height and the largest |qvel| are read at each time T of a long run, beside MuJoCo's.

quadruped.xml also holds the fetch task's 14.1 kg ball (a free body dropped from 3 m straight
above the torso, condim 6 with torsional and rolling friction 0.005, modelled since session 15:
docs/contact.md).  The ball lands on the quadruped's back and stays there at MuJoCo's exactly
symmetric start; on a convex back that is an unstable equilibrium, which eomc's regularised
rolling friction (viscous below ω_s = v_s/ρ, no true sticking) slows but does not hold: the ball
rolls off later.  The row "quadruped, ball 5 m aside" is the same file with the ball's body
moved to x = 5 m (it falls on the floor): the quadruped alone.

"statics" (last column): eomc started at MuJoCo's state at the last T with zero speeds and run
5 s more: its root height then minus MuJoCo's (the resting laws on the same pose).

    python benchmarks/bench_dm_rest.py
"""
import os
import shutil
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_dm_suite import eomc_root_height  # noqa: E402
from common import environment_header, format_table, write_results  # noqa: E402

TIMES = (5.0, 30.0, 120.0, 480.0)
STATICS = 5.0
# (row, file, its variant's name and the text changed, or None)
CASES = [("cheetah", "cheetah.xml", None),
         ("quadruped", "quadruped.xml", None),
         ("quadruped, ball 5 m aside", "quadruped.xml",
          ("quadruped_noball.xml", '<body name="ball" pos="0 0 3">', '<body name="ball" pos="5 0 3">'))]


def mujoco_run(path, times):
    """[(root z, max |qvel|)] at each time, and the qpos at the last."""
    import mujoco
    from eomc.compiler.mjcf.model import load_mjmodel
    m = load_mjmodel(path)
    d = mujoco.MjData(m)
    out = []
    for t in times:
        while d.time < t - 1e-9:
            mujoco.mj_step(m, d)
        out.append((float(d.xpos[1][2]), float(np.abs(d.qvel).max())))
    return out, d.qpos.copy()


def eomc_run(path, times, cache, rest_qpos):
    """[(root z, max |qvel|)] of eomc's default run at each time, and the statics height."""
    import mujoco
    import eomc
    from eomc.compiler.mjcf.compare import from_mujoco, to_mujoco, tree_of
    from eomc.compiler.mjcf.model import load_mjmodel
    model = eomc.compile(path, cache_dir=cache, progress=False)
    res = model.simulate(model.initial_state, (0.0, times[-1]), t_eval=list(times))
    m = load_mjmodel(path)
    built = tree_of(m, model)
    d = mujoco.MjData(m)
    nq, nu = model.nq, model.nu
    out = []
    for x in res.x:
        d.qpos[:], d.qvel[:] = to_mujoco(m, built, x[:nq], x[nq:nq + nu])
        out.append((eomc_root_height(path, model, x), float(np.abs(d.qvel).max())))
    q, u = from_mujoco(m, built, rest_qpos, np.zeros(m.nv))
    x0 = np.concatenate([q, 0 * np.asarray(u), np.zeros(len(model.state_names) - nq - nu)])
    again = model.simulate(x0, (0.0, STATICS), t_eval=[STATICS])
    return out, eomc_root_height(path, model, again.x[-1]), res.status


def main():
    import dm_control
    import mujoco
    suite = Path(dm_control.__file__).parent / "suite"
    headers = ["model"] + [f"root z at {t:g} s MuJoCo/eomc m (diff mm)" for t in TIMES] + \
        [f"max abs qvel at {TIMES[-1]:g} s MuJoCo/eomc", "statics diff mm"]
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench_dm_rest_") as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        copy = Path(tmp) / "suite"
        shutil.copytree(suite, copy, ignore=shutil.ignore_patterns("*.py", "__pycache__"))
        for label, name, change in CASES:
            path = copy / name
            if change:
                text = path.read_text()
                assert change[1] in text, change[1]
                path = copy / change[0]
                path.write_text(text.replace(*change[1:]))
            mj, rest = mujoco_run(path, TIMES)
            ours, statics, status = eomc_run(path, TIMES, Path(os.environ.get("EOMC_CACHE_DIR", Path(tmp) / "cache")),
                                             rest)
            row = [label] + [f"{a[0]:.4f}/{b[0]:.4f} ({1e3 * (b[0] - a[0]):+.1f})" for a, b in zip(mj, ours)]
            row += [f"{mj[-1][1]:.0e}/{ours[-1][1]:.0e}" + ("" if status == 0 else f" (eomc status {status})"),
                    f"{1e3 * (statics - mj[-1][0]):+.1f}"]
            rows.append(row)
            print(" | ".join(row), flush=True)
    load = os.getloadavg()
    text = environment_header("dm_control cheetah and quadruped: where they come to rest, eomc vs mj_step",
                              notes=(f"load average at end {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}",
                                     f"dm_control's suite; mujoco {mujoco.__version__}"))
    text += "\n" + format_table(headers, rows) + "\n\n" + (__doc__ or "")
    print(format_table(headers, rows))
    write_results("dm_rest", text, keep_notes=True)


if __name__ == "__main__":
    main()
