"""Issue 23 item 1: MuJoCo models (MJCF) -- build time, agreement with mj_forward, and speed against it.

Per model (the MJCF files in the gymnasium wheel, ``pip install gymnasium``; and, when
dm_control is importable or ``--dm-suite DIR`` names the ``dm_control/suite`` folder of its
wheel, dm_control's acrobot, cartpole, hopper, walker, cheetah and humanoid):

- build: a fresh Python process runs ``eomc.compile(MjcfModel(path, ignore=...))`` for rhs
  into an empty cache (MuJoCo's compile + tree + generate + gcc + load); wall time in the
  child, CPU its user+sys including gcc.
- error: max over 20 random states and controls of |qacc_eomc - qacc_mujoco| / max(1, |qacc|),
  eomc's states mapped to MuJoCo's (eomc.compiler.mjcf.compare: quaternions for free/ball
  joints, world-frame free-joint velocity), MuJoCo with contacts, constraints and limits off;
  controls drawn in [-1.5, 1.5], beyond most ctrlranges: both clamp them.  Armature is
  kept on both sides (eomc adds it to the joint-space inertia as MuJoCo does); nothing is
  ignored (gymnasium humanoid's two fixed tendons apply no force and are accepted as they are).
- ns per call, each in its own C harness timed with CLOCK_THREAD_CPUTIME_ID over the same
  NSTATES random states (each in its own coordinates), zero controls, the two harnesses
  interleaved repeat by repeat, the process pinned to one core:
    eomc    NAME_rhs (q' and u' from x), eomc's default flags (gcc -O2); harness gcc -O2
    MuJoCo  mj_forward (libmujoco from the mujoco wheel), the same flags (armature kept)
  mj_forward also runs MuJoCo's position/velocity/sensor stages and computes the
  quantities its constraint and contact stages would need; eomc's rhs also returns q'.
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

MODELS = [("gym", "inverted_pendulum", ()), ("gym", "inverted_double_pendulum", ()),
          ("gym", "hopper", ()), ("gym", "walker2d", ()), ("gym", "half_cheetah", ()), ("gym", "ant", ()),
          ("gym", "humanoid", ()),
          ("dm", "acrobot", ()), ("dm", "cartpole", ()), ("dm", "hopper", ()), ("dm", "walker", ()),
          ("dm", "cheetah", ()), ("dm", "humanoid", ())]
NSTATES, NCALLS, REPEAT = 200, 20000, 7
CORE = 1

CONTACTS_OFF = "    m->opt.disableflags |= mjDSBL_CONTACT | mjDSBL_CONSTRAINT | mjDSBL_LIMIT;\n"
MUJOCO_HARNESS = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include <mujoco/mujoco.h>
static double cpu(void) { struct timespec t; clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t); return t.tv_sec + 1e-9 * t.tv_nsec; }
int main(int argc, char **argv) {
    char err[1000];
    mjModel *m = mj_loadXML(argv[1], NULL, err, sizeof err);
    if (!m) { fprintf(stderr, "%s\n", err); return 2; }
    m->opt.disableflags |= mjDSBL_CONTACT | mjDSBL_CONSTRAINT | mjDSBL_LIMIT;
    mjData *d = mj_makeData(m);
    const int nq = m->nq, nv = m->nv, ns = atoi(argv[3]); const long nc = atol(argv[4]);
    double *Q = malloc(sizeof(double) * nq * ns), *V = malloc(sizeof(double) * nv * ns);
    FILE *f = fopen(argv[2], "rb");
    for (int k = 0; k < ns; ++k)
        if (fread(Q + k * nq, sizeof(double), nq, f) != (size_t)nq || fread(V + k * nv, sizeof(double), nv, f) != (size_t)nv) return 3;
    fclose(f);
    mju_copy(d->qpos, Q, nq); mju_copy(d->qvel, V, nv); mj_forward(m, d);
    printf("first"); for (int j = 0; j < nv; ++j) printf(" %.17g", d->qacc[j]); printf("\n");
    double sum = 0.0, t0 = cpu();
    for (long i = 0; i < nc; ++i) {
        mju_copy(d->qpos, Q + (i % ns) * nq, nq); mju_copy(d->qvel, V + (i % ns) * nv, nv);
        mj_forward(m, d); sum += d->qacc[nv - 1];
    }
    printf("ns %.3f\nchecksum %g\n", 1e9 * (cpu() - t0) / nc, sum);
    mj_deleteData(d); mj_deleteModel(m);
    return 0;
}
"""

