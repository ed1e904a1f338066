"""A model file's tilted planes in the ground points' loop: its default build before and after, and
its functions against each other (benchmarks/results/tilted_planes.md).

"Before" is this checkout with the loop's eligibility as it was (ground_table.eligible: the plane
z = 0 only), "after" as it is (any plane of numbers, the loop in the plane's frame).  Both builds
run in this process one after the other, fresh caches, default functions; then the two libraries
are called interleaved at the file's initial state (rhs and outputs, Python call included, median
of blocks) and compared at perturbed states (rhs, outputs, jac_x: the largest difference over the
state's largest entry).

Usage: python benchmarks/tilted_planes.py MODEL.xml [--rounds N]
"""
import argparse
import os
import resource
import shutil
import sys
import tempfile
import time
import warnings

import numpy as np

import eomc
from eomc.compiler.contact import ground_table as gt

OLD = gt.eligible


def flat_only(load):
    return OLD(load) and gt.plane_of(load) == gt.FLAT


def build(path, cache, eligible):
    gt.eligible = eligible
    try:
        c0, w0 = time.process_time(), time.perf_counter()
        ch0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = eomc.compile(path, cache_dir=cache, progress=False)
        ch1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        gcc = (ch1.ru_utime + ch1.ru_stime) - (ch0.ru_utime + ch0.ru_stime)
        return model, time.process_time() - c0, gcc, time.perf_counter() - w0, os.path.getsize(model.source_path)
    finally:
        gt.eligible = OLD


def by_function(source, name):
    """[(function, characters)] of the generated C, largest first: each public NAME_<f>( definition
    with the static routines and parts before it since the last one (its own split parts)."""
    import re
    marks = [(m.start(), m.group(1)) for m in re.finditer(rf"^int {name}_(\w+)\(", source, re.M)]
    sizes, last = {}, 0
    for at, fn in marks:
        end = source.find("\n}\n", at)
        sizes[fn] = sizes.get(fn, 0) + (end - last)
        last = end
    return sorted(sizes.items(), key=lambda kv: -kv[1])[:8]


def per_call(fn, x, n=2000):
    t = time.perf_counter()
    for _ in range(n):
        fn(0.0, x)
    return (time.perf_counter() - t) / n


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("model")
    ap.add_argument("--rounds", type=int, default=7)
    args = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="tilted_")
    try:
        rows = {}
        for tag, eligible in (("before", flat_only), ("after", OLD)):
            rows[tag] = build(args.model, os.path.join(tmp, tag), eligible)
            m, py, gcc, wall, size = rows[tag]
            source = open(m.source_path).read()
            print(f"{tag}: python CPU {py:.1f} s, gcc CPU {gcc:.1f} s, wall {wall:.1f} s, C {size / 1e6:.2f} MB, "
                  f"loop in rhs: {'eomc_ground(' in source[source.index(f'int {m.name}_rhs('):]}", flush=True)
            print("   C by function (MB): " + ", ".join(f"{k} {v / 1e6:.2f}" for k, v in by_function(source, m.name)),
                  flush=True)
        a, b = rows["after"][0], rows["before"][0]
        x0 = np.array(a.initial_state, dtype=float)
        rng = np.random.default_rng(0)
        worst = {"rhs": 0.0, "outputs": 0.0, "jac_x": 0.0}
        for _ in range(20):
            x = x0.copy()
            x[:a.nq] += rng.normal(scale=0.05, size=a.nq)
            x[a.nq:a.nq + a.nu] = rng.normal(scale=0.5, size=a.nu)
            for name in worst:
                ya, yb = getattr(a, name)(0.0, x), getattr(b, name)(0.0, x)
                ya, yb = (np.array(list(v.values())) if isinstance(v, dict) else np.asarray(v) for v in (ya, yb))
                worst[name] = max(worst[name], float(np.abs(ya - yb).max() / max(1.0, np.abs(yb).max())))
        print("agreement after vs before at 20 perturbed states (max relative):",
              ", ".join(f"{k} {v:.1e}" for k, v in worst.items()))
        for fn in ("rhs", "outputs"):
            times = {"after": [], "before": []}
            for r in range(args.rounds):
                for tag, m in (("after", a), ("before", b)) if r % 2 == 0 else (("before", b), ("after", a)):
                    times[tag].append(per_call(getattr(m, fn), x0))
            print(f"{fn} at the initial state, median of {args.rounds} blocks: after {np.median(times['after']) * 1e9:.0f} ns, "
                  f"before {np.median(times['before']) * 1e9:.0f} ns")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
