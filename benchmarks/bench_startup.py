"""How fast `eomc simulate DIR` of a built directory starts and finishes (issue 10: goal <= 0.3 s).

Contestants, run as fresh processes, interleaved round by round, pinned to one core:

- ``python -c pass``            the interpreter alone (the floor)
- ``python -c "import numpy"``  the runtime's one heavy dependency (the realistic floor)
- ``eomc simulate DIR``         load a built double pendulum and integrate 1 s (the path under test)
- ``eomc simulate MODEL.py``    the same from the model file, warm cache (runs the file: SymPy)

Per process: wall time, and CPU time (user + sys of the child, from getrusage), which is what
a quiet machine's wall time would be.  Usage: ``python benchmarks/bench_startup.py [--repeat N]``.
"""
import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import Timing, environment_header, format_table, write_results  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
MODEL = ROOT / "examples" / "double_pendulum.py"
GOAL = 0.3


def _pin():
    try:
        os.sched_setaffinity(0, {max(os.sched_getaffinity(0))})
    except (AttributeError, OSError):
        pass


def _run(argv, env):
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(argv, env=env, check=True, stdout=subprocess.DEVNULL, preexec_fn=_pin)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=9)
    args = parser.parse_args()
    py = sys.executable
    with tempfile.TemporaryDirectory() as tmp:
        env = {**os.environ, "EOMC_CACHE_DIR": str(Path(tmp) / "cache")}
        built = Path(tmp) / "dp"
        subprocess.run([py, "-m", "eomc", "build", str(MODEL), "-o", str(built), "-q"], env=env, check=True,
                       stdout=subprocess.DEVNULL)
        sim = ["simulate", "--t-final", "1", "-o", os.devnull]
        contestants = {
            "python -c pass": [py, "-c", "pass"],
            "python -c 'import numpy'": [py, "-c", "import numpy"],
            "eomc simulate DIR": [py, "-m", "eomc", sim[0], str(built), *sim[1:]],
            "eomc simulate MODEL.py (warm cache)": [py, "-m", "eomc", sim[0], str(MODEL), *sim[1:]],
        }
        for argv in contestants.values():      # warm the page cache and the build cache
            _run(argv, env)
        walls = {k: [] for k in contestants}
        cpus = {k: [] for k in contestants}
        for _ in range(args.repeat):
            for name, argv in contestants.items():
                wall, cpu = _run(argv, env)
                walls[name].append(wall)
                cpus[name].append(cpu)
    numpy_cpu = Timing(cpus["python -c 'import numpy'"]).median
    rows = []
    for name in contestants:
        w, c = Timing(walls[name]), Timing(cpus[name])
        rows.append([name, w.median, w.iqr, c.median, c.iqr, c.median / numpy_cpu,
                     ("met" if c.median <= GOAL else "missed") if name == "eomc simulate DIR" else ""])
    headers = ["process", "wall [s]", "wall IQR [s]", "CPU [s]", "CPU IQR [s]", "CPU / import numpy",
               f"goal CPU <= {GOAL} s"]
    table = format_table(headers, rows)
    print(table)
    notes = [f"{args.repeat} rounds, contestants interleaved within each round, each a fresh process "
             f"pinned to one core; medians with IQR",
             "CPU = user + sys of the child process (getrusage): the wall time of a quiet machine; "
             "wall times here include waiting for the shared, loaded CPUs",
             "eomc simulate integrates the double pendulum over 1 s (dop853) and writes the CSV to /dev/null"]
    text = environment_header("Start-up of `eomc simulate` on a built directory (issue 10)", args, notes)
    write_results("startup", text + "\n" + table + "\n")


if __name__ == "__main__":
    main()
