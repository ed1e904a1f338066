"""What the default ground costs: a URDF robot with named feet, with and without its other
bodies' <collision> geometry meeting the ground (issue 29; compiler/urdf/model._ground).

    taskset -c 1 python benchmarks/bench_default_ground.py [--repeat 7] [--no-write] [--robot go2 ...]

Per robot, three builds (feet only: ``@no-ground``; the default: feet plus every other link's
collision geometry as bounding-box corners, its rhs with the broad phase of
compiler/emit/guards.py -- a body's contact block skipped while its bounding sphere is above
the ground; and the default printed straight-line, every point's law at every call, as before
the broad phase): the number of contact points, the build's CPU time (a cold build in a fresh
cache: generation and C compile, this process's and its children's CPU), and the rhs per call
(thread CPU time of ``rhs_many`` over 2000 states, C loop, blocks interleaved
between the builds, medians of the repeats).  The ratios are ÷ feet only, from the same run.
Two sets of states: "random" near the zero pose (floating base height uniform in 0...0.4 m,
joints and tilt N(0, 0.2): most bodies within reach of the floor, the broad phase's worst
case) and "no-flag run" (2000 states evenly along the default model's 2 s run from eomc
simulate's default start with the default method: what a user's simulation evaluates).  The
last column is the largest difference between the default's rhs and the straight-line one at
those states.
"""
import resource
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from common import environment_header, robots_dir, format_table, median_iqr, parse_args, write_results  # noqa: E402

ROBOTS = robots_dir()
FEET = {
    "go2": ("go2_description/urdf/go2.urdf", [f"{n}:0,0,0:0.022" for n in ("FL_foot", "FR_foot", "RL_foot", "RR_foot")]),
    "solo12": ("solo_description/robots/solo12.urdf", [f"{n}:0,0,0:0.016" for n in ("FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT")]),
    "g1": ("g1_description/urdf/g1_29dof_rev_1_0.urdf", ["@collision"]),
}


def cpu():
    a, b = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return a.ru_utime + a.ru_stime + b.ru_utime + b.ru_stime


def build(path, contacts, cache, straight=False):
    """(model, build CPU s); ``straight``: the rhs printed without its broad phase."""
    import eomc
    import eomc.compiler.formulations.recursive as recursive
    from eomc.compiler.urdf.model import UrdfModel
    guarded_rhs = recursive.tree_rhs_body
    if straight:
        recursive.tree_rhs_body = lambda ctx, prog, guards=(): guarded_rhs(ctx, prog)
    c0 = cpu()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = eomc.compile(UrdfModel(path, floating_base=True, contacts=tuple(contacts)), cache_dir=cache,
                                 progress=False)
    finally:
        recursive.tree_rhs_body = guarded_rhs
    return model, cpu() - c0


def trajectory(model, n, t_final=2.0):
    """n states along the no-flag run (eomc simulate's default start: the zero pose lifted onto
    the ground; the default method) of ``model`` over t_final: the states a user's run evaluates
    the rhs at (the robot drops, collapses or stands, most bodies above the floor)."""
    from eomc.cli.common import initial_state
    x0 = initial_state(model, {})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = model.simulate([x0[s] for s in model.state_names], (0.0, t_final))
    rows = np.asarray(res.x)
    return rows[np.linspace(0, len(rows) - 1, n).round().astype(int)]


def states(model, n, rng):
    X = np.zeros((n, model.nx))
    z = model.state_names.index(next(s for s in model.state_names if s.endswith("_floating_z")))
    X[:, :model.nq] = rng.normal(scale=0.2, size=(n, model.nq))
    X[:, z] = rng.uniform(0.0, 0.4, size=n)          # some bodies in the ground, some not
    X[:, model.nq:] = rng.normal(scale=0.5, size=(n, model.nu))
    return X


def main():
    args = parse_args(__doc__.splitlines()[0], default_n=[2000], default_repeat=7,
                      extra=lambda p: p.add_argument("--robot", action="append", choices=sorted(FEET)))
    rows, csv = [], []
    for name, (rel, feet) in FEET.items():
        if args.robot and name not in args.robot:
            continue
        path = ROBOTS / rel
        with tempfile.TemporaryDirectory() as tmp:
            plain, b_plain = build(path, feet + ["@no-ground"], Path(tmp) / "a")
            full, b_full = build(path, feet, Path(tmp) / "b")
            line, b_line = build(path, feet, Path(tmp) / "c", straight=True)
            npts = [sum(n.startswith("depth_") for n in m.output_names) for m in (plain, full)]
            for label, X in (("random", states(plain, args.n[0], np.random.default_rng(29))),
                             ("no-flag run", trajectory(full, args.n[0]))):
                agree = np.max(np.abs(full.rhs_many(0.0, X) - line.rhs_many(0.0, X)))
                times = {"plain": [], "full": [], "line": []}
                for _ in range(args.repeat):             # interleaved blocks
                    for key, m in (("plain", plain), ("full", full), ("line", line)):
                        m.rhs_many(0.0, X[:50])
                        t0 = time.thread_time()
                        m.rhs_many(0.0, X)
                        times[key].append((time.thread_time() - t0) / len(X))
                tp, tf, tl = (median_iqr(times[k])[0] for k in ("plain", "full", "line"))
                rows.append([name, label, npts[0], npts[1], f"{b_plain:.1f}", f"{b_full:.1f}", f"{b_line:.1f}",
                             f"{tp * 1e6:.2f}", f"{tf * 1e6:.2f}", f"{tl * 1e6:.2f}", f"{tf / tp:.2f}",
                             f"{tl / tp:.2f}", f"{agree:.1e}"])
                csv.append([name, label, npts[0], npts[1], b_plain, b_full, b_line, tp, tf, tl, agree])
                print(rows[-1], flush=True)
    headers = ["robot", "states", "contact points (feet only)", "contact points (default)", "build CPU s (feet only)",
               "build CPU s (default)", "build CPU s (default, straight-line)", "rhs µs (feet only)",
               "rhs µs (default)", "rhs µs (default, straight-line)", "rhs ratio (default)",
               "rhs ratio (straight-line)", "max |rhs - straight-line|"]
    table = format_table(headers, rows)
    text = environment_header("The default ground's cost: feet only vs feet + the other links' collision geometry",
                              args) + "\n" + __doc__.split("\n\n", 2)[2] + "\n\n" + table + "\n"
    print(table)
    if not args.no_write:
        write_results("default_ground", text, csv, ["robot", "states", "points_feet", "points_default", "build_feet_s",
                                                    "build_default_s", "build_straight_s", "rhs_feet_s",
                                                    "rhs_default_s", "rhs_straight_s", "max_abs_difference"])


if __name__ == "__main__":
    main()
