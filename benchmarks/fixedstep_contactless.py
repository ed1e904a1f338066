"""The fixed step on robots without contacts: the default build (the whole jac_x) against NAME_implicit.

    python benchmarks/fixedstep_contactless.py                      # the arms and hands below
    python benchmarks/fixedstep_contactless.py ur10_robot.urdf z1.urdf --no-write

Why: a tree without contacts builds NAME_implicit only on request (session 53); without it
``method="implicitfast"`` linearises with the whole ``jac_x``.  Should it be the default?  This
says what each costs and gives, per example-robot-data URDF (fixed base, its joint limits,
damping and friction):

- build CPU s of each (a child process and a fresh cache each: user + sys of the child and gcc);
- ``eomc.rollout`` of 16 rows x 1 s at 1 ms, one thread, from the file's start with every speed
  uniform in +-0.5 (seed 0, rollout_sweep.starts): the rows' statuses and the call's process CPU
  (its second call: the first does the model's one-time work);
- the error at t = 1, max |x - reference| over rows 0, 5 and 11 where both ran clean, the
  reference Radau at rtol 1e-10, atol 1e-12.

Nothing here is a speed contest with a peer (MuJoCo has no URDF loader for these without
conversion, and its Euler step is bench_fixedstep's subject): it is the choice between eomc's two
fixed steps, so it is measured within eomc alone.
"""
import argparse
import resource
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import environment_header, format_table, write_results  # noqa: E402
from rollout_sweep import starts  # noqa: E402

FILES = ("ur5_robot.urdf", "ur10_robot.urdf", "panda.urdf", "z1.urdf", "kinova.urdf", "so101.urdf",
         "xarm7.urdf", "talos_left_arm.urdf", "allegro_left_hand.urdf", "double_pendulum.urdf",
         "tiago.urdf", "talos_full_v2.urdf")
ROWS, DT, T = 16, 0.001, 1.0
REFERENCE_ROWS = (0, 5, 11)

BUILD = r"""
import sys, warnings, eomc
from eomc.compiler.emit.signatures import FUNCTION_ORDER, ON_REQUEST
fns = None if sys.argv[2] == "default" else tuple(f for f in FUNCTION_ORDER if f not in ON_REQUEST)
with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    eomc.compile(sys.argv[1], cache_dir=sys.argv[3], functions=fns, progress=False)
"""


def urdf(name):
    from importlib.metadata import distribution
    root = Path(distribution("example-robot-data").locate_file("cmeel.prefix/share/example-robot-data/robots"))
    found = sorted(root.rglob(name))
    if not found:
        raise SystemExit(f"{name}: not in example-robot-data")
    return found[0]


def build_cpu(path, which):
    """CPU s of a fresh build (child process, fresh cache) with the default functions or with implicit."""
    with tempfile.TemporaryDirectory() as d:
        r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        subprocess.run([sys.executable, "-c", BUILD, str(path), which, d], check=True, capture_output=True)
        r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r1.ru_utime + r1.ru_stime - r0.ru_utime - r0.ru_stime


def one_file(path, cache):
    import eomc
    from eomc.compiler.emit.signatures import FUNCTION_ORDER, ON_REQUEST
    default = tuple(f for f in FUNCTION_ORDER if f not in ON_REQUEST)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        models = {"default": eomc.compile(str(path), cache_dir=cache, progress=False),
                  "implicit": eomc.compile(str(path), cache_dir=cache, functions=default, progress=False)}
    X0 = starts(models["default"], ROWS)
    refs = {}
    for i in REFERENCE_ROWS:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            refs[i] = models["default"].simulate(X0[i], (0, T), method="radau", rtol=1e-10, atol=1e-12,
                                                 raise_on_failure=False)
    row = [path.name, models["default"].nx]
    for which, m in models.items():
        kw = dict(steps=int(round(T / DT)), dt=DT, threads=1, raise_on_failure=False)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            eomc.rollout(m, X0, **kw)
            t0 = time.process_time()
            r = eomc.rollout(m, X0, **kw)
            cpu = time.process_time() - t0
        errs = [float(np.abs(r.x[i] - refs[i].x_final).max()) for i in refs
                if r.status[i] == 0 and refs[i].status == 0]
        statuses = ", ".join(f"{c} x {v}" for v, c in zip(*np.unique(r.status, return_counts=True)))
        row += [f"{build_cpu(path, which):.1f}", statuses, f"{cpu:.3f}", f"{max(errs):.2g}" if errs else "-"]
    return row


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("files", nargs="*", default=FILES, help="URDF file names in example-robot-data")
    parser.add_argument("--cache-dir", help="the rollouts' build cache (default: a fresh temporary one)")
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args()
    cache = args.cache_dir or tempfile.mkdtemp(prefix="eomc_contactless_")
    rows = []
    for name in args.files:
        rows.append(one_file(urdf(name), cache))
        print(" | ".join(map(str, rows[-1])), flush=True)
    header = ["URDF", "nx"] + [f"{which}: {what}" for which in ("default (jac_x)", "with implicit")
                               for what in ("build CPU s", f"statuses ({ROWS} rows)", "rollout CPU s", "error at t = 1")]
    text = "\n".join([
        environment_header("The fixed step on robots without contacts: the default build (jac_x) against NAME_implicit",
                           args=True),
        f"- {ROWS} rows x {T:g} s at {DT:g} s, one thread; starts: the file's start, every speed uniform in +-0.5 "
        f"(seed 0); error: max |x - Radau(1e-10)| at t = {T:g} over rows {', '.join(map(str, REFERENCE_ROWS))} "
        "where both ran clean; status 20: the energy verdict (energy created in a passive model)",
        "", format_table(header, rows), ""])
    print(text)
    if not args.no_write:
        write_results("fixedstep_contactless", text, keep_notes=True)


if __name__ == "__main__":
    main()
