"""NAME_implicit's mass matrix by the form compiler/tree/crba.py chooses (implicit_mass_matrix: the
world form where it has fewer operations) against the body-frame CRBA it used before, in the
fixed step's own loop.

    python benchmarks/bench_world_crba.py [--models hopper,walker2d,ant,humanoid] [--robots g1]
        [--rounds 21] [--no-write]

Each model is built twice in one process -- as the compiler builds it, and with M from the
body-frame CRBA (lower.implicit_mass_matrix replaced) -- and both builds' implicitfast runs
(bench_fixedstep's: the gymnasium models from qpos0 at their MJCF timestep, G1 collapsing onto its
feet at 2 ms; 1 simulated second, events off) alternate round by round in the same process,
pinned to one core (taskset by the caller), thread CPU per simulated second, medians.  Also
printed: the operations each form's M entries read beyond the screws (the count the choice
makes), the form chosen, and the largest difference of the two builds' end states.
"""
import argparse
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_fixedstep import cpu_block, eomc_call, eomc_model, eomc_start, gym_xml, urdf_robot  # noqa: E402
from common import environment_header, pin_to_one_core, write_results  # noqa: E402


def forms():
    """(the compiler's choice with its counts recorded, the body-frame form)."""
    import eomc.compiler.tree.crba as crba_module
    seen = {}
    chosen = crba_module.implicit_mass_matrix

    def counting(bodies, rec, poses, screws):
        seen["counts"] = crba_module.form_operations(bodies, rec, poses, screws)
        return chosen(bodies, rec, poses, screws)
    return seen, counting, lambda bodies, rec, poses, screws: crba_module.crba(bodies, rec)


def run(name, rounds, tmp):
    import mujoco
    import eomc.compiler.tree.lower as lower
    seen, chosen, body = forms()
    shipped = lower.implicit_mass_matrix
    runs = {}
    try:
        for tag, form in (("chosen", chosen), ("body", body)):
            lower.implicit_mass_matrix = form
            if name in ("go2", "g1"):
                model, x0 = urdf_robot(name, tmp / tag)
                dt = 0.002
            else:
                base = mujoco.MjModel.from_xml_path(str(gym_xml(name)))
                model = eomc_model(name, tmp / tag)
                x0, dt = eomc_start(model, base), float(base.opt.timestep)
            call, x_last, stats = eomc_call(model, x0, dt)
            call()
            runs[tag] = (call, x_last.copy(), stats.nfev, model.nu)
    finally:
        lower.implicit_mass_matrix = shipped
    samples = {tag: [] for tag in runs}
    for r in range(rounds):
        for tag in (("chosen", "body") if r % 2 == 0 else ("body", "chosen")):
            samples[tag].append(cpu_block(runs[tag][0], 0.05))
    c, b = (float(np.median(samples[t])) for t in ("chosen", "body"))
    ops = seen.get("counts", [0, 0])
    form = "world" if ops[1] < ops[0] else "body"
    diff = float(np.max(np.abs(runs["chosen"][1] - runs["body"][1])))
    return (name, runs["chosen"][3], ops[0], ops[1], form, runs["body"][2], runs["chosen"][2], b * 1e3, c * 1e3,
            b / c, diff)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", default="hopper,walker2d,ant,humanoid")
    parser.add_argument("--robots", default="g1")
    parser.add_argument("--rounds", type=int, default=21)
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args(argv)
    pin_to_one_core()
    rows = []
    with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name in [m for m in (args.models + "," + args.robots).split(",") if m]:
            rows.append(run(name, args.rounds, Path(tmp) / name))
            print(rows[-1], flush=True)
    table = ["| model | speeds | M's operations, body-frame | world | form chosen | calls body / chosen "
             "| body-frame CRBA, ms per simulated s | chosen, ms | ratio | end states' max difference |",
             "|---|--:|--:|--:|---|--:|--:|--:|--:|--:|"]
    table += [f"| {n} | {nu} | {ob} | {ow} | {f} | {cb} / {cc} | {b:.3f} | {c:.3f} | {r:.3f}x | {d:.1e} |"
              for n, nu, ob, ow, f, cb, cc, b, c, r, d in rows]
    text = "\n".join(table)
    print(text)
    if not args.no_write:
        write_results("world_crba", environment_header("NAME_implicit's mass matrix: the form chosen against "
                                                       "the body-frame CRBA, in the fixed step's loop", args)
                      + "\n" + text + "\n", keep_notes=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
