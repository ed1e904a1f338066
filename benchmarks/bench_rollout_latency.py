"""Small rollouts: the cost of one eomc.rollout / eomc.Rollout call against one mujoco.rollout call.

Why: reinforcement learning steps its environments a few steps at a time (gymnasium's vector
envs: every env one step a call, or frame_skip steps), so what a call costs beyond its steps --
argument checks, the verdicts, the C set-up of each row -- is paid on every env step.
bench_rollout_contacts.py measures long rollouts (64 rows x 1 s), where that cost vanishes;
here the calls are short: 1 row x 1 step, 64 rows x 1 step, 64 rows x the gymnasium env's
frame_skip steps (hopper, walker2d 4; ant, humanoid 5).  eomc.Rollout is the persistent object
(checks, method, options and the fast path's C set-up made once, as mujoco's Rollout keeps its
threads): what an environment would hold; eomc.rollout, the one-off call.

Both sides from Python, one thread, the same starts (bench_rollout_contacts.starts: hinge speeds
uniform in +-0.5) and physics (contacts and limits on both sides; eomc implicitfast checked, as the
rollout defaults; MuJoCo its default Euler, the gymnasium files' integrator), calls interleaved,
process CPU (mujoco.rollout runs its rows on its own pool thread) and wall per call, medians of
``--repeat`` blocks of ``--calls`` calls, the process pinned to one core.

    taskset -c 1 python benchmarks/bench_rollout_latency.py [--models hopper,ant,humanoid] [--no-write]
"""
import argparse
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import environment_header, format_table, write_results  # noqa: E402

FRAME_SKIP = {"hopper": 4, "walker2d": 4, "ant": 5, "humanoid": 5}


def _block(f, calls):
    t0, c0 = time.perf_counter(), time.process_time()
    for _ in range(calls):
        f()
    return (time.perf_counter() - t0) / calls, (time.process_time() - c0) / calls


def case(name, cache_dir, repeat, calls):
    import mujoco
    from mujoco import rollout as mj_rollout

    import bench_rollout_contacts as R
    import eomc
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        em, mm, me, fine, height, pose = R._models(name, cache_dir)
    dt = float(me.opt.timestep)
    X0, S0 = R.starts(em, me, height, pose)
    rows = []
    kept = eomc.Rollout(em, dt=dt, threads=1, raise_on_failure=False)
    with mj_rollout.Rollout(nthread=1) as ro:
        data = [mujoco.MjData(me)]
        for nrow, nstep in ((1, 1), (64, 1), (64, FRAME_SKIP.get(name, 5))):
            X, S = X0[:nrow], S0[:nrow]
            ctrl = np.zeros((nrow, nstep, me.nu))
            sides = {
                "eomc.rollout": lambda: eomc.rollout(em, X, steps=nstep, dt=dt, threads=1, raise_on_failure=False),
                "eomc.Rollout": lambda: kept(X, steps=nstep),
                "mujoco.rollout": lambda: ro.rollout([me] * nrow, data, S, ctrl, nstep=nstep),
            }
            a, b = sides["eomc.rollout"](), sides["eomc.Rollout"]()
            assert np.array_equal(a.x, b.x) and np.array_equal(a.status, b.status), "Rollout != rollout"
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                for f in sides.values():
                    f()
                got = {k: ([], []) for k in sides}
                for r in range(repeat):
                    order = list(sides)
                    for k in order[r % 3:] + order[:r % 3]:
                        wall, cpu = _block(sides[k], calls)
                        got[k][0].append(wall)
                        got[k][1].append(cpu)
            med = {k: (float(np.median(w)), float(np.median(c))) for k, (w, c) in got.items()}
            e_w, e_c = med["eomc.rollout"]
            k_w, k_c = med["eomc.Rollout"]
            m_w, m_c = med["mujoco.rollout"]
            rows.append([name, f"{dt:g}", nrow, nstep, f"{e_c * 1e6:.0f}", f"{k_c * 1e6:.0f}", f"{m_c * 1e6:.0f}",
                         f"{m_c / e_c:.2f}", f"{m_c / k_c:.2f}", f"{k_w * 1e6:.0f}", f"{m_w * 1e6:.0f}",
                         f"{m_w / k_w:.2f}", f"{k_c / (nrow * nstep) * 1e6:.1f}", f"{m_c / (nrow * nstep) * 1e6:.1f}"])
            print(rows[-1], flush=True)
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", default="hopper,ant,humanoid")
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--calls", type=int, default=40, help="calls per timed block")
    parser.add_argument("--cache-dir", default=os.environ.get("EOMC_CACHE_DIR"))
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args()
    load0 = os.getloadavg()[0]
    rows = []
    for name in args.models.split(","):
        rows += case(name, args.cache_dir, args.repeat, args.calls)
    header = ["model", "dt", "rows", "steps", "eomc.rollout CPU us/call", "eomc.Rollout CPU us/call",
              "mujoco CPU us/call", "mujoco / eomc.rollout (CPU)", "mujoco / eomc.Rollout (CPU)",
              "eomc.Rollout wall us/call", "mujoco wall us/call", "mujoco / eomc.Rollout (wall)",
              "eomc.Rollout CPU us/step", "mujoco CPU us/step"]
    try:
        cores = sorted(os.sched_getaffinity(0))
    except AttributeError:
        cores = "?"
    text = "\n".join([
        environment_header("Small rollouts: one eomc.rollout or eomc.Rollout call against one mujoco.rollout call",
                           args=True),
        f"- process pinned to cores {cores}; load {load0:.1f} -> {os.getloadavg()[0]:.1f}; medians of "
        f"{args.repeat} interleaved blocks of {args.calls} calls; one thread each side; eomc implicitfast "
        "(checked, the rollout's default), MuJoCo Euler (the files' integrator); a ratio > 1: eomc faster; "
        "eomc.Rollout's rows asserted equal to eomc.rollout's (states and statuses)",
        "", format_table(header, rows), ""])
    print(text)
    if not args.no_write:
        write_results("rollout_latency", text, keep_notes=True)


if __name__ == "__main__":
    main()
