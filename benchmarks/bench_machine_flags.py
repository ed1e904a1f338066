"""The default build for this machine's CPU against the portable build (issue 31 item 4).

eomc's double libraries are built with ``-O2 -fPIC -std=c99`` plus, on an x86-64 CPU with
AVX2, ``-mavx2 -ffp-contract=off`` (compiler/build/toolchain.MACHINE_FLAGS); ``portable=True``
(``eomc build --portable``) keeps the plain flags.  For each robot (example-robot-data URDFs,
``--limits off``; floating bases with the quaternion) this builds the same generated C both
ways and reports:

- the rhs time of each library (one harness, gcc -O2, benchmarks/bench_urdf.py's; the same
  random states; thread CPU time, pinned to one core, the two builds interleaved, the order
  rotated every repeat; medians) and ns per operation (eomc's operation count of NAME_rhs);
- the machine code size of the library (``size``'s text) and the build's CPU time;
- whether rhs (and jac_x where generated) give the same bits at 256 random states.

    python benchmarks/bench_machine_flags.py             # ur10 solo12 go2 g1 talos
    python benchmarks/bench_machine_flags.py ur10 g1
"""
import os
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from bench_urdf import CORE, NCALLS, NSTATES, _run, _timed, _write, eomc_harness  # noqa: E402
from common import environment_header, format_table, median_iqr, write_results  # noqa: E402

ROBOTS = {"ur10": ("ur_description/urdf/ur10_robot.urdf", False, ["rhs", "jac_x"]),
          "solo12": ("solo12", "quaternion", ["rhs", "jac_x"]),
          "go2": ("go2_description/urdf/go2.urdf", "quaternion", ["rhs", "jac_x"]),
          "g1": ("g1_description/urdf/g1_29dof_rev_1_0.urdf", "quaternion", ["rhs", "jac_x"]),
          "talos": ("talos_data/robots/talos_full_v2.urdf", "quaternion", ["rhs"])}   # Talos' jac_x builds for hours
BUILDS = ("portable", "machine")
REPEAT = 9


def _children_cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _bits(models, rng):
    """True when every build gives the same bytes for rhs (and jac_x) at 256 random states."""
    base = models[BUILDS[0]]
    X = rng.uniform(-1.0, 1.0, (256, base.nx)) * rng.choice([0.3, 1.0, 3.0], (256, base.nx))
    def out(m):
        rows = [m.rhs(0.0, x) for x in X]
        if "jac_x" in m.metadata["functions"]:
            rows += [m.jac_x(0.0, x).ravel() for x in X]
        return np.concatenate(rows).view(np.uint64)
    ref = out(base)
    return all(np.array_equal(ref, out(models[b])) for b in BUILDS[1:])


def main(names):
    from eomc.compiler.build import build
    from eomc.compiler.driver import generate
    from eomc.compiler.urdf.model import UrdfModel
    from eomc.runtime.loader import load
    from helpers.robots import robot_path
    os.sched_setaffinity(0, {CORE})
    rng = np.random.default_rng(4)
    rows, robots, flags = [], [], {}
    with tempfile.TemporaryDirectory(prefix="bench_machine_flags_") as tmpname:
        tmp = Path(tmpname)
        for name in names:
            path, floating, functions = ROBOTS[name]
            _, gen = generate(UrdfModel(robot_path(path), floating_base=floating, limits=False), name,
                              functions=functions, cache_dir=tmp / "cache", progress=False)
            models, cmds, cpu, text = {}, {}, {}, {}
            for b in BUILDS:
                before = _children_cpu()
                built = build(gen, cache_dir=tmp / "cache", portable=b == "portable")
                cpu[b] = _children_cpu() - before
                models[b] = m = load(built.directory)
                flags[b] = " ".join(m.metadata["build"]["cflags"])
                text[b] = int(_run(["size", str(built.library)]).stdout.splitlines()[1].split()[0])
                states = [rng.uniform(-1.0, 1.0, m.nx) for _ in range(NSTATES)]
                if floating:
                    for x in states:
                        x[3:7] /= np.linalg.norm(x[3:7])
                (tmp / b).mkdir(exist_ok=True)
                _write(tmp / b / f"{name}.bin", states, head=[float(v) for v in m.param_defaults])
                cmds[b] = [str(eomc_harness(m, built.directory, tmp / b)), str(tmp / b / f"{name}.bin"),
                           str(NSTATES), str(NCALLS)]
            same = _bits(models, rng)
            ops = sum(int(v) for v in models["machine"].metadata["op_counts"]["rhs"].values())
            robots.append((name, cmds, cpu, text, same, ops, functions))
            print(f"{name}: built; same bits: {same}", flush=True)
        samples = {(r[0], b): [] for r in robots for b in BUILDS}
        for rep in range(REPEAT):
            for name, cmds, *_ in robots:
                for b in (BUILDS if rep % 2 == 0 else BUILDS[::-1]):
                    samples[name, b].append(_timed(cmds[b])[0])
            print(f"repeat {rep + 1}/{REPEAT}", flush=True)
    for name, cmds, cpu, text, same, ops, functions in robots:
        med = {b: median_iqr(samples[name, b])[0] for b in BUILDS}
        ratio = np.median(np.array(samples[name, "portable"]) / np.array(samples[name, "machine"]))
        rows.append([name, "+".join(functions), ops, round(med["portable"]), round(med["machine"]), f"{ratio:.3f}",
                     f"{med['portable'] / ops:.3f}", f"{med['machine'] / ops:.3f}",
                     f"{text['portable'] // 1024}", f"{text['machine'] // 1024}",
                     f"{cpu['portable']:.1f}", f"{cpu['machine']:.1f}", "yes" if same else "NO"])
    headers = ["robot", "functions", "rhs ops", "portable rhs [ns]", "machine rhs [ns]", "portable / machine",
               "portable ns/op", "machine ns/op", "portable text [kB]", "machine text [kB]",
               "portable build [s CPU]", "machine build [s CPU]", "same bits (rhs, jac_x)"]
    table = format_table(headers, rows)
    print(table)
    uptime = _run(["uptime"]).stdout.strip()
    header = environment_header(
        "The machine build (-mavx2 -ffp-contract=off) against the portable build (issue 31 item 4)", None,
        notes=[f"`python3 benchmarks/bench_machine_flags.py {' '.join(names)}`; uptime at the end: {uptime}",
               f"portable flags: {flags['portable']}; machine flags: {flags['machine']}",
               f"pinned to core {CORE}; thread CPU time; medians of {REPEAT} repeats of {NCALLS} calls over "
               f"{NSTATES} random states, the two builds interleaved (order alternated); ratio: median of the "
               "per-repeat ratios",
               "rhs ops: adds + multiplies + divides + calls of NAME_rhs as eomc counts them; text: `size` of the "
               "whole library (every generated function); build: CPU time of the compiler for the library",
               "same bits: rhs (and jac_x where built) byte for byte equal at 256 random states"])
    write_results("machine_flags", header + "\n" + table + "\n", csv_rows=rows, csv_headers=headers)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:] or list(ROBOTS)))
