"""Cost and margins of the pair verdict (runtime/pair_check.py) on the gymnasium and dm_control pair models.

The verdict runs once per simulate() call, after the integration, over the run's output rows (a fixed
step's rows are its steps): one NAME_poses call per row, the pairs' broad phase at once, the exact
measure where the shapes come near.  Nothing runs in the rhs, NAME_implicit or a step.

Per model (no flags: the file's contacts and self-pairs, its start) and method (implicitfast at the
file's time step; the default "auto"), T simulated seconds:
- check: CPU ms of one passed_through call on the run's rows and outputs, as simulate makes it
  (thread CPU, median of REPEAT); "before": the same with the modules of ``--before REV`` (its
  runtime/pair_check.py and poses.py loaded beside this one's);
- simulate with / without: CPU ms of the whole simulate() call per simulated second, with the check
  and with it replaced by a no-op (and with REV's check), interleaved rounds in one process (thread
  CPU, medians of REPEAT);
- least s/rho: over the run's rows and the paths between them, each pair's core's least signed
  distance from the other shape over its inner size (the verdict names a pair below 1 - PASS_FRACTION
  = 0.5; the rows of these runs are the same with and without the check);
- status and whether the verdict named a pair.

    python benchmarks/bench_pair_check.py [--before REV]    # writes benchmarks/results/pair_check.md
"""
import argparse
import statistics
import subprocess
import sys
import types
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


def _before(rev):
    """passed_through of revision ``rev``'s runtime/pair_check.py and poses.py (git show), loaded as
    modules of eomc.runtime; called as simulate calls today's (``outputs`` dropped when it takes none)."""
    import inspect
    def show(path):
        return subprocess.run(["git", "-C", str(Path(__file__).resolve().parent.parent), "show", f"{rev}:{path}"],
                              check=True, capture_output=True, text=True).stdout
    # REV's runtime/poses.py too (the rows' NAME_poses calls), its kernel cached on the model under
    # its own attribute so the two never share one
    poses = types.ModuleType("eomc.runtime._poses_before")
    poses.__package__ = "eomc.runtime"
    exec(compile(show("runtime/poses.py").replace("_pose_kernel", "_pose_kernel_before"),
                 f"{rev}:runtime/poses.py", "exec"), poses.__dict__)
    sys.modules[poses.__name__] = poses
    src = show("runtime/pair_check.py").replace("from .poses import", "from ._poses_before import")
    mod = types.ModuleType("eomc.runtime._pair_check_before")
    mod.__package__ = "eomc.runtime"
    exec(compile(src, f"{rev}:runtime/pair_check.py", "exec"), mod.__dict__)
    fn = mod.passed_through
    if "outputs" in inspect.signature(fn).parameters:
        return fn
    return lambda model, t, X, p, fraction=mod.PASS_FRACTION, outputs=None: fn(model, t, X, p, fraction)


def main():
    import eomc
    from eomc.runtime import pair_check as pc
    ap = argparse.ArgumentParser()
    ap.add_argument("--before", help="a revision whose pair check to time beside this one")
    args = ap.parse_args()
    pin_to_one_core()
    real, off = pc.passed_through, (lambda *a, **k: [])
    old = _before(args.before) if args.before else None
    variants = {"with": real, "without": off, **({"before": old} if old else {})}
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
            check = {k: [] for k in variants if k != "without"}
            for _ in range(REPEAT):
                for k in check:
                    t0 = time.thread_time()
                    variants[k](model, res.t, res.x, None, outputs=res.outputs)
                    check[k].append(time.thread_time() - t0)
            cpu = {k: [] for k in variants}
            for _ in range(REPEAT):
                for k, fn in variants.items():
                    pc.passed_through = fn
                    try:
                        with warnings.catch_warnings():
                            warnings.simplefilter("ignore")
                            t0 = time.thread_time()
                            model.simulate(model.initial_state, (0.0, T), raise_on_failure=False, **kw)
                            cpu[k].append(time.thread_time() - t0)
                    finally:
                        pc.passed_through = real
            ms = {k: statistics.median(v) / T * 1e3 for k, v in cpu.items()}
            chk = {k: f"{statistics.median(v) * 1e3:.2f}" for k, v in check.items()}
            row = [f"{where} {name}", kw.get("method", "auto"), npairs, len(res.t)]
            if old:
                row += [chk["before"], chk["with"], f"{ms['before']:.1f}", f"{ms['with']:.1f}", f"{ms['without']:.1f}",
                        f"{ms['before'] / ms['without']:.3f}", f"{ms['with'] / ms['without']:.3f}"]
            else:
                row += [chk["with"], f"{ms['with']:.1f}", f"{ms['without']:.1f}", f"{ms['with'] / ms['without']:.3f}"]
            rows_out.append(row + [f"{_least(model, res):.3f}", res.status, "yes" if named else "no"])
            print(rows_out[-1], flush=True)
    headers = ["model", "method", "pairs", "rows"] + (
        ["check ms before", "now", "simulate ms/s with before's", "with now's", "without", "ratio before",
         "ratio now"] if old else ["check ms", "simulate ms/s with", "without", "ratio"]) + [
        "least s/rho", "status", "named"]
    text = environment_header("Pair verdict (runtime/pair_check.py): cost per run and margins") + "\n" + \
        format_table(headers, rows_out) + "\n" + (
            f"\nbefore: runtime/pair_check.py and poses.py of {args.before}\n" if old else "")
    write_results("pair_check", text, keep_notes=True)


if __name__ == "__main__":
    main()