COLD_BUILD = r"""
import sys, time, warnings
t0 = time.perf_counter()
import eomc
from pathlib import Path
from eomc.compiler.mjcf.model import MjcfModel
path, name, cache, out, ignore = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4], sys.argv[5]
warnings.simplefilter("ignore")
model = eomc.compile(MjcfModel(Path(path), ignore=tuple(x for x in ignore.split(",") if x), limits=False, geoms=False), name,
                     functions=["rhs"], cache_dir=cache, output_dir=out, progress=False)
print("wall", time.perf_counter() - t0)
"""


def cold_build(path, name, ignore, tmp):
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    proc = _run([sys.executable, "-c", COLD_BUILD, str(path), name, str(tmp / f"cache_{name}"),
                 str(tmp / f"out_{name}"), ",".join(ignore)])
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return float(proc.stdout.split()[-1]), (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def prepared_pair(path, ignore, model):
    """(MjModel as timed, MjcfTree, motor ids) -- the oracle's model and eomc's tree of it in the
    built ``model``'s state layout (compare.tree_of)."""
    import mujoco  # noqa: F401
    from eomc.compiler.mjcf.compare import prepared, tree_of
    from eomc.compiler.mjcf.model import check_model, load_mjmodel
    m = prepared(load_mjmodel(path))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        motors = check_model(m, path, ignore)
    return m, tree_of(m, model, actuators=motors), motors


def random_q(model, rng):
    """Random coordinates in [-1, 1], each quaternion (the MJCF default's) scaled to unit length."""
    q = rng.uniform(-1, 1, model.nq)
    for w in model.quaternions:
        q[w:w + 4] /= np.linalg.norm(q[w:w + 4])
    return q


def max_error(model, m, built, motors, rng, trials=20):
    import mujoco
    from eomc.compiler.mjcf.compare import qacc_of, to_mujoco
    d, nq = mujoco.MjData(m), model.nq
    worst = 0.0
    for _ in range(trials):
        q, u = random_q(model, rng), rng.uniform(-1, 1, model.nx - nq)
        r = rng.uniform(-1.5, 1.5, len(motors))
        xd = model.rhs(0.0, np.concatenate([q, u]), r=r)
        d.qpos[:], d.qvel[:] = to_mujoco(m, built, q, u)
        d.ctrl[:] = 0
        d.ctrl[motors] = r
        mujoco.mj_forward(m, d)
        worst = max(worst, np.max(np.abs(qacc_of(m, built, q, u, xd[nq:]) - d.qacc)) / max(1, np.max(np.abs(d.qacc))))
    return worst


def build_mj_forward(tmp):
    """tmp/mj_forward: the C harness that times MuJoCo's mj_forward (MUJOCO_HARNESS)."""
    mjd = _mujoco_dir()
    (tmp / "mj.c").write_text(MUJOCO_HARNESS)
    _run(["gcc", "-O2", "-std=c99", str(tmp / "mj.c"), f"-I{mjd / 'include'}", str(next(mjd.glob("libmujoco.so*"))),
          f"-Wl,-rpath,{mjd}", "-lm", "-o", str(tmp / "mj_forward")])


def measure(path, name, ignore, tmp, rng):
    """One model's figures (dict: nv, build wall and CPU s, max relative error, eomc and MuJoCo
    ns per call): a cold build, the error against mj_forward at random states and in the timed
    harnesses' first call, and the median of REPEAT interleaved runs of each harness over the
    same NSTATES states.  Needs tmp/mj_forward (:func:`build_mj_forward`).  Shared with
    bench_fluid.py."""
    import eomc
    from eomc.compiler.mjcf.compare import qacc_of, to_mujoco
    wall, cpu = cold_build(path, name, ignore, tmp)
    model = eomc.load(tmp / f"out_{name}")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m, built, motors = prepared_pair(path, ignore, model)
    err = max_error(model, m, built, motors, rng)
    nq, nv = model.nq, model.nx - model.nq
    X, QV = [], []
    for _ in range(NSTATES):
        q, u = random_q(model, rng), rng.uniform(-1, 1, nv)
        X.append(np.concatenate([q, u]))
        QV.extend(to_mujoco(m, built, q, u))
    _write(tmp / f"{name}.eomc", X, head=model.param_defaults)
    _write(tmp / f"{name}.mj", QV)
    exe = eomc_harness(model, tmp / f"out_{name}", tmp)
    times = {"eomc": [], "mujoco": []}
    firsts = {}
    for _ in range(REPEAT):
        for who, cmd in (("eomc", [str(exe), str(tmp / f"{name}.eomc"), str(NSTATES), str(NCALLS)]),
                         ("mujoco", [str(tmp / "mj_forward"), str(path), str(tmp / f"{name}.mj"),
                                     str(NSTATES), str(NCALLS)])):
            ns, first = _timed(cmd)
            times[who].append(ns)
            firsts[who] = first
    q0, u0 = X[0][:nq], X[0][nq:]
    c_err = np.max(np.abs(qacc_of(m, built, q0, u0, firsts["eomc"]) - firsts["mujoco"])) / \
        max(1, np.max(np.abs(firsts["mujoco"])))
    return dict(nv=nv, wall=wall, cpu=cpu, err=max(err, c_err), eomc=statistics.median(times["eomc"]),
                mujoco=statistics.median(times["mujoco"]))


def main():
    import gymnasium
    import mujoco
    import argparse
    parser = argparse.ArgumentParser()
    parser.add_argument("--dm-suite", help="dm_control/suite folder (default: the installed dm_control's)")
    args = parser.parse_args()
    folders = {"gym": Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets"}
    if args.dm_suite:
        folders["dm"] = Path(args.dm_suite)
    else:
        try:
            import dm_control
            folders["dm"] = Path(dm_control.__file__).parent / "suite"
        except ImportError:
            print("dm_control not installed and no --dm-suite: its models are left out")
    os.sched_setaffinity(0, {CORE})
    rng = np.random.default_rng(23)
    rows, csv = [], []
    with tempfile.TemporaryDirectory(prefix="bench_mjcf_") as tmpname:
        tmp = Path(tmpname)
        here = os.getcwd()
        os.chdir(tmp)     # libmujoco's warnings (half_cheetah's settotalmass) go to ./MUJOCO_LOG.TXT
        build_mj_forward(tmp)
        for source, stem, ignore in MODELS:
            if source not in folders:
                continue
            path, name = folders[source] / f"{stem}.xml", f"{source}_{stem}"
            r = measure(path, name, ignore, tmp, rng)
            nv, wall, cpu, err, e, j = r["nv"], r["wall"], r["cpu"], r["err"], r["eomc"], r["mujoco"]
            rows.append([name, str(nv), f"{wall:.2f}", f"{cpu:.2f}", f"{err:.1e}", f"{e:.0f}", f"{j:.0f}",
                         f"{j / e:.2f}x", ",".join(ignore) or "-"])
            csv.append([name, nv, wall, cpu, err, e, j])
            print(" | ".join(rows[-1]), flush=True)
        os.chdir(here)
    headers = ["model", "dof", "build wall s", "build CPU s", "max rel err", "eomc rhs ns", "mj_forward ns",
               "speedup", "ignored"]
    load = os.getloadavg()
    text = environment_header("MJCF models: eomc vs MuJoCo mj_forward (contacts/constraints/limits off, "
                              "armature kept)",
                              notes=(f"load average at end {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} on a shared "
                                     f"2-core machine; pinned to core {CORE}",
                                     f"models: gym_* from gymnasium {gymnasium.__version__}'s wheel, dm_* from "
                                     f"{folders.get('dm', '(not run)')} (dm_control 1.0.50 wheel); "
                                     f"mujoco {mujoco.__version__}",
                                     f"{NSTATES} states, {NCALLS} calls per run, {REPEAT} interleaved repeats, medians"))
    text += "\n" + format_table(headers, rows) + "\n\n" + (__doc__ or "")
    print(write_results("mjcf", text, csv, ["model", "dof", "build_wall_s", "build_cpu_s", "max_rel_err",
                                            "eomc_ns", "mujoco_ns"]))


if __name__ == "__main__":
    main()
