"""Box–box law of session 19 vs session 18's on dm_control's stacker: build, rhs/jac_x in contact, runs.

Session 19 (pairs._box_box): each box's 44 sample points against the other box's exact signed
distance (88 points a pair, conservative: counted in the energy).  Session 18: each box's 8 corners
past the face the separating-axis test picked, gated by the corner's foot lying on it (16 points,
not conservative).  The old law is patched in from commit OLD (git show) for the "old" build.

- build: a fresh child process pinned to core 1 runs ``eomc.compile(stacker.xml)`` into an empty
  cache; CPU seconds (user + sys, child and compiler) and the C file's size;
- rhs and jac_x: ns per call at NSTATES stacked states (box1 on box0, box2 on box1, box3 on the
  floor, small random heights, turns and speeds), thread CPU time pinned to core 1, the two builds
  and MuJoCo's mj_forward (the same states mapped by compare.to_mujoco) interleaved, medians of REPEAT;
  also with the boxes near but apart (the broad phase passes, no point pressed) and far apart;
- runs: from one stacked start, 2 s with the default method and implicitfast at the file's step;
  the boxes' heights at 2 s beside mj_step's.

    python benchmarks/bench_box_box.py          # writes benchmarks/results/box_box.md
"""
import ast
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import environment_header, format_table, write_results  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
OLD = "64d076da"                 # main before session 19's box–box law
NSTATES, REPEAT, CORE = 50, 7, 1


def stacker():
    import dm_control
    return Path(dm_control.__file__).parent / "suite" / "stacker.xml"


def patch_old_law():
    """Session 18's BOX_GATE, _box_box, pair_parts and counted_kinds into eomc's pairs module."""
    import eomc.compiler.contact.pairs as P
    src = subprocess.run(["git", "-C", str(ROOT), "show", f"{OLD}:compiler/contact/pairs.py"],
                         check=True, capture_output=True, text=True).stdout
    keep = []
    for node in ast.parse(src).body:
        name = getattr(node, "name", None) or (node.targets[0].id if isinstance(node, ast.Assign)
                                               and isinstance(node.targets[0], ast.Name) else None)
        if name in ("BOX_GATE", "_box_box", "pair_parts", "counted_kinds"):
            keep.append(ast.get_source_segment(src, node))
    exec("\n\n".join(keep), P.__dict__)
    assert len(P.pair_parts("box", "box")) == 16


def child(variant, cache):
    if variant == "old":
        patch_old_law()
    import eomc
    warnings.simplefilter("ignore")
    eomc.compile(stacker(), "m", cache_dir=cache, progress=False)


def build(variant, cache):
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(["taskset", "-c", str(CORE), sys.executable, __file__, "--child", variant, str(cache)], check=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    c = max(Path(cache).rglob("m.c"), key=lambda p: p.stat().st_mtime)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), c.stat().st_size


def load(cache):
    import eomc
    j = max(Path(cache).rglob("m.json"), key=lambda p: p.stat().st_mtime)
    return eomc.load(j.parent, "m")


def stacked_states(m, n, rng):
    names = list(m.state_names)
    X = np.tile(np.asarray(m.initial_state, float), (n, 1))
    base = {"q_box0_x": 0.3, "q_box0_z": 0.022 - 2e-4, "q_box1_x": 0.305, "q_box1_z": 0.066 - 6e-4,
            "q_box2_x": 0.298, "q_box2_z": 0.110 - 1e-3, "q_box3_x": 0.1, "q_box3_z": 0.022 - 2e-4}
    for k, v in base.items():
        X[:, names.index(k)] = v + rng.uniform(-2e-4, 2e-4, n) * k.endswith("_z")
    for b in range(4):
        X[:, names.index(f"q_box{b}_y")] = rng.uniform(-0.01, 0.01, n)
    nq = sum(s.startswith("q_") for s in names)
    X[:, nq:] = rng.normal(scale=0.05, size=(n, len(names) - nq))
    return X, nq


def timed(fn):
    t0 = time.thread_time_ns()
    fn()
    return time.thread_time_ns() - t0


