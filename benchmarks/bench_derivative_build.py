"""What the derivatives cost at build time: `eomc build` with the default function set against
`--outputs rhs`, same model, same run (issue 30: default build <= 1.5x the rhs-only build; a
200-link chain's default build <= 40 s and <= 500 MB; jac_x's code within 10x the rhs's).

Each build is a fresh child process with a fresh cache, started by a small wrapper process that
reports its own children's resource use: CPU = user + sys of the build and its C compiler, peak
RSS = the largest of them (ru_maxrss; the Python process, or gcc on a large file).  Builds of one
model are interleaved (rhs-only, default, then with --per-function `rhs,F` for every function F
of the default set) and repeated; figures are medians.

Per function: its CPU is the median of `rhs,F` minus the median of rhs-only (what adding F to a
build costs: its symbolic work, optimization, printing and compiling); its code is the bytes of
C of `NAME_F` and its `NAME_F_part*` helpers in the default build's NAME.c (shared helpers such as
the analytic kernel are listed on their own row).

Models: the n-link cart as a SymPy System (tree_models/cart_rel_joints.py), a URDF chain of n
revolute links (alternating axes, bench_urdf_build.chain_text) and example-robot-data robots
(G1 29-dof, Go2, Talos full body; floating base, the file's joint limits on as by default).

    python benchmarks/bench_derivative_build.py [--cart 80] [--chain 200] [--robots g1]
        [--repeat 1] [--per-function g1,cart80] [--cpu-cap 600] [--before "python-of-another-checkout"]
"""
import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "tests"))

ROBOTS = {"g1": ("g1_description/urdf/g1_29dof_rev_1_0.urdf", True),
          "go2": ("go2_description/urdf/go2.urdf", True),
          "talos": ("talos_data/robots/talos_full_v2.urdf", True)}

# The wrapper: runs the build as its child (CPU limit set in the child), then prints the
# children's CPU seconds, peak RSS (MB) and the build's last stderr line as JSON.
_WRAPPER = r"""
import json, resource, subprocess, sys
cap = int(sys.argv[1])
def limit():
    resource.setrlimit(resource.RLIMIT_CPU, (cap, cap + 5))
p = subprocess.run(sys.argv[2:], capture_output=True, text=True, preexec_fn=limit)
r = resource.getrusage(resource.RUSAGE_CHILDREN)
err = None if p.returncode == 0 else ((p.stderr.strip().splitlines() or ["?"])[-1][:120] or str(p.returncode))
print(json.dumps([r.ru_utime + r.ru_stime, r.ru_maxrss / 1024, err]))
"""


def build(args, env, cap, python=None):
    """{cpu, wall, rss, err} of one cold build (``python``: the interpreter command running
    `-m eomc`, e.g. one that imports another checkout; default this one)."""
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", _WRAPPER, str(cap), python or sys.executable, "-m", "eomc", "build",
                           *args, "-q"], env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    cpu, rss, err = json.loads(proc.stdout.strip().splitlines()[-1])
    return {"cpu": cpu, "wall": wall, "rss": rss, "err": err}


_DEF = re.compile(r"^(?:static )?(?:EOMC_NOINLINE )?(?:int|void|double) (\w+)\(", re.M)


def function_sizes(c_text, name):
    """{function: bytes of C}: each definition's text up to the next one, a NAME_F_part* helper
    counted with F; file-level text (includes, name tables, the model struct) under "(file)"."""
    sizes = {}
    marks = [(m.start(), m.group(1)) for m in _DEF.finditer(c_text)]
    bounds = [(0, "(file)")] + marks + [(len(c_text), None)]
    for (start, fn), (end, _) in zip(bounds, bounds[1:]):
        if fn == "(file)":
            key, stop = fn, end
        else:
            key = re.sub(r"_part\d+(_\d+)*$", "", fn.removeprefix(name + "_"))
            close = c_text.find("\n}\n", start, end)     # what follows a body's end: tables, the struct
            stop = end if close < 0 else close + 3
            sizes["(file)"] = sizes.get("(file)", 0) + end - stop
        sizes[key] = sizes.get(key, 0) + stop - start
    return sizes


def cases_of(a, work):
    cases = []
    for n in filter(None, a.cart.split(",")):
        cases.append((f"cart{n}", f"cart n = {n}", [str(HERE / "tree_models" / "cart_rel_joints.py")],
                      {"EOMC_N_LINKS": n}))
    for n in filter(None, a.chain.split(",")):
        from bench_urdf_build import chain_text
        path = work / f"chain{n}.urdf"
        path.write_text(chain_text(int(n)))
        cases.append((f"chain{n}", f"URDF chain n = {n}", [str(path)], {}))
    for r in filter(None, a.robots.split(",")):
        from helpers.robots import robot_path
        rel, fb = ROBOTS[r]
        cases.append((r, r, [str(robot_path(rel))] + (["--floating-base"] if fb else []), {}))
    return cases


