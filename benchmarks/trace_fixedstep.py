"""Where implicitfast's model calls beyond one a step go: its tries sorted by what made them.

    python benchmarks/trace_fixedstep.py [--models hopper,walker2d,ant,humanoid] [--rows 16]
        [--cache-dir DIR] [--no-write]

Why: the fixed step's speed against MuJoCo's (bench_fixedstep.py, bench_rollout_contacts.py) is its
cost per call times its calls per step, and the checked step (the residual test, simulate's default)
takes more calls than steps wherever a contact touches down or a joint enters its limit inside a step.
Which of the step's rules those calls go to -- the failed whole steps, the part before a located
onset, the onset cell, the walk back up the grid after it, plain halving -- and what changed regime
in them decides what to work on next; the count of calls alone cannot say it.

How: the integrator library is built a second time with -DEOMC_FS_TRACE (runtime/c/eomc_fixedstep.c
prints one line per try of its fast path; the installed library has no such code), into a temporary
directory, and each model runs in a worker process that opens that library instead of the installed
one: bench_fixedstep's qpos0 run (the pose at rest, 1 s at the file's timestep) and the first --rows
of bench_rollout_contacts' starts (seed 0: its random joint speeds), each as ``simulate(method=
"implicitfast")``'s C call with events off (bench_fixedstep.eomc_call).  The same code and bits as
the installed library's runs, with the lines added.

Per model: steps, tries and model calls (a try is one call; a cell Newton solves (fs_last_cell) makes
more), then a split step's tries after its failed whole try -- the extra tries -- by kind, each "ok"
(taken) or "failed" (tried again smaller from the same place), and the split steps by what changed
regime over their whole try: contacts (touching down, lifting off, a depth or a clip changing) with a
touch-down's onset cell located in the step or without one, joint laws (a limit entered or left),
both, or neither (the residual alone: friction switching, the chart).
"""
import argparse
import collections
import os
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import environment_header, format_table, write_results  # noqa: E402

MODELS = ("hopper", "walker2d", "ant", "humanoid")
GRID = 64           # eomc_fixedstep.c MAX_SPLIT: a whole step's try is (pos 0, size 64)
ROOT = Path(__file__).resolve().parent.parent
SOURCES = ("eomc_integrators.c", "eomc_fixedstep.c", "eomc_fixedstep_avx2.c", "eomc_bdf.c", "eomc_sensitivity.c",
           "eomc_rollout.c", "eomc_adjoint.c", "eomc_rows.c")
KINDS = ("before onset", "onset cell", "walk", "halving")
# eomc_fixedstep.c's walk: the next size aims at a ratio of WALK_TARGET * split (split: simulate's
# IMPLICITFAST_SPLIT), at most WALK_GROW times the take's, cut to the halving grid (fs_walk_size)
WALK_AIM = 0.5 * 0.5
WALK_GROW = 16
BANDS = (0.05, 0.1, 0.25, 0.5)
CAUSES = ("contacts, an onset located", "contacts, none located", "joint laws", "contacts and joint laws", "neither")


def build_traced(out_dir):
    """The integrator library with -DEOMC_FS_TRACE (setup.py's flags), built from this checkout's
    runtime/c into ``out_dir``; its path."""
    c = ROOT / "runtime" / "c"
    lib = Path(out_dir) / "_eomc_integrators_trace.so"
    cmd = [os.environ.get("CC", "cc"), "-O2", "-std=c99", "-pthread", "-fPIC", "-shared", "-falign-functions=64",
           "-falign-loops=32", "-DEOMC_FS_TRACE", f"-I{c}", *[str(c / s) for s in SOURCES], "-lm", "-o", str(lib)]
    run = subprocess.run(cmd, capture_output=True, text=True)
    if run.returncode:
        sys.exit(f"building the traced integrator library failed:\n{' '.join(cmd)}\n{run.stderr}")
    return lib


