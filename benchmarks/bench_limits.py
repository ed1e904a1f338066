"""Joint limits, damping and friction on real files: what the README's limits section quotes.

    python benchmarks/bench_limits.py [--repeat 7]

1. Panda (example-robot-data), no flags: its fingers (range 0-0.04 m) under gravity for 2 s
   (DOP853 rtol 1e-6) with the file's limits, and with the fingers' limit stiffness and
   damping set to 0 at run time (what the robot did before limits were read).
2. A 0.5 m, 1 kg MJCF pendulum dropped 0.5 rad onto its limit: eomc (limits from MuJoCo's
   solref/solimp, Radau rtol 1e-9) against MuJoCo's mj_step (RK4, 0.1 ms), same file
   (the model of tests/compiler/mjcf/test_mjcf_limits.py).
3. The cost of the laws: Panda's rhs with and without them (`--limits off`), operation
   counts and thread CPU time per call (medians, interleaved, one core).
"""
import importlib.util
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import environment_header, format_table, median_iqr, parse_args, pin_to_one_core, write_results  # noqa: E402

import eomc  # noqa: E402
from eomc.compiler.mjcf.model import MjcfModel, load_mjmodel  # noqa: E402
from eomc.compiler.urdf.model import UrdfModel  # noqa: E402
from eomc.runtime.simulate import simulate  # noqa: E402
from helpers.robots import robot_path  # noqa: E402


def _drop_model():
    spec = importlib.util.spec_from_file_location(
        "mjcf_limits_cases", ROOT / "tests" / "compiler" / "mjcf" / "test_mjcf_limits.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.DROP


def panda_fingers(cache):
    panda = eomc.compile(robot_path("panda"), "panda", functions=["rhs"], cache_dir=cache, progress=False)
    fingers = [i for i, n in enumerate(panda.state_names) if n.startswith("q_panda_finger_joint")]
    x0 = np.zeros(panda.nx)
    x0[[panda.state_names.index(f"q_panda_joint{i}") for i in (2, 4, 6)]] = (0.8, -1.5, 1.0)
    x0[fingers] = 0.02
    p_off = panda.param_defaults.copy()
    for i, n in enumerate(panda.param_names):
        if n.startswith(("limit_k_panda_finger", "limit_c_panda_finger")):
            p_off[i] = 0.0
    rows = []
    for label, p in (("file's limits (default)", None), ("finger limits k = c = 0", p_off)):
        res = simulate(panda, x0, (0.0, 2.0), p=p, method="dop853", rtol=1e-6, atol=1e-8, n_points=401)
        q = res.x[:, fingers]
        outside = np.maximum(np.maximum(-q, q - 0.04), 0.0)
        rows.append([label, f"{1e3 * outside.max():.2f}", f"{1e3 * outside[-1].max():.2f}"])
    return rows


def drop(tmp):
    import mujoco
    path = tmp / "drop.xml"
    path.write_text(_drop_model())
    model = eomc.compile(MjcfModel(path), functions=["rhs", "jac_x"], cache_dir=tmp / "c", progress=False)
    res = simulate(model, np.array([-0.5, 0.0]), (0.0, 2.0), method="radau", rtol=1e-9, atol=1e-11,
                   n_points=20001)
    m = load_mjmodel(path)
    d = mujoco.MjData(m)
    d.qpos[0] = -0.5
    deepest = 0.0
    for _ in range(int(round(2.0 / m.opt.timestep))):
        mujoco.mj_step(m, d)
        deepest = max(deepest, float(d.qpos[0]))
    return [["eomc (spring-damper from solref)", f"{res.x[:, 0].max():.4f}", f"{res.x[-1, 0]:.5f}"],
            ["MuJoCo mj_step (soft constraint)", f"{deepest:.4f}", f"{float(d.qpos[0]):.5f}"]]


def cost(cache, repeat):
    path = robot_path("panda")
    models = {label: eomc.compile(UrdfModel(path, limits=on), f"panda_{label.split()[-1]}", functions=["rhs"],
                                  cache_dir=cache, progress=False)
              for label, on in (("limits on", True), ("limits off", False))}
    rng = np.random.default_rng(0)
    xs = [np.concatenate([rng.uniform(-1, 1, m.nq), rng.uniform(-1, 1, m.nx - m.nq)]) for m in models.values()]
    samples = {k: [] for k in models}
    for _ in range(repeat):          # interleaved
        for (label, m), x in zip(models.items(), xs):
            t0 = time.thread_time()
            for _ in range(20000):
                m.rhs(0.0, x)
            samples[label].append((time.thread_time() - t0) / 20000)
    rows = []
    for label, m in models.items():
        ops = sum(v for k, v in m.metadata["op_counts"]["rhs"].items())
        rows.append([label, ops, f"{1e9 * median_iqr(samples[label])[0]:.0f}"])
    return rows


def main():
    args = parse_args(__doc__, default_n=[0], default_repeat=7)
    pin_to_one_core()
    warnings.simplefilter("ignore")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        fingers = panda_fingers(tmp / "cache")
        dropped = drop(tmp)
        costs = cost(tmp / "cache", args.repeat)
    header = environment_header("Joint limits, damping and friction (benchmarks/bench_limits.py)", args)
    text = "\n\n".join([
        header,
        "## Panda's fingers under gravity, 2 s (range 0-40 mm)\n\n"
        + format_table(["model", "furthest outside the range (mm)", "outside at 2 s (mm)"], fingers),
        "## A pendulum dropped 0.5 rad onto its MJCF limit\n\n"
        + format_table(["contestant", "first penetration (rad)", "at rest, 2 s (rad)"], dropped),
        "## Panda's rhs with and without the laws (thread CPU per call, median, Python call included)\n\n"
        + format_table(["build", "rhs ops", "ns per call"], costs)])
    print(text)
    if not args.no_write:
        write_results("limits", text)


if __name__ == "__main__":
    main()
