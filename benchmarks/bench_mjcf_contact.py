"""Issue 33: MJCF models with the file's ground contacts -- build time, rhs vs mj_forward with contacts.

Per gymnasium model (hopper, walker2d, ant, humanoid; the MJCF files in the gymnasium wheel):

- build: a fresh Python process runs ``eomc.compile(path)`` (no flags: the file's contacts, limits
  and frictionloss as eomc models them) for rhs into an empty cache; wall time in the child, CPU
  its user+sys including gcc.  Also built without the contacts (``geoms=False``): the
  contacts' share of the rhs.
- states: MuJoCo's own passive run from the model's initial state (``mj_step`` at the file's
  time step for 3 s: it lands, and hopper/walker/humanoid topple), NSTATES states sampled from
  t = 0.5 .. 3 s where contacts are active, each mapped to eomc's coordinates
  (eomc.compiler.mjcf.compare.from_mujoco).  The tables give MuJoCo's mean number of contacts
  at those states and eomc's contact points (each evaluated at every call).
- ns per call, each in its own C harness timed with CLOCK_THREAD_CPUTIME_ID over the same
  states, zero controls, interleaved repeat by repeat, pinned to one core:
    eomc            NAME_rhs with contacts (gcc -O2, eomc's default flags)
    eomc no contact NAME_rhs of the geoms=False build
    MuJoCo          mj_forward with its defaults (collision, contacts, limits, constraint solve)
  The two do not compute the same forces (MuJoCo's contact is a soft constraint solved per
  call, eomc's a smooth force law): this is the cost of one dynamics evaluation with contacts.
"""
import os
import resource
import statistics
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import environment_header, format_table, write_results  # noqa: E402
from bench_urdf import _mujoco_dir, _run, _timed, _write, eomc_harness  # noqa: E402
import bench_mjcf  # noqa: E402

# (file stem, row label, eomc's self-collision pairs: True MjcfModel(pairs=True), False
# MjcfModel(pairs="trees"), the default before session 11 (self-pairs are in by default since);
# how the pairs are generated: "" inlined, "law" law routines (compiler/contact/pairs.LAW_ROUTINES),
# "table" one table-driven loop (pairs.PAIR_TABLE, compiler/contact/table.py; the default since
# session 11, so the child switches it off for the other two))
MODELS = [(stem, stem, False, "") for stem in ("hopper", "walker2d", "ant", "humanoid")] + [
    ("humanoid", "humanoid, pairs=True", True, ""),
    ("humanoid", "humanoid, pairs=True, law routines", True, "law"),
    ("humanoid", "humanoid, pairs=True, table", True, "table")]
NSTATES, NCALLS, REPEAT = 100, 20000, 7
CORE = int(sys.argv[sys.argv.index("--core") + 1]) if "--core" in sys.argv else 1
# --only STEM: that model's rows only, printed, no results file written (a quick check)
ONLY = sys.argv[sys.argv.index("--only") + 1] if "--only" in sys.argv else None

# bench_mjcf.py's mj_forward timing harness with MuJoCo's contacts, constraints and limits left on
MUJOCO_HARNESS = bench_mjcf.MUJOCO_HARNESS.replace(bench_mjcf.CONTACTS_OFF, "")
assert MUJOCO_HARNESS != bench_mjcf.MUJOCO_HARNESS, "bench_mjcf's harness no longer switches contacts off"

COLD_BUILD = r"""
import sys, time, warnings
t0 = time.perf_counter()
import eomc
from pathlib import Path
from eomc.compiler.mjcf.model import MjcfModel
path, name, cache, out, geoms = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4], sys.argv[5] == "1"
pairs = len(sys.argv) > 6 and sys.argv[6] == "1"
from eomc.compiler.contact import pairs as pair_code
mode = sys.argv[7] if len(sys.argv) > 7 else ""
pair_code.PAIR_TABLE = mode == "table"
pair_code.LAW_ROUTINES = mode == "law"
warnings.simplefilter("ignore")
model = eomc.compile(MjcfModel(Path(path), geoms=geoms, pairs=True if pairs else "trees"), name, functions=["rhs"], cache_dir=cache, output_dir=out,
                     progress=False)
print("wall", time.perf_counter() - t0)
"""


