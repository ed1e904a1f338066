"""dm_control's humanoid_CMU default build with its ground-touching ellipsoids (its hands) planned
in the analytic kernel (contacts.support_motion, analytic block GM) against the tangent path they
kept before session 14 (``contacts.PLAN_SHAPES = False``: the plan refused, jac_x differentiated
the whole recursion per state column): build phases' CPU, C size, jac_x per call and its
agreement (issue 33 / issue 30: the CMU default build cost ~330-406 s CPU).

Builds (``--build``): each in a fresh child with a fresh cache, ``eomc.compile`` with the default
function set and no flags; the stages' clocks (derive / generate / compile, compiler/driver.py)
read the child's CPU time with its waited-for children (gcc), so each stage's figure is CPU s.
``--before DIR --after DIR``: libraries built elsewhere (``eomc build ... -o DIR``) instead.

jac_x: thread CPU per call, the contestants interleaved per round, medians of the rounds, at the
file's initial state (standing, at rest: no hand on the floor) and at random states near it with
the body lowered so that feet or hands press the floor (the hands' contacts' normal forces, the
outputs Fn_lhand / Fn_rhand, counted).  Agreement: the kernel's jac_x against the tangent's, and
against central differences of each library's rhs (h = 1e-6 max(1, |x_k|)), relative to max(1, |J|).

    taskset -c 0 python benchmarks/bench_ellipsoid_kernel.py --build [--rounds 5] [--no-write]
    taskset -c 0 python benchmarks/bench_ellipsoid_kernel.py --before DIR --after DIR
    python benchmarks/bench_ellipsoid_kernel.py --child MODE OUT     (one build)
"""
import glob
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests" / "compiler" / "tree"))

MODES = ("tangent", "kernel")
STATES = 6          # random states (besides the initial one)
CALLS = 20


def cmu_file():
    import dm_control
    return os.path.join(os.path.dirname(dm_control.__file__), "suite", "humanoid_CMU.xml")


class _CpuClock:
    """compiler/driver.py's ``time`` for the child: perf_counter reads CPU (self + waited children)."""

    @staticmethod
    def perf_counter():
        me, ch = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
        return me.ru_utime + me.ru_stime + ch.ru_utime + ch.ru_stime

    def __getattr__(self, name):
        return getattr(time, name)


def child(mode, out):
    import eomc
    from eomc.compiler import driver
    from eomc.compiler.mjcf.model import MjcfModel
    from eomc.compiler.tree import contacts
    contacts.PLAN_SHAPES = mode == "kernel"
    driver.time = _CpuClock()
    timings, base = {}, driver.Progress

    class Recorded(base):       # compile() makes its own Progress: its stage timings land in ``timings``
        def __init__(self, *a, **k):
            super().__init__(*a, **k)
            self.timings = timings

    driver.Progress = Recorded
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(MjcfModel(cmu_file()), "cmu", cache_dir=out, progress=False)
    size = sum(os.path.getsize(f) for f in glob.glob(f"{out}/**/cmu*.c", recursive=True))
    print(json.dumps({"timings": timings, "c": size, "dir": str(Path(model.source_path).parent),
                      "rss": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss,
                      "gcc_rss": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss}))


def per_call(call, n=CALLS):
    from common import thread_cpu_per_call
    return thread_cpu_per_call(call, n)


def relative(J, ref):
    """max |J - ref| / max(1, max |ref|) (tests/compiler/tree/test_analytic_contacts.py's measure)."""
    return float(np.abs(J - ref).max()) / max(1.0, float(np.abs(ref).max()))


def states(model):
    """The initial state, then random states near it lowered onto the floor: (label, x, hands)."""
    names = list(model.output_names)
    hands = [i for i, k in enumerate(names) if k in ("Fn_lhand", "Fn_rhand")]
    iz = model.state_names.index("q_root_z")
    x0 = np.asarray(model.initial_state, dtype=float)
    rng = np.random.default_rng(3)
    out, kinds = [("initial (at rest)", x0)], {True: 0, False: 0}
    while min(kinds.values()) < STATES // 2:     # half with a hand on the floor, half without
        x = x0.copy()
        x[:model.nq] += rng.normal(scale=0.5, size=model.nq)
        x[iz] = rng.uniform(0.05, 0.6)
        x[model.nq:] = rng.normal(scale=0.5, size=model.nu)
        hand = bool(np.any(np.array(list(model.outputs(0.0, x).values()))[hands] > 0))
        if kinds[hand] < STATES // 2:
            kinds[hand] += 1
            out.append((f"random {len(out)}", x))
    return [(lab, x, int(np.count_nonzero(np.array(list(model.outputs(0.0, x).values()))[hands] > 0)))
            for lab, x in out]