def worker(lib, name, rows, cache_dir):
    """In this process, with the traced library: the model's runs, each announced on stderr
    (``EOMC_FS_RUN label calls``) after its tries' lines."""
    import mujoco

    import eomc.runtime.native as native
    native._library_path = lambda: Path(lib)
    import bench_fixedstep as B
    import bench_rollout_contacts as R
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        em, mm, _, _, height, pose = R._models(name, cache_dir)
        X0 = R.starts(em, mm, height, pose)[0][:rows]
    base = mujoco.MjModel.from_xml_path(str(B.gym_xml(name)))
    dt = float(mm.opt.timestep)
    starts = [("qpos0", B.eomc_start(em, base))] + [(f"start {i}", x0) for i, x0 in enumerate(X0)]
    for label, x0 in starts:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            call, _, st = B.eomc_call(em, x0, dt)
            call()
        sys.stderr.flush()
        print(f"EOMC_FS_RUN {label.replace(' ', '_')} {st.nfev}", file=sys.stderr, flush=True)


def parse(text):
    """[(label, calls, [try dicts])] from a worker's stderr."""
    runs, tries = [], []
    for line in text.splitlines():
        f = line.split()
        if not f:
            continue
        if f[0] == "EOMC_FS_TRY":
            tries.append(dict(t=float(f[1]), pos=int(f[2]), size=int(f[3]), status=int(f[4]), ratio=float(f[5]),
                              onset=int(f[6]), walk=int(f[7]), located=int(f[8]), touching=int(f[9]),
                              contacts=int(f[10]), joints=int(f[11])))
        elif f[0] == "EOMC_FS_RUN":
            runs.append((f[1], int(f[2]), tries))
            tries = []
    return runs


def steps_of(tries):
    """The tries grouped by step: each step starts with its whole try (pos 0, the whole grid)."""
    out = []
    for t in tries:
        if t["pos"] == 0 and t["size"] == GRID:
            out.append([])
        if out:
            out[-1].append(t)
    return out


def kind_of(t):
    if t["onset"] == t["pos"] and t["size"] == 1:
        return "onset cell"
    if t["walk"]:
        return "walk"
    if t["located"]:
        return "before onset"
    return "halving"


def cause_of(whole):
    """What changed regime over a split step's whole try (fs_switched's tests, each on its own)."""
    c, j = whole["contacts"], whole["joints"]
    if c and j:
        return "contacts and joint laws"
    if j:
        return "joint laws"
    if c:
        return "contacts, an onset located" if whole["touchdown"] else "contacts, none located"
    return "neither"


def bands():
    """The ratio bands' labels, lowest first."""
    edges = (None,) + BANDS
    return [f"< {b:g}" if a is None else f"{a:g} - {b:g}" for a, b in zip(edges, BANDS)] + [f">= {BANDS[-1]:g}"]


def band(r):
    return bands()[next((i for i, b in enumerate(BANDS) if r < b), len(BANDS))]


def walk_limit(t, nxt):
    """What sized the try after a taken walk try ``t`` (``nxt``: the next try of its step, or None)."""
    end = t["pos"] + t["size"]
    if end >= GRID:
        return "it ended the step"
    aimed = t["size"] * min(WALK_GROW, WALK_AIM / t["ratio"] if t["ratio"] > 0 else WALK_GROW)
    if aimed >= GRID - end:
        return "its ratio allowed the rest of the step (the grid cut it)"
    if nxt is not None and nxt["size"] < aimed / 2:
        return "the grid cut it below half its ratio's aim"
    return "its ratio (the aim of WALK_TARGET * split)"


def tally(runs):
    """Counts over runs: steps, tries, calls, per kind (ok, failed), per cause (split steps, extra tries),
    and the taken walk tries by ratio band and by what sized the try after them."""
    n = collections.Counter()
    kinds = collections.Counter()
    causes = collections.Counter()
    walks = collections.Counter()
    for _, calls, tries in runs:
        n["calls"] += calls
        n["tries"] += len(tries)
        for step in steps_of(tries):
            n["steps"] += 1
            if len(step) == 1:
                continue
            whole = dict(step[0], touchdown=any(kind_of(t) == "onset cell" for t in step))
            cause = cause_of(whole)
            causes[(cause, "steps")] += 1
            causes[(cause, "extra")] += len(step) - 1
            for i, t in enumerate(step[1:], 1):
                nxt = step[i + 1] if i + 1 < len(step) else None
                failed = nxt is not None and nxt["pos"] == t["pos"]
                kinds[(kind_of(t), "failed" if failed else "ok")] += 1
                if kind_of(t) == "walk" and not failed:
                    walks[("band", band(t["ratio"]))] += 1
                    walks[("limit", walk_limit(t, nxt))] += 1
            kinds[("whole step", "failed")] += 1
    return n, kinds, causes, walks


