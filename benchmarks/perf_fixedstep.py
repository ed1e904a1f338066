"""Where one implicitfast call's time goes: perf's samples of bench_fixedstep's C call, by function.

    python benchmarks/perf_fixedstep.py [--model humanoid] [--seconds 15] [--core 0] [--group]

Why: the fixed step's cost per simulated second is calls x (one NAME_implicit call + the step's
share per call), and which side to cut -- the generated model function's parts or the step's
(runtime/c/eomc_fixedstep.c) -- needs their split on the run itself, not on a harness.  This runs
the gymnasium model's qpos0 run at its MJCF timestep (bench_fixedstep.eomc_call, events off) in a
loop under ``perf record`` (cpu-clock sampling: no hardware counters are needed, so it works
under KVM), with sampling switched on only once the model is loaded (perf's control fifo), and
prints per function its share of the C loop's samples and its ns per model call (the loop's
thread CPU per run over the run's calls).  Python and the kernel are left out of the shares.

The model library is loaded from a copy that is deleted once open (runtime/native's trash
directory), so perf cannot name its static functions (NAME_implicit_part*, the pairs' and
ground points' loops, NAME_finite_wide); they are named here from ``nm`` of the cached library
the run loaded (the same bytes).  Functions inlined into NAME_implicit_var (the pairs' loop on the
gymnasium humanoid) count as it.  --group sums NAME_implicit_partA_B by A.  Needs perf
(/usr/bin/perf) and nm.  Prints, writes nothing; results are quoted in
benchmarks/results/fixedstep.md's notes.
"""
import argparse
import bisect
import collections
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))


def child(model_name, seconds, ctl, cache_dir, split=None):
    """Load the model, make its call, switch perf on, loop the call for ``seconds`` of thread CPU;
    print the run's calls, the CPU per run and the model library's path."""
    import mujoco
    import numpy as np  # noqa: F401
    from bench_fixedstep import eomc_call, eomc_model, eomc_start, gym_xml
    m = eomc_model(model_name, cache_dir)
    base = mujoco.MjModel.from_xml_path(str(gym_xml(model_name)))
    call, _, st = eomc_call(m, eomc_start(m, base), float(base.opt.timestep), split=split)
    call()
    with open(ctl, "w") as f:          # perf: start sampling
        f.write("enable\n")
    t0, n = time.thread_time(), 0
    while time.thread_time() - t0 < seconds:
        call()
        n += 1
    per_run = (time.thread_time() - t0) / n
    lib = Path(m.library_path) if getattr(m, "library_path", None) else None
    print(f"RESULT {st.nfev} {per_run!r} {lib}", flush=True)


def model_symbols(lib):
    """(sorted start addresses, names) of the library's text symbols, static ones included."""
    out = subprocess.run(["nm", "-n", "--defined-only", str(lib)], capture_output=True, text=True, check=True).stdout
    syms = []
    for line in out.splitlines():
        parts = line.split()
        if len(parts) == 3 and parts[1] in "tTwW":
            syms.append((int(parts[0], 16), parts[2]))
    syms.sort()
    return [a for a, _ in syms], [n for _, n in syms]


def clean(name):
    return re.sub(r"\.(isra|part|constprop|cold)\.\d+", "", name)