def med(runs, key):
    vals = [r[key] for r in runs if r["err"] is None]
    return statistics.median(vals) if vals else float("nan")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--cart", default="80")
    ap.add_argument("--chain", default="200")
    ap.add_argument("--robots", default="g1")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--per-function", default="", help="case keys (cart80, chain200, g1, ...) to split by function")
    ap.add_argument("--cpu-cap", type=int, default=600)
    ap.add_argument("--before", default="", help="an interpreter command whose `-m eomc` is another checkout "
                    "(e.g. main before a change): its default build joins the interleaved runs as 'before'")
    a = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="eomc_dbb_"))
    split = set(filter(None, a.per_function.split(",")))
    print(f"load at start {os.getloadavg()[0]:.2f}", flush=True)
    summary, detail = [], []
    for key, label, args, extra in cases_of(a, work):
        runs = {"rhs": [], "default": []}
        sizes = meta = before_sizes = None
        order = ["rhs", "default"] + (["before"] if a.before else [])
        for rep in range(a.repeat):
            for kind in order:
                flags = {"rhs": ["--outputs", "rhs"], "default": [], "before": []}.get(kind, ["--outputs", kind])
                env = dict(os.environ, EOMC_CACHE_DIR=tempfile.mkdtemp(prefix="eomc_dbbc_"), **extra)
                out = Path(tempfile.mkdtemp(prefix="eomc_dbbo_"))
                runs.setdefault(kind, []).append(build(args + flags + ["-o", str(out)], env, a.cpu_cap,
                                                       a.before if kind == "before" else None))
                if kind == "before" and before_sizes is None and runs[kind][-1]["err"] is None:
                    bname = next(p for p in out.glob("*.json") if not p.name.startswith(".")).stem
                    before_sizes = function_sizes((out / f"{bname}.c").read_text(), bname)
                if kind == "default" and sizes is None and runs[kind][-1]["err"] is None:
                    meta = json.loads(next(p for p in out.glob("*.json") if not p.name.startswith(".")).read_text())
                    sizes = function_sizes((out / f"{meta['name']}.c").read_text(), meta["name"])
                    if key in split and rep == 0:
                        more = [f"rhs,{f}" for f in meta["functions"] if f not in ("rhs", "linearize")]
                        order += more
                        for kind2 in more:     # the first repeat's per-function builds, now
                            env = dict(os.environ, EOMC_CACHE_DIR=tempfile.mkdtemp(prefix="eomc_dbbc_"), **extra)
                            out2 = tempfile.mkdtemp(prefix="eomc_dbbo_")
                            runs.setdefault(kind2, []).append(
                                build(args + ["--outputs", kind2, "-o", out2], env, a.cpu_cap))
        d, r = runs["default"], runs["rhs"]
        err = next((x["err"] for x in d if x["err"]), None)
        note = f" ({err})" if err else ""
        jx = sizes.get("jac_x", 0) / max(sizes.get("rhs", 1), 1) if sizes else float("nan")
        b = runs.get("before")
        was = (f" | {med(b, 'cpu'):.1f} ({med(b, 'cpu') / med(r, 'cpu'):.2f}x), {med(b, 'rss'):.0f} MB, "
               f"{sum(before_sizes.values()) / 1e3 if before_sizes else 0:.0f} kB") if b else ""
        summary.append(f"| {label} | {med(d, 'cpu'):.1f}{note} | {med(r, 'cpu'):.1f} | "
                       f"**{med(d, 'cpu') / med(r, 'cpu'):.2f}** | {med(d, 'wall'):.1f} | {med(d, 'rss'):.0f} | "
                       f"{med(r, 'rss'):.0f} | {sum(sizes.values()) / 1e3 if sizes else 0:.0f} | "
                       f"{sizes.get('rhs', 0) / 1e3 if sizes else 0:.0f} | {jx:.2f}{was} |")
        print(summary[-1], flush=True)
        if sizes:
            base = med(r, "cpu")
            for fn, size in sorted(sizes.items(), key=lambda kv: -kv[1]):
                extra_cpu = runs.get(f"rhs,{fn}")
                cpu = f"{med(extra_cpu, 'cpu') - base:.1f}" if extra_cpu else ("0 (in rhs)" if fn == "rhs" else "")
                rss = f"{med(extra_cpu, 'rss'):.0f}" if extra_cpu else ""
                ops = meta["op_counts"].get(fn, {})
                nops = sum(ops.get(k, 0) for k in ("adds", "muls", "divs", "calls")) if ops else ""
                old = f"{before_sizes.get(fn, 0) / 1e3:.0f}" if before_sizes else ""
                detail.append(f"| {label} | {fn} | {size / 1e3:.0f} | {cpu} | {rss} | {nops} | {old} |")
                print(detail[-1], flush=True)
    print()
    print("| model | default CPU s | rhs-only CPU s | **ratio** | default wall s | default peak RSS MB | "
          "rhs-only peak RSS MB | default C kB | rhs C kB | jac_x C / rhs C |"
          + (" before: default CPU s (ratio), peak RSS, C |" if a.before else ""))
    print("|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|" + ("--:|" if a.before else ""))
    print("\n".join(summary))
    print()
    print("| model | function | C kB | + CPU s over rhs-only (`--outputs rhs,F`) | its peak RSS MB | ops per call |"
          " before: C kB |")
    print("|---|---|--:|--:|--:|--:|--:|")
    print("\n".join(detail))


if __name__ == "__main__":
    main()
