"""`eomc build` with no flags of a model file that calls ``system.form_eoms()`` itself (eomc's
System, the n-link cart: benchmarks/tree_models/cart_rel_joints_form_eoms.py): what forming
Kane's equations in the file costs when the default build (auto) takes the recursive form.

Contestants, interleaved per n and repeat, each in a fresh child process with a fresh cache
(CPU = user + sys of the child and its C compiler):

- "form_eoms(), result unused": the file as SymPy's documentation writes it;
- "form_eoms(), result read": the same file also reads the returned equations
  (EOMC_READ_EOMS=1: their shape), so Kane's equations are formed in the file whatever the
  build does -- what every form_eoms() call cost before it was made lazy;
- "no form_eoms() (unformed System)": the same file without the call (EOMC_FORM_EOMS=0),
  the cost the lazy call should come close to.

The default function set unless --outputs.  A build past --cpu-cap CPU s is stopped.

    python benchmarks/bench_form_eoms.py [--n 40] [--repeat 1] [--cpu-cap 300] [--outputs rhs]
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

MODEL = Path(__file__).resolve().parent / "tree_models" / "cart_rel_joints_form_eoms.py"
CONTESTANTS = {"form_eoms(), result unused": {}, "form_eoms(), result read": {"EOMC_READ_EOMS": "1"},
               "no form_eoms() (unformed System)": {"EOMC_FORM_EOMS": "0"}}


def build(n, env_extra, cap, outputs):
    """(CPU s or None when stopped at the cap, wall s, NAME.json metadata or None, peak RSS MB)."""
    out = tempfile.mkdtemp(prefix="eomc_fe_")
    env = dict(os.environ, EOMC_N_LINKS=str(n), EOMC_CACHE_DIR=tempfile.mkdtemp(prefix="eomc_fec_"),
               **env_extra)

    def limit():
        resource.setrlimit(resource.RLIMIT_CPU, (cap, cap + 5))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    cmd = [sys.executable, "-m", "eomc", "build", str(MODEL), "-o", out, "-q"]
    if outputs:
        cmd += ["--outputs", outputs]
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True, preexec_fn=limit)
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
    def extra(p):
        p.add_argument("--cpu-cap", type=int, default=300, help="stop a build after this many CPU s")
        p.add_argument("--outputs", help="functions to generate (default: the default set)")
    args = parse_args(__doc__.splitlines()[0], default_n=[40], default_repeat=1, argv=argv, extra=extra)
    load_start = " / ".join(f"{v:.2f}" for v in os.getloadavg())
    results = {}
    for n in args.n:
        for _ in range(args.repeat):
            for label, env_extra in CONTESTANTS.items():
                cpu, wall, meta, rss = build(n, env_extra, args.cpu_cap, args.outputs)
                results.setdefault((n, label), []).append((cpu, wall, meta, rss))
                shown = f"{cpu:.1f}" if cpu is not None else f"> {args.cpu_cap}"
                print(f"n={n} {label}: {shown} s CPU, {wall:.1f} s wall, "
                      f"{meta['formulation'] if meta else '-'}", flush=True)
    headers = ["n", "contestant", "formulation", "CPU s (median)", "wall s (median)", "peak RSS MB", "rhs ops"]
    rows = []
    for (n, label), runs in results.items():
        done = [r for r in runs if r[0] is not None]
        meta = done[0][2] if done else None
        ops = (meta or {}).get("op_counts", {})
        rows.append([n, label, meta["formulation"] if meta else "-",
                     f"{median_iqr([r[0] for r in done])[0]:.1f}" if len(done) == len(runs)
                     else f"> {args.cpu_cap} (stopped)",
                     f"{median_iqr([r[1] for r in runs])[0]:.1f}", f"{max(r[3] for r in runs):.0f}",
                     sum(ops["rhs"].values()) if "rhs" in ops else "-"])
    table = format_table(headers, rows)
    print(table)
    if not args.no_write:
        text = environment_header("A model file that calls System.form_eoms(), built with no flags", args, notes=[
            "Model: benchmarks/tree_models/cart_rel_joints_form_eoms.py (eomc's System of one "
            "PrismaticJoint and n PinJoints; the file calls system.form_eoms()); "
            f"functions: {args.outputs or 'the default set'}; runtime parameters; a fresh child "
            "process and cache per build; CPU = user + sys of the child and its C compiler.",
            "'result read' forms Kane's equations in the file (what form_eoms() did before it "
            "was made lazy); 'result unused' is the same file as SymPy's documentation writes it.",
            f"load average at the start of the run: {load_start}"])
        write_results("form_eoms_build", text + "\n" + table + "\n")


if __name__ == "__main__":
    main()
