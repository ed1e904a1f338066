"""dm_control's suite with no flags: does each model build, simulate 5 s, and agree with MuJoCo?

Per model of dm_control's wheel (``dm_control/suite/*.xml``; dog and lqr are not in the
issue's list):

- build: ``eomc.compile(path)`` with no flags (the file's ground contacts, body–body pairs
  between kinematic trees, limits, tendons, couplings, activations, fluid), CPU seconds of
  this process and its compiler children, or the refusal's first line;
- simulate: 5 s from the file's initial state with no control and the default method; wall
  seconds, the number of rhs calls' output points, whether every state stayed finite, the
  root body's height at 5 s next to MuJoCo's ``mj_step`` at the file's time step (both
  passive);
- vs MuJoCo: the rhs against ``mj_forward`` at random states (limits, contacts off on both
  sides; couplings exact: ``eomc.compiler.mjcf.compare.rhs_error``), the largest relative error.

    python benchmarks/bench_dm_suite.py            # every model (humanoid_CMU's build is the long one)
    python benchmarks/bench_dm_suite.py -k hopper -k walker
"""
import argparse
import resource
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import environment_header, format_table, write_results  # noqa: E402

MODELS = ["acrobot", "ball_in_cup", "cartpole", "cheetah", "finger", "fish", "hopper", "humanoid", "humanoid_CMU",
          "manipulator", "pendulum", "point_mass", "quadruped", "reacher", "stacker", "swimmer", "walker"]
T = 5.0


def _cpu():
    own, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def mujoco_root_height(path, t_final=T):
    """The root body's height after t_final s of passive mj_step (MuJoCo's own contacts and constraints)."""
    import mujoco
    from eomc.compiler.mjcf.model import load_mjmodel
    m = load_mjmodel(path)
    d = mujoco.MjData(m)
    for _ in range(int(round(t_final / m.opt.timestep))):
        mujoco.mj_step(m, d)
    return float(d.xpos[1][2]) if m.nbody > 1 else float("nan")


def eomc_root_height(path, model, x):
    """The root body's height at eomc's state ``x`` (coordinates, then speeds: the state's or a CSV row's
    order; ``model`` gives the orientation of its free and ball joints, None: the MJCF default, as
    ``eomc sim`` builds it): the state mapped to MuJoCo's and its kinematics."""
    import mujoco
    from eomc.compiler.mjcf.compare import to_mujoco, tree_of
    from eomc.compiler.mjcf.model import MjcfModel, check_model, load_mjmodel
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = load_mjmodel(path)
        built = tree_of(m, model if model is not None else MjcfModel(path), actuators=check_model(m, path))
    if m.nbody < 2:
        return float("nan")
    d = mujoco.MjData(m)
    nq, nu = len(built.coordinates), len(built.speeds)
    d.qpos[:], d.qvel[:] = to_mujoco(m, built, x[:nq], x[nq:nq + nu])
    mujoco.mj_kinematics(m, d)
    return float(d.xpos[1][2])


def run(name, cache):
    import eomc
    from eomc.compiler.mjcf import MjcfModel
    from eomc.compiler.mjcf.compare import rhs_error
    import dm_control
    path = Path(dm_control.__file__).parent / "suite" / f"{name}.xml"
    row = {"model": name}
    c0 = _cpu()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = eomc.compile(path, cache_dir=cache, progress=False)
    except Exception as exc:  # noqa: BLE001 -- the refusal is the row
        row.update(built="refused: " + str(exc).splitlines()[0].replace(str(path.parent) + "/", "")[:150])
        return row
    row["built"] = f"yes ({_cpu() - c0:.1f} s CPU)"
    w0 = time.perf_counter()
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        try:
            res = model.simulate(model.initial_state, (0.0, T))
        except Exception as exc:  # noqa: BLE001 -- a run that stops is the row's answer
            row["simulated"] = "NO: " + str(exc).splitlines()[0][:120]
            return row
    x = np.asarray(res.x)
    row["simulated"] = f"{'yes' if np.isfinite(x).all() and res.t[-1] >= T - 1e-9 else 'NO'} " \
                       f"({time.perf_counter() - w0:.2f} s wall)"
    row["warnings"] = len(seen)
    row["root z MuJoCo/eomc m"] = f"{mujoco_root_height(path):.4f}/{eomc_root_height(path, model, res.x[-1]):.4f}"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        bare = eomc.compile(MjcfModel(path, limits=False, geoms=False),
                            functions=["rhs", "constraints", "constraints_jac"], cache_dir=cache, progress=False)
    row["rhs vs mj_forward"] = f"{rhs_error(path, bare):.1e}"
    return row


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-k", action="append", default=[], help="only models whose name contains this")
    parser.add_argument("--write-as", default=None, help="with -k: write the subset's table as results/NAME.md")
    args = parser.parse_args()
    names = [n for n in MODELS if not args.k or any(k in n for k in args.k)]
    rows = []
    with tempfile.TemporaryDirectory() as cache:
        for name in names:
            row = run(name, Path(cache))
            print(row, flush=True)
            rows.append(row)
    columns = ["model", "built", "simulated", "warnings", "root z MuJoCo/eomc m", "rhs vs mj_forward"]
    table = format_table(columns, [[str(r.get(c, "")) for c in columns] for r in rows])
    import dm_control  # noqa: F401
    from importlib.metadata import version
    header = environment_header("dm_control's suite with no flags: build, 5 s simulation, rhs vs mj_forward",
                                notes=[f"dm_control {version('dm_control')}, mujoco {version('mujoco')}"])
    print(table)
    if not args.k or args.write_as:
        write_results(args.write_as or "dm_suite", header + "\n" + table + "\n\n" + __doc__, keep_notes=True)


if __name__ == "__main__":
    main()
