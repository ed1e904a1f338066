"""Cases of the report that the tester ran by hand (attempts.md rows 550-649 with no script): rerun here.

Not one of the tester's scripts: written for the rerun (issue 24) from the descriptions in attempts.md,
with the tester's own helper scripts sigint_cb.py and cb_after.py where they exist.  Records with the
same surface and case names as attempts.md so review.py pairs them with the report's rows.
"""
import os
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, "$SCRATCH/work")
from h import record, api, cli, last_line, env, W, VENV

D = Path(W) / "s11"
D.mkdir(exist_ok=True)
CACHE = "$SCRATCH/cache_in"
os.environ["EOMC_CACHE_DIR"] = CACHE
E = env(EOMC_CACHE_DIR=CACHE)
import eomc

# ---- inputs: complex K / x_ref (rows 560, 561), needs s5's cartpole build
cp = eomc.load(Path(W) / "s5" / "cartpole")
up = np.array([0.0, np.pi, 0.0, 0.0])
Kgood = np.array([[-3.16, 60.0, -4.0, 10.0]])
cpx0 = np.array([0.0, np.pi - 0.1, 0, 0])
for case, kw in [("K with a nonzero imaginary part (K + 5j)", dict(K=Kgood + 5j, x_ref=up)),
                 ("x_ref complex (x_ref + 1j)", dict(K=Kgood, x_ref=up + 1j))]:
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        kind, v = api(lambda: cp.simulate(cpx0, (0, 2), **kw))
    record("inputs", case, {"eomc": "clear", "other": "raw"}.get(kind, "wrong"),
           str(v)[:300] if kind != "ok" else f"accepted: {v}")

# ---- inputs: Ctrl-C during a slow input callable, 150 s run, SIGINT at 3 s (row 562)
t = time.time()
p = subprocess.run([f"{VENV}/python", "sigint_cb.py", "150", "3"], capture_output=True, text=True, timeout=200,
                   cwd=W, env=E)
out = (p.stdout + p.stderr).strip()
late = None
if "KeyboardInterrupt after" in out:
    late = float(out.split("KeyboardInterrupt after ")[1].split("s")[0]) - 3.0
record("inputs", "Ctrl-C during simulate with a slow input callable (150 s run, SIGINT at 3 s)",
       "ok" if late is not None and late < 2.0 else ("hang" if late is not None or "finished" in out else "raw"),
       f"rc={p.returncode} {time.time() - t:.1f}s: {last_line(out)[:300]}")

# ---- inputs: callable raising once at t=0.53 in a 30 s run (row 563); cb_after.py prints calls after the raise
p = subprocess.run([f"{VENV}/python", "cb_after.py"], capture_output=True, text=True, timeout=300, cwd=W, env=E)
lines = p.stdout.strip().splitlines()
rt = [l for l in lines if "RuntimeError" in l]
ki = [l for l in lines if l.startswith("KeyboardInterrupt")]
def stopped(l):
    return bool(l) and int(l[0].split("calls after the raise:")[1].split()[0]) <= 20
record("inputs", "callable raising RuntimeError once at t=0.53 in a 30 s run",
       "clear" if stopped(rt) and stopped(ki) else ("raw" if "Traceback" in p.stderr else "hang"),
       f"rc={p.returncode} {' / '.join(lines)[:300]} {last_line(p.stderr)[:150]}")

# ---- sweep: what a callable reduce sees vs simulate() (row 557), cartpole_lqr has a terminal event
from h import EX
cpl = eomc.compile(Path(EX) / "cartpole_lqr.py", output_dir=str(D / "cpl"))
xs = [dict(zip(cpl.state_names, cpl.initial_state))]
def seen(r):
    return (r.t_final, None if r.x_final is None else list(r.x_final),
            None if r.t_events is None else [list(np.atleast_1d(e)) for e in r.t_events], r.status)
kind, v = api(lambda: eomc.sweep(cpl, {"x": [0.0, 0.1]}, (0, 5), reduce=seen, progress=False))
if kind == "ok":
    refs = [seen(cpl.simulate({**xs[0], "x": x}, (0, 5))) for x in (0.0, 0.1)]
    vals = list(v.values)
    same = all(a[0] == b[0] and np.allclose(a[1], b[1]) and str(a[2]) == str(b[2]) and a[3] == b[3]
               for a, b in zip(vals, refs))
    record("sweep", "sweep(reduce=f): the SimulationResult f receives vs simulate()'s", "ok" if same else "wrong",
           f"f saw {str(vals)[:200]}; simulate {str(refs)[:200]}")
