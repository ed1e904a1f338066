"""The default function set of gymnasium's humanoid with its 109 self-collision pairs as one table
call (``pairs.PAIR_TABLE``, jac_x on the analytic kernel, compiler/tree/analytic.py block W)
against the default without self-pairs, each build in a fresh child with a fresh cache, CPU time
of the child and its C compiler, contestants interleaved per round (issue 33 item 1: a default
with self-pairs must cost at most ~1.2x today's default build).

    python benchmarks/bench_pair_default_build.py [--rounds 3]      (pin it: taskset -c 1)
    python benchmarks/bench_pair_default_build.py --child MODE OUT  (one build; MODE nopairs|table)
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

MODES = ("nopairs", "table")


def child(mode, out):
    import gymnasium
    import eomc
    from eomc.compiler.contact import pairs
    from eomc.compiler.mjcf.model import MjcfModel
    path = os.path.join(os.path.dirname(gymnasium.__file__), "envs/mujoco/assets/humanoid.xml")
    kw = dict(pairs="trees")            # no self-pairs: the default before session 11
    if mode == "table":
        pairs.PAIR_TABLE = True
        kw = dict(pairs=True)
    t0 = time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        eomc.compile(MjcfModel(path, **kw), "hum", cache_dir=out, progress=False)
    own = time.process_time() - t0
    ch = resource.getrusage(resource.RUSAGE_CHILDREN)
    size = sum(os.path.getsize(f) for f in glob.glob(f"{out}/**/hum*.c", recursive=True))
    print(f"{own + ch.ru_utime + ch.ru_stime:.2f} {own:.2f} {size}")


def main():
    from common import environment_header, write_results
    rounds = int(sys.argv[sys.argv.index("--rounds") + 1]) if "--rounds" in sys.argv else 3
    cpu, rows = {m: [] for m in MODES}, []
    for r in range(rounds):
        for mode in MODES:
            load = os.getloadavg()[0]
            out = tempfile.mkdtemp(prefix="eomc_pdb_")
            env = dict(os.environ, EOMC_CACHE_DIR=tempfile.mkdtemp(prefix="eomc_pdbc_"))
            text = subprocess.run([sys.executable, __file__, "--child", mode, out], env=env, check=True,
                                  capture_output=True, text=True).stdout.split()
            total, own, size = float(text[0]), float(text[1]), int(text[2])
            cpu[mode].append(total)
            rows.append(f"| {r + 1} | {mode} | {total:.1f} | {own:.1f} | {size / 1e6:.2f} | {load:.1f} |")
            print(rows[-1], flush=True)
    med = {m: statistics.median(v) for m, v in cpu.items()}
    ratio = med["table"] / med["nopairs"]
    text = "\n".join([environment_header("Humanoid default build with self-pairs (table + kernel jac_x)"), "",
                      "| round | build | CPU s (incl. gcc) | Python s | C MB | load |", "|---|---|---|---|---|---|",
                      *rows, "", f"Median CPU: no self-pairs {med['nopairs']:.1f} s, table {med['table']:.1f} s, "
                      f"ratio {ratio:.2f}x."])
    print(text)
    if "--no-write" not in sys.argv:
        write_results("pair_default_build", text, keep_notes=True)


if __name__ == "__main__":
    if "--child" in sys.argv:
        i = sys.argv.index("--child")
        child(sys.argv[i + 1], sys.argv[i + 2])
    else:
        main()
