"""What the derivatives cost at build time: `eomc build` with the default function set against
`--outputs rhs`, same model, same run (issue 30: default build <= 1.5x the rhs-only build).

Each build is a fresh child process with a fresh cache; CPU = user + sys of the child and its
C compiler, peak RSS of the largest child (ru_maxrss).  Models: the n-link cart as a SymPy
System (tree_models/cart_rel_joints.py), a URDF chain of n revolute links (alternating axes,
bench_urdf_build.chain_text) and example-robot-data robots (G1 29-dof, floating base).

    python benchmarks/bench_derivative_build.py [--cart 80] [--chain 200] [--robots g1] [--cpu-cap 600]
"""
import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "tests"))

ROBOTS = {"g1": ("g1_description/urdf/g1_29dof_rev_1_0.urdf", True),
          "go2": ("go2_description/urdf/go2.urdf", True)}


def build(args, env, cap):
    """(CPU s, wall s, peak RSS MB of the children so far, error or None)."""
    def limit():
        resource.setrlimit(resource.RLIMIT_CPU, (cap, cap + 5))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "eomc", "build", *args, "-q"], env=env, capture_output=True,
                          text=True, preexec_fn=limit)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    err = None if proc.returncode == 0 else (proc.stderr.strip().splitlines() or ["?"])[-1][:120]
    return cpu, wall, after.ru_maxrss / 1024, err


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--cart", default="80")
    ap.add_argument("--chain", default="200")
    ap.add_argument("--robots", default="g1")
    ap.add_argument("--cpu-cap", type=int, default=600)
    a = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="eomc_dbb_"))
    cases = []
    for n in filter(None, a.cart.split(",")):
        cases.append((f"cart n = {n}", [str(HERE / "tree_models" / "cart_rel_joints.py")], {"EOMC_N_LINKS": n}))
    for n in filter(None, a.chain.split(",")):
        from bench_urdf_build import chain_text
        path = work / f"chain{n}.urdf"
        path.write_text(chain_text(int(n)))
        cases.append((f"URDF chain n = {n}", [str(path)], {}))
    for r in filter(None, a.robots.split(",")):
        from helpers.robots import robot_path
        rel, fb = ROBOTS[r]
        cases.append((r, [str(robot_path(rel))] + (["--floating-base"] if fb else []), {}))
    print("| model | default CPU s | rhs-only CPU s | **ratio** | default wall s | peak RSS MB |")
    print("|---|--:|--:|--:|--:|--:|")
    for label, args, extra in cases:
        res = {}
        for kind, flags in (("rhs", ["--outputs", "rhs"]), ("default", [])):
            env = dict(os.environ, EOMC_CACHE_DIR=tempfile.mkdtemp(prefix="eomc_dbbc_"), **extra)
            out = tempfile.mkdtemp(prefix="eomc_dbbo_")
            res[kind] = build(args + flags + ["-o", out], env, a.cpu_cap)
        d, r = res["default"], res["rhs"]
        note = f" ({d[3]})" if d[3] else ""
        print(f"| {label} | {d[0]:.1f}{note} | {r[0]:.1f} | **{d[0] / r[0]:.2f}** | {d[1]:.1f} | {d[2]:.0f} |",
              flush=True)


if __name__ == "__main__":
    main()