else:
    record("sweep", "sweep(reduce=f): the SimulationResult f receives vs simulate()'s",
           "clear" if kind == "eomc" else "raw", v)

# ---- travel: pickle a model from eomc.compile(path) after `eomc cache clear` (row 559)
import pickle
from models import SPRING
(D / "spring.py").write_text(SPRING)
c559 = D / "cache559"
os.environ["EOMC_CACHE_DIR"] = str(c559)
m559 = eomc.compile(str(D / "spring.py"))
cli(["cache", "clear"], envv=env(EOMC_CACHE_DIR=str(c559)))
kind, v = api(lambda: pickle.loads(pickle.dumps(m559)).rhs(0.0, [2.0, 0.0], r=[0.0]))
record("travel", "pickle a model from eomc.compile(path) after `eomc cache clear` (its entry removed)",
       {"ok": "ok" if kind == "ok" and np.allclose(v, [0.0, -4.0]) else "wrong", "eomc": "clear", "other": "raw"}[kind],
       str(v)[:300])
os.environ["EOMC_CACHE_DIR"] = CACHE

# ---- cache: same process, eomc.compile(model.py, output_dir=DIR) again after an edit (rows 568, 569)
(D / "n.py").write_text(SPRING)
out2 = D / "out2"
m1 = eomc.compile(str(D / "n.py"), output_dir=str(out2))
a1 = m1.rhs(0.0, [2.0, 0.0], r=[0.0])
(D / "n.py").write_text(SPRING.replace("LOAD = -k * q + F", "LOAD = -2 * k * q + F"))
kind, v = api(lambda: eomc.compile(str(D / "n.py"), output_dir=str(out2)))
if kind == "ok":
    a2 = v.rhs(0.0, [2.0, 0.0], r=[0.0])
    record("cache", "same process: eomc.compile(model.py, output_dir=DIR) again after editing the model's equations (same parameters)",
           "ok" if a2[1] == -8.0 else "wrong", f"rhs u' first {a1[1]}, after the edit {a2[1]} (expect -8.0)")
else:
    record("cache", "same process: eomc.compile(model.py, output_dir=DIR) again after editing the model's equations (same parameters)",
           "clear" if kind == "eomc" else "raw", v)
(D / "n.py").write_text(SPRING.replace("k: 2.0", "k: 3.0"))
kind, v = api(lambda: eomc.compile(str(D / "n.py"), output_dir=str(out2)))
if kind == "ok":
    a3 = v.rhs(0.0, [2.0, 0.0], r=[0.0])
    record("cache", "same process: eomc.compile(model.py, output_dir=DIR) again after changing a parameter default",
           "ok" if a3[1] == -6.0 else "wrong", f"rhs u' with the new default k=3: {a3[1]} (expect -6.0)")
else:
    record("cache", "same process: eomc.compile(model.py, output_dir=DIR) again after changing a parameter default",
           "clear" if kind == "eomc" else "raw", v)

# ---- cache: builds on full file systems (rows 622, 623), in a private mount namespace
from h import classify_cli
for case, mnt, size, out in [("cold eomc build with a full cache file system (tmpfs 60K)", D / "fullcache", "60k", D / "o622"),
                             ("eomc build -o DIR on a full file system (tmpfs 30K)", D / "fullout", "30k", D / "fullout")]:
    mnt.mkdir(exist_ok=True)
    e = env(EOMC_CACHE_DIR=str(mnt) if "cache" in case else str(D / "cache623"))
    cmd = f"mount -t tmpfs -o size={size} tmpfs {mnt} && exec {VENV}/eomc build -q {D / 'spring.py'} -o {out}"
    t = time.time()
    try:
        p = subprocess.run(["unshare", "-m", "sh", "-c", cmd], capture_output=True, text=True, env=e, timeout=300)
        rc, se = p.returncode, p.stderr
    except subprocess.TimeoutExpired:
        rc, se = "TIMEOUT", ""
    cls = classify_cli(rc, "", se)
    if rc != 0 and cls == "clear" and len([l for l in se.strip().splitlines() if l.strip()]) > 2:
        cls = "raw"
    record("cache", case, cls, f"rc={rc} {time.time() - t:.0f}s {last_line(se)[:300]}")

