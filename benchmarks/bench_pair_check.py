"""Cost and margins of the pair verdict (runtime/pair_check.py) on the gymnasium and dm_control pair models.

The verdict runs once per simulate() call, after the integration, over the run's output rows (a fixed
step's rows are its steps): one NAME_poses call per row, the pairs' broad phase at once, the exact
measure where the shapes come near.  Nothing runs in the rhs, NAME_implicit or a step.

Per model (no flags: the file's contacts and self-pairs, its start) and method (implicitfast at the
file's time step; the default "auto"), T simulated seconds:
- check: CPU ms of one passed_through call on the run's rows (thread CPU, median of REPEAT);
- simulate with / without: CPU ms of the whole simulate() call per simulated second, with the check
  and with it replaced by a no-op, interleaved rounds in one process (thread CPU, medians of REPEAT);
- least s/rho: over the run's rows and the paths between them, each pair's core's least signed
  distance from the other shape over its inner size (the verdict names a pair below 1 - PASS_FRACTION
  = 0.5; the rows of these runs are the same with and without the check);
- status and whether the verdict named a pair.

    python benchmarks/bench_pair_check.py        # writes benchmarks/results/pair_check.md
"""
import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import environment_header, format_table, pin_to_one_core, write_results  # noqa: E402

REPEAT = 7
MODELS = [("gymnasium", "humanoid", 1.0), ("gymnasium", "hopper", 1.0), ("dm_control", "stacker", 1.0),
          ("dm_control", "manipulator", 1.0), ("dm_control", "ball_in_cup", 1.0), ("gymnasium", "pusher", 1.0)]


def _file(where, name):
    import importlib
    pkg = importlib.import_module(where)
    return Path(pkg.__file__).parent / ("envs/mujoco/assets" if where == "gymnasium" else "suite") / f"{name}.xml"


def _least(model, res):
    from eomc.runtime import pair_check as pc
    from eomc.runtime.poses import evaluate_poses, pose_layout
    frames = list(pose_layout(model)[0])
    poses = evaluate_poses(model, res.t, res.x, None)
    worst = np.inf
    for pair in model.metadata["pair_check"]["pairs"]:
        shapes = pair["shapes"]
        placed = [pc._placed(s, poses, frames) for s in shapes]
        for x, y in ((0, 1), (1, 0)):
            rows, between = pc.pair_overlaps(shapes[x], shapes[y], *placed[x], *placed[y], fraction=1.0,
                                                 pruned=False)
            least = min(rows.min(), between.min() if between.size else np.inf)
            worst = min(worst, least / pc.inner_size(shapes[x]["kind"], shapes[x]["size"]))
    return worst


def main():
    import eomc
    from eomc.runtime import pair_check as pc
    pin_to_one_core()
    real, off = pc.passed_through, (lambda *a, **k: [])
    rows_out = []
    for where, name, T in MODELS:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = eomc.compile(_file(where, name), progress=False)
        npairs = len(model.metadata["pair_check"]["pairs"])
        for kw in (dict(method="implicitfast", dt=model.metadata["timestep"]), dict()):
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                res = model.simulate(model.initial_state, (0.0, T), raise_on_failure=False, **kw)
            named = any("passed into each other" in str(w.message) for w in caught)
            check = []
            for _ in range(REPEAT):
                t0 = time.thread_time()
                real(model, res.t, res.x, None)
                check.append(time.thread_time() - t0)
            cpu = {True: [], False: []}
            for _ in range(REPEAT):
                for on in (True, False):
                    pc.passed_through = real if on else off
                    try:
                        with warnings.catch_warnings():
                            warnings.simplefilter("ignore")
                            t0 = time.thread_time()
                            model.simulate(model.initial_state, (0.0, T), raise_on_failure=False, **kw)
                            cpu[on].append(time.thread_time() - t0)
                    finally:
                        pc.passed_through = real
            with_, without = (statistics.median(cpu[k]) / T * 1e3 for k in (True, False))
            rows_out.append([f"{where} {name}", kw.get("method", "auto"), npairs, len(res.t),
                             f"{statistics.median(check) * 1e3:.2f}", f"{with_:.1f}", f"{without:.1f}",
                             f"{with_ / without:.3f}", f"{_least(model, res):.3f}", res.status,
                             "yes" if named else "no"])
            print(rows_out[-1], flush=True)
    headers = ["model", "method", "pairs", "rows", "check ms", "simulate ms/s with", "without", "ratio",
               "least s/rho", "status", "named"]
    text = environment_header("Pair verdict (runtime/pair_check.py): cost per run and margins") + "\n" + \
        format_table(headers, rows_out) + "\n"
    write_results("pair_check", text, keep_notes=True)


if __name__ == "__main__":
    main()
