"""Surface 10: generated C (recursive formulation, URDF robots) under -Wall -Wextra -fsanitize=address,undefined."""
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import sympy as sm

sys.path.insert(0, "$SCRATCH/work")
from h import record, cli, classify_cli, last_line, env, W, VENV, EX

S = "sanitize"
D = Path(W) / "s10"
D.mkdir(exist_ok=True)
CACHE = "$SCRATCH/cache_san"
os.environ["EOMC_CACHE_DIR"] = CACHE
E = env(EOMC_CACHE_DIR=CACHE)
import eomc
from eomc import mechanics as em

ERD = "$ERD"
TPL = Path(W, "harness.c.tpl").read_text()
ITERS = int(os.environ.get("ITERS", "20000"))


def chain_with_torques(n):
    ground = em.RigidBody("ground")
    s = em.System.from_newtonian(ground)
    bodies = [ground]
    for i in range(n):
        b = em.RigidBody(f"b{i}", mass=sm.Symbol(f"m{i}"))
        b.inertia = (em.inertia(b.frame, 0.01, 0.02, sm.Symbol(f"I{i}")), b.masscenter)
        q, u = em.dynamicsymbols(f"q{i} u{i}")
        T = em.dynamicsymbols(f"T{i}")
        j = em.PinJoint(f"J{i}", bodies[-1], b, q, u, parent_point=(0.5 if i else 0) * bodies[-1].x,
                        child_point=-0.25 * b.x, joint_axis=bodies[-1].z if i % 2 else bodies[-1].y)
        s.add_joints(j)
        s.add_actuators(em.TorqueActuator(T, j.joint_axis, b, bodies[-1]))
        bodies.append(b)
    s.apply_uniform_gravity(-sm.Symbol("g") * ground.y)
    params = {sm.Symbol("g"): 9.81, **{sm.Symbol(f"m{i}"): 1.0 + 0.1 * i for i in range(n)},
              **{sm.Symbol(f"I{i}"): 0.05 for i in range(n)}}
    return s, params


def build_api(name, system, params, formulation, functions=None):
    out = D / name
    eomc.compile(system, name, parameters=params, formulation=formulation, output_dir=out, progress=False,
                 functions=functions)
    return out


def build_cli(name, path, *extra):
    out = D / name
    rc, so, se, dt = cli(["build", "-q", str(path), "-o", str(out), "--name", name, *extra], envv=E, timeout=600)
    if rc:
        raise RuntimeError(last_line(se))
    return out


def sanitize(case, out, name):
    h = (out / f"{name}.h").read_text()
    src = D / f"h_{name}.c"
    src.write_text(TPL.replace("@NAME@", name))
    defs = []
    if f"{name}_inverse_dynamics(" in h:
        defs.append("-DHAS_ID")
    if f"{name}_linearize(" in h:
        defs.append("-DHAS_LIN")
    exe = D / f"h_{name}"
    flags = ["-std=c99", "-O1", "-g", "-Wall", "-Wextra", "-Werror", "-fsanitize=address,undefined", "-fno-sanitize-recover=all",
             "-fno-omit-frame-pointer"]
    t = time.time()
    cc = subprocess.run(["nice", "-n", "5", "gcc", *flags, *defs, f"-I{out}", "-o", str(exe), str(src), str(out / f"{name}.c"), "-lm"],
                        capture_output=True, text=True, timeout=900)
    if cc.returncode:
        warn = [l for l in cc.stderr.splitlines() if "error" in l or "warning" in l][:3]
        record(S, f"{case}: compile -Wall -Wextra -Werror + sanitizers", "raw", f"{warn}")
        return
    record(S, f"{case}: compile -Wall -Wextra -Werror + sanitizers", "ok", f"clean ({time.time()-t:.0f}s, {len((out / f'{name}.c').read_text())//1024} KiB of C)")
    t = time.time()
    run = subprocess.run(["nice", "-n", "5", str(exe), str(ITERS)], capture_output=True, text=True, timeout=1200,
                         env={**os.environ, "ASAN_OPTIONS": "detect_leaks=1:abort_on_error=0", "UBSAN_OPTIONS": "print_stacktrace=1"})
    san = [l for l in run.stderr.splitlines() if "Sanitizer" in l or "runtime error" in l]
    viol = [l for l in run.stderr.splitlines() if l.startswith("VIOLATION")]
    if run.returncode < 0 or san:
        cls = "crash"
    elif viol:
        cls = "wrong"
    elif run.returncode:
        cls = "raw"
    else:
        cls = "ok"
    record(S, f"{case}: {ITERS} random/special states, every function", cls,
           f"rc={run.returncode} {time.time()-t:.0f}s {run.stdout.strip()} {san[:2]} {viol[:2]}")
    # extra warnings (not -Werror): count
    w = subprocess.run(["gcc", "-std=c99", "-O2", "-fsyntax-only", "-Wall", "-Wextra", "-Wpedantic", "-Wshadow", "-Wconversion",
                        "-Wdouble-promotion", "-Wcast-qual", f"-I{out}", str(out / f"{name}.c")], capture_output=True, text=True)
    nwarn = w.stderr.count("warning:")
    record(S, f"{case}: -Wpedantic -Wshadow -Wconversion -Wdouble-promotion -Wcast-qual", "ok" if nwarn == 0 else "raw",
           f"{nwarn} warnings {[l for l in w.stderr.splitlines() if 'warning:' in l][:2]}")


jobs = []
jobs.append(("URDF random mixed robot (rand2: continuous+revolute+prismatic, recursive)", lambda: build_cli("rand2r", f"{W}/urdf2/rand2.urdf", "--formulation", "recursive"), "rand2r"))
jobs.append(("URDF random robot rand3 with fixed joints (kane)", lambda: build_cli("rand3k", f"{W}/urdf2/rand3.urdf"), "rand3k"))
jobs.append(("URDF with mimic=True constraints (kane)", lambda: (eomc.compile(__import__("eomc.compiler.urdf", fromlist=["from_urdf"]).from_urdf(
    f"{W}/urdf2/mimic_true_mult2.urdf", mimic=True), "mimic2", output_dir=D / "mimic2", progress=False), D / "mimic2")[1], "mimic2"))
jobs.append(("four-bar (constraints, kane)", lambda: build_cli("fourbar", f"{EX}/four_bar_system.py"), "fourbar"))
for case, make, name in jobs:
    try:
        out = make()
    except Exception as exc:
        record(S, f"{case}: build", "raw" if "Error" not in type(exc).__name__ else "clear", f"{type(exc).__name__}: {exc}"[:250])
        continue
    sanitize(case, Path(out), name)
