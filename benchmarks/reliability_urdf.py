"""Re-run the URDF cases N7 and N8 of the 2026-11 reliability report (r3); one line per attempt.

    case | outcome | detail

outcome: "clear error" (exit 1, one line naming file:line), "correct" (built, and the
built model passes the case's check), "silent wrong" (built what should have been
refused, or a wrong model), "traceback", "hang" (over the time limit).  Each case
runs `eomc build` in a child process with a fresh cache, as a user would.
Usage: python benchmarks/reliability_urdf.py [--quick | --n8]  (--quick: skip the longest
chains; --n8: only the N8 inputs)
"""
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

LINK = ('  <link name="{name}"><inertial><origin xyz="{com}"/><mass value="{mass}"/>'
        '<inertia ixx="{ixx}" ixy="0" ixz="0" iyy="{iyy}" iyz="0" izz="{izz}"/></inertial></link>\n')
JOINT = ('  <joint name="{name}" type="{type}"><parent link="{parent}"/><child link="{child}"/>'
         '<origin xyz="0 0 0.4"/><axis xyz="{axis}"/>{extra}</joint>\n')


def link(name, mass="1.0", com="0 0 0.2", ixx="0.02", iyy="0.02", izz="0.001"):
    return LINK.format(name=name, mass=mass, com=com, ixx=ixx, iyy=iyy, izz=izz)


def joint(name, parent, child, type="revolute", axis="0 1 0", extra=""):
    return JOINT.format(name=name, type=type, parent=parent, child=child, axis=axis, extra=extra)


def robot(body, name="arm"):
    return f'<?xml version="1.0"?>\n<robot name="{name}">\n  <link name="base"/>\n{body}</robot>\n'


def arm(upper=None, lower=None, shoulder=None, elbow=None):
    return robot(link("upper", **(upper or {})) + link("lower", **(lower or {}))
                 + joint("shoulder", "base", "upper", **(shoulder or {}))
                 + joint("elbow", "upper", "lower", **{"type": "continuous", **(elbow or {})}))


def chain(n, kind="revolute", axes=("1 0 0", "0 1 0")):
    body, parent = "", "base"
    for k in range(n):
        body += link(f"l{k}", mass="0.1", com="0 0 0.05", ixx="1e-4", iyy="1e-4", izz="1e-5")
        t = kind if kind != "mixed" else ("fixed" if k % 2 else "revolute")
        body += joint(f"j{k}", parent, f"l{k}", type=t, axis=axes[k % len(axes)])
        parent = f"l{k}"
    return robot(body, name=f"chain{n}")


def names(j1, j2, l1="upper", l2="lower", t1="revolute", a1="0 1 0"):
    return robot(link(l1) + link(l2) + joint(j1, "base", l1, type=t1, axis=a1) + joint(j2, l1, l2))


def mimic(mult, off):
    return f'<mimic joint="shoulder" multiplier="{mult}" offset="{off}"/>'


def run(work, case, text, args=(), timeout=300, expect="error", check=None):
    run.count = getattr(run, "count", 0) + 1
    path = work / f"case{run.count:02d}.urdf"
    path.write_text(text)
    out = work / f"out_{path.stem}"
    env = dict(os.environ, EOMC_CACHE_DIR=tempfile.mkdtemp(prefix="eomc_rel_"))
    t0 = time.time()
    try:
        proc = subprocess.run([sys.executable, "-m", "eomc", "build", "-q", str(path), "-o", str(out),
                               "--formulation", "recursive", "--outputs", "rhs", *args],
                              capture_output=True, text=True, timeout=timeout, env=env)
    except subprocess.TimeoutExpired:
        return print(f"{case} | hang | over {timeout} s", flush=True)
    dt = time.time() - t0
    err = [line for line in proc.stderr.strip().splitlines() if line.strip()]
    warn = [line for line in err if "Warning" in line]
    if proc.returncode:
        last = err[-1] if err else ""
        if "Traceback" in proc.stderr:
            outcome = "traceback"
        elif len([e for e in err if "Warning" not in e]) == 1 and re.search(rf"{re.escape(str(path))}:\d+: ", last):
            outcome = "clear error" if expect == "error" else "clear error (expected it to build)"
        else:
            outcome = "unclear error"
        return print(f"{case} | {outcome} | {dt:.1f} s: {last.replace(str(work) + '/', '')[:220]}", flush=True)
    if expect == "error":
        return print(f"{case} | silent wrong | built in {dt:.1f} s, expected a refusal", flush=True)
    detail = f"built in {dt:.1f} s" + (f"; warned: {warn[0].split('Warning: ')[-1][:160]}" if warn else "")
    if check is not None:
        good, more = check(out)
        return print(f"{case} | {'correct' if good else 'silent wrong'} | {detail}; {more}", flush=True)
    print(f"{case} | correct | {detail}", flush=True)