def cold_build(path, name, geoms, tmp, pairs=False, mode=""):
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    proc = _run([sys.executable, "-c", COLD_BUILD, str(path), name, str(tmp / f"cache_{name}"),
                 str(tmp / f"out_{name}"), "1" if geoms else "0", "1" if pairs else "0", mode])
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return float(proc.stdout.split()[-1]), (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def contact_states(path, rng):
    """MuJoCo's (qpos, qvel) at NSTATES times of its passive run between 0.5 and 3 s, and the
    mean number of contacts there."""
    import mujoco
    from eomc.compiler.mjcf.model import load_mjmodel
    m = load_mjmodel(path)
    d = mujoco.MjData(m)
    steps = int(round(3.0 / m.opt.timestep))
    keep = set(rng.choice(np.arange(int(0.5 / m.opt.timestep), steps), NSTATES, replace=False).tolist())
    out, ncon = [], []
    for i in range(steps):
        mujoco.mj_step(m, d)
        if i in keep:
            out.append((d.qpos.copy(), d.qvel.copy()))
            ncon.append(d.ncon)
    return out, float(np.mean(ncon))


def main():
    import eomc
    import gymnasium
    import mujoco
    from eomc.compiler.mjcf.compare import from_mujoco, tree_of
    from eomc.compiler.mjcf.model import load_mjmodel
    folder = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets"
    os.sched_setaffinity(0, {CORE})
    rng = np.random.default_rng(33)
    rows, csv, free_build = [], [], {}
    with tempfile.TemporaryDirectory(prefix="bench_mjcf_contact_") as tmpname:
        tmp = Path(tmpname)
        here = os.getcwd()
        os.chdir(tmp)
        mjd = _mujoco_dir()
        (tmp / "mj.c").write_text(MUJOCO_HARNESS)
        _run(["gcc", "-O2", "-std=c99", str(tmp / "mj.c"), f"-I{mjd / 'include'}", str(next(mjd.glob("libmujoco.so*"))),
              f"-Wl,-rpath,{mjd}", "-lm", "-o", str(tmp / "mj_forward")])
        for stem, label, pairs, mode in MODELS:
            if ONLY and stem != ONLY:
                continue
            path = folder / f"{stem}.xml"
            tag = stem + ("_pairs" if pairs else "") + (f"_{mode}" if mode else "")
            wall, cpu = cold_build(path, tag, True, tmp, pairs, mode)
            if pairs:
                (tmp / f"out_{tag}_free").symlink_to(tmp / f"out_{stem}_free")
                wall0, cpu0 = free_build[stem]
                stem = tag
            else:
                wall0, cpu0 = cold_build(path, f"{stem}_free", False, tmp)
                free_build[stem] = wall0, cpu0
            model = eomc.load(tmp / f"out_{stem}")
            free = eomc.load(tmp / f"out_{stem}_free")
            points = sum(1 for k in model.output_names if k.startswith("depth_"))
            m = load_mjmodel(path)
            built = tree_of(m, model)
            states, ncon = contact_states(path, rng)
            X, QV = [], []
            for qpos, qvel in states:
                q, u = from_mujoco(m, built, qpos, qvel)
                X.append(np.concatenate([q, u]))
                QV.extend((qpos, qvel))
            _write(tmp / f"{stem}.eomc", X, head=model.param_defaults)
            _write(tmp / f"{stem}_free.eomc", X, head=free.param_defaults)
            _write(tmp / f"{stem}.mj", QV)
            exe = eomc_harness(model, tmp / f"out_{stem}", tmp)
            exe0 = eomc_harness(free, tmp / f"out_{stem}_free", tmp)
            times = {"eomc": [], "free": [], "mujoco": []}
            for _ in range(REPEAT):
                for who, cmd in (("eomc", [str(exe), str(tmp / f"{stem}.eomc"), str(NSTATES), str(NCALLS)]),
                                 ("free", [str(exe0), str(tmp / f"{stem}_free.eomc"), str(NSTATES), str(NCALLS)]),
                                 ("mujoco", [str(tmp / "mj_forward"), str(path), str(tmp / f"{stem}.mj"),
                                             str(NSTATES), str(NCALLS)])):
                    ns, _ = _timed(cmd)
                    times[who].append(ns)
            e, f0, j = (statistics.median(times[k]) for k in ("eomc", "free", "mujoco"))
            rows.append([label, str(model.nx - model.nq), str(points), f"{ncon:.1f}", f"{wall:.2f}", f"{cpu:.2f}",
                         f"{cpu0:.2f}", f"{e:.0f}", f"{f0:.0f}", f"{e / f0:.2f}x", f"{j:.0f}", f"{j / e:.2f}x"])
            csv.append([label, model.nx - model.nq, points, ncon, wall, cpu, cpu0, e, f0, j])
            print(" | ".join(rows[-1]), flush=True)
        os.chdir(here)
    headers = ["model", "dof", "eomc contact points", "MuJoCo contacts (mean)", "build wall s", "build CPU s",
               "build CPU s (no contacts)", "eomc rhs ns", "eomc rhs ns (no contacts)", "contacts' cost",
               "mj_forward ns", "speedup vs mj_forward"]
    load = os.getloadavg()
    text = environment_header("MJCF models with the file's ground contacts: eomc rhs vs MuJoCo mj_forward "
                              "(contacts on both sides)",
                              notes=(f"load average at end {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} on a shared "
                                     f"2-core machine; pinned to core {CORE}",
                                     f"models from gymnasium {gymnasium.__version__}'s wheel; mujoco {mujoco.__version__}",
                                     f"{NSTATES} states from MuJoCo's passive run (0.5-3 s), {NCALLS} calls per run, "
                                     f"{REPEAT} interleaved repeats, medians"))
    if ONLY:
        return
    text += "\n" + format_table(headers, rows) + "\n\n" + (__doc__ or "")
    print(write_results("mjcf_contact", text, csv, ["model", "dof", "points", "mujoco_ncon", "build_wall_s",
                                                    "build_cpu_s", "build_cpu_s_free", "eomc_ns", "eomc_free_ns",
                                                    "mujoco_ns"]))


if __name__ == "__main__":
    warnings.simplefilter("ignore")
    main()
