"""Driver: rerun the 649 attempts of the round-3 reliability report against this checkout (issue 24).

Origin: the scripts in this folder (h.py, models.py, s2_urdf_lib.py, s1..s10 surface scripts, verify_*,
sigint_cb.py, cb_after.py, harness.c.tpl, aggregate.py, attempts.md) are the independent tester's
scripts from /work/shared/reports/reliability-2026-11-r3/ (report reliability-2026-11-r3.md), copied
unchanged except: the example-robot-data path became the placeholder "$ERD", and the three 900/600-s
scale attempts (s2b 1000-link chain, s2c deep chains, s2f scaling) take their timeout from
REL_SCALE_TIMEOUT.  They keep the tester's absolute scratch paths as the placeholder "$SCRATCH".

Why a driver: the scripts write into fixed scratch folders and share files between surfaces (s2d and
s10 read URDF files written by s2b; verify_gimbal reads s3_system.py from its cwd).  This driver makes
a temporary scratch folder S with S/venv -> the running venv, S/eomc -> this checkout, S/work (cwd of
every script), copies the scripts into S/work with "$SCRATCH" -> S and "$ERD" -> the installed
example-robot-data robots, then runs every surface script under `timeout` and `nice` in a few lanes
(dependencies respected), and aggregates S/work/attempts.jsonl with review.py (this run's hand review).
Nothing is skipped silently: a script that fails, times out or cannot run is a row of the table,
and every case the report has that this run did not record is listed as "not run".

Usage:  python benchmarks/reliability_scripts/run.py [--scratch DIR] [--lanes 3] [--script-timeout 1500]
        [--scale-timeout 120] [--only s4_events,s6_consistent]
Writes S/work/attempts.jsonl, S/logs/<script>.log and S/logs/<script>.status; prints where.  Then
`python benchmarks/reliability_scripts/review.py S` prints the tables (see its docstring).
Needs root for the `unshare -m` + bind/tmpfs mounts of s1 (F6), s7 and s8, as the report did.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
LOCK = threading.Lock()
REPO = HERE.parent.parent

# lanes: scripts in a lane run one after another; "after" waits for a script of another lane.
LANES = [
    ["s2_urdf"],
    ["s2b_urdf", "s2c_urdf", "s2d_cont", "s2f_scale"],
    ["s1_rerun", "s1b_f8", "s3_system", "verify_s3", "verify_gimbal", "s4_events", "s6_consistent",
     "s10_sanitize", "s10b_sanitize"],
    ["s5_inputs", "s7_travel", "s9_cache", "s9b_cache", "s9c_cache", "s11_handrun"],
    ["s8_sweep", "s8b_sweep", "s8c_dask"],
]
AFTER = {"s11_handrun": "s6_consistent", "s10_sanitize": "s2b_urdf", "s10b_sanitize": "s2b_urdf", "s2d_cont": "s2b_urdf"}
HEAVY = {"s2f_scale", "s2b_urdf", "s2c_urdf", "s10_sanitize", "s10b_sanitize", "s8b_sweep", "s1b_f8"}
# Scripts of the tester's folder that record no attempt and need hand-made inputs: not run, said so.
NOT_RUN = {"s9v_sweep_prune_race": "a hand check of the tester (needs sp0.py/sp1.py/cases.csv made by hand "
                                   "in work/s9v); records no attempt -- its case is s9_cache's prune race"}


def erd_path():
    import glob
    for base in [sys.prefix, *sys.path]:
        hits = glob.glob(os.path.join(base, "**", "cmeel.prefix", "share", "example-robot-data", "robots"),
                         recursive=False) or glob.glob(os.path.join(base, "cmeel.prefix", "share",
                                                                    "example-robot-data", "robots"))
        if hits:
            return hits[0]
    try:
        import example_robot_data  # noqa: F401
        return os.path.join(os.path.dirname(example_robot_data.__file__), "robots")
    except ImportError:
        return "/nonexistent/example-robot-data/robots"


def prepare(S):
    S = Path(S)
    (S / "work").mkdir(parents=True, exist_ok=True)
    (S / "logs").mkdir(exist_ok=True)
    if not (S / "eomc").exists():
        os.symlink(str(REPO), S / "eomc")
    # S/venv: the running venv's bin and lib, plus a `dask` command when the venv has none (a venv
    # over system site-packages has dask importable but its console script elsewhere).
    (S / "venv" / "bin").mkdir(parents=True, exist_ok=True)
    for f in Path(sys.prefix).iterdir():   # pyvenv.cfg above all: without it S/venv/bin/python is the base
        if f.name != "bin" and not (S / "venv" / f.name).exists():   # interpreter, with another eomc
            os.symlink(f, S / "venv" / f.name)
    for f in Path(sys.prefix, "bin").iterdir():
        if not (S / "venv" / "bin" / f.name).exists():
            os.symlink(f, S / "venv" / "bin" / f.name)
    if not (S / "venv" / "bin" / "dask").exists():
        (S / "venv" / "bin" / "dask").write_text(f'#!/bin/sh\nexec {sys.executable} -m dask "$@"\n')
        (S / "venv" / "bin" / "dask").chmod(0o755)
    erd = erd_path()
    for f in HERE.iterdir():
        if f.suffix in (".py", ".tpl") and f.name not in ("run.py", "review.py"):
            text = f.read_text().replace("$SCRATCH", str(S)).replace("$ERD", erd)
            (S / "work" / f.name).write_text(text)
    return S


def run_script(S, name, timeout, scale_timeout, status):
    log = S / "logs" / f"{name}.log"
    cmd = ["timeout", "-k", "30", str(timeout)]
    if name in HEAVY:
        cmd += ["nice", "-n", "10"]
    cmd += [str(S / "venv" / "bin" / "python"), "-u", name + ".py"]
    env = dict(os.environ, REL_LOG=str(S / "work" / "attempts.jsonl"), REL_SCALE_TIMEOUT=str(scale_timeout),
               PYTHONDONTWRITEBYTECODE="1")
    jl = S / "work" / "attempts.jsonl"
    if jl.exists():   # a rerun of one script replaces its earlier records
        with LOCK:
            keep = [l for l in jl.read_text().splitlines(True) if json.loads(l).get("script") != name + ".py"]
            jl.write_text("".join(keep))
    t = time.time()
    with open(log, "w") as fh:
        rc = subprocess.run(cmd, cwd=S / "work", stdout=fh, stderr=subprocess.STDOUT, env=env).returncode
    status[name] = {"rc": rc, "seconds": round(time.time() - t, 1), "timed_out": rc in (124, 137)}
    print(f"[run] {name}: rc={rc} {time.time() - t:.0f}s (log {log})", flush=True)
    (S / "logs" / f"{name}.status").write_text(json.dumps(status[name]))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--scratch")
    ap.add_argument("--lanes", type=int, default=len(LANES))
    ap.add_argument("--script-timeout", type=int, default=1500)
    ap.add_argument("--scale-timeout", type=int, default=120)
    ap.add_argument("--only")
    a = ap.parse_args()
    S = prepare(a.scratch or tempfile.mkdtemp(prefix="eomc-rel-r3-"))
    print(f"[run] scratch {S}", flush=True)
    only = set(a.only.split(",")) if a.only else None
    status = {}
    for k, v in NOT_RUN.items():
        (S / "logs" / f"{k}.status").write_text(json.dumps({"rc": None, "not_run": v}))
    done = {n: threading.Event() for lane in LANES for n in lane}

    def lane(names):
        for n in names:
            if only is None or n in only:
                if n in AFTER and (only is None or AFTER[n] in only):
                    done[AFTER[n]].wait()
                run_script(S, n, a.script_timeout, a.scale_timeout, status)
            done[n].set()

    lanes = LANES if a.lanes >= len(LANES) else [sum(LANES, [])]
    ths = [threading.Thread(target=lane, args=(ln,)) for ln in lanes]
    for th in ths:
        th.start()
    for th in ths:
        th.join()
    print(f"[run] done; now: python {HERE / 'review.py'} {S}")


if __name__ == "__main__":
    main()
