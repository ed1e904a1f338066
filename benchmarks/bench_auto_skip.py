"""What auto's comparison of the two forms costs at build time, model by model (issue 31 item 5, task autoskip).

For every model auto may form Kane's equations for (at most select.AUTO_KANE_MAX_SPEEDS speeds): every
example-robot-data URDF with 1-6 moving joints (fixed base), the cart System (benchmarks/tree_models/
cart_rel_joints.py, n = 1-6 links) and the SymPy mechanics examples (examples/*.py).  One child process per
model runs ``eomc.compiler.driver.generate(model, formulation="auto", use_cache=False)`` with the default
functions, as a default ``eomc build`` does, and times in thread CPU time (time.thread_time):

* the recursive generate (select._generate_recursive),
* forming Kane's equations for the comparison (select._kane_side: the "Kane's equations (auto)" step),
* generating Kane's C (select._generate_kane), and the whole generate.

Each model is generated "before" (select.AUTO_SKIP_KANE = False: auto forms Kane's equations up to 6 speeds
whatever the tree, as before the skip) and "after" (the default), the two one after the other in a swapped
order each round (--rounds), medians; the table gives both picks and costs, the chain length the skip reads
(select.chain_length), and the generate CPU saved.  Child processes run --jobs at a time.
Usage: python benchmarks/bench_auto_skip.py [--rounds 3] [--jobs 2] [-k LABEL] [--json OUT] [--write]
"""
import argparse
import concurrent.futures
import json
import os
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent

CHILD = r"""
import json, sys, time
import eomc.compiler.formulations.select as s
from eomc.compiler.driver import generate
skip = sys.argv[2] == "1"
if not skip:
    s.AUTO_SKIP_KANE = False
cpu = {"recursive": 0.0, "kane_form": 0.0, "kane_generate": 0.0}
def timed(key, f):
    def wrapper(*a, **k):
        t0 = time.thread_time()
        try:
            return f(*a, **k)
        finally:
            cpu[key] += time.thread_time() - t0
    return wrapper
s._generate_recursive = timed("recursive", s._generate_recursive)
s._kane_side = timed("kane_form", s._kane_side)
s._generate_kane = timed("kane_generate", s._generate_kane)
t0 = time.thread_time()
spec, gen = generate(sys.argv[1], formulation="auto", use_cache=False, progress=False)
total = time.thread_time() - t0
m = gen.metadata
tree = getattr(spec.formed, "tree", None)
print(json.dumps(dict(cpu=cpu, total=total, chain=s.chain_length(tree) if tree is not None else None, formulation=m.get("formulation"), nu=m.get("nu"),
                      costs=m.get("formulation_costs"), note=m.get("formulation_note"),
                      rhs_ops=m.get("op_counts", {}).get("rhs"))))
"""


def models():
    """(label, model path, environment)."""
    from importlib.metadata import distribution
    robots = Path(distribution("example-robot-data").locate_file(
        "cmeel.prefix/share/example-robot-data/robots"))
    out = [(f"cart n={n}", HERE / "tree_models" / "cart_rel_joints.py", {"EOMC_N_LINKS": str(n)})
           for n in range(1, 7)]
    for ex in ("double_pendulum", "cart_pole_system", "heavy_top", "four_bar_system", "biomechanical_arm"):
        out.append((ex, ROOT / "examples" / f"{ex}.py", {}))
    for rel in ("asr_twodof_description/urdf/TwoDofs.urdf", "borinot_description/urdf/borinot_flying_arm_2.urdf",
                "double_pendulum_description/urdf/double_pendulum.urdf",
                "double_pendulum_description/urdf/double_pendulum_continuous.urdf",
                "double_pendulum_description/urdf/double_pendulum_simple.urdf",
                "finger_edu_description/robots/finger_edu.urdf", "iris_description/robots/iris.urdf",
                "hextilt_description/urdf/hextilt_flying_arm_5.urdf", "bolt_description/robots/bolt.urdf",
                "kinova_description/robots/kinova.urdf", "so_arm_description/urdf/so100.urdf",
                "so_arm_description/urdf/so101.urdf", "ur_description/urdf/ur3_robot.urdf",
                "ur_description/urdf/ur3_gripper.urdf", "ur_description/urdf/ur5_robot.urdf",
                "ur_description/urdf/ur5_gripper.urdf", "ur_description/urdf/ur10_robot.urdf"):
        out.append((Path(rel).stem, robots / rel, {}))
    return out


def run(label, path, env, skip):
    proc = subprocess.run([sys.executable, "-c", CHILD, str(path), "1" if skip else "0"], cwd="/tmp",
                          env=dict(os.environ, **env), capture_output=True, text=True)
    if proc.returncode:
        return dict(label=label, skip=skip, error=(proc.stderr.strip().splitlines() or ["failed"])[-1][:160])
    return dict(label=label, skip=skip, **json.loads(proc.stdout.strip().splitlines()[-1]))