def shares(data, lib, group):
    """{label: percent of all samples} over perf's report of ``data``; the model library's
    addresses named from ``lib``'s symbols."""
    addrs, names = model_symbols(lib)
    rep = subprocess.run(["perf", "report", "-i", data, "--no-children", "--sort", "dso,sym", "-F", "overhead,dso,sym",
                          "--field-separator", "|"], capture_output=True, text=True, check=True).stdout
    out = collections.Counter()
    for line in rep.splitlines():
        if line.startswith("#") or line.count("|") < 2:
            continue
        ov, dso, sym = (s.strip() for s in line.split("|", 2))
        ov = float(ov.rstrip("%"))
        sym = sym.replace("[.]", "").replace("[k]", "").strip()
        if dso.startswith(("libpython", "[kernel", "_cffi", "[vdso", "python")):
            out["(python, kernel)"] += ov
            continue
        if dso == lib.name:
            hit = re.search(r"0x([0-9a-f]+)", sym)
            if hit:
                i = bisect.bisect_right(addrs, int(hit.group(1), 16)) - 1
                sym = names[i] if i >= 0 else "?"
            sym = clean(sym)
            if group:
                sym = re.sub(r"(_implicit_part\d+)_\d+$", r"\1_*", sym)
            out[f"model: {sym}"] += ov
        elif dso.startswith("_eomc_integrators"):
            out[f"step: {clean(sym)}"] += ov
        else:
            out[f"{dso.split('.so')[0]}: {clean(sym)}"] += ov
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="humanoid", help="a gymnasium model of bench_fixedstep (hopper, walker2d, "
                        "ant, humanoid)")
    parser.add_argument("--seconds", type=float, default=15.0, help="thread CPU seconds of the sampled loop")
    parser.add_argument("--core", type=int, default=0)
    parser.add_argument("--frequency", type=int, default=5000, help="perf's samples per second")
    parser.add_argument("--group", action="store_true", help="sum NAME_implicit_partA_B by A")
    parser.add_argument("--top", type=int, default=40)
    parser.add_argument("--cache-dir", default=os.environ.get("EOMC_CACHE_DIR"))
    parser.add_argument("--split", type=float, default=None,
                        help="the fast path's residual test (default: simulate's; 0: off, one call a step)")
    parser.add_argument("--child", nargs=2, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.model, args.seconds, args.child[0], args.child[1] or None, args.split)
        return
    with tempfile.TemporaryDirectory() as tmp:
        ctl, data = os.path.join(tmp, "ctl"), os.path.join(tmp, "perf.data")
        os.mkfifo(ctl)
        cmd = ["taskset", "-c", str(args.core), "perf", "record", "-q", "-F", str(args.frequency), "-D", "-1",
               "--control", f"fifo:{ctl}", "-o", data, "--", sys.executable, __file__, "--model", args.model,
               "--seconds", str(args.seconds), "--child", ctl, args.cache_dir or ""]
        if args.split is not None:
            cmd += ["--split", repr(args.split)]
        load0 = open("/proc/loadavg").read().split()[0]
        run = subprocess.run(cmd, capture_output=True, text=True)
        hit = [line for line in run.stdout.splitlines() if line.startswith("RESULT ")]
        if run.returncode or not hit:
            sys.exit(f"perf run failed ({run.returncode}):\n{run.stdout}\n{run.stderr}")
        _, calls, per_run, lib = hit[0].split(" ", 3)
        calls, per_run, lib = int(calls), float(per_run), Path(lib)
        got = shares(data, lib, args.group)
    load1 = open("/proc/loadavg").read().split()[0]
    ns_call = per_run / calls * 1e9
    loop = sum(v for k, v in got.items() if k != "(python, kernel)")
    print(f"{args.model}: {per_run * 1e3:.3f} ms CPU per simulated s, {calls} model calls: {ns_call:.0f} ns a call "
          f"with its share of the step; core {args.core}, load {load0} -> {load1}; "
          f"{got['(python, kernel)']:.1f} % of the samples in Python and the kernel (left out)")
    print(f"{'share':>7} {'ns/call':>8}  function")
    side = collections.Counter()
    for k, v in got.most_common():
        if k == "(python, kernel)":
            continue
        side[k.split(":")[0]] += v
    for k, v in [kv for kv in got.most_common() if kv[0] != "(python, kernel)"][:args.top]:
        print(f"{v / loop * 100:6.1f}% {v / loop * ns_call:8.0f}  {k}")
    print("by library: " + ", ".join(f"{k} {v / loop * 100:.1f} % ({v / loop * ns_call:.0f} ns)"
                                     for k, v in side.most_common() if v / loop >= 0.005))


if __name__ == "__main__":
    main()
