"""jac_x per call of gymnasium's humanoid with its 109 self-collision pairs (the pairs' table,
compiler/contact/table.py, through the analytic kernel, which calls the table's tangent loop) against the same model built
without self-pairs (``pairs="trees"``), with MuJoCo's ``mj_forward`` and its finite-difference
transition Jacobian (``mjd_transitionFD``, forward differences) beside them for scale (issue 33:
jac_x with the table at most ~2x the trees-only figure).

States: the file's initial state (no self-pair in contact), t = 2.5 s of its 10 s passive fall
and t = 10 s (at rest, limbs pressed together); per state the self-pairs' points in contact.
Thread CPU time per call, the contestants interleaved per round, medians of the rounds.
``--before DIR``: also a table build made by an earlier checkout (a directory ``eomc.load``
reads), the same states.  ``table blockW``: the table's jac_x as before session 13 (the table
inputs' tangents from generated code per state column into the kernel's block W; forced by
refusing lower._kernel_table), left out with ``--no-blockw``.

    taskset -c 1 python benchmarks/bench_pair_jac_x.py [--rounds 7] [--before DIR] [--no-blockw] [--no-write]
"""
import os
import statistics
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

TIMES = (0.0, 2.5, 10.0)
CALLS = 200


def per_call(call, n=CALLS):
    from common import thread_cpu_per_call
    return thread_cpu_per_call(call, n)


def main(argv):
    import mujoco
    import eomc
    from eomc.compiler.mjcf.compare import to_mujoco
    from eomc.compiler.mjcf.model import MjcfModel
    from bench_passive import Mapped, gym_file
    from common import format_table, publish
    rounds = int(argv[argv.index("--rounds") + 1]) if "--rounds" in argv else 7
    path = gym_file("humanoid")
    cache = Path(os.environ.get("EOMC_CACHE_DIR") or tempfile.mkdtemp(prefix="eomc_pjx_"))
    models = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        models["table"] = eomc.compile(MjcfModel(str(path)), "hum", cache_dir=cache / "table", progress=False)
        models["trees"] = eomc.compile(MjcfModel(str(path), pairs="trees"), "hum", cache_dir=cache / "trees",
                                       progress=False)
        if "--no-blockw" not in argv:   # the path before session 13, forced (bench_pair_default_build's blockw)
            from eomc.compiler.tree import lower
            kernel_table, lower._kernel_table = lower._kernel_table, lambda *a: None
            try:
                models["table blockW"] = eomc.compile(MjcfModel(str(path)), "hum", cache_dir=cache / "blockw",
                                                      progress=False)
            finally:
                lower._kernel_table = kernel_table
        if "--before" in argv:
            models["table before"] = eomc.load(argv[argv.index("--before") + 1])
        table = models["table"]
        run = table.simulate(table.initial_state, (0.0, TIMES[-1]), t_eval=np.array(TIMES))
    view = Mapped(path, table)
    m, d = view.m, view.d
    from eomc.compiler.mjcf.model import load_mjmodel
    mfd = load_mjmodel(path)     # mjd_transitionFD takes Euler or implicit steps, not the file's RK4
    mfd.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
    dfd = mujoco.MjData(mfd)
    names = list(table.output_names)
    fn = [i for i, k in enumerate(names) if k.startswith("Fn_") and "__" in k]
    nv = m.nv
    A = np.zeros((2 * nv + m.na, 2 * nv + m.na))
    B = np.zeros((2 * nv + m.na, m.nu))
    rows = []
    for t, x in zip(TIMES, run.x):
        pressed = int(np.count_nonzero(np.array(list(table.outputs(0.0, x).values()))[fn] > 0))
        d.qpos[:], d.qvel[:] = to_mujoco(m, view.built, x[:table.nq], x[table.nq:table.nq + table.nu])
        dfd.qpos[:], dfd.qvel[:] = d.qpos, d.qvel
        contestants = {k: (lambda mm=mm: mm.jac_x(0.0, x)) for k, mm in models.items()}
        contestants["mj_forward"] = lambda: mujoco.mj_forward(m, d)
        contestants["mjd_transitionFD"] = lambda: mujoco.mjd_transitionFD(mfd, dfd, 1e-6, 0, A, B, None, None)
        samples = {k: [] for k in contestants}
        for _ in range(rounds):
            for k, call in contestants.items():
                samples[k].append(per_call(call, CALLS if "FD" not in k else 20))
        med = {k: statistics.median(v) for k, v in samples.items()}
        J = table.jac_x(0.0, x)
        agree = ([float(np.abs(J - models["table blockW"].jac_x(0.0, x)).max() / max(1.0, np.abs(J).max()))]
                 if "table blockW" in models else [])
        rows.append([f"{t:g}", pressed] + [med[k] * 1e6 for k in contestants]
                    + [med[k] / med["trees"] for k in models if k != "trees"] + agree)
        print(rows[-1], flush=True)
    heads = ["t (s)", "self-pair points in contact"] + [f"{k} µs" for k in contestants] + [f"{k} / trees" for k in models if k != "trees"] + (
        ["|table - blockW| / max(1, |J|)"] if "table blockW" in models else [])
    publish("pair_jac_x", "Humanoid jac_x with its self-pairs (the pairs' table)", [
        format_table(heads, rows),
        f"Thread CPU per call, medians of {rounds} interleaved rounds ({CALLS} calls each; mjd_transitionFD "
        "20), at the states of the humanoid's passive fall from its initial state (eomc, default build); "
        "jac_x: eomc's (46 x 46, the rhs's state Jacobian); MuJoCo at the same qpos and qvel: mj_forward, "
        "and mjd_transitionFD (forward differences, eps 1e-6, the (2 nv) x (2 nv) transition matrix of one "
        "step: 2 nv + 1 steps; the file's RK4 set to Euler, which it requires)."], argv)


if __name__ == "__main__":
    main(sys.argv[1:])
