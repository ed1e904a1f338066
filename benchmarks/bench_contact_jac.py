"""jac_x of contact models: the analytic kernel with its ground-contact terms against the unrolled
tangent it replaces (issue 29/30), same run.

    taskset -c 1 python benchmarks/bench_contact_jac.py [--models ant,hopper,solo12,go2] [--repeat 7] [--no-write]

Per model two cold builds in fresh caches, the model's default functions: "analytic" (this
checkout: compiler/tree/analytic.py takes ground contacts, block G) and "tangent" (the same
checkout with the analytic plan refused the contacts, as before: jac_x differentiates the rhs
trace column by column, unrolled).  Models: gymnasium's ant and hopper (contacts from the file,
as benchmarks/bench_fixedstep.py), Solo12 as bench_contact_wp.py builds it (examples/
quadruped_stand.py: four foot spheres plus the URDF's default ground), Go2 with its four feet
and the default ground (bench_default_ground.py's).  The hopper has 12 states, where jac_x keeps
the unrolled columns (symbolic.TANGENT_MIN_STATES), so its "analytic" row is forced.

States: 400 along the model's own 1 s run (eomc's default method from the benchmarks' start:
the gym qpos0, Solo12's stance, Go2's default start), touch-downs and stance included -- what
an implicit integrator evaluates.  Columns: build CPU s (generation and C compile, this
process's and its children's), jac_x and rhs µs per call (Python call included, about 0.5 µs,
thread CPU time, blocks interleaved, medians of --repeat), and the largest difference of the
two jac_x over the states relative to the largest entry.
"""
import argparse
import resource
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "examples"))
from common import environment_header, format_table, pin_to_one_core, write_results  # noqa: E402


def cpu():
    a, b = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return a.ru_utime + a.ru_stime + b.ru_utime + b.ru_stime


def source(name):
    """(what eomc.compile takes, its keyword arguments, start state function)."""
    if name in ("ant", "hopper"):
        import mujoco
        import bench_fixedstep as fs
        from eomc.compiler.mjcf.model import MjcfModel
        base = mujoco.MjModel.from_xml_path(str(fs.gym_xml(name)))
        return MjcfModel(fs.gym_xml(name)), {}, lambda m: fs.eomc_start(m, base)
    from eomc.compiler.urdf.model import UrdfModel
    if name == "solo12":
        import quadruped_stand as qs
        feet = [dict(link=f"{leg}_FOOT", radius=qs.FOOT_RADIUS, vs=qs.VS) for leg in qs.LEGS]
        return (UrdfModel(qs.solo12_path(), floating_base=True),
                dict(contacts=feet, functions=("rhs", "jac_x", "jac_r", "outputs", "events")),
                lambda m: qs.stance(m)[0])
    import bench_default_ground as dg
    rel, feet = dg.FEET[name]

    def start(m):
        from eomc.cli.common import initial_state
        x0 = initial_state(m, {})
        return np.array([x0[s] for s in m.state_names])
    return UrdfModel(dg.ROBOTS / rel, floating_base=True, contacts=tuple(feet)), {}, start


def build(name, mode, cache):
    import eomc
    from eomc.compiler.tree import analytic as an
    from eomc.compiler.tree import lower
    src, kw, start = source(name)
    plan, threshold = an.analytic_plan, lower.TANGENT_MIN_STATES
    if mode == "tangent":
        an.analytic_plan = lambda *a: plan(*a[:5], None)
    elif name == "hopper":
        lower.TANGENT_MIN_STATES = 0
    c0 = cpu()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = eomc.compile(src, name=f"cj_{name}_{mode}", cache_dir=cache, progress=False, **kw)
    finally:
        an.analytic_plan, lower.TANGENT_MIN_STATES = plan, threshold
    return model, cpu() - c0, start


def per_call(fn, X):
    fn(0.0, X[0])
    t0 = time.thread_time()
    for x in X:
        fn(0.0, x)
    return (time.thread_time() - t0) / len(X) * 1e6


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", default="ant,hopper,solo12,go2")
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--n", type=int, default=400)
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args()
    core = pin_to_one_core()
    rows = []
    for name in args.models.split(","):
        with tempfile.TemporaryDirectory() as tmp:
            fast, b_fast, start = build(name, "analytic", Path(tmp) / "a")
            slow, b_slow, _ = build(name, "tangent", Path(tmp) / "t")
            assert "_rnea_derivs(" in fast.source_path.read_text()
            assert "_rnea_derivs(" not in slow.source_path.read_text()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                res = fast.simulate(start(fast), (0.0, 1.0))
            xs = np.asarray(res.x)
            X = xs[np.linspace(0, len(xs) - 1, args.n).round().astype(int)]
            diff = max(np.max(np.abs(fast.jac_x(0.0, x) - slow.jac_x(0.0, x)))
                       / max(1.0, np.max(np.abs(slow.jac_x(0.0, x)))) for x in X)
            t = {"fast": [], "slow": [], "rhs": []}
            for _ in range(args.repeat):
                t["fast"].append(per_call(fast.jac_x, X))
                t["slow"].append(per_call(slow.jac_x, X))
                t["rhs"].append(per_call(fast.rhs, X))
            med = {k: float(np.median(v)) for k, v in t.items()}
            rows.append([name, fast.nx, f"{b_slow:.1f}", f"{b_fast:.1f}", f"{med['slow']:.2f}", f"{med['fast']:.2f}",
                         f"{med['slow'] / med['fast']:.2f}", f"{med['rhs']:.2f}",
                         f"{med['fast'] / med['rhs']:.1f}", f"{diff:.1e}"])
            print(rows[-1], flush=True)
    headers = ["model", "states", "build CPU s (tangent)", "build CPU s (analytic)", "jac_x µs (tangent)",
               "jac_x µs (analytic)", "tangent / analytic", "rhs µs", "analytic jac_x / rhs",
               "max |J_an - J_tg| / max |J|"]
    table = format_table(headers, rows)
    print(table)
    if not args.no_write:
        head = environment_header("jac_x of contact models: analytic kernel with ground-contact terms vs the unrolled tangent",
                                  args, notes=[f"pinned to core {core}"])
        write_results("contact_jac", head + "\n" + __doc__.split("\n\n", 1)[1] + "\n\n" + table + "\n")


if __name__ == "__main__":
    main()
