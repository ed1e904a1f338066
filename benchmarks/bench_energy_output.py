"""Issue 29 item 1: what the generated ``energy`` output costs where it is new (gymnasium's humanoid).

Since session 16 a model with body-body pairs and joint springs gets the ``energy`` output (the
pairs' elastic energy and the springs' potential counted, compiler/tree/contacts.py), so the
runtime's energy verdict judges its runs.  Two contestants, the same file, the same default
function set of ``eomc.compile(path)``:

- ``energy``: as built now;
- ``none``: ``eomc.compiler.contact.tree.passive_contacts`` patched to False, so no ``energy``
  output: what main built before (the rest of the C is the same).

Build: CPU seconds (the child Python's user+sys and its gcc's) of a cold build in a fresh cache,
one child process per build, the contestants alternating, median of --repeat.  Per call: thread
CPU per call of NAME_outputs (the whole output vector, no dict: what simulate evaluates at each
of its output points) and per ``rhs`` (unchanged: the energy is only in the outputs), both models loaded
in one process on one core, interleaved rounds at states from a 1 s fall, medians.

Since session 17 a model with joint limits and no ground contact (a URDF arm, gymnasium's
reacher), a position servo's bias and fluid forces with no wind get it too: ``--model`` takes a
gymnasium asset name, an .xml or .urdf path, or an example-robot-data robot (ur5, panda: fixed
base, the file's limits).  Such a model had no outputs at all before, so its ``none`` row has no
outputs call ("-"); the column that matters there is ``simulate``: thread CPU of a 1 s run from
the default start with the default method (the outputs at its 1001 points and the verdict
included), interleaved, median.  Results: energy_output.md for the humanoid,
energy_output_<model>.md for the others.

    python benchmarks/bench_energy_output.py [--repeat 3] [--core 1] [--model humanoid]
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

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import environment_header, format_table, write_results  # noqa: E402

CHILD = r"""
import sys, warnings, time
warnings.simplefilter("ignore")
import eomc
from eomc.compiler.mjcf import MjcfModel
from eomc.compiler.urdf.model import UrdfModel
if sys.argv[1] == "none":
    import eomc.compiler.contact.tree as tree
    tree.passive_contacts = lambda read: False
