"""The default function set of a humanoid with its self-collision pairs as one table call
(``pairs.PAIR_TABLE``, jac_x on the analytic kernel, compiler/tree/analytic.py) against the
default without self-pairs, each build in a fresh child with a fresh cache, CPU time of the
child and its C compiler and their peak RSS, contestants interleaved per round (issue 33 item 1:
a default with self-pairs must cost at most ~1.2x today's default build).

Models: gymnasium's humanoid (109 self-pairs; results/pair_default_build.md) or, with
``--model cmu``, dm_control's humanoid_CMU (1002; results/pair_default_build_cmu.md).
Builds: ``nopairs`` (``pairs="trees"``), ``table`` (the default: the kernel forms the table
inputs' tangents and calls its tangent loop itself, analytic._kernel_pair_lines) and ``blockw``
(the path before it, forced: the tangents per state column from generated SymPy code into an[]
block W, lower._kernel_table refused -- the same C as main before session 13).

    python benchmarks/bench_pair_default_build.py [--model cmu] [--rounds 3] [--modes nopairs,table,blockw] [--nice]
        (pin it: taskset -c 1; --nice: the builds under nice)
    python benchmarks/bench_pair_default_build.py --child MODEL MODE OUT  (one build)
"""
import glob
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

MODES = ("nopairs", "table", "blockw")
MODELS = {"humanoid": ("gymnasium", "envs/mujoco/assets/humanoid.xml", "pair_default_build",
                       "Humanoid default build with self-pairs (table + kernel jac_x)"),
          "cmu": ("dm_control", "suite/humanoid_CMU.xml", "pair_default_build_cmu",
                  "dm_control humanoid_CMU default build with its 1002 self-pairs (table + kernel jac_x)")}


def child(model, mode, out):
    import importlib
    import eomc
    from eomc.compiler.contact import pairs
    from eomc.compiler.mjcf.model import MjcfModel
    from eomc.compiler.tree import lower
    package, rel, *_ = MODELS[model]
    path = os.path.join(os.path.dirname(importlib.import_module(package).__file__), rel)
    kw = dict(pairs="trees")            # no self-pairs: the default before session 11
    if mode in ("table", "blockw"):
        pairs.PAIR_TABLE = True
        kw = dict(pairs=True)
    if mode == "blockw":
        lower._kernel_table = lambda *a: None
    t0 = time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        eomc.compile(MjcfModel(path, **kw), "hum", cache_dir=out, progress=False)
    own = time.process_time() - t0
    ch = resource.getrusage(resource.RUSAGE_CHILDREN)
    me = resource.getrusage(resource.RUSAGE_SELF)
    size = sum(os.path.getsize(f) for f in glob.glob(f"{out}/**/hum*.c", recursive=True))
    print(f"{own + ch.ru_utime + ch.ru_stime:.2f} {own:.2f} {size} {me.ru_maxrss} {ch.ru_maxrss}")


def main():
    from common import environment_header, write_results
    rounds = int(sys.argv[sys.argv.index("--rounds") + 1]) if "--rounds" in sys.argv else 3
    model = sys.argv[sys.argv.index("--model") + 1] if "--model" in sys.argv else "humanoid"
    modes = (tuple(sys.argv[sys.argv.index("--modes") + 1].split(",")) if "--modes" in sys.argv
             else MODES)
    _, _, result, title = MODELS[model]
    cpu, rows = {m: [] for m in modes}, []
    for r in range(rounds):
        for mode in modes:
            load = os.getloadavg()[0]
            out = tempfile.mkdtemp(prefix="eomc_pdb_")
            env = dict(os.environ, EOMC_CACHE_DIR=tempfile.mkdtemp(prefix="eomc_pdbc_"))
            nice = ["nice"] if "--nice" in sys.argv else []
            text = subprocess.run(nice + [sys.executable, __file__, "--child", model, mode, out], env=env,
                                  check=True, capture_output=True, text=True).stdout.split()
            total, own, size, rss, crss = float(text[0]), float(text[1]), int(text[2]), int(text[3]), int(text[4])
            cpu[mode].append(total)
            rows.append(f"| {r + 1} | {mode} | {total:.1f} | {own:.1f} | {size / 1e6:.2f} | {rss / 1024:.0f} "
                        f"| {crss / 1024:.0f} | {load:.1f} |")
            print(rows[-1], flush=True)
    med = {m: statistics.median(v) for m, v in cpu.items()}
    ratios = [f"{m} {med[m] / med['nopairs']:.2f}x" for m in modes if m != "nopairs"] if "nopairs" in med else []
    text = "\n".join([environment_header(title), "",
                      "| round | build | CPU s (incl. gcc) | Python s | C MB | peak RSS Python MB | peak RSS gcc MB | load |",
                      "|---|---|---|---|---|---|---|---|",
                      *rows, "", "Median CPU: " + ", ".join(f"{m} {v:.1f} s" for m, v in med.items())
                      + (" (against no self-pairs: " + ", ".join(ratios) + ")." if ratios else ".")])
    print(text)
    if "--no-write" not in sys.argv:
        write_results(result, text, keep_notes=True)


if __name__ == "__main__":
    if "--child" in sys.argv:
        i = sys.argv.index("--child")
        child(sys.argv[i + 1], sys.argv[i + 2], sys.argv[i + 3])
    else:
        main()