def median(xs):
    xs = sorted(xs)
    return xs[len(xs) // 2] if len(xs) % 2 else (xs[len(xs) // 2 - 1] + xs[len(xs) // 2]) / 2


def table(rows):
    """One line per model from the runs of both modes (medians of the rounds)."""
    head = ("| model | speeds | chain | auto before (costs) | auto after (costs) | recursive generate CPU s | "
            "Kane forming CPU s | Kane generate CPU s | generate CPU s before | after | saved |")
    lines = [head, "|" + "--:|" * (head.count("|") - 1)]
    labels = list(dict.fromkeys(r["label"] for r in rows))
    for label in labels:
        runs = {m: [r for r in rows if r["label"] == label and r["skip"] == m] for m in (False, True)}
        if any("error" in r for rs in runs.values() for r in rs) or not all(runs.values()):
            err = next((r["error"] for rs in runs.values() for r in rs if "error" in r), "not run")
            lines.append(f"| {label} | failed: {err} |" + " |" * 9)
            continue
        b, a = runs[False], runs[True]

        def pick(rs):
            r = rs[0]
            costs = r.get("costs") or {}
            text = ", ".join(f"{k} {v}" for k, v in sorted(costs.items())) or (r.get("note") or "")[:60]
            return f"{r['formulation']} ({text})"
        tb, ta = median([r["total"] for r in b]), median([r["total"] for r in a])
        lines.append(f"| {label} | {b[0]['nu']} | {b[0].get('chain') or '-'} | {pick(b)} | {pick(a)} | "
                     f"{median([r['cpu']['recursive'] for r in b]):.2f} | {median([r['cpu']['kane_form'] for r in b]):.2f} | "
                     f"{median([r['cpu']['kane_generate'] for r in b]):.2f} | {tb:.2f} | {ta:.2f} | "
                     f"{tb - ta:.2f} ({(tb - ta) / tb:.0%}) |")
    return "\n".join(lines)


def main(argv):
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=3, help="runs of each mode per model, interleaved")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("-k", action="append", default=[])
    ap.add_argument("--json", help="append the rows to this file (one json per line)")
    ap.add_argument("--write", action="store_true", help="write results/auto_skip.md")
    ap.add_argument("--from", dest="source", help="no runs: the table of the rows a --json run saved "
                                                  "(its first line may be {\"load\": ...})")
    args = ap.parse_args(argv)
    chosen = [m for m in models() if not args.k or any(k == m[0] for k in args.k)]
    start = " ".join(f"{v:.2f}" for v in os.getloadavg())
    if args.source:
        rows = [json.loads(line) for line in Path(args.source).read_text().splitlines() if line.strip()]
        loads = [r["load"] for r in rows if "load" in r]
        rows = [r for r in rows if "label" in r]
        start, end = loads[-1].split(" / ") if loads else ("?", "?")
        args.rounds = max(sum(1 for r in rows if r["label"] == rows[0]["label"] and r["skip"]), 1)
        return report(rows, args, start, end)
    # before and after of one model one after another, the order swapped each round
    tasks = []
    for rnd in range(args.rounds):
        for i, m in enumerate(chosen):
            first = (rnd + i) % 2 == 0
            tasks += [(m, first), (m, not first)]
    rows = []
    with concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
        futs = [pool.submit(run, *m, skip) for m, skip in tasks]
        for fut in futs:
            row = fut.result()
            rows.append(row)
            print(json.dumps(row), flush=True)
            if args.json:
                with open(args.json, "a") as fh:
                    fh.write(json.dumps(row) + "\n")
    end = " ".join(f"{v:.2f}" for v in os.getloadavg())
    if args.json:
        with open(args.json, "a") as fh:
            fh.write(json.dumps({"load": f"{start} / {end}"}) + "\n")
    return report(rows, args, start, end)


def report(rows, args, start, end):
    text = table(rows)
    print(text)
    if args.write:
        from common import environment_header, write_results
        notes = [f"load average at start: {start}, at the end: {end} (a shared 2-core machine): CPU is thread CPU "
                 f"time of the generating thread, medians of {args.rounds} runs per mode, before/after interleaved",
                 "before: select.AUTO_SKIP_KANE = False (Kane's equations formed up to 6 speeds, as before the skip)"]
        print(write_results("auto_skip", environment_header(
            "auto's build time: forming Kane's equations it will not keep", notes=notes)
            + "\n" + (__doc__ or "") + "\n" + text + "\n", keep_notes=True))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