def table(name, runs):
    n, kinds, causes, walks = tally(runs)
    extra = n["tries"] - n["steps"]
    out = [f"**{name}** ({len(runs)} runs: qpos0 and {len(runs) - 1} of bench_rollout_contacts' starts): "
           f"{n['steps']} steps, {n['tries']} tries, {n['calls']} model calls; "
           f"{extra} tries beyond one a step ({100 * extra / max(n['steps'], 1):.1f} per 100 steps)", ""]
    rows = []
    for k in KINDS:
        ok, failed = kinds[(k, "ok")], kinds[(k, "failed")]
        if ok or failed:
            rows.append([k, ok, failed, f"{100 * (ok + failed) / max(extra, 1):.0f} %"])
    out.append(format_table([f"extra try ({kinds[('whole step', 'failed')]} split steps)", "ok", "failed",
                             "of the extra tries"], rows))
    out.append("")
    rows = [[c, causes[(c, "steps")], causes[(c, "extra")], f"{100 * causes[(c, 'extra')] / max(extra, 1):.0f} %"]
            for c in CAUSES if causes[(c, "steps")]]
    out.append(format_table(["split steps: what changed regime in the whole try", "steps", "extra tries",
                             "of the extra tries"], rows))
    taken = kinds[("walk", "ok")]
    if taken:
        out.append("")
        rows = [[f"ratio {b}", walks[("band", b)], f"{100 * walks[('band', b)] / taken:.0f} %"]
                for b in bands() if walks[("band", b)]]
        rows += [[f"next try sized by: {k}", v, f"{100 * v / taken:.0f} %"]
                 for (what, k), v in sorted(walks.items()) if what == "limit"]
        out.append(format_table(["taken walk tries", "tries", "share"], rows))
    return "\n".join(out), n, kinds, causes


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", default=",".join(MODELS))
    parser.add_argument("--rows", type=int, default=16, help="bench_rollout_contacts' starts per model")
    parser.add_argument("--cache-dir", default=os.environ.get("EOMC_CACHE_DIR"))
    parser.add_argument("--no-write", action="store_true")
    parser.add_argument("--worker", nargs=2, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        worker(args.worker[0], args.worker[1], args.rows, args.cache_dir)
        return
    parts = []
    summary = []
    with tempfile.TemporaryDirectory() as tmp:
        lib = build_traced(tmp)
        for name in args.models.split(","):
            cmd = [sys.executable, __file__, "--worker", str(lib), name, "--rows", str(args.rows)]
            if args.cache_dir:
                cmd += ["--cache-dir", args.cache_dir]
            run = subprocess.run(cmd, capture_output=True, text=True)
            if run.returncode:
                sys.exit(f"{name}: the worker failed ({run.returncode}):\n{run.stderr[-4000:]}")
            runs = parse(run.stderr)
            text, n, kinds, causes = table(name, runs)
            print(text + "\n", flush=True)
            parts.append(text)
            extra = n["tries"] - n["steps"]
            walk = kinds[("walk", "ok")] + kinds[("walk", "failed")]
            onset = sum(kinds[(k, s)] for k in ("before onset", "onset cell") for s in ("ok", "failed"))
            summary.append([name, n["steps"], n["tries"], n["calls"], f"{100 * extra / max(n['steps'], 1):.1f}",
                            kinds[("whole step", "failed")],
                            f"{100 * onset / max(extra, 1):.0f} %", f"{100 * walk / max(extra, 1):.0f} %",
                            f"{100 * (kinds[('halving', 'ok')] + kinds[('halving', 'failed')]) / max(extra, 1):.0f} %"])
    head = environment_header("implicitfast's tries: where the calls beyond one a step go", args,
                              notes=("no timing here: counts over one run per start (the same on any machine "
                                     "for the same library and model)",))
    summ = format_table(["model", "steps", "tries", "model calls", "extra tries per 100 steps", "split steps",
                         "onset located (before + cell)", "walk back", "halving"], summary)
    text = "\n\n".join([head, __doc__.split("\n\n", 2)[2].strip(), summ, *parts])
    if not args.no_write:
        write_results("fixedstep_tries", text, keep_notes=True)


if __name__ == "__main__":
    main()
