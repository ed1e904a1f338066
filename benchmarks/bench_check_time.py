"""How long a user waits for `eomc check` with no flags on the contact robots of issue 29's "done
when" (G1 and Go2 with their feet as contacts, Solo12, gymnasium's humanoid and ant), cold (an
empty build cache: derivation, C generation and gcc included) and warm (the same cache again),
for two checkouts in the same run.

    python benchmarks/bench_check_time.py --side main=/work/venvs/base31/bin/eomc \\
        --side branch=/work/venvs/check3/bin/eomc [--models g1,go2,solo12,humanoid,ant] \\
        [--rounds 1] [--cpus 0] [--phases cold,warm] [--no-write]

Each `eomc check` runs as a user types it (a fresh process, stdout and stderr to files); its wall
time and CPU time (its and its children's: gcc, the second reference's thread) are recorded with
the load before and after, its exit status (0 passed, 1 failed, 3 inconclusive), its summary line
and up to when it judged ("until t=" of the reference line).  The sides alternate (which goes
first alternates by model and round), each with a cache of its own per round, so both see the
same load in turn.  --cpus pins every command to those cores (taskset): with one core the two
references cannot run at once, and what is left is the stop where they part.
Why (s31, check3): G1's cold check took 305 s wall at load ~1-7 (s30), most of it two references
run one after the other to t = 10 where they part at t = 1.15.
"""
import argparse
import os
import re
import resource
import shutil
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from common import environment_header, write_results  # noqa: E402
from contact_defaults import robots  # noqa: E402

UNTIL = re.compile(r"\[\s*ok\] reference: they agree to \S+ x tolerance until t=(\S+),")
SUMMARY = re.compile(r"^\d+ of \d+ checks passed.*$", re.M)


def loadavg():
    return float(Path("/proc/loadavg").read_text().split()[0])


def check(eomc, spec, cache, work, cpus):
    """(exit, wall s, CPU s, load before, load after, summary, judged until) of one check."""
    cmd = ([shutil.which("taskset"), "-c", cpus] if cpus else []) + [eomc, "check", *spec]
    env = {**os.environ, "EOMC_CACHE_DIR": str(cache)}
    before, load0 = resource.getrusage(resource.RUSAGE_CHILDREN), loadavg()
    t0 = time.perf_counter()
    with open(work / "out.txt", "w") as out, open(work / "err.txt", "w") as err:
        rc = subprocess.run(cmd, cwd=work, env=env, stdout=out, stderr=err).returncode
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    text = (work / "out.txt").read_text()
    summary = SUMMARY.search(text)
    until = UNTIL.search(text)
    return (rc, wall, cpu, load0, loadavg(), summary.group(0) if summary else text.strip()[-120:],
            until.group(1) if until else "t_final")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--side", action="append", required=True, help="NAME=path/to/eomc (two or more)")
    ap.add_argument("--models", default="g1,go2,solo12,humanoid,ant")
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--cpus", default="", help="taskset -c CPUS for every command (default: none)")
    ap.add_argument("--phases", default="cold,warm", help="cold (a new cache, then warm) and/or warm (the "
                    "cache of a previous run in --work, or built by the first run)")
    ap.add_argument("--work", default="/tmp/bench_check_time")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    sides = [s.split("=", 1) for s in args.side]
    every = robots()
    rows = []
    for r in range(args.rounds):
        for k, name in enumerate(args.models.split(",")):
            order = sides if (k + r) % 2 == 0 else sides[::-1]
            for phase in args.phases.split(","):
                for side, eomc in order:
                    cache = Path(args.work) / f"cache-{side}-{name}-{r}"
                    if phase == "cold" and cache.exists():
                        shutil.rmtree(cache)
                    work = Path(args.work) / f"{side}-{name}-{r}-{phase}"
                    work.mkdir(parents=True, exist_ok=True)
                    got = check(eomc, every[name], cache, work, args.cpus)
                    rows.append((r, name, phase, side, *got))
                    print(f"round {r} {name:9s} {phase} {side:8s} exit {got[0]} wall {got[1]:7.1f} s "
                          f"CPU {got[2]:7.1f} s load {got[3]:.1f}->{got[4]:.1f} judged until {got[6]}: "
                          f"{got[5][:90]}", flush=True)
    table = ["| round | robot | cache | side | exit | wall s | CPU s | wall / first side's | load before → after | judged until t | summary |",
             "|--:|---|---|---|--:|--:|--:|--:|---|---|---|"]
    first = sides[0][0]
    base = {(r, n, ph): wall for r, n, ph, s, rc, wall, *_ in rows if s == first}
    for r, name, phase, side, rc, wall, cpu, l0, l1, summary, until in rows:
        ratio = wall / base[(r, name, phase)] if base.get((r, name, phase)) else float("nan")
        table.append(f"| {r} | {name} | {phase} | {side} | {rc} | {wall:.1f} | {cpu:.1f} | {ratio:.2f} | "
                     f"{l0:.1f} → {l1:.1f} | {until} | {summary.replace('|', '/')[:140]} |")
    text = environment_header("`eomc check` with no flags: wall and CPU, cold and warm cache, two checkouts", args,
                              notes=[f"sides: {', '.join(f'{s} = {e}' for s, e in sides)}",
                                     f"cores: {'taskset -c ' + args.cpus if args.cpus else 'not pinned'}"]) \
        + "\n" + "\n".join(table) + "\n"
    print(text)
    if not args.no_write:
        for path in write_results("check_time", text, keep_notes=True):
            print("wrote", path)


if __name__ == "__main__":
    main()
