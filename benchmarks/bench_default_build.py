"""`eomc build` with no flags at all -- what a user gets by default -- on the n-link cart as a
SymPy System of joints (benchmarks/tree_models/cart_rel_joints.py), against the previous
default (`--formulation kane`), measured in the same run.

Each build runs in a fresh child process with a fresh cache: default function set (rhs,
jac_x, jac_r, mass_matrix, forcing, inverse_dynamics, linearize), runtime parameters.  CPU
time is the child's user + sys (its C compiler included); the goal of issue 19 is <= 12 s
CPU at n = 40.  A contestant that passes --cpu-cap seconds is stopped (RLIMIT_CPU) and shown
as "> cap".  Contestants are interleaved per n and repeat.

    python benchmarks/bench_default_build.py [--n 4,20,40] [--repeat 1] [--cpu-cap 300]
"""
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import environment_header, format_table, median_iqr, parse_args, write_results  # noqa: E402

MODEL = Path(__file__).resolve().parent / "tree_models" / "cart_rel_joints.py"
CONTESTANTS = {"default (no flags)": [], "--formulation kane (previous default)": ["--formulation", "kane"]}


def build(n, flags, cap):
    """(CPU s or None when stopped at the cap, wall s, NAME.json metadata or None, peak RSS MB)."""
    out = tempfile.mkdtemp(prefix="eomc_db_")
    env = dict(os.environ, EOMC_N_LINKS=str(n), EOMC_CACHE_DIR=tempfile.mkdtemp(prefix="eomc_dbc_"))

    def limit():
        resource.setrlimit(resource.RLIMIT_CPU, (cap, cap + 5))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "eomc", "build", str(MODEL), "-o", out, "-q", *flags],
                          env=env, capture_output=True, text=True, preexec_fn=limit)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if proc.returncode:
        if proc.returncode < 0 or cpu >= cap:
            return None, wall, None, after.ru_maxrss / 1024
        raise RuntimeError(proc.stderr)
    meta = json.loads(next(p for p in Path(out).glob("*.json") if not p.name.startswith(".")).read_text())
    return cpu, wall, meta, after.ru_maxrss / 1024


def main(argv=None):
    args = parse_args(__doc__.splitlines()[0], default_n=[4, 20, 40], default_repeat=1, argv=argv,
                      extra=lambda p: p.add_argument("--cpu-cap", type=int, default=300,
                                                     help="stop a build after this many CPU s"))
    load_start = " / ".join(f"{v:.2f}" for v in os.getloadavg())
    results = {}
    for n in args.n:
        for _ in range(args.repeat):
            for label, flags in CONTESTANTS.items():
                cpu, wall, meta, rss = build(n, flags, args.cpu_cap)
                results.setdefault((n, label), []).append((cpu, wall, meta, rss))
                shown = f"{cpu:.1f}" if cpu is not None else f"> {args.cpu_cap}"
                print(f"n={n} {label}: {shown} s CPU, {wall:.1f} s wall, "
                      f"{meta['formulation'] if meta else '-'}", flush=True)
    headers = ["n", "contestant", "formulation", "CPU s (median)", "wall s", "peak RSS MB (largest child so far in the run)",
               "rhs ops", "jac_x ops"]
    rows = []
    for (n, label), runs in results.items():
        done = [r for r in runs if r[0] is not None]
        meta = done[0][2] if done else None
        ops = (meta or {}).get("op_counts", {})
        rows.append([n, label, meta["formulation"] if meta else "-",
                     f"{median_iqr([r[0] for r in done])[0]:.1f}" if len(done) == len(runs)
                     else f"> {args.cpu_cap} (stopped)",
                     f"{median_iqr([r[1] for r in runs])[0]:.1f}", f"{max(r[3] for r in runs):.0f}",
                     sum(ops["rhs"].values()) if "rhs" in ops else "-",
                     sum(ops["jac_x"].values()) if "jac_x" in ops else "-"])
    table = format_table(headers, rows)
    print(table)
    if not args.no_write:
        text = environment_header("Default build (`eomc build` with no flags) of the n-link cart System",
                                  args, notes=[
                                      "Model: benchmarks/tree_models/cart_rel_joints.py (a SymPy System of "
                                      "one PrismaticJoint and n PinJoints), default function set, runtime "
                                      "parameters; a fresh child process and cache per build; CPU = user + "
                                      "sys of the child and its C compiler.",
                                      "Goal (issue 19): <= 12 s CPU at n = 40 with the default functions.",
                                      f"load average at the start of the run: {load_start}"])
        write_results("default_build", text + "\n" + table + "\n")


if __name__ == "__main__":
    main()
