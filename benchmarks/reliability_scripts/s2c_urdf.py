"""Surface 2, batch 2: more URDF cases, random robots against Pinocchio."""
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, "$SCRATCH/work")
from h import cli, record, last_line, classify_cli, env, api, W, VENV
import s2_urdf_lib as L

D = Path(W) / "urdf2"
D.mkdir(exist_ok=True)
CACHE = "$SCRATCH/cache_urdf"
E = env(EOMC_CACHE_DIR=CACHE)
os.environ["EOMC_CACHE_DIR"] = CACHE
import eomc
from eomc.compiler.urdf import from_urdf


def build(case, text, fname=None, extra=(), timeout=300, expect="error", check=None):
    path = D / (fname or f"{case}.urdf")
    path.write_text(text)
    out = D / f"out_{case}"
    rc, so, se, dt = cli(["build", "-q", str(path), "-o", str(out), *extra], timeout=timeout, envv=E)
    cls = classify_cli(rc, so, se)
    detail = f"rc={rc} {dt:.1f}s: " + (last_line(se) if rc != 0 else "built")
    if cls == "ok" and check is not None:
        cls, more = check(out)
        detail += " | " + more
    elif cls == "ok" and expect == "error":
        cls = "wrong"
        detail += " | accepted, expected a refusal"
    record("urdf", case, cls, detail)
    return rc, out


def states(out):
    try:
        m = eomc.load(out)
        return "ok", f"states={list(m.state_names)} params={list(m.param_names)[:4]}"
    except Exception as exc:
        return "raw", repr(exc)[:200]


# ---- random robots vs Pinocchio (silent wrong answers?)
import pinocchio as pin
rng = np.random.default_rng(7)


def rand_inertia():
    while True:
        R = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        d = rng.uniform(0.01, 0.2, 3)
        if 2 * d.max() < d.sum():
            I = R @ np.diag(d) @ R.T
            return I


def rand_robot(n, types):
    body = ""
    parents = ["base"]
    for i in range(n):
        I = rand_inertia()
        body += f"""  <link name="l{i}">
    <inertial>
      <origin xyz="{' '.join(f'{v:.17g}' for v in rng.normal(0, .2, 3))}" rpy="{' '.join(f'{v:.17g}' for v in rng.uniform(-3, 3, 3))}"/>
      <mass value="{rng.uniform(0.5, 3):.17g}"/>
      <inertia ixx="{I[0,0]:.17g}" ixy="{I[0,1]:.17g}" ixz="{I[0,2]:.17g}" iyy="{I[1,1]:.17g}" iyz="{I[1,2]:.17g}" izz="{I[2,2]:.17g}"/>
    </inertial>
  </link>
"""
        parent = parents[rng.integers(len(parents))]
        ax = rng.normal(size=3) * rng.choice([1, 3, 0.2])
        t = types[i % len(types)]
        body += L.joint(f"j{i}", parent, f"l{i}", type=t, xyz=" ".join(f"{v:.17g}" for v in rng.normal(0, .3, 3)),
                        rpy=" ".join(f"{v:.17g}" for v in rng.uniform(-3, 3, 3)), axis=" ".join(f"{v:.17g}" for v in ax),
                        extra='\n    <limit lower="-10" upper="10" effort="100" velocity="100"/>' if t in ("revolute", "prismatic") else "")
        parents.append(f"l{i}")
    return L.robot(body, name=f"rand{n}")


for k, (n, types, form) in enumerate([(4, ["revolute"], "kane"), (5, ["revolute", "prismatic"], "kane"),
                                      (6, ["continuous", "revolute", "prismatic"], "recursive"),
                                      (7, ["revolute", "fixed", "prismatic"], "recursive"),
                                      (5, ["revolute", "prismatic"], "auto")]):
    text = rand_robot(n, types)
    pth = D / f"rand{k}.urdf"
    pth.write_text(text)

    def compare(pth=pth, form=form):
        m = eomc.compile(str(pth), formulation=form, progress=False)
        pm = pin.buildModelFromUrdf(str(pth))
        pd = pm.createData()
        worst = 0.0
        for trial in range(20):
            q = rng.uniform(-2, 2, pm.nq)
            v = rng.uniform(-2, 2, pm.nv)
            tau = rng.uniform(-1, 1, pm.nv)
            # eomc order is the URDF joint order; map by joint names
            names = [pm.names[i] for i in range(1, pm.njoints)]
            order = [m.state_names.index(f"q_{nm}") for nm in names]
            x = np.zeros(m.nx)
            x[order] = q
            x[[m.nq + o for o in order]] = v
            r = np.zeros(m.ninput)
            r[[m.input_names.index(f"tau_{nm}") for nm in names]] = tau
            xd = m.rhs(0.0, x, r=r)
            a = pin.aba(pm, pd, q, v, tau)
            err = np.max(np.abs(xd[[m.nq + o for o in order]] - a)) / max(1.0, np.max(np.abs(a)))
            worst = max(worst, err)
        return worst, m.nx
    kind, v = api(compare)
    if kind == "ok":
        worst, nx = v
        cls = "ok" if worst < 1e-8 else "wrong"
        record("urdf", f"random robot {k} n={n} {types} {form} vs pinocchio.aba", cls, f"nx={nx} max rel err {worst:.2e}")
    else:
        record("urdf", f"random robot {k} n={n} {types} {form} vs pinocchio.aba", "raw" if kind == "other" else "clear", str(v)[:250])


# ---- how deep can a URDF chain be?  (tree walk recursion)
def chain(n, kind="revolute"):
    body = ""
    for i in range(n):
        body += L.link(f"l{i}", com="0 0 0.1") + L.joint(f"j{i}", "base" if i == 0 else f"l{i-1}", f"l{i}",
                                                          type=kind if (kind != "mixed") else ("fixed" if i % 2 else "revolute"),
                                                          xyz="0 0 0.2", axis="0 1 0" if i % 2 else "1 0 0")
    return L.robot(body, name=f"chain{n}")


for n, kind in [(300, "revolute"), (400, "revolute"), (450, "revolute"), (500, "revolute"), (1000, "fixed"), (600, "mixed")]:
    pth = D / f"deep_{kind}_{n}.urdf"
    pth.write_text(chain(n, kind))
    rc, so, se, dt = cli(["inspect", "-q", str(pth), "--formulation", "recursive"] if False else
                         ["build", "-q", str(pth), "-o", str(D / f"out_deep_{kind}_{n}"), "--formulation", "recursive", "--outputs", "rhs"],
                         envv=E, timeout=int(os.environ.get("REL_SCALE_TIMEOUT", "900")))
    cls = classify_cli(rc, so, se)
    record("urdf", f"{n}-link {kind} chain, --formulation recursive --outputs rhs", cls,
           f"rc={rc} {dt:.0f}s {last_line(se)[:200]}")