def main():
    import mujoco
    from eomc.compiler.mjcf.compare import to_mujoco, tree_of
    from eomc.compiler.mjcf.model import check_model, load_mjmodel
    os.sched_setaffinity(0, {CORE})
    rows, runs = [], []
    with tempfile.TemporaryDirectory(prefix="bench_box_box_") as tmp:
        built = {v: build(v, Path(tmp) / v) for v in ("old", "new")}
        ms = {v: load(Path(tmp) / v) for v in ("old", "new")}
        names = list(ms["new"].state_names)
        X, nq = stacked_states(ms["new"], NSTATES, np.random.default_rng(19))
        near, far = X.copy(), X.copy()
        for b, z in ((0, 0.023), (1, 0.073), (2, 0.123)):     # 6 mm gaps: the broad phase passes
            near[:, names.index(f"q_box{b}_z")], near[:, names.index(f"q_box{b}_x")] = z, 0.3
        for b in range(4):
            far[:, names.index(f"q_box{b}_x")], far[:, names.index(f"q_box{b}_z")] = 0.1 + 0.15 * b, 0.03
        mm = load_mjmodel(stacker())
        d = mujoco.MjData(mm)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            tree = tree_of(mm, ms["new"], actuators=check_model(mm, stacker()))   # its layout (quaternions)
        for label, S in (("stacked", X), ("near, apart", near), ("far apart", far)):
            st = [to_mujoco(mm, tree, x[:nq], x[nq:]) for x in S]

            def forward():
                for qp, qv in st:
                    d.qpos[:], d.qvel[:] = qp, qv
                    mujoco.mj_forward(mm, d)
            rhs, jac, mj = {v: [] for v in ms}, {v: [] for v in ms}, []
            for _ in range(REPEAT):
                for v, m in ms.items():
                    rhs[v].append(timed(lambda: [m.rhs_many(0.0, S) for _ in range(20)]) / (20 * NSTATES))
                    jac[v].append(timed(lambda: [m.jac_x(0.0, x) for x in S]) / NSTATES)
                mj.append(timed(lambda: [forward() for _ in range(20)]) / (20 * NSTATES))
            r = {v: statistics.median(x) for v, x in rhs.items()}
            j = {v: statistics.median(x) for v, x in jac.items()}
            f = statistics.median(mj)
            forward()
            rows.append([label, f"{built['old'][0]:.1f}", f"{built['new'][0]:.1f}", f"{built['old'][1] / 1e6:.2f}",
                         f"{built['new'][1] / 1e6:.2f}", f"{r['old']:.0f}", f"{r['new']:.0f}", f"{r['new'] / r['old']:.2f}",
                         f"{j['old']:.0f}", f"{j['new']:.0f}", f"{f:.0f}", str(d.ncon)])
            print(rows[-1], flush=True)
        x0 = X[:1].copy()
        x0[0, nq:] = 0.0
        d.qpos[:], d.qvel[:] = to_mujoco(mm, tree, x0[0, :nq], x0[0, nq:])
        while d.time < 2.0 - 1e-9:
            mujoco.mj_step(mm, d)
        mjz = "/".join(f"{d.qpos[mm.jnt_qposadr[mujoco.mj_name2id(mm, mujoco.mjtObj.mjOBJ_JOINT, f'box{b}_z')]]:.4f}"
                       for b in range(3))
        for v, m in ms.items():
            for method, kw in (("default", {}), ("implicitfast", dict(method="implicitfast", dt=float(mm.opt.timestep)))):
                w = time.perf_counter()
                with warnings.catch_warnings(record=True) as seen:
                    warnings.simplefilter("always")
                    res = m.simulate(x0[0], (0, 2.0), raise_on_failure=False, **kw)
                z = "/".join(f"{res.x[-1][names.index(f'q_box{b}_z')]:.4f}" for b in range(3))
                runs.append([v, method, str(res.status), f"{time.perf_counter() - w:.2f}", z, mjz, str(len(seen))])
                print(runs[-1], flush=True)
    header = environment_header("dm_control stacker: box–box law of session 19 vs session 18",
                                notes=(f"stacker.xml; core {CORE}; old law from {OLD}", f"load at end {os.getloadavg()}"))
    table = format_table(["states", "build CPU s old", "build CPU s new", "C MB old", "C MB new", "rhs ns old",
                          "rhs ns new", "ratio", "jac_x ns old", "jac_x ns new", "mj_forward ns", "MuJoCo ncon"], rows)
    table += "\n\n" + format_table(["law", "method", "status", "wall s", "box0/1/2 z at 2 s", "mj_step", "warnings"], runs)
    write_results("box_box", header + "\n" + table + "\n\n" + __doc__, keep_notes=True)


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        child(sys.argv[2], sys.argv[3])
    else:
        main()