source = UrdfModel(sys.argv[2]) if sys.argv[2].endswith(".urdf") else MjcfModel(sys.argv[2])
model = eomc.compile(source, cache_dir=sys.argv[3], progress=False)
print("ENERGY", "energy" in model.output_names, model.path if hasattr(model, "path") else "")
"""


ROBOTS = {"ur5": "ur_description/urdf/ur5_robot.urdf", "panda": "panda_description/urdf/panda.urdf"}


def asset(name):
    """A gymnasium asset's path, an example-robot-data robot's (ROBOTS), or ``name`` itself."""
    if name in ROBOTS:
        from importlib.metadata import distribution
        return Path(distribution("example-robot-data").locate_file(
            "cmeel.prefix/share/example-robot-data/robots")) / ROBOTS[name]
    if name.endswith((".xml", ".urdf")):
        return Path(name).resolve()
    import gymnasium
    return Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / f"{name}.xml"


def cold_build(kind, path, cache, core):
    """CPU seconds of one cold build (child and its compiler)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    out = subprocess.run(["taskset", "-c", str(core), sys.executable, "-c", CHILD, kind, str(path), str(cache)],
                         capture_output=True, text=True, cwd=tempfile.gettempdir())
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if out.returncode:
        raise RuntimeError(out.stderr[-2000:])
    has = "ENERGY True" in out.stdout
    assert has == (kind == "energy"), out.stdout
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def load(kind, path, cache):
    import warnings
    import eomc
    import eomc.compiler.contact.tree as tree
    from eomc.compiler.mjcf import MjcfModel
    from eomc.compiler.urdf.model import UrdfModel
    saved = tree.passive_contacts
    if kind == "none":
        tree.passive_contacts = lambda read: False
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            source = UrdfModel(path) if str(path).endswith(".urdf") else MjcfModel(path)
            return eomc.compile(source, cache_dir=cache, progress=False)
    finally:
        tree.passive_contacts = saved


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--core", type=int, default=1)
    parser.add_argument("--model", default="humanoid")
    parser.add_argument("--calls", type=int, default=2000)
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args(argv)
    os.sched_setaffinity(0, {args.core})
    path = asset(args.model)
    root = Path(tempfile.mkdtemp(prefix="bench_energy_"))
    kinds = ("energy", "none")
    build = {k: [] for k in kinds}
    for r in range(args.repeat):
        for k in (kinds if r % 2 == 0 else kinds[::-1]):
            build[k].append(cold_build(k, path, root / f"b_{k}_{r}", args.core))
            print(f"build {k} {build[k][-1]:.1f} s CPU", flush=True)
    import numpy as np
    import warnings
    models = {k: load(k, path, root / f"b_{k}_0") for k in kinds}
    m = models["energy"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run = m.simulate(m.initial_state, (0, 1.0), n_points=41)
    states = [np.array(x) for x in run.x]
    calls = {(k, f): [] for k in kinds for f in ("outputs", "rhs")}
    runs = {k: [] for k in kinds}
    for _ in range(args.rounds):
        for k in kinds:
            model = models[k]
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                t0 = time.thread_time()
                model.simulate(model.initial_state, (0, 1.0))
                runs[k].append(time.thread_time() - t0)
            for f in ("outputs", "rhs"):
                if f == "outputs" and not model.noutput:
                    continue
                fun = ((lambda t, x, _m=model: _m._vector_call("outputs", _m.noutput, t, x, None, None))
                       if f == "outputs" else (lambda t, x, _m=model: _m.rhs(t, x)))
                fun(0.0, states[0])
                t0 = time.thread_time()
                n = 0
                while n < args.calls:
                    for x in states:
                        fun(0.0, x)
                    n += len(states)
                calls[(k, f)].append((time.thread_time() - t0) / n)
    med = {key: statistics.median(v) for key, v in calls.items() if v}
    bmed = {k: statistics.median(v) for k, v in build.items()}
    rmed = {k: statistics.median(v) for k, v in runs.items()}
    us = lambda key: f"{med[key] * 1e6:.2f}" if key in med else "-"     # noqa: E731
    rows = [[k, f"{bmed[k]:.1f}", us((k, 'outputs')), f"{med[(k, 'rhs')] * 1e6:.2f}", f"{rmed[k] * 1e3:.2f}"]
            for k in kinds]
    rows.append(["energy / none", f"{bmed['energy'] / bmed['none']:.3f}",
                 f"{med[('energy', 'outputs')] / med[('none', 'outputs')]:.3f}" if ("none", "outputs") in med
                 else "-",
                 f"{med[('energy', 'rhs')] / med[('none', 'rhs')]:.3f}", f"{rmed['energy'] / rmed['none']:.3f}"])
    table = format_table(["contestant", "build CPU s (median)", "outputs µs/call", "rhs µs/call",
                          "simulate 1 s ms/run"], rows)
    what = args.model if args.model in ROBOTS or args.model.endswith((".xml", ".urdf")) else f"gymnasium {args.model}"
    text = (environment_header(f"The energy output's cost on {what}", args,
                               notes=[f"builds: {args.repeat} per contestant, cold, alternating; per call: "
                                      f"{args.rounds} interleaved rounds of >= {args.calls} calls at 41 states "
                                      f"of a 1 s fall, thread CPU, pinned to core {args.core}",
                                      "raw builds: " + "; ".join(f"{k} " + ", ".join(f"{v:.1f}" for v in build[k])
                                                                 for k in kinds)])
            + "\n" + table + "\n")
    print(text)
    if not args.no_write:
        stem = Path(args.model).stem if args.model.endswith((".xml", ".urdf")) else args.model
        write_results("energy_output" if stem == "humanoid" else f"energy_output_{stem}", text, keep_notes=True)


if __name__ == "__main__":
    main()
