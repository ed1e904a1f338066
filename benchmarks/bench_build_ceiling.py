"""How a URDF chain's build grows with its length, and where it stops (issue 34, item 7).

The round-4 reliability report built alternating-axis chains (`eomc build chainN.urdf -q
--outputs rhs --formulation recursive`): linear to 1000 links (108 s, 823 MB), then a
5000-link chain ran 20 min and 8.2 GB without finishing or saying anything.

Three measurements:

1. The derivation stage alone (read the URDF, check the model: `read_model` + `spec_of`,
   recursive), CPU seconds, at 500 ... 5000 links: this code against the earlier
   `check_inputs` (compiler/model/validate.py) and `merged_defaults`
   (compiler/multibody/model.py) of the revision before (--before), loaded from git and swapped in: they tested membership
   in lists of SymPy functions, one equality test per pair -- quadratic, ~80 us a pair.
2. Builds in a fresh process (`eomc build -q`, /usr/bin/time: CPU of the process and its
   children, peak RSS of the largest), rhs only, at 250 ... N links; and the default
   function set (with jac_x, jac_r, linearize) at 50 and 100 links: its C grows with the
   square of the length (a dense 2n x 2n Jacobian), which is why the default build has a
   ceiling (compiler/model/ceiling.py).
3. The refusal past the ceiling: CPU seconds from the command to its one-line error.

Usage: python benchmarks/bench_build_ceiling.py [--derive 500,1000,2000,5000] [--rhs 250,500,1000]
       [--default 50,100] [--refuse 1000,5000] [--no-write]
"""
import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import environment_header, format_table, write_results  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
EOMC = [sys.executable, "-m", "eomc"]
PIN = ["taskset", "-c", "1"] if os.path.exists("/usr/bin/taskset") else []
LINK = ('<link name="l{i}"><inertial><origin xyz="0 0 0.2"/><mass value="1"/><inertia ixx="0.02" ixy="0" '
        'ixz="0" iyy="0.02" iyz="0" izz="0.001"/></inertial></link>\n')
JOINT = ('<joint name="j{i}" type="revolute"><parent link="l{p}"/><child link="l{i}"/><origin xyz="0 0 0.4"/>'
         '<axis xyz="{a}"/></joint>\n')

DERIVE = r"""
import subprocess, sys, time, types
from eomc.compiler.model.spec import read_model, spec_of
path, old = sys.argv[1], sys.argv[2] == "before"
if old:     # the membership tests of the revision before, from git, swapped in
    import eomc.compiler.model.validate as validate, eomc.compiler.multibody.model as mb
    for module, rel, name in ((validate, "compiler/model/validate.py", "check_inputs"),
                              (mb, "compiler/multibody/model.py", "merged_defaults")):
        text = subprocess.run(["git", "-C", sys.argv[3], "show", sys.argv[4] + ":" + rel], capture_output=True,
                              text=True, check=True).stdout
        ns = dict(vars(module))
        exec(compile(text, module.__file__, "exec"), ns)
        setattr(module, name, ns[name])
        for other in list(sys.modules.values()):     # modules that imported the name
            if getattr(other, name, None) is not None and other is not module and \
                    getattr(other, "__name__", "").startswith("eomc."):
                setattr(other, name, ns[name])
t0 = time.process_time()
read = read_model(path)
t1 = time.process_time()
spec_of(read, formulation="recursive")
t2 = time.process_time()
print(f"{t1 - t0:.3f} {t2 - t1:.3f}")
"""


def chain(folder, n):
    path = Path(folder) / f"chain{n}.urdf"
    body = "".join(LINK.format(i=i) + JOINT.format(i=i, p=i - 1, a="1 0 0" if i % 2 else "0 1 0")
                   for i in range(1, n + 1))
    path.write_text(f'<?xml version="1.0"?>\n<robot name="chain">\n<link name="l0"/>\n{body}</robot>\n')
    return path


def derive(folder, sizes, before):
    rows = []
    for n in sizes:
        path = chain(folder, n)
        row = [n]
        for code in ("before", "now"):
            if code == "before" and n > 2000:
                row += ["-", "(quadratic: skipped)"]
                continue
            out = subprocess.run([*PIN, sys.executable, "-c", DERIVE, str(path), code, str(ROOT), before],
                                 capture_output=True, text=True, check=True).stdout.split()
            row += [f"{float(out[0]):.2f}", f"{float(out[1]):.2f}"]
        rows.append(row)
        print(rows[-1], flush=True)
    return format_table(["links", f"read ({before})", f"check ({before})", "read (now)", "check (now)"], rows)