def main(argv):
    import eomc
    from common import environment_header, format_table, write_results
    from test_analytic_contacts import central      # the tests' central differences of the rhs
    rounds = int(argv[argv.index("--rounds") + 1]) if "--rounds" in argv else 5
    builds, dirs = [], {}
    if "--build" in argv:
        for mode in MODES:
            load = os.getloadavg()[0]
            out = tempfile.mkdtemp(prefix="eomc_ek_")
            env = dict(os.environ, EOMC_CACHE_DIR=tempfile.mkdtemp(prefix="eomc_ekc_"))
            res = json.loads(subprocess.run([sys.executable, __file__, "--child", mode, out], env=env, check=True,
                                            capture_output=True, text=True).stdout.splitlines()[-1])
            t = res["timings"]
            builds.append([mode, t.get("derive", 0), t.get("generate", 0), t.get("compile", 0),
                           sum(t.values()), res["c"] / 1e6, res["rss"] / 1024, res["gcc_rss"] / 1024, load])
            print(builds[-1], flush=True)
            dirs[mode] = res["dir"]
    else:
        dirs = {"tangent": argv[argv.index("--before") + 1], "kernel": argv[argv.index("--after") + 1]}
    models = {k: eomc.load(v) for k, v in dirs.items()}
    fast, slow = models["kernel"], models["tangent"]
    rows = []
    for label, x, hands in states(fast):
        contestants = {k: (lambda mm=mm: mm.jac_x(0.0, x)) for k, mm in models.items()}
        samples = {k: [] for k in contestants}
        for _ in range(rounds):
            for k, call in contestants.items():
                samples[k].append(per_call(call))
        med = {k: statistics.median(v) for k, v in samples.items()}
        J, ref, fd = fast.jac_x(0.0, x), slow.jac_x(0.0, x), central(fast, x)
        rows.append([label, hands, med["tangent"] * 1e6, med["kernel"] * 1e6, med["kernel"] / med["tangent"],
                     relative(J, ref), relative(J, fd), relative(ref, central(slow, x))])
        print(rows[-1], flush=True)
    parts = [environment_header("humanoid_CMU: ellipsoid contacts in the analytic kernel"), ""]
    if builds:
        parts += [format_table(["build", "derive CPU s", "generate CPU s", "compile CPU s (gcc)", "total CPU s",
                                "C MB", "peak RSS Python MB", "peak RSS gcc MB", "load"], builds), "",
                  "One child per build, fresh cache, default function set, no flags; stage clocks read CPU "
                  "(self + waited children).", ""]
    parts += [format_table(["state", "hands on the floor", "tangent jac_x µs", "kernel jac_x µs", "kernel / tangent",
                            "|kernel - tangent|", "|kernel - central|", "|tangent - central|"], rows), "",
              f"jac_x: thread CPU per call, medians of {rounds} interleaved rounds ({CALLS} calls each). "
              "Differences: max |difference| / max(1, max |reference|) (the reference: the tangent's J, or "
              "central differences of that library's rhs, h = 1e-6 max(1, |x_k|)). "
              "The initial state has joints at their limits (the fingers' and wrists'): jac_x there is "
              "one side's slope, so central differences differ in those columns for both paths."]
    text = "\n".join(parts)
    print(text)
    if "--no-write" not in argv:
        write_results("ellipsoid_kernel_cmu", text, keep_notes=True)


if __name__ == "__main__":
    if "--child" in sys.argv:
        i = sys.argv.index("--child")
        child(sys.argv[i + 1], sys.argv[i + 2])
    else:
        main(sys.argv[1:])
