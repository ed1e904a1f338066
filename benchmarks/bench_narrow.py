"""Issue 33: the body–body pairs' narrow phase as called C routines vs inlined as SymPy.

Per model with body–body pairs (gymnasium's humanoid with its self-collisions, ``pairs=True``;
dm_control's finger, stacker, manipulator, quadruped with no flags), and gymnasium's hopper and ant
(ground contacts only: the two builds' C differ only by the generator switch, a check that the
broad phase's changes cost nothing there):

- build: a fresh Python process runs ``eomc.compile`` with the default functions into an empty
  cache, once with the schemes inlined (``pairs.INLINE_NARROW = True``: the default) and once
  with the routines (compiler/contact/narrow.py, ``INLINE_NARROW = False``); CPU seconds of
  the child and its compiler (user + sys), and the C file's size;
- rhs and jac_x: ns per call over the same NSTATES states (the model's initial state with random
  speeds and small random coordinate offsets), thread CPU time of ``rhs_many`` (one call per
  state) and of ``jac_x`` state by state, pinned to one core, the two builds interleaved repeat
  by repeat, medians of REPEAT;
- mj_forward: MuJoCo's ns per call on the same file (its contacts and collisions) at NSTATES states
  of its own (qpos0 moved by the same scales, random speeds), interleaved with the two builds.

    python benchmarks/bench_narrow.py [-k stacker]
"""
import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import environment_header, format_table, write_results  # noqa: E402

NSTATES, REPEAT, CORE = 50, 7, 1
BUILD = r"""
import sys, warnings
from pathlib import Path
import eomc
import eomc.compiler.contact.pairs as pairs
from eomc.compiler.mjcf.model import MjcfModel
path, cache, inline, self_pairs = Path(sys.argv[1]), sys.argv[2], sys.argv[3] == "1", sys.argv[4] == "1"
pairs.INLINE_NARROW = inline
pairs.PAIR_TABLE = False       # the table is the default since session 11; this compares the other two
warnings.simplefilter("ignore")
eomc.compile(MjcfModel(path, pairs=True if self_pairs else "trees"), "m", cache_dir=cache, progress=False)
"""


def models():
    import dm_control
    import gymnasium
    gym = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets"
    suite = Path(dm_control.__file__).parent / "suite"
    return [(f"{n} (dm_control)", suite / f"{n}.xml", False) for n in ("finger", "stacker", "manipulator", "quadruped")] + [
        ("humanoid (gymnasium), pairs=True", gym / "humanoid.xml", True)] + [
        (f"{n} (gymnasium)", gym / f"{n}.xml", False) for n in ("hopper", "ant")]


def build(path, cache, inline, self_pairs):
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(["taskset", "-c", str(CORE), sys.executable, "-c", BUILD, str(path), str(cache),
                    "1" if inline else "0", "1" if self_pairs else "0"], check=True, capture_output=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    source = max(Path(cache).rglob("m.c"), key=lambda p: p.stat().st_mtime)
    return cpu, source.stat().st_size


def load(path, cache, inline, self_pairs):
    import warnings
    import eomc
    import eomc.compiler.contact.pairs as pairs
    from eomc.compiler.mjcf.model import MjcfModel
    pairs.INLINE_NARROW = inline
    pairs.PAIR_TABLE = False
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return eomc.compile(MjcfModel(path, pairs=True if self_pairs else "trees"), "m", cache_dir=cache,
                            progress=False)


def mujoco_forward(path, n):
    """A function running MuJoCo's mj_forward at ``n`` states (the file's qpos0 with random speeds and
    small coordinate offsets, in MuJoCo's own coordinates; the file's contacts and collisions)."""
    import mujoco
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    rng = np.random.default_rng(33)
    states = []
    for _ in range(n):
        qpos = m.qpos0.copy()
        dq = rng.normal(scale=0.02, size=m.nv)
        mujoco.mj_integratePos(m, qpos, dq, 1.0)
        states.append((qpos, rng.normal(scale=0.5, size=m.nv)))

    def run():
        for qpos, qvel in states:
            d.qpos[:] = qpos
            d.qvel[:] = qvel
            mujoco.mj_forward(m, d)
    return run


def timed(fn):
    t0 = time.thread_time_ns()
    fn()
    return time.thread_time_ns() - t0


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-k", action="append", default=[])
    args = parser.parse_args()
    os.sched_setaffinity(0, {CORE})
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench_narrow_") as tmp:
        for label, path, self_pairs in models():
            if args.k and not any(k in label for k in args.k):
                continue
            built, loaded = {}, {}
            for inline in (True, False):
                cache = Path(tmp) / f"{label.split()[0]}_{int(inline)}"
                built[inline] = build(path, cache, inline, self_pairs)
                loaded[inline] = load(path, cache, inline, self_pairs)
            m = loaded[False]
            rng = np.random.default_rng(33)
            X = np.tile(np.asarray(m.initial_state, dtype=float), (NSTATES, 1))
            X[:, :m.nq] += rng.normal(scale=0.02, size=(NSTATES, m.nq))
            X[:, m.nq:m.nq + m.nu] = rng.normal(scale=0.5, size=(NSTATES, m.nu))
            agree = max(np.abs(loaded[True].rhs_many(0.0, X) - m.rhs_many(0.0, X)).max()
                        / (1 + np.abs(m.rhs_many(0.0, X)).max()), 0.0)
            forward = mujoco_forward(path, NSTATES)
            rhs, jac, mj = {True: [], False: []}, {True: [], False: []}, []
            for _ in range(REPEAT):
                for inline in (True, False):
                    mod = loaded[inline]
                    rhs[inline].append(timed(lambda: [mod.rhs_many(0.0, X) for _ in range(20)]) / (20 * NSTATES))
                    jac[inline].append(timed(lambda: [mod.jac_x(0.0, x) for x in X]) / NSTATES)
                mj.append(timed(lambda: [forward() for _ in range(20)]) / (20 * NSTATES))
            r = {k: statistics.median(v) for k, v in rhs.items()}
            j = {k: statistics.median(v) for k, v in jac.items()}
            f = statistics.median(mj)
            row = [label, f"{built[True][0]:.1f}", f"{built[False][0]:.1f}", f"{built[True][0] / built[False][0]:.2f}",
                   f"{built[True][1] / 1e6:.2f}", f"{built[False][1] / 1e6:.2f}", f"{r[True]:.0f}", f"{r[False]:.0f}",
                   f"{r[True] / r[False]:.2f}", f"{f:.0f}", f"{f / r[True]:.2f}", f"{f / r[False]:.2f}",
                   f"{j[True]:.0f}", f"{j[False]:.0f}", f"{j[True] / j[False]:.2f}", f"{agree:.1e}"]
            print(row, flush=True)
            rows.append(row)
            _write(rows, args)
    _write(rows, args)


def _write(rows, args):
    columns = ["model", "build CPU s inlined", "build CPU s routines", "ratio", "C MB inlined", "C MB routines",
               "rhs ns inlined", "rhs ns routines", "ratio", "mj_forward ns", "mj_forward / rhs inlined",
               "mj_forward / rhs routines", "jac_x ns inlined", "jac_x ns routines", "ratio", "rhs rel. diff"]
    table = format_table(columns, rows)
    header = environment_header("Body–body pairs' narrow phase: called routines vs inlined schemes (build, rhs, jac_x)")
    write_results("narrow", header + "\n" + table + "\n\n" + __doc__, keep_notes=True)


if __name__ == "__main__":
    main()