def finite_rhs(out):
    import numpy as np
    import eomc
    m = eomc.load(out)
    x = np.full(m.nx, 0.1)
    xd = m.rhs(0.0, x)
    ok = bool(np.all(np.isfinite(xd)))
    return ok, f"nx={m.nx}, rhs finite={ok}, states {list(m.state_names)[:4]}"


def main():
    quick, n8 = "--quick" in sys.argv, "--n8" in sys.argv
    work = Path(tempfile.mkdtemp(prefix="rel_r3_urdf_"))
    print("case | outcome | detail")
    if not n8:
        n7(work, quick)
    n8_cases(work)


def n7(work, quick):
    # N7: deep and 3-D chains
    run(work, "N7 1000-link fixed chain (1 revolute at the end)", chain(999, "fixed") .replace(
        '<joint name="j998" type="fixed"', '<joint name="j998" type="revolute"'), expect="ok", check=finite_rhs)
    run(work, "N7 600-link mixed fixed/revolute chain", chain(600, "mixed"), expect="ok", check=finite_rhs,
        timeout=600)
    for n in ((8, 16, 24, 40) if quick else (8, 16, 24, 40, 200)):
        run(work, f"N7 {n}-link chain alternating x/y axes", chain(n), expect="ok", check=finite_rhs, timeout=600)
    run(work, "N7 40-link planar chain (all y axes)", chain(40, axes=("0 1 0",)), expect="ok", check=finite_rhs)
    if not quick:
        run(work, "N7 1000-link revolute chain", chain(1000), expect="ok", check=finite_rhs, timeout=900)


def n8_cases(work):
    run(work, 'N8 <robot name="e"/> (no links)', '<?xml version="1.0"?>\n<robot name="e"/>\n')
    run(work, "N8 a lone link", '<?xml version="1.0"?>\n<robot name="e"><link name="a"/></robot>\n')
    run(work, "N8 only fixed joints (0 states)", robot(link("a") + joint("f", "base", "a", type="fixed")))
    run(work, "N8 axis 1e200 1e200 0", arm(shoulder={"axis": "1e200 1e200 0"}), expect="ok", check=finite_rhs)
    run(work, "N8 joints a-b and a_b", names("a-b", "a_b"))
    run(work, "N8 joints a.b and a b", names("a.b", "a b"))
    run(work, "N8 joints je-acute and je-grave", names("j\u00e9", "j\u00e8"))
    run(work, "N8 joints 1 and _1", names("1", "_1"))
    run(work, "N8 links l-1 and l_1", names("j1", "j2", "l-1", "l_1"))
    run(work, "N8 --floating-base beside a joint base_floating_x",
        robot(link("upper") + link("lower") + joint("shoulder", "base", "upper")
              + joint("base_floating_x", "upper", "lower")).replace('<link name="base"/>', link("base")),
        args=("--floating-base",))
    run(work, "N8 planar p beside p_x", names("p", "p_x", t1="planar", a1="0 0 1"))
    run(work, "N8 inertia 1e308 on the diagonal", arm(upper={"ixx": "1e308", "iyy": "1e308", "izz": "1e308"}))
    run(work, "N8 inertia ixx 1e308", arm(upper={"ixx": "1e308"}))
    run(work, "N8 <robot> without name", arm().replace('<robot name="arm">', "<robot>"))
    run(work, 'N8 <limit upper="abc">', arm(shoulder={"type": "prismatic", "extra":
                                                      '<limit lower="0" upper="abc" effort="1" velocity="1"/>'}))
    # mimic multiplier 0 needs from_urdf(..., mimic=True): in-process
    path = work / "mimic0.urdf"
    path.write_text(arm(elbow={"extra": mimic("0", "0.3")}))
    code = ("import warnings; warnings.simplefilter('ignore'); import eomc; from eomc.mechanics import from_urdf; "
            f"eomc.compile(from_urdf({str(path)!r}, mimic=True), progress=False)")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300,
                          env=dict(os.environ, EOMC_CACHE_DIR=tempfile.mkdtemp(prefix="eomc_rel_")))
    last = proc.stderr.strip().splitlines()[-1] if proc.stderr.strip() else ""
    outcome = ("clear error" if proc.returncode and "ModelFileError" in last and f"{path}:" in last
               and "joint 'elbow'" in last else "silent wrong" if proc.returncode == 0 else "traceback")
    print(f'N8 <mimic multiplier="0"> with from_urdf(mimic=True) | {outcome} | {last[-220:]}', flush=True)


if __name__ == "__main__":
    main()
