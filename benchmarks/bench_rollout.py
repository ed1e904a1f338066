"""Issue 31 item 2 (first piece): eomc.rollout vs mujoco.rollout vs a Python loop over simulate.

Same physics on both sides: gymnasium's MJCF files compiled by eomc with limits and geoms off
(MjcfModel(..., limits=False, geoms=False)) and MuJoCo with contacts, constraints and limits
disabled (mjDSBL_CONTACT | mjDSBL_CONSTRAINT | mjDSBL_LIMIT), armature and damping kept on
both, zero controls.  Same method and step: MuJoCo's RK4 integrator (mjINT_RK4) at the
model's own timestep, eomc's method="rk4" with dt = that timestep.  Same thread count (1 and
2): mujoco.rollout gets one MjData per thread; eomc.rollout threads=k.

Contestants, each on NROLL random starts (qpos, qvel uniform in +-0.1 around the model's
qpos0) for NSTEP steps:
  eomc final   eomc.rollout(record="final")  -- final states only (n x nx)
  eomc steps   eomc.rollout(record="steps")  -- every step, like mujoco.rollout's output
  mujoco       mujoco.rollout.rollout(...)   -- writes the full physics state at every step
  simulate     a Python loop of eomc simulate(..., method="rk4", dt, t_eval=[T]) (threads=1
               only; NROLL_LOOP starts, scaled to steps/s)
Wall time (what a user waits for) and process CPU time (all threads; steadier on a loaded
machine, and the cost of the work whatever the thread count), the process pinned to cores 0,1
(taskset), contestants interleaved repeat by repeat, medians of REPEAT.  steps/s =
NROLL * NSTEP / median time.  Agreement: max over rows and states of |x_eomc - x_mujoco|
/ max(1, |x|) at the final step (different arithmetic, same method: round-off level expected).

    taskset -c 0,1 nice python benchmarks/bench_rollout.py
"""
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import environment_header, format_table, write_results  # noqa: E402

MODELS = ("inverted_double_pendulum", "hopper")
NROLL, NSTEP, NROLL_LOOP, REPEAT = 256, 500, 32, 7


def _models(name):
    import gymnasium
    import mujoco

    import eomc
    from eomc.compiler.mjcf import MjcfModel
    path = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / f"{name}.xml"
    em = eomc.compile(MjcfModel(path, limits=False, geoms=False), name=f"rollout_{name}", progress=False)
    mm = mujoco.MjModel.from_xml_path(str(path))
    mm.opt.disableflags |= (mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
                            | mujoco.mjtDisableBit.mjDSBL_LIMIT)
    mm.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    return em, mm


def _case(name, threads_list):
    import mujoco
    from mujoco import rollout as mj_rollout

    import eomc
    from eomc.runtime.simulate import simulate
    em, mm = _models(name)
    assert mm.nq == mm.nv and em.nx == mm.nq + mm.nv, (name, em.state_names)
    mj_names = [mm.joint(j).name for j in range(mm.njnt)]
    order = [em.state_names.index(f"q_{n}") for n in mj_names]
    order += [em.state_names.index(f"u_{n}") for n in mj_names]
    dt = float(mm.opt.timestep)
    rng = np.random.default_rng(0)
    qpos = mm.qpos0 + rng.uniform(-0.1, 0.1, (NROLL, mm.nq))
    qvel = rng.uniform(-0.1, 0.1, (NROLL, mm.nv))
    X0 = np.empty((NROLL, em.nx))
    X0[:, order] = np.hstack([qpos, qvel])
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    nstate = mujoco.mj_stateSize(mm, spec)
    d = mujoco.MjData(mm)
    S0 = np.empty((NROLL, nstate))
    for i in range(NROLL):
        mujoco.mj_resetData(mm, d)
        d.qpos[:], d.qvel[:] = qpos[i], qvel[i]
        mujoco.mj_getState(mm, d, S0[i], spec)
    ctrl = np.zeros((NROLL, NSTEP, mm.nu))
    rows = []
    for k in threads_list:
        datas = [mujoco.MjData(mm) for _ in range(k)]
        with mj_rollout.Rollout(nthread=k) as ro:
            contestants = {
                "eomc final": lambda: eomc.rollout(em, X0, steps=NSTEP, dt=dt, threads=k, method="rk4").x,
                "eomc steps": lambda: eomc.rollout(em, X0, steps=NSTEP, dt=dt, threads=k, method="rk4",
                                                   record="steps").x,
                "mujoco": lambda: ro.rollout([mm] * NROLL, datas, S0, ctrl, nstep=NSTEP)[0],
            }
            if k == 1:
                contestants["simulate loop"] = lambda: [simulate(em, X0[i], (0.0, NSTEP * dt), method="rk4", dt=dt,
                                                                 t_eval=[NSTEP * dt]).x[-1]
                                                        for i in range(NROLL_LOOP)]
            times = {c: [] for c in contestants}
            cpu = {c: [] for c in contestants}
            out = {}
            for _ in range(REPEAT):
                for c, f in contestants.items():
                    t0, c0 = time.perf_counter(), time.process_time()
                    out[c] = f()
                    times[c].append(time.perf_counter() - t0)
                    cpu[c].append(time.process_time() - c0)
        mj_final = out["mujoco"][:, -1, 1:1 + 2 * mm.nq]          # [time, qpos, qvel, ...]
        ours = out["eomc final"][:, order]
        agree = float(np.max(np.abs(ours - mj_final) / np.maximum(1.0, np.abs(mj_final))))
        assert np.array_equal(out["eomc steps"][:, -1], out["eomc final"])
        total = {c: (NROLL_LOOP if c == "simulate loop" else NROLL) * NSTEP for c in contestants}
        sps = {c: total[c] / statistics.median(v) for c, v in times.items()}
        cps = {c: total[c] / statistics.median(v) for c, v in cpu.items()}
        for c in contestants:
            rows.append([name, k, c, f"{sps[c]:.3g}", f"{sps[c] / sps['mujoco']:.2f}",
                         f"{cps[c]:.3g}", f"{cps[c] / cps['mujoco']:.2f}",
                         f"{agree:.1e}" if c == "eomc final" else ""])
        print(rows[-len(contestants):], flush=True)
    return rows, dt


def main():
    threads = [1, 2] if len(os.sched_getaffinity(0)) >= 2 else [1]
    rows, dts = [], {}
    for name in MODELS:
        r, dts[name] = _case(name, threads)
        rows += r
    table = format_table(["model", "threads", "contestant", "steps/s (wall)", "vs mujoco.rollout",
                          "steps/CPU-s", "vs mujoco.rollout (CPU)", "final-state agreement"], rows)
    text = environment_header(
        "Rollouts: eomc.rollout vs mujoco.rollout vs a Python loop over simulate (issue 31)",
        notes=[f"{NROLL} starts x {NSTEP} steps per call (simulate loop: {NROLL_LOOP} starts), RK4 on both sides "
               f"at the model's timestep ({', '.join(f'{n} {dt:g} s' for n, dt in dts.items())}); contacts, "
               f"constraints and limits off on both sides; zero controls; wall and process-CPU medians of {REPEAT} "
               f"interleaved repeats, process pinned to cores {sorted(os.sched_getaffinity(0))}; shared noisy "
               f"machine.  Agreement: max |x_eomc - x_mujoco| / max(1, |x|) over rows and states at the end."]
    ) + "\n" + table + "\n"
    print(table)
    write_results("rollout", text)


if __name__ == "__main__":
    main()
