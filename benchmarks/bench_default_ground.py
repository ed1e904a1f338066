"""What the default ground costs: a URDF robot with named feet, with and without its other
bodies' <collision> geometry meeting the ground (issue 29; compiler/urdf/model._ground).

    taskset -c 1 python benchmarks/bench_default_ground.py [--repeat 7] [--no-write]

Per robot, both builds (feet only: ``@no-ground``; the default: feet plus every other link's
collision geometry as bounding-box corners): the number of contact points, the build's CPU
time (a cold build in a fresh cache: generation and C compile, this process's and its
children's CPU), and the rhs per call (thread CPU time of ``rhs_many`` over 2000 random
states near the standing pose, C loop, blocks interleaved between the two builds, medians of
the repeats).  The ratio is default ÷ feet only from the same run.
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
from common import environment_header, format_table, median_iqr, parse_args, write_results  # noqa: E402

ROBOTS = Path("/root/.pyenv/versions/3.11.7/lib/python3.11/site-packages/cmeel.prefix/share/"
              "example-robot-data/robots")
FEET = {
    "go2": ("go2_description/urdf/go2.urdf", [f"{n}:0,0,0:0.022" for n in ("FL_foot", "FR_foot", "RL_foot", "RR_foot")]),
    "solo12": ("solo_description/robots/solo12.urdf", [f"{n}:0,0,0:0.016" for n in ("FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT")]),
    "g1": ("g1_description/urdf/g1_29dof_rev_1_0.urdf", ["@collision"]),
}


def cpu():
    a, b = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return a.ru_utime + a.ru_stime + b.ru_utime + b.ru_stime


def build(path, contacts, cache):
    import eomc
    from eomc.compiler.urdf.model import UrdfModel
    c0 = cpu()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(UrdfModel(path, floating_base=True, contacts=tuple(contacts)), cache_dir=cache,
                             progress=False)
    return model, cpu() - c0


def states(model, n, rng):
    X = np.zeros((n, model.nx))
    z = model.state_names.index(next(s for s in model.state_names if s.endswith("_floating_z")))
    X[:, :model.nq] = rng.normal(scale=0.2, size=(n, model.nq))
    X[:, z] = rng.uniform(0.0, 0.4, size=n)          # some bodies in the ground, some not
    X[:, model.nq:] = rng.normal(scale=0.5, size=(n, model.nu))
    return X


def main():
    args = parse_args(__doc__.splitlines()[0], default_n=[2000], default_repeat=7)
    rows, csv = [], []
    for name, (rel, feet) in FEET.items():
        path = ROBOTS / rel
        with tempfile.TemporaryDirectory() as tmp:
            plain, b_plain = build(path, feet + ["@no-ground"], Path(tmp) / "a")
            full, b_full = build(path, feet, Path(tmp) / "b")
            X = states(plain, args.n[0], np.random.default_rng(29))
            times = {"plain": [], "full": []}
            for _ in range(args.repeat):             # interleaved blocks
                for label, m in (("plain", plain), ("full", full)):
                    m.rhs_many(0.0, X[:50])
                    t0 = time.thread_time()
                    m.rhs_many(0.0, X)
                    times[label].append((time.thread_time() - t0) / len(X))
            npts = [sum(n.startswith("depth_") for n in m.output_names) for m in (plain, full)]
            tp, tf = median_iqr(times["plain"])[0], median_iqr(times["full"])[0]
            rows.append([name, npts[0], npts[1], f"{b_plain:.1f}", f"{b_full:.1f}", f"{tp * 1e6:.2f}",
                         f"{tf * 1e6:.2f}", f"{tf / tp:.2f}"])
            csv.append([name, npts[0], npts[1], b_plain, b_full, tp, tf])
            print(rows[-1], flush=True)
    headers = ["robot", "contact points (feet only)", "contact points (default)", "build CPU s (feet only)",
               "build CPU s (default)", "rhs µs (feet only)", "rhs µs (default)", "rhs ratio"]
    table = format_table(headers, rows)
    text = environment_header("The default ground's cost: feet only vs feet + the other links' collision geometry",
                              args) + "\n" + __doc__.split("\n\n", 2)[2] + "\n\n" + table + "\n"
    print(table)
    if not args.no_write:
        write_results("default_ground", text, csv, ["robot", "points_feet", "points_default", "build_feet_s",
                                                    "build_default_s", "rhs_feet_s", "rhs_default_s"])


if __name__ == "__main__":
    main()
