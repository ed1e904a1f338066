"""Closed loops on the tree: `eomc build MODEL` with no flags (auto, the default function set).

Measures the cold build (process CPU time of the `eomc build` child: model file, generate,
compile, load; a fresh cache each time) of the four-bar example and closed n-link chains
(benchmarks/bench_loops.py's ``closed_chain``), and reports which formulation auto took.
Contestants, interleaved per repetition:

* ``after``   this checkout;
* ``before``  another checkout (``--before DIR``, e.g. a worktree of main), run by
              redirecting the editable install's package mapping to it (a sitecustomize
              on PYTHONPATH), so the same interpreter and C compiler build both;
* ``kane``    this checkout with ``--formulation kane`` (the peer auto falls back to).

Run:  git worktree add --detach /tmp/main-wt main && cp runtime/*.so /tmp/main-wt/runtime/
      python benchmarks/bench_loops_default.py --before /tmp/main-wt [--n 8,10] [--reps 1]
(the compiled runtime extensions are not in git: the checkout borrows this one's)
"""
import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TIMEOUT = 420      # s wall per build

CHAIN = """import sys
sys.path.insert(0, {bench!r})
from bench_loops import closed_chain
system, parameters, initial_state = closed_chain({n})
name = "chain_{n}"
"""

SITE = """import importlib
try:
    f = importlib.import_module("__editable___eomc_0_1_0_finder")
except ImportError:
    f = None
if f is not None:
    for k, v in list(f.MAPPING.items()):
        f.MAPPING[k] = v.replace({old!r}, {root!r}, 1)
    for k, v in list(f.NAMESPACES.items()):
        f.NAMESPACES[k] = [p.replace({old!r}, {root!r}, 1) for p in v]
"""


def _site(before, tmp):
    d = Path(tmp) / "site_before"
    d.mkdir(exist_ok=True)
    (d / "sitecustomize.py").write_text(SITE.format(old=str(ROOT), root=str(before)))
    return str(d)


def _build(model, label, tmp, flags=(), pythonpath=None):
    cache = tempfile.mkdtemp(dir=tmp)
    out = tempfile.mkdtemp(dir=tmp)
    env = dict(os.environ, EOMC_CACHE_DIR=cache)
    if pythonpath:
        env["PYTHONPATH"] = pythonpath
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    try:
        p = subprocess.run([sys.executable, "-m", "eomc", "build", str(model), "-o", out, "-q",
                            "--cache-dir", cache, *flags], env=env, capture_output=True, text=True,
                           timeout=TIMEOUT)
    except subprocess.TimeoutExpired:
        return {"cpu": float("nan"), "wall": time.perf_counter() - t0,
                "error": f"not finished in {TIMEOUT} s wall"}
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if p.returncode:
        return {"cpu": cpu, "wall": wall, "error": (p.stderr or p.stdout).strip().splitlines()[-1:]}
    metas = list(Path(out).rglob("*.json"))
    meta = json.loads(metas[0].read_text()) if metas else {}
    return {"cpu": cpu, "wall": wall, "formulation": meta.get("formulation"),
            "note": meta.get("formulation_note", ""), "functions": meta.get("functions")}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", required=True, help="checkout of the code before the change")
    ap.add_argument("--n", default="8,10", help="closed-chain sizes")
    ap.add_argument("--reps", type=int, default=1)
    ap.add_argument("--skip", default="", help="contestant:model pairs to skip, e.g. kane:chain_10")
    args = ap.parse_args(argv)
    skip = set(filter(None, args.skip.split(",")))
    with tempfile.TemporaryDirectory() as tmp:
        models = {"four_bar": ROOT / "examples" / "four_bar_system.py"}
        for n in (int(x) for x in args.n.split(",")):
            f = Path(tmp) / f"chain_{n}.py"
            f.write_text(CHAIN.format(bench=str(ROOT / "benchmarks"), n=n))
            models[f"chain_{n}"] = f
        site = _site(Path(args.before).resolve(), tmp)
        contestants = {"after": ((), None), "before": ((), site), "kane": (("--formulation", "kane"), None)}
        rows = {}
        print(f"load before: {os.getloadavg()[0]:.2f}", flush=True)
        for rep in range(args.reps):
            for label, model in models.items():
                for who, (flags, pp) in contestants.items():
                    if f"{who}:{label}" in skip:
                        continue
                    r = _build(model, label, tmp, flags, pp)
                    rows.setdefault((label, who), []).append(r)
                    print(label, who, json.dumps(r), flush=True)
        print(f"load after: {os.getloadavg()[0]:.2f}")
        print(f"python {platform.python_version()}, {platform.node()}, {os.cpu_count()} cores")
        print("| model | contestant | CPU s (median) | formulation taken |")
        print("|---|---|---|---|")
        for (label, who), rs in rows.items():
            cpus = sorted(r["cpu"] for r in rs)
            form = rs[0].get("formulation") or rs[0].get("error")
            print(f"| {label} | {who} | {cpus[len(cpus) // 2]:.2f} | {form} |")


if __name__ == "__main__":
    main()
