"""The C compile of big default builds, one process against gcc's parallel back end (-flto=N).

    python benchmarks/bench_parallel_build.py [--rounds 2] [--no-write]

Why: the generated C of a model with many contacts is megabytes of straight-line code that gcc
compiled in one process while the machine's other cores idled (dm_control's stacker: 30 s of a
52 s default build).  Since session 44 a translation unit from toolchain.PARALLEL_FROM bytes is
compiled with -flto=N, N = $EOMC_BUILD_JOBS or the CPUs this process may use (at most 8).  This
generates each model's default functions once, then builds the same C into fresh caches with
EOMC_BUILD_JOBS=1 (one unit, as before) and with the default, alternating, and reports the
build's wall time and its compiler processes' CPU, medians over rounds; and whether every output
of rhs and jac_x agrees bit for bit between the two libraries at 50 random states.
"""
import argparse
import os
import resource
import statistics
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import publish  # noqa: E402

MODELS = {
    "gymnasium humanoid": ("gymnasium", "envs/mujoco/assets/humanoid.xml"),
    "dm_control stacker": ("dm_control", "suite/stacker.xml"),
}


def model_path(pkg, rel):
    mod = __import__(pkg)
    return Path(mod.__file__).parent / rel


def timed_build(gen, jobs):
    from eomc.compiler.build import build
    from eomc.runtime.loader import load
    old = os.environ.get("EOMC_BUILD_JOBS")
    if jobs is None:
        os.environ.pop("EOMC_BUILD_JOBS", None)
    else:
        os.environ["EOMC_BUILD_JOBS"] = str(jobs)
    try:
        with tempfile.TemporaryDirectory() as tmp:
            c0 = resource.getrusage(resource.RUSAGE_CHILDREN)
            t0 = time.perf_counter()
            res = build(gen, cache_dir=tmp)
            wall = time.perf_counter() - t0
            c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
            model = load(res.directory)
            rng = np.random.default_rng(0)
            outs = [np.concatenate([model.rhs(0.0, x), model.jac_x(0.0, x).ravel()])
                    for x in rng.uniform(-0.5, 0.5, (50, model.nx))]
            parallel = model.metadata["build"].get("parallel", [])
            del model
    finally:
        if old is None:
            os.environ.pop("EOMC_BUILD_JOBS", None)
        else:
            os.environ["EOMC_BUILD_JOBS"] = old
    cpu = (c1.ru_utime + c1.ru_stime) - (c0.ru_utime + c0.ru_stime)
    return wall, cpu, np.array(outs), parallel


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args()
    from eomc.compiler.build.toolchain import build_jobs
    from eomc.compiler.driver import generate
    rows = []
    for label, (pkg, rel) in MODELS.items():
        with warnings.catch_warnings(), tempfile.TemporaryDirectory() as gcache:
            warnings.simplefilter("ignore")
            _, gen = generate(model_path(pkg, rel), "m", cache_dir=gcache, progress=False)
        got = {1: [], None: []}
        ref = {}
        for r in range(args.rounds):
            for jobs in ((1, None) if r % 2 == 0 else (None, 1)):
                wall, cpu, outs, parallel = timed_build(gen, jobs)
                got[jobs].append((wall, cpu))
                ref[jobs] = (outs, parallel)
        same = np.array_equal(ref[1][0].view(np.uint64), ref[None][0].view(np.uint64))
        w1 = statistics.median(w for w, _ in got[1])
        wn = statistics.median(w for w, _ in got[None])
        rows.append([label, f"{len(gen.c_source) / 1e6:.2f}", " ".join(ref[None][1]) or "(one unit)",
                     f"{w1:.1f}", f"{statistics.median(c for _, c in got[1]):.1f}",
                     f"{wn:.1f}", f"{statistics.median(c for _, c in got[None]):.1f}", f"{w1 / wn:.2f}",
                     "yes" if same else "NO"])
        print(rows[-1], flush=True)
    head = ["model", "C [MB]", "default's flag", "one unit: wall [s]", "one unit: compiler CPU [s]",
            "default: wall [s]", "default: compiler CPU [s]", "wall one / default", "same bits (rhs, jac_x)"]
    table = "| " + " | ".join(head) + " |\n|" + "---|" * len(head) + "\n" + "".join(
        "| " + " | ".join(r) + " |\n" for r in rows)
    publish("parallel_build", "The C compile of big default builds: one process vs gcc's parallel back end",
            [__doc__.split("\n\n", 2)[2].strip(),
             f"build jobs on this machine: {build_jobs()}; {args.rounds} rounds, the two builds alternating, "
             f"medians; wall = eomc's build() (compile, stack measurement, publishing), CPU = its "
             f"compiler processes'.", table], sys.argv)


if __name__ == "__main__":
    main()