# ---- cache: 4 concurrent `eomc sweep model.py` + prune/clear loop, rounds 2-5 (rows 646-649; s9_cache is round 1)
S9 = Path(W) / "s9"
for rnd in range(2, 6):
    cache = S9 / f"cache_r{rnd}"
    stop = S9 / f"stop{rnd}"
    pr = subprocess.Popen(["sh", "-c", f"while [ ! -e {stop} ]; do {VENV}/eomc cache prune --max-size 1K >/dev/null 2>&1; "
                                       f"{VENV}/eomc cache clear >/dev/null 2>&1; done"], env=env(EOMC_CACHE_DIR=str(cache)))
    ps = [subprocess.Popen(["nice", "-n", "5", f"{VENV}/eomc", "sweep", f"sp{i % 2}.py", "--cases", "cases.csv", "--t-final", "2",
                            "-o", f"r{rnd}_{i}.csv", "-q", "--workers", "2"], env=env(EOMC_CACHE_DIR=str(cache)), cwd=S9,
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for i in range(4)]
    outs = [p.communicate(timeout=900) for p in ps]
    stop.write_text("x")
    pr.wait(timeout=120)
    rcs = [p.returncode for p in ps]
    tb = [last_line(o[1])[:150] for o in outs if "Traceback" in o[1]]
    same = (S9 / f"r{rnd}_0.csv").read_text() == (S9 / f"r{rnd}_2.csv").read_text() if rcs[0] == rcs[2] == 0 else None
    record("cache", f"4 concurrent `eomc sweep model.py` + prune/clear loop, round {rnd}",
           "ok" if rcs == [0] * 4 and same else ("raw" if tb else "clear"),
           f"exit {rcs}; a0==a2 {same}; tracebacks {tb[:2]}; {[last_line(o[1])[:120] for o in outs if o[1].strip()][:2]}")

# ---- consistent_state: the tester's re-runs of two test bugs, residual checked with the p used (rows 553, 554)
S6 = Path(W) / "s6"
fb = eomc.load(S6 / "four_bar_system")
wb = eomc.load(S6 / "whipple_bicycle")
for case, model, target, p in [
        ("four-bar p with zero crank length (l2=0), residual checked with that p", fb, {"q1": 0.3}, {"l2": 0.0}),
        ("bicycle consistent_state all-zero parameters, residual checked with that p", wb, {},
         {n: 0.0 for n in wb.param_names})]:
    kind, v = api(lambda: model.consistent_state(target, p=p))
    if kind == "ok":
        res = float(np.max(np.abs(model.constraints(0.0, v, p=p)))) if model.nhol + model.nvel else 0.0
        record("consistent", case, "ok" if res < 1e-9 else "wrong", f"x={np.round(v, 6).tolist()} residual {res:.1e}")
    else:
        record("consistent", case, "clear" if kind == "eomc" else "raw", v)

# ---- events: `eomc sweep examples/cartpole_lqr.py` (terminal event 'fallen'), 3 cases (row 322)
import csv
cases = D / "cp_cases.csv"
cases.write_text("x\n0.0\n0.1\n-0.1\n")
rc, so, se, dt = cli(["sweep", str(Path(EX) / "cartpole_lqr.py"), "--cases", str(cases), "--t-final", "5",
                      "-o", str(D / "cp_res.csv"), "-q"], envv=E)
if rc == 0:
    rows = list(csv.DictReader(open(D / "cp_res.csv")))
    bad = []
    for row in rows:
        x0 = dict(zip(cpl.state_names, cpl.initial_state), x=float(row["x"]))
        ref = cpl.simulate(x0, (0, 5))
        got = np.array([float(row[f"final_{n}"]) for n in cpl.state_names])
        if int(row["status"]) != ref.status or not np.allclose(got, ref.x_final, rtol=1e-9, atol=1e-12) \
                or abs(float(row["t_final"]) - ref.t_final) > 1e-12:
            bad.append((row["x"], row["status"], row["t_final"], got.tolist(), ref.t_final, ref.x_final.tolist()))
    record("events", "eomc sweep examples/cartpole_lqr.py (its terminal event 'fallen'), 3 cases",
           "ok" if not bad and len(rows) == 3 else "wrong",
           f"{len(rows)} rows; final state, t_final and status equal simulate()'s: {not bad} {str(bad)[:300]}")
else:
    record("events", "eomc sweep examples/cartpole_lqr.py (its terminal event 'fallen'), 3 cases",
           classify_cli(rc, so, se), f"rc={rc} {last_line(se)[:300]}")
