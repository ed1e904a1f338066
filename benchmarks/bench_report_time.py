"""How long a user waits for `eomc report MODEL` with no flags (G1 and Go2 with their feet as
contacts, Solo12, gymnasium's humanoid, the double pendulum example), cold (an empty build cache:
derivation, C generation and gcc included), for two or more checkouts in the same run.

    python benchmarks/bench_report_time.py --side main=/path/to/eomc --side branch=/path/to/eomc \\
        [--models g1,go2,humanoid,pendulum] [--cpus 1] [--no-write]

Each `eomc report` runs as a user types it (a fresh process, stdout and stderr to files, a new
EOMC_CACHE_DIR); its wall time and CPU time (its and its children's: gcc, a second thread) are
recorded with the load before and after, its exit status, and where the wall time went: every
stderr line is stamped with the seconds since the start (err.txt), and the table sums the time
between progress lines by stage (build: until the reference starts; reference; each method's rows;
the rest: writing the CSV, PNG and Markdown).  The sides alternate (which goes first alternates
by model), so both see the same load in turn.  --cpus pins every command to those cores (taskset).
Why (s34, reportg1): G1's report with no flags took 41 min wall at load 5-10 (s33).
"""
import argparse
import os
import re
import resource
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from common import environment_header, write_results  # noqa: E402
from contact_defaults import robots  # noqa: E402

ROW = re.compile(r"^eomc report: (\w+)\s+(dt=[^\s:]+|tol=[^\s:]+)\s+(.*)$")


def models():
    every = robots()
    pendulum = HERE.parent / "examples" / "double_pendulum.py"
    return {"g1": every["g1"], "go2": every["go2"], "solo12": every["solo12"],
            "humanoid": every["humanoid"], "pendulum": [str(pendulum)]}


def loadavg():
    return float(Path("/proc/loadavg").read_text().split()[0])


def _stamp(stream, path, t0):
    with open(path, "w") as f:
        for raw in iter(stream.readline, b""):
            line = raw.decode(errors="replace").rstrip("\n")
            # a terminal's live line is not drawn in a log; each line is one event
            f.write(f"{time.perf_counter() - t0:9.2f} {line}\n")
            f.flush()


def report(eomc, spec, cache, work, cpus, extra):
    """(exit, wall s, CPU s, load before, load after, stages {name: s}, rows, last stdout line)."""
    out_dir = work / "out"
    if out_dir.exists():
        shutil.rmtree(out_dir)
    cmd = ([shutil.which("taskset"), "-c", cpus] if cpus else []) + [eomc, "report", *spec, "-o",
                                                                      str(out_dir), *extra]
    env = {**os.environ, "EOMC_CACHE_DIR": str(cache)}
    before, load0 = resource.getrusage(resource.RUSAGE_CHILDREN), loadavg()
    t0 = time.perf_counter()
    with open(work / "out.txt", "w") as out:
        p = subprocess.Popen(cmd, cwd=work, env=env, stdout=out, stderr=subprocess.PIPE)
        th = threading.Thread(target=_stamp, args=(p.stderr, work / "err.txt", t0))
        th.start()
        rc = p.wait()
        th.join()
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    stages, rows, last_t, where = {}, 0, 0.0, "build"
    for line in (work / "err.txt").read_text().splitlines():
        t, _, text = line.strip().partition(" ")
        t = float(t)
        m = ROW.match(text.strip())
        if "computing the reference" in text:
            stages["build"] = stages.get("build", 0.0) + t - last_t
            last_t, where = t, "reference"
        elif where == "reference" and text.startswith("eomc report: reference: ") and (
                "checked against" in text or "not checked" in text):
            stages["reference"] = stages.get("reference", 0.0) + t - last_t
            last_t, where = t, "rows"
        elif m:
            # rows on threads: each gap between row lines goes to the row that ended it
            stages[m.group(1)] = stages.get(m.group(1), 0.0) + t - last_t
            last_t, rows = t, rows + 1
    stages["rest"] = wall - last_t
    tail = [ln for ln in (work / "out.txt").read_text().splitlines() if ln.strip()]
    return rc, wall, cpu, load0, loadavg(), stages, rows, (tail[-3] if len(tail) >= 3 else "")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--side", action="append", required=True, help="NAME=path/to/eomc (one or more)")
    ap.add_argument("--models", default="g1,go2,humanoid,pendulum")
    ap.add_argument("--cpus", default="", help="taskset -c CPUS for every command (default: none)")
    ap.add_argument("--extra", default="", help="arguments added to every report (e.g. '--t-final 5')")
    ap.add_argument("--work", default="/tmp/bench_report_time")
    ap.add_argument("--name", default="report_time", help="results/NAME.md")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    sides = [s.split("=", 1) for s in args.side]
    every = models()
    rows = []
    for k, name in enumerate(args.models.split(",")):
        order = sides if k % 2 == 0 else sides[::-1]
        for side, eomc in order:
            cache = Path(args.work) / f"cache-{side}-{name}"
            if cache.exists():
                shutil.rmtree(cache)
            work = Path(args.work) / f"{side}-{name}"
            work.mkdir(parents=True, exist_ok=True)
            got = report(eomc, every[name], cache, work, args.cpus, args.extra.split())
            rows.append((name, side, *got))
            st = ", ".join(f"{s} {v:.0f}" for s, v in got[5].items())
            print(f"{name:9s} {side:8s} exit {got[0]} wall {got[1]:7.1f} s CPU {got[2]:7.1f} s "
                  f"load {got[3]:.1f}->{got[4]:.1f} rows {got[6]} [{st}]", flush=True)
    table = ["| robot | side | exit | wall s | CPU s | load before → after | rows | wall by stage (s) |",
             "|---|---|--:|--:|--:|---|--:|---|"]
    for name, side, rc, wall, cpu, l0, l1, stages, n, _ in rows:
        st = ", ".join(f"{s} {v:.0f}" for s, v in stages.items())
        table.append(f"| {name} | {side} | {rc} | {wall:.1f} | {cpu:.1f} | {l0:.1f} → {l1:.1f} | {n} | {st} |")
    text = environment_header("`eomc report` with no flags: wall and CPU, cold cache", args,
                              notes=[f"sides: {', '.join(f'{s} = {e}' for s, e in sides)}",
                                     f"cores: {'taskset -c ' + args.cpus if args.cpus else 'not pinned'}",
                                     f"models: {', '.join(' '.join(every[n]) for n in args.models.split(','))}"]) \
        + "\n" + "\n".join(table) + "\n"
    print(text)
    if not args.no_write:
        for path in write_results(args.name, text, keep_notes=True):
            print("wrote", path)


if __name__ == "__main__":
    main()