def timed(argv, env):
    """(CPU seconds of the process and its children, peak RSS MB, wall s, return code, last line)."""
    start = time.time()
    done = subprocess.run(["/usr/bin/time", "-f", "EOMC_TIME %U %S %M", *PIN, *argv], capture_output=True,
                          text=True, env=env)
    wall = time.time() - start
    m = re.search(r"EOMC_TIME ([\d.]+) ([\d.]+) (\d+)", done.stderr)
    lines = [line for line in done.stderr.splitlines()
             if line and not line.startswith(("EOMC_TIME", "Command exited with"))]
    return (float(m.group(1)) + float(m.group(2)), int(m.group(3)) / 1024, wall, done.returncode,
            lines[-1] if lines else "")


def builds(folder, sizes, outputs):
    rows = []
    for n in sizes:
        path = chain(folder, n)
        env = {**os.environ, "EOMC_CACHE_DIR": str(Path(folder) / f"cache-{n}-{outputs or 'default'}")}
        argv = [*EOMC, "build", str(path), "-q", "-o", str(Path(folder) / f"out{n}")]
        if outputs:
            argv += ["--outputs", outputs, "--formulation", "recursive"]
        cpu, rss, wall, code, last = timed(argv, env)
        c_file = Path(folder) / f"out{n}" / f"chain{n}.c"
        size = c_file.stat().st_size / 1e6 if c_file.exists() else float("nan")
        rows.append([n, outputs or "default", f"{cpu:.1f}", f"{cpu / n:.3f}", f"{rss:.0f}", f"{size:.1f}",
                     f"{wall:.0f}", "ok" if code == 0 else f"exit {code}: {last[:60]}"])
        print(rows[-1], flush=True)
    return format_table(["links", "functions", "CPU s", "CPU s/link", "peak MB", "C MB", "wall s", "result"],
                        rows)


def refusals(folder, sizes):
    rows = []
    for n in sizes:
        path = chain(folder, n)
        env = {**os.environ, "EOMC_CACHE_DIR": str(Path(folder) / "cache-refuse")}
        cpu, rss, wall, code, last = timed([*EOMC, "build", str(path), "-q", "-o", str(Path(folder) / "r")], env)
        figure = re.search(r"about ([\d.]+ [MGT]B) of C.*least ([\d.]+ (?:h|min)) and ([\d.]+ [MGT]B)", last)
        rows.append([n, f"{cpu:.1f}", f"{rss:.0f}", code, " / ".join(figure.groups()) if figure else last[:80]])
        print(rows[-1], flush=True)
    return format_table(["links", "CPU s to the error", "peak MB", "exit", "stated: C / gcc time / gcc memory"],
                        rows)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--derive", default="500,1000,2000,5000")
    ap.add_argument("--rhs", default="250,500,1000")
    ap.add_argument("--default", default="50,100")
    ap.add_argument("--refuse", default="1000,5000")
    ap.add_argument("--before", default="7aacdf9", help="revision with the quadratic checks (before c96735c)")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    sizes = {k: [int(v) for v in getattr(args, k).split(",") if v] for k in ("derive", "rhs", "default", "refuse")}
    with tempfile.TemporaryDirectory() as folder:
        parts = [environment_header("URDF chain builds: growth and ceiling (bench_build_ceiling.py)", args,
                                    notes=["each figure is one run (a build takes minutes): CPU seconds, "
                                           "which the machine's load disturbs less than wall time"])]
        if sizes["derive"]:
            parts += ["## 1. Derivation stage (read + check), CPU s, pinned to one core",
                      derive(folder, sizes["derive"], args.before)]
        if sizes["rhs"] or sizes["default"]:
            parts += ["## 2. Builds (`eomc build -q`), fresh process and cache",
                      builds(folder, sizes["rhs"], "rhs") if sizes["rhs"] else "",
                      builds(folder, sizes["default"], None) if sizes["default"] else ""]
        if sizes["refuse"]:
            parts += ["## 3. Default builds past the ceiling: refused", refusals(folder, sizes["refuse"])]
    text = "\n\n".join(p for p in parts if p) + "\n"
    print(text)
    if not args.no_write:
        write_results("build_ceiling", text)


if __name__ == "__main__":
    main()
