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
revolute links (alternating axes, bench_urdf_build.chain_text), example-robot-data robots
(G1 29-dof, Go2, Talos full body; floating base, the file's joint limits on as by default) and
gymnasium's MuJoCo models (--gym ant,humanoid).

``--phases``: instead, the default build's Python phases against ``--before``'s, interleaved:
per model, a fresh child process per contestant derives and generates without the generation
cache (what a cold `eomc build` does before the C compiler) and reports the CPU seconds of
each stage (the driver's stage timer read as process CPU time), sha256 of the C and its peak
RSS; with
``--with-build``, also the CPU of one whole cold `eomc build` each (C compiler included).

``--breakdown``: where the default build's extra over the rhs-only build goes, per model (issue 30's
<= 1.5x bar): the Python side (a fresh child per contestant, as ``--phases``: derive and generate CPU,
default against ``--functions rhs``), then gcc on each NAME.c alone (``-c``, the library's flags:
DEFAULT_CFLAGS, the machine flags, the lanes, the call-graph flag; user + sys of the child), and gcc
on the default NAME.c with one group's bodies emptied at a time (a function the rhs-only C does not
have, with its ``NAME_F_part*`` helpers; "kernels": rnea_derivs and its rd_* helpers; an emptied
function's static callees then go unused and gcc drops them, so their time counts with it): the
drop from the whole file is that group's gcc time.  Interleaved, repeated, medians; the generator
is not changed.

    python benchmarks/bench_derivative_build.py [--cart 80] [--chain 200] [--robots g1] [--gym ant]
        [--repeat 1] [--per-function g1,cart80] [--cpu-cap 600] [--before "python-of-another-checkout"]
    python benchmarks/bench_derivative_build.py --phases --before PYTHON [--with-build] [--cart 80] ...
    python benchmarks/bench_derivative_build.py --breakdown [--repeat 3] [--robots g1,talos] [--cart ""] ...
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


# The phases' child: derive and generate one model (argv: model, flags) with no generation cache;
# prints {stage: CPU s}, the passes' CPU s, sha256 of the C and the peak RSS (MB) as JSON.
_PHASES = r"""
import hashlib, json, sys, time
time.perf_counter = time.process_time      # the driver's stage timer, read as CPU time
from eomc.compiler.driver import Progress, generate
model = sys.argv[1]
if model.endswith(".py"):
    name = None
else:
    from eomc.cli.common import with_options
    model, name = with_options(model, None, floating_base="--floating-base" in sys.argv)
p, passes = Progress(False), {}
p.pass_done = lambda n, s: passes.__setitem__(n, passes.get(n, 0.0) + s)
fns = next((x.split("=", 1)[1].split(",") for x in sys.argv if x.startswith("--functions=")), None)
spec, g = generate(model, name, progress=p, use_cache=False, functions=fns)
for x in sys.argv:
    if x.startswith("--c-out="):
        open(x.split("=", 1)[1], "w").write(g.c_source)
        open(x.split("=", 1)[1][:-2] + ".h", "w").write(g.header)
import resource
print(json.dumps({**p.timings, "passes": passes, "sha": hashlib.sha256(g.c_source.encode()).hexdigest(),
                  "rss": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""


def phases(args, env, python=None):
    """{derive, generate (CPU s), passes, sha, rss} of one cold derive + generate."""
    proc = subprocess.run([python or sys.executable, "-c", _PHASES, *args], env=env, capture_output=True, text=True)
    if proc.returncode:
        return {"err": (proc.stderr.strip().splitlines() or ["?"])[-1][:120]}
    return {**json.loads(proc.stdout.strip().splitlines()[-1]), "err": None}


def build(args, env, cap, python=None):
    """{cpu, wall, rss, err} of one cold build (``python``: the interpreter command running
    `-m eomc`, e.g. one that imports another checkout; default this one)."""
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", _WRAPPER, str(cap), python or sys.executable, "-m", "eomc", "build",
                           *args, "-q"], env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    cpu, rss, err = json.loads(proc.stdout.strip().splitlines()[-1])
    return {"cpu": cpu, "wall": wall, "rss": rss, "err": err}


_DEF = re.compile(r"^(?:static )?(?:EOMC_NOINLINE |EOMC_NEAR )?(?:int|void|double) (\w+)\(", re.M)


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
    for m in filter(None, a.gym.split(",")):
        import gymnasium
        cases.append((m, f"gymnasium {m}", [str(Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets"
                                                / f"{m}.xml")], {}))
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
    ap.add_argument("--gym", default="", help="gymnasium MuJoCo models, e.g. ant,humanoid")
    ap.add_argument("--phases", action="store_true", help="the Python phases against --before's (see the doc)")
    ap.add_argument("--with-build", action="store_true", help="with --phases: one whole cold build each too")
    ap.add_argument("--breakdown", action="store_true", help="the default build's extra: Python, gcc per group")
    a = ap.parse_args()
    if a.phases:
        return phase_table(a)
    if a.breakdown:
        return breakdown(a)
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
        # each build's CPU s in the order run (the ratio moves +-0.1 run to run at a load of 5-10)
        print(f"  ({label}, CPU s of each build: " + "; ".join(
            f"{k} " + " / ".join(f"{x['cpu']:.2f}" for x in runs[k]) for k in order[:3] if runs.get(k)) + ")",
            flush=True)
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


def phase_table(a):
    """--phases: derive and generate CPU, this checkout against --before's, interleaved per model."""
    work = Path(tempfile.mkdtemp(prefix="eomc_dbb_"))
    print(f"load at start {os.getloadavg()[0]:.2f}", flush=True)
    rows = []
    for key, label, args, extra in cases_of(a, work):
        runs = {"before": [], "after": []}
        whole = {"before": [], "after": []}
        for _ in range(a.repeat):
            for kind in ("before", "after") if a.before else ("after",):
                python = a.before if kind == "before" else None
                env = dict(os.environ, EOMC_CACHE_DIR=tempfile.mkdtemp(prefix="eomc_dbbc_"), **extra)
                runs[kind].append(phases(args, env, python))
                if a.with_build:
                    out = tempfile.mkdtemp(prefix="eomc_dbbo_")
                    whole[kind].append(build(args + ["-o", out], env, a.cpu_cap, python))
        cells = []
        for kind in ("before", "after") if a.before else ("after",):
            ok = [r for r in runs[kind] if r["err"] is None]
            if not ok:
                cells.append(f"({runs[kind][0]['err']})")
                continue
            d, g = (statistics.median(r[s] for r in ok) for s in ("derive", "generate"))
            cse = statistics.median(r["passes"].get("cse", 0.0) for r in ok)
            rss = max(r["rss"] for r in ok)
            w = f" / {med(whole[kind], 'cpu'):.1f}" if a.with_build else ""
            cells.append(f"{d:.2f} / {g:.2f} (CSE {cse:.2f}){w}, {rss:.0f} MB")
        same = len({r.get("sha") for k in runs for r in runs[k]}) == 1
        ratio = ""
        if a.before and all(r["err"] is None for k in runs for r in runs[k]):
            after, before = (statistics.median(r["generate"] for r in runs[k]) for k in ("after", "before"))
            ratio = f"**{after / before:.2f}**"
        rows.append(f"| {label} | {' | '.join(cells)} | {ratio} | {'yes' if same else 'NO'} |")
        print(rows[-1], flush=True)
    what = "derive / generate (CSE) CPU s" + (" / whole build CPU s" if a.with_build else "") + ", peak RSS"
    print()
    print(f"| model | {'before: ' + what + ' | ' if a.before else ''}after: {what} | generate after/before | same C |")
    print("|---|" + ("--:|" if a.before else "") + "--:|--:|:-:|")
    print("\n".join(rows))


_HELPERS = re.compile(r"^(rnea_derivs|rd_\w+)$")


def group_of(fn, name):
    """The group an emptied definition belongs to (function_sizes' key; the kernels as one)."""
    key = re.sub(r"_part\d+(_\d+)*$", "", fn.removeprefix(name + "_"))
    return "kernels" if _HELPERS.match(key) else key


def emptied(c_text, name, group):
    """``c_text`` with the bodies of ``group``'s definitions emptied (an int or double function
    returns 0; _DEF does not match the static inline one-liners: their callers are emptied)."""
    out, last = [], 0
    for m in _DEF.finditer(c_text):
        if group_of(m.group(1), name) != group:
            continue
        body = c_text.find("\n{", m.end())
        close = c_text.find("\n}\n", body)
        kind = re.match(r"(?:static )?(?:EOMC_NOINLINE |EOMC_NEAR )?(\w+) ", m.group(0)).group(1)
        ret = {"int": "    return 0;\n", "double": "    return 0.0;\n"}.get(kind, "")
        out += [c_text[last:body + 3], ret]
        last = close + 1
    return "".join(out) + c_text[last:]


def gcc_cpu(path, flags):
    """user + sys s of ``cc -c`` on one file (the child's own rusage)."""
    from eomc.compiler.build.toolchain import find_compiler
    before = resource_children()
    proc = subprocess.run([*find_compiler().argv, *flags, "-c", path.name, "-o", path.stem + ".o"], cwd=path.parent,
                          capture_output=True, text=True)
    if proc.returncode:
        raise RuntimeError(f"cc failed on {path}: {proc.stderr[-400:]}")
    return resource_children() - before


def resource_children():
    import resource
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def library_flags(c_text):
    """The flags eomc's builder compiles a library with on this machine (compiler/build/builder.py)."""
    from eomc.compiler.build.builder import machine_lanes, resolve_cflags
    from eomc.compiler.build.stack import CALLGRAPH_FLAG, supports_callgraph
    from eomc.compiler.build.toolchain import find_compiler, machine_flags
    tc = find_compiler()
    flags = resolve_cflags(None) + list(machine_flags(tc))
    if "_batch(" in c_text:
        flags.append(f"-DEOMC_BATCH_LANES={machine_lanes()}")
    return flags + ([CALLGRAPH_FLAG] if supports_callgraph(tc) else [])


def breakdown(a):
    """--breakdown: the default build's extra over rhs-only, Python side and gcc per group."""
    work = Path(tempfile.mkdtemp(prefix="eomc_dbb_"))
    print(f"load at start {os.getloadavg()[0]:.2f}", flush=True)
    for key, label, args, extra in cases_of(a, work):
        py = {"default": [], "rhs": []}
        from eomc.compiler.build.builder import SHIPPED_HEADERS, shipped_c_dir
        for kind in py:     # each NAME.c in its own directory, beside its NAME.h and the shipped headers
            (work / key / kind).mkdir(parents=True)
            for n in SHIPPED_HEADERS:
                (work / key / kind / n).write_bytes((shipped_c_dir() / n).read_bytes())
        for rep in range(a.repeat):
            for kind in ("rhs", "default"):
                env = dict(os.environ, EOMC_CACHE_DIR=tempfile.mkdtemp(prefix="eomc_dbbc_"), **extra)
                more = [f"--c-out={work / key / kind / 'model.c'}"] + (["--functions=rhs"] if kind == "rhs" else [])
                py[kind].append(phases(args + more, env))
        for kind in py:
            if any(r["err"] for r in py[kind]):
                print(f"| {label} | {kind}: {py[kind][0]['err']} |", flush=True)
                return
        cd, cr = (work / key / k / "model.c" for k in ("default", "rhs"))
        text = cd.read_text()
        name = re.search(r'^#include "(\w+)\.h"', text, re.M).group(1)
        for kind in py:
            (work / key / kind / "model.h").replace(work / key / kind / f"{name}.h")
        flags = library_flags(text)
        sizes = function_sizes(text, name)
        groups = {}
        for fn in sizes:
            if fn != "(file)":
                g = "kernels" if _HELPERS.match(fn) else fn
                groups[g] = groups.get(g, 0) + sizes[fn]
        in_rhs = set(function_sizes(cr.read_text(), name))
        variants = {"rhs": cr, "default": cd}
        for g in sorted(groups, key=lambda g: -groups[g]):
            if g in in_rhs or groups[g] < 1000:     # the rhs's own code is in both builds
                continue
            v = work / key / "default" / f"no_{g}.c"
            v.write_text(emptied(text, name, g))
            variants[g] = v
        gcc = {v: [] for v in variants}
        for rep in range(a.repeat):
            for v, path in variants.items():
                gcc[v].append(gcc_cpu(path, flags))
        m = {v: statistics.median(gcc[v]) for v in gcc}
        pyd = {k: (statistics.median(r["derive"] for r in py[k]), statistics.median(r["generate"] for r in py[k]))
               for k in py}
        print(f"\n{label} ({a.repeat} interleaved repeats, medians, CPU s; load now {os.getloadavg()[0]:.1f})\n")
        print("| part | default | rhs-only | extra |\n|---|--:|--:|--:|")
        for i, what in enumerate(("Python derive", "Python generate")):
            print(f"| {what} | {pyd['default'][i]:.2f} | {pyd['rhs'][i]:.2f} | {pyd['default'][i] - pyd['rhs'][i]:+.2f} |")
        print(f"| gcc -c NAME.c | {m['default']:.2f} | {m['rhs']:.2f} | {m['default'] - m['rhs']:+.2f} |")
        print(f"  (gcc each run: default " + " / ".join(f"{x:.2f}" for x in gcc["default"]) + "; rhs-only "
              + " / ".join(f"{x:.2f}" for x in gcc["rhs"]) + ")")
        print("\n| group emptied | its C kB | gcc s without it | its gcc s (drop) |\n|---|--:|--:|--:|")
        for g in variants:
            if g in ("rhs", "default"):
                continue
            print(f"| {g} | {groups[g] / 1e3:.0f} | {m[g]:.2f} | {m['default'] - m[g]:.2f} |", flush=True)


if __name__ == "__main__":
    main()
