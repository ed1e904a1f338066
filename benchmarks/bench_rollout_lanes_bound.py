"""Issue 31 S2: how far SIMD lanes could take eomc.rollout's checked implicitfast step with contacts.

Why: a lanes driver for the checked fixed step (rows advancing together in groups of the lane
width, a row whose step must split leaving the group for that step) only speeds up the steps
that every row of a group takes whole.  A split step (the residual test fails: a touch-down, a
limit, friction switching) is a run of sub-steps of its own length in one row and stays scalar.
So before building it, this measures the share of the work lanes could take and the bound that
gives (Amdahl), on bench_rollout_contacts' cases (same models, starts and time steps):

* terms calls per row (simulate's stats["nfev"]: NAME_implicit calls, one per try; the fast
  path calls neither the rhs nor jac_x): every step's first, whole-step try is one call, so
  L = steps / calls is the share of the calls a lanes driver could make in lanes (each call
  comes with its matrix assembly, tree LU and solves, which lanes would take too);
* CPU time of eomc.rollout checked (the default), unchecked (split = 0: one call a step, all of
  it lane-able) and mujoco.rollout implicitfast, interleaved, medians of REPEAT, one thread;
* the bound: checked / mujoco x 1 / ((1 - L) + L / s) for a lane speed-up s of the whole step
  (4: rhs_batch's 3.5-4.4x at 4 lanes, results/rhs_batch.md; 5.5: its 8-lane figure; infinite),
  and unchecked / mujoco x s.  Per-call cost is taken as equal in whole and split tries (a split
  try assembles and factors as a whole one does).

    taskset -c 0 python benchmarks/bench_rollout_lanes_bound.py [--models ant,humanoid]
"""
import argparse
import os
import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import environment_header, format_table, write_results  # noqa: E402
import bench_rollout_contacts as RC  # noqa: E402

REPEAT = 5
LANE_SPEEDUPS = (4.0, 5.5, float("inf"))


def _calls(em, X0, nstep, dt):
    """(n,) NAME_implicit calls per row of the checked step over the rollout's second."""
    out = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for x0 in X0:
            r = em.simulate(x0, (0.0, nstep * dt), method="implicitfast", dt=dt, t_eval=[nstep * dt],
                            raise_on_failure=False)
            out.append(r.stats["nfev"])
    return np.array(out)


def _case(name, cache_dir):
    import mujoco
    from mujoco import rollout as mj_rollout

    import eomc
    em, mm, _, _, height, pose = RC._models(name, cache_dir)
    dt = float(mm.opt.timestep)
    nstep = int(round(1.0 / dt))
    X0, S0 = RC.starts(em, mm, height, pose)
    calls = _calls(em, X0, nstep, dt)
    share = RC.NROLL * nstep / calls.sum()
    ctrl = np.zeros((RC.NROLL, nstep, mm.nu))
    datas = [mujoco.MjData(mm)]
    with mj_rollout.Rollout(nthread=1) as ro:
        contestants = {
            "checked": lambda: eomc.rollout(em, X0, steps=nstep, dt=dt, threads=1, method="implicitfast",
                                            raise_on_failure=False),
            "unchecked": lambda: eomc.rollout(em, X0, steps=nstep, dt=dt, threads=1, method="implicitfast",
                                              split=0.0, raise_on_failure=False),
            "mujoco": lambda: ro.rollout([mm] * RC.NROLL, datas, S0, ctrl, nstep=nstep),
        }
        cpu = {c: [] for c in contestants}
        for _ in range(REPEAT):
            for c, f in contestants.items():
                c0 = time.process_time()
                f()
                cpu[c].append(time.process_time() - c0)
    med = {c: statistics.median(v) for c, v in cpu.items()}
    total = RC.NROLL * nstep
    checked, unchecked = med["mujoco"] / med["checked"], med["mujoco"] / med["unchecked"]
    bound = [checked / ((1 - share) + share / s) for s in LANE_SPEEDUPS]
    row = [name, f"{dt:g}", nstep, f"{np.median(calls):g} / {calls.mean():.0f} / {calls.max()}",
           f"{share:.2f}", f"{med['checked'] / total * 1e9:.0f}", f"{med['unchecked'] / total * 1e9:.0f}",
           f"{med['mujoco'] / total * 1e9:.0f}", f"{checked:.2f}", f"{unchecked:.2f}",
           *[f"{b:.2f}" for b in bound], f"{unchecked * LANE_SPEEDUPS[0]:.1f}"]
    print(row, flush=True)
    return row


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", default=",".join(RC.MODELS))
    parser.add_argument("--cache-dir", default=os.environ.get("EOMC_CACHE_DIR"))
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args()
    rows = [_case(name, args.cache_dir) for name in args.models.split(",")]
    import mujoco
    table = format_table(
        ["model", "timestep", "steps", "checked: terms calls per row, median / mean / max",
         "lane-able share L (steps / calls)", "checked ns/step (CPU)", "unchecked ns/step",
         "mujoco implicitfast ns/step", "checked vs mujoco", "unchecked vs mujoco",
         "bound, lanes 4x", "bound, lanes 5.5x", "bound, lanes infinitely fast",
         "unchecked bound, lanes 4x"], rows)
    text = environment_header(
        "How far SIMD lanes could take the checked implicitfast rollout with contacts (issue 31 S2)",
        notes=[f"MuJoCo {mujoco.__version__}; bench_rollout_contacts' cases ({RC.NROLL} starts x 1 simulated "
               f"second, zero controls, contacts and limits on both sides); process-CPU medians of {REPEAT} "
               f"interleaved repeats, one thread, process pinned to cores {sorted(os.sched_getaffinity(0))}; "
               "bounds: checked vs mujoco x 1 / ((1 - L) + L / s), unchecked vs mujoco x s; "
               "shared noisy machine."]
    ) + "\n" + table + "\n"
    print(table)
    if not args.no_write:
        write_results("rollout_lanes_bound", text, keep_notes=True)


if __name__ == "__main__":
    main()
