"""`eomc build MODEL.xml -o DIR` with no flags (cold cache, the default function set) on
gymnasium's hopper, walker2d, ant and humanoid: CPU per phase (derive, generate, compile: the
C compiler's CPU), the whole build's CPU and the C's size, per function too (issue 33: build
<= 10 s CPU each).

Contestants, in the same run, interleaved per round, each build in a fresh child with a fresh
cache: ``before`` (``split.LEAN_MIN`` out of reach: every function's body at the command line's
-O2, the C of main before session 15), ``after`` (the default: the long rhs, jac_x and
NAME_implicit bodies under EOMC_LEAN, compiler/emit/split.py) and, on request, ``kernels_off``
(also ``lower.CONTACT_KERNELS = False``: mass_matrix, jac_r, forcing and inverse_dynamics as
straight-line copies of their own, the C of main before session 14), ``unfolded``
(``split.FOLD_BLOCKS = False``: the contacts' guard blocks are not statements of the split's
runs, the C of main before session 17) and ``base`` (the default build of another checkout:
``--base DIR``, a folder whose ``eomc`` package is that checkout laid out as installed --
facade/ as eomc/, with compiler/, runtime/ (its built .so files) and templates/ inside -- put
first on the child's PYTHONPATH; e.g. main before a change) and ``no_ground`` (the default build
with no ground contact: the MJCF's planes made non-colliding in a copy of the file, a URDF without
``--ground``; what any lowering of the ground contacts could save at most, issue 33).  The first
mode given is the one the ratios compare with.

Models: gymnasium's ``hopper``, ``walker2d``, ``ant`` and ``humanoid`` (the default set), and on
request ``go2``: ``eomc build go2.urdf --floating-base --ground`` (example-robot-data; its 19
collision meshes, each thinned to a hull of 32 points: 608 ground points; ~65 s CPU, ~870 MB peak).
"Peak MB" is the larger of the child's and its C compiler's peak resident size.

Phases are CPU seconds: the driver's stage clock is replaced in the child by the process's
CPU time plus its finished children's (the C compiler runs as a child), so "compile" is gcc's
CPU.  The build is the CLI's own (eomc.cli.main), as a user runs it.

    python benchmarks/bench_mjcf_build.py [--models hopper,walker2d,ant,humanoid] [--modes before,after]
        [--rounds 1] [--base DIR] [--no-write]      (pin it: taskset -c 1)
    python benchmarks/bench_mjcf_build.py --child MODEL MODE OUT   (one build; prints JSON)
"""
import json
import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

MODELS = ("hopper", "walker2d", "ant", "humanoid")
MODES = ("before", "after")   # also: kernels_off, unfolded, base, no_ground
URDF_MODELS = {"go2": ("go2_description/urdf/go2.urdf", ["--floating-base", "--ground"])}   # example-robot-data


def _cpu():
    own = time.process_time()
    ch = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own + ch.ru_utime + ch.ru_stime


def _sizes(text, name):
    """C bytes per generated function (its _part routines included), the static routines that
    no function's name prefixes (the pairs' table and narrow phase: "routines") and the
    name/default tables with the model struct ("tables")."""
    starts = []
    for m in re.finditer(r"^(?:EOMC_LEAN\w* )?(?:static |int |void |const |double )[^\n;=]*\(|^(?:static )?const [^\n(]*=", text, re.M):
        own = re.match(rf"[^(]*?\b{name}_(\w+?)(?:_part\d+_\d+)?\(", m.group(0))
        starts.append((m.start(), own.group(1) if own and "(" in m.group(0) else
                       "tables" if m.group(0).endswith("=") else "routines"))
    sizes = {}
    for (at, fn), (end, _) in zip(starts, starts[1:] + [(len(text), "")]):
        sizes[fn] = sizes.get(fn, 0) + end - at
    return sizes


def _robots():
    """example-robot-data's robots folder (its cmeel package, on sys.path)."""
    for entry in sys.path:
        folder = Path(entry) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
        if folder.is_dir():
            return folder
    raise RuntimeError("example-robot-data (pip install example-robot-data) is not installed")


