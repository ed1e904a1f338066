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
shutil.rmtree(D, ignore_errors=True)
D.mkdir()
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


A = L.arm()
build("names_injection_c_escaped", L.names_robot("a&quot;);system(&quot;id", "*/ int x; /*"), expect="ok", check=states)
build("names_backslash_percent", L.names_robot("a\\b%n%s", "c$(id)`id`"), expect="ok", check=states)
build("limit_nan_only", L.arm(shoulder={"extra": '\n    <limit lower="nan" upper="inf" effort="1" velocity="1"/>'}),
      expect="ok", check=states)
build("floating_in_file_plus_flag", L.arm(shoulder={"type": "floating"}).replace('<link name="base"/>', L.link("base")),
      extra=("--floating-base",), expect="ok", check=states)
build("massless_fixed_chain_welded", L.robot(L.link("a") + '  <link name="tool0"/>\n  <link name="tool1"/>\n'
      + L.joint("j", "base", "a") + L.joint("f0", "a", "tool0", type="fixed") + L.joint("f1", "tool0", "tool1", type="fixed")),
      expect="ok", check=states)
build("only_massless_welded_to_moving", L.robot('  <link name="a"/>\n' + L.link("b") + L.joint("j", "base", "a")
      + L.joint("f", "a", "b", type="fixed")), expect="ok", check=states)
build("prismatic_zero_mass_far", L.arm(shoulder={"type": "prismatic"}, lower={"mass": "1e-300"}), expect="ok", check=states)

# ---- Python API
p = D / "arm.urdf"
p.write_text(A)
for case, fn in [
    ("from_urdf missing path", lambda: from_urdf(D / "nope.urdf")),
    ("from_urdf directory", lambda: from_urdf(D)),
    ("from_urdf bytes path", lambda: from_urdf(str(p).encode())),
    ("from_urdf int path", lambda: from_urdf(3)),
    ("from_urdf gravity nan", lambda: eomc.compile(from_urdf(p, gravity=float("nan")), progress=False)),
    ("from_urdf gravity str", lambda: from_urdf(p, gravity="9.81")),
    ("from_urdf mimic=True no mimic tags", lambda: eomc.compile(from_urdf(p, mimic=True), progress=False).nx),
    ("eomc.compile urdf str formulation bogus", lambda: eomc.compile(str(p), formulation="bogus", progress=False)),
]:
    kind, v = api(fn)
    if kind == "other":
        cls = "raw"
    elif kind == "eomc":
        cls = "clear"
    else:
        cls = "ok"
    if case in ("from_urdf gravity nan",) and kind == "ok":
        cls = "wrong"
    record("urdf", case, cls, str(v)[:220])

# mimic=True
mim = lambda mult, off="0", target="shoulder": f'\n    <mimic joint="{target}" multiplier="{mult}" offset="{off}"/>'
for case, text in [("mimic_true_mult2", L.arm(elbow={"extra": mim("2", "0.1")})),
                   ("mimic_true_mult0", L.arm(elbow={"extra": mim("0", "0.3")})),
                   ("mimic_true_mult1e300", L.arm(elbow={"extra": mim("1e300")})),
                   ("mimic_true_target_floating", L.arm(shoulder={"type": "floating"}, elbow={"extra": mim("1")})),
                   ("mimic_true_chain", L.robot(L.link("a") + L.link("b") + L.link("c") + L.joint("ja", "base", "a")
                                                + L.joint("jb", "a", "b", extra=mim("1", target="ja"))
                                                + L.joint("jc", "b", "c", extra=mim("1", target="jb"))))]:
    pth = D / f"{case}.urdf"
    pth.write_text(text)

    def go(pth=pth):
        m = eomc.compile(from_urdf(pth, mimic=True), progress=False)
        x0 = m.consistent_state({}) if m.nhol else np.zeros(m.nx)
        r = m.simulate(x0, (0, 0.5))
        return f"nx={m.nx} nhol={m.nhol} final={np.round(r.x_final, 4)}"
    kind, v = api(go)
    cls = {"ok": "ok", "eomc": "clear", "other": "raw"}[kind]
    record("urdf", case, cls, str(v)[:260])

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
                        rpy=" ".join(f"{v:.17g}" for v in rng.uniform(-3, 3, 3)), axis=" ".join(f"{v:.17g}" for v in ax))
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

# ---- big chains (time/memory), recursive, and Kane at 60
def chain(n):
    body = ""
    for i in range(n):
        body += L.link(f"l{i}", com="0 0 0.1") + L.joint(f"j{i}", "base" if i == 0 else f"l{i-1}", f"l{i}",
                                                          xyz="0 0 0.2", axis="0 1 0" if i % 2 else "1 0 0")
    return L.robot(body, name=f"chain{n}")


for n, form, tmo in [(1000, "recursive", min(600, int(os.environ.get("REL_SCALE_TIMEOUT", "600")))), (200, "kane", min(300, int(os.environ.get("REL_SCALE_TIMEOUT", "300"))))]:
    pth = D / f"chain{n}.urdf"
    pth.write_text(chain(n))
    t = time.time()
    p = subprocess.run(["/usr/bin/time", "-v", "timeout", str(tmo), "nice", "-n", "5", f"{VENV}/eomc", "build", "-q", str(pth), "-o",
                        str(D / f"out_chain{n}_{form}"), "--formulation", form, "--outputs", "rhs"],
                       capture_output=True, text=True, env=E)
    dt = time.time() - t
    rss = [l for l in p.stderr.splitlines() if "Maximum resident" in l]
    rss = rss[0].split(":")[-1].strip() if rss else "?"
    if p.returncode == 124:
        cls = "hang"
        detail = f"killed by timeout {tmo}s; peak RSS {rss} kB; no output in that time: {last_line(p.stderr.split('Command being timed')[0])[:120]}"
    else:
        cls = classify_cli(p.returncode, p.stdout, p.stderr.split("\tCommand being timed")[0])
        detail = f"rc={p.returncode} {dt:.0f}s peak RSS {rss} kB {last_line(p.stderr.split(chr(9)+'Command being timed')[0])[:150]}"
    record("urdf", f"{n}-link chain build --formulation {form} --outputs rhs", cls, detail)
