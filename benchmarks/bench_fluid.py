"""Issue 33 item 3: MuJoCo's fluid models -- eomc's rhs beside mj_forward, per fluid model.

Models: gymnasium's swimmer as it is (the inertia-box model on its three bodies), the same file
with ``fluidshape="ellipsoid"`` on its geoms (the ellipsoid model on each capsule, MuJoCo's
default fluidcoef), and the mixed model of tests/compiler/mjcf/test_mjcf_fluid.py (MIXED: a free
hull with two asking geoms and one not, a box-model fin, an ellipsoid-model tip, a millimetre
mote); each also without its fluid (density = viscosity = 0 in the file) for what the fluid costs.

- build: a fresh Python process runs ``eomc.compile(MjcfModel(path, limits=False, geoms=False))``
  for rhs into an empty cache (benchmarks/bench_mjcf.cold_build); wall time in the child, CPU
  its user+sys including gcc.
- error: max over 20 random states of |qacc_eomc - qacc_mujoco| / max(1, |qacc|)
  (bench_mjcf.max_error; MuJoCo with contacts, constraints and limits off).
- ns per call, each in its own C harness timed with CLOCK_THREAD_CPUTIME_ID over the same
  NSTATES random states, the two harnesses interleaved repeat by repeat, pinned to core 0:
  eomc's NAME_rhs (gcc -O2) and MuJoCo's mj_forward (libmujoco of the wheel), as bench_mjcf.
Usage: python benchmarks/bench_fluid.py
"""
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "compiler" / "mjcf"))

from common import environment_header, format_table, write_results  # noqa: E402
from bench_mjcf import NCALLS, NSTATES, REPEAT, build_mj_forward, measure  # noqa: E402

CORE = 0


def model_files(tmp):
    """[(name, fluid model, path)] with and without the fluid."""
    import gymnasium
    from test_mjcf_fluid import MIXED
    swimmer = (Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / "swimmer.xml").read_text()
    ellipsoid = swimmer.replace('<geom conaffinity="0"', '<geom fluidshape="ellipsoid" conaffinity="0"')
    texts = [("swimmer", "inertia box", swimmer), ("swimmer_ellipsoid", "ellipsoid", ellipsoid),
             ("mixed", "both", MIXED)]
    out = []
    for name, kind, text in texts:
        for suffix, body in (("", text), ("_dry", _no_fluid(text))):
            path = tmp / f"{name}{suffix}.xml"
            path.write_text(body)
            out.append((name + suffix, kind if not suffix else "none", path))
    return out


def _no_fluid(text):
    """The file with its <option>'s density and viscosity at 0 (geoms' own density kept)."""
    import re
    option = re.search(r"<option[^>]*>", text).group(0)
    bare = re.sub(r'\s(density|viscosity)="[^"]*"', "", option)
    return text.replace(option, bare)


def main():
    import gymnasium
    import mujoco
    os.sched_setaffinity(0, {CORE})
    rng = np.random.default_rng(33)
    rows, csv, times_of = [], [], {}
    with tempfile.TemporaryDirectory(prefix="bench_fluid_") as tmpname:
        tmp = Path(tmpname)
        here = os.getcwd()
        os.chdir(tmp)
        build_mj_forward(tmp)
        for name, kind, path in model_files(tmp):
            r = measure(path, name, (), tmp, rng)
            nv, wall, cpu, err, e, j = r["nv"], r["wall"], r["cpu"], r["err"], r["eomc"], r["mujoco"]
            times_of[name] = (e, j)
            rows.append([name, kind, str(nv), f"{wall:.2f}", f"{cpu:.2f}", f"{err:.1e}", f"{e:.0f}",
                         f"{j:.0f}", f"{j / e:.2f}x"])
            csv.append([name, kind, nv, wall, cpu, err, e, j])
            print(" | ".join(rows[-1]), flush=True)
        os.chdir(here)
    for row in rows:        # what the fluid adds to each, from the dry build's times in this run
        dry = times_of.get(row[0] + "_dry")
        if dry:
            e, j = times_of[row[0]]
            row.append(f"+{e - dry[0]:.0f} / +{j - dry[1]:.0f}")
        else:
            row.append("-")
    headers = ["model", "fluid model", "dof", "build wall s", "build CPU s", "max rel err", "eomc rhs ns",
               "mj_forward ns", "mj_forward / rhs", "fluid's cost ns (eomc / MuJoCo)"]
    load = os.getloadavg()
    text = environment_header("MuJoCo's fluid models: eomc rhs vs mj_forward",
                              notes=(f"load average at end {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} on a shared "
                                     f"2-core machine; pinned to core {CORE}",
                                     f"swimmer from gymnasium {gymnasium.__version__}'s wheel; mujoco "
                                     f"{mujoco.__version__}",
                                     f"{NSTATES} states, {NCALLS} calls per run, {REPEAT} interleaved repeats, medians"))
    text += "\n" + format_table(headers, rows) + "\n\n" + (__doc__ or "")
    print(write_results("fluid", text, csv, ["model", "fluid_model", "dof", "build_wall_s", "build_cpu_s",
                                             "max_rel_err", "eomc_ns", "mujoco_ns"], keep_notes=True))


if __name__ == "__main__":
    main()