def _without_ground(path, out):
    """A copy of the MJCF file ``path`` (in the folder ``out``) whose planes collide with nothing
    (contype = conaffinity = 0): the model with no ground contact.  Checked: MuJoCo finds no
    ground geom in it (compiler/mjcf/collision.ground_geoms)."""
    import xml.etree.ElementTree as ET
    import mujoco
    from eomc.compiler.mjcf.collision import ground_geoms
    tree = ET.parse(path)
    if any(e.get("file") for e in tree.iter()):
        raise RuntimeError(f"{path}: no_ground copies the file alone; it reads other files")
    for geom in tree.iter("geom"):
        if geom.get("type") == "plane":
            geom.set("contype", "0")
            geom.set("conaffinity", "0")
    copy = Path(out) / "no_ground" / Path(path).name
    copy.parent.mkdir(parents=True, exist_ok=True)
    tree.write(copy)
    if ground_geoms(mujoco.MjModel.from_xml_path(str(copy)), str(copy)):
        raise RuntimeError(f"{copy}: the model still touches a ground plane")
    return str(copy)


def child(model, mode, out):
    import types
    import warnings
    import gymnasium
    import eomc.cli
    from eomc.compiler import driver
    from eomc.compiler.tree import lower
    from eomc.compiler.emit import split
    if mode in ("before", "kernels_off"):
        split.LEAN_MIN = float("inf")
    if mode == "unfolded":
        split.FOLD_BLOCKS = False
    if mode == "kernels_off":
        lower.CONTACT_KERNELS = False
    driver.time = types.SimpleNamespace(perf_counter=_cpu)       # stage clock: CPU, gcc's included
    seen = {}
    stage = driver.Progress.stage

    def recording(self, label):
        self.timings = seen
        return stage(self, label)
    driver.Progress.stage = recording
    flags = []
    if model in URDF_MODELS:
        rel, flags = URDF_MODELS[model]
        path = str(_robots() / rel)
        if mode == "no_ground":
            flags = [f for f in flags if f != "--ground"]
    else:
        path = os.path.join(os.path.dirname(gymnasium.__file__), "envs", "mujoco", "assets", f"{model}.xml")
        if mode == "no_ground":
            path = _without_ground(path, out)
    t0 = _cpu()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        status = eomc.cli.main(["build", path, "-o", out, "-q", "--name", model, *flags])
    total = _cpu() - t0
    text = (Path(out) / f"{model}.c").read_text()
    print(json.dumps({"status": status, "cpu": total, "phases": seen, "c_bytes": len(text),
                      "functions": _sizes(text, model),
                      "rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                      "gcc_rss_mb": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024}))


def _peak(res):
    return max(res.get("rss_mb", 0.0), res.get("gcc_rss_mb", 0.0))


def main():
    from common import environment_header, write_results

    def arg(flag, default):
        return sys.argv[sys.argv.index(flag) + 1] if flag in sys.argv else default
    models = tuple(arg("--models", ",".join(MODELS)).split(","))
    modes = tuple(arg("--modes", ",".join(MODES)).split(","))
    rounds = int(arg("--rounds", "1"))
    runs = {(m, k): [] for m in models for k in modes}
    loads = []
    for r in range(rounds):
        for model in models:
            for mode in modes:
                loads.append(os.getloadavg()[0])
                out = tempfile.mkdtemp(prefix="eomc_mb_")
                env = dict(os.environ, EOMC_CACHE_DIR=tempfile.mkdtemp(prefix="eomc_mbc_"))
                if mode == "base":
                    env["PYTHONPATH"] = os.pathsep.join([arg("--base", None)] + env.get("PYTHONPATH", "").split(os.pathsep)).rstrip(os.pathsep)
                proc = subprocess.run([sys.executable, __file__, "--child", model, mode, out], env=env,
                                      capture_output=True, text=True, cwd=tempfile.gettempdir())
                if proc.returncode:
                    raise RuntimeError(f"{model} {mode}: {proc.stderr[-2000:]}")
                res = json.loads(proc.stdout.strip().splitlines()[-1])
                runs[model, mode].append(res)
                ph = res["phases"]
                print(f"round {r + 1} {model:9s} {mode:6s} CPU {res['cpu']:6.1f} s  derive {ph.get('derive', 0):5.1f}"
                      f"  generate {ph.get('generate', 0):5.1f}  compile {ph.get('compile', 0):5.1f}"
                      f"  C {res['c_bytes'] / 1e3:6.0f} kB  peak {_peak(res):5.0f} MB  load {loads[-1]:.1f}", flush=True)

    def med(model, mode, get):
        return statistics.median(get(x) for x in runs[model, mode])
    rows = [f"| model | build | CPU s | derive s | generate s | compile (gcc) s | C kB | peak MB | vs {modes[0]} (CPU) | vs {modes[0]} (C) |",
            "|---|---|---|---|---|---|---|---|---|---|"]
    for model in models:
        for mode in modes:
            cpu = med(model, mode, lambda x: x["cpu"])
            size = med(model, mode, lambda x: x["c_bytes"])
            peak = med(model, mode, _peak)
            ph = {k: med(model, mode, lambda x, k=k: x["phases"].get(k, 0.0)) for k in ("derive", "generate", "compile")}
            ratio = ratio_c = "-"
            if mode != modes[0]:
                ratio = f"{cpu / med(model, modes[0], lambda x: x['cpu']):.2f}x"
                ratio_c = f"{size / med(model, modes[0], lambda x: x['c_bytes']):.2f}x"
            rows.append(f"| {model} | {mode} | {cpu:.1f} | {ph['derive']:.2f} | {ph['generate']:.2f} | "
                        f"{ph['compile']:.2f} | {size / 1e3:.0f} | {peak:.0f} | {ratio} | {ratio_c} |")
    fns = sorted({f for v in runs.values() for x in v for f in x["functions"]},
                 key=lambda f: -max(x["functions"].get(f, 0) for v in runs.values() for x in v))
    big = [f for f in fns if max(x["functions"].get(f, 0) for v in runs.values() for x in v) >= 20000]
    table2 = ["| model | build | " + " | ".join(big) + " |", "|---|---|" + "---|" * len(big)]
    for model in models:
        for mode in modes:
            x = runs[model, mode][0]
            table2.append(f"| {model} | {mode} | " + " | ".join(
                f"{x['functions'].get(f, 0) / 1e3:.0f}" for f in big) + " |")
    text = "\n".join([
        environment_header("`eomc build` of gymnasium MJCF models with no flags (and Go2 --ground): CPU per phase "
                           "and C size"), "",
        f"- rounds: {rounds}; 1-min load at the builds: min {min(loads):.1f}, median {statistics.median(loads):.1f}, "
        f"max {max(loads):.1f}; CPU = the child's user + sys and its C compiler's (medians over rounds)",
        "- before: `split.LEAN_MIN` out of reach (every body at -O2, the C of main before session 15); after: the "
        "default; kernels_off: also "
        "`lower.CONTACT_KERNELS = False` (the C of main before session 14); unfolded: `split.FOLD_BLOCKS = False` "
        "(the guard blocks not in the split's runs: the C of main before session 17)"
        + (f"; base: the default build of the checkout in {arg('--base', '')}" if "base" in modes else "")
        + ("; no_ground: the default build with no ground contact (the MJCF's planes non-colliding, the URDF "
           "without --ground)" if "no_ground" in modes else "")
        + ("; go2: `eomc build go2.urdf --floating-base --ground` (example-robot-data, 608 hull points)"
           if "go2" in models else "")
        + "; peak MB: the larger of the child's and its C compiler's peak resident size", "",
        *rows, "", "C kB per function (its _part routines included; routines: the static ones no function's name prefixes, "
        "the pairs' table and narrow phase; tables: names, defaults, the model struct; first round; >= 20 kB in some build):", "",
        *table2])
    print(text)
    if "--no-write" not in sys.argv:
        write_results("mjcf_build", text, keep_notes=True)


if __name__ == "__main__":
    if "--child" in sys.argv:
        i = sys.argv.index("--child")
        child(sys.argv[i + 1], sys.argv[i + 2], sys.argv[i + 3])
    else:
        main()
