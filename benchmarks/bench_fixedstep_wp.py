"""Fixed steps' work and precision: eomc implicitfast and MuJoCo mj_step at several step sizes.

    python benchmarks/bench_fixedstep_wp.py [--models hopper,walker2d,ant,humanoid] [--rounds 7]
        [--eomc-steps 1,1.5,2,2.5,3] [--mujoco-steps 0.5,1,1.5,2] [--cache-dir DIR] [--no-write]

Why: bench_fixedstep.py compares the two at each file's own timestep, where eomc's checked step buys an
error several times smaller than MuJoCo's with the model calls its touch-downs take
(fixedstep_tries.md).  What a user trades is CPU for error: this table and its figure put each side's
error against its CPU at a few multiples of the timestep, so the speed at equal error can be read off.

Each side's error is against its own reference, as in bench_fixedstep.py (the contact laws differ:
eomc's compliant law tuned to rest at MuJoCo's depth, MuJoCo's soft constraints): eomc against its
Radau at rtol = atol = 1e-9, MuJoCo against its RK4 at timestep / 16; max |q| difference at t = 1 over
bench_fixedstep.compared_q (free joints: the base position).  The gymnasium models with zero control, 1 simulated second,
from --starts states: the pose at rest (qpos0: bench_fixedstep's run) and the first of
bench_rollout_contacts' starts (its hinge speeds uniform in +-0.5, seed 0); the error is the median
over those starts (one chaotic fall's error moves by factors with the step), the CPU the mean per
start.  A step size k times the file's timestep is rounded so that a whole number of steps ends at
t = 1.  eomc: simulate's C loop, method="implicitfast", checked
(simulate's default) and unchecked (split = 0: one model call a step, MuJoCo's scheme); MuJoCo: its
default integrator (Euler) through mujoco.rollout (C).  Time: thread CPU per simulated second, pinned
to one core, contestants interleaved (order rotated per round), median over rounds of blocks of runs.
A run that ends non-finite or with a non-zero status counts with its error as inf.
"""
import argparse
import os
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_fixedstep as B  # noqa: E402
from common import RESULTS_DIR, environment_header, format_table, pin_to_one_core, work_precision_figure  # noqa: E402
from common import write_results  # noqa: E402

MODELS = B.MODELS


def _steps(text):
    return [float(v) for v in text.split(",") if v]


def whole(ts, k):
    """The step nearest k * ts that ends a whole number of steps at t = 1, and that number."""
    n = max(1, int(round(1.0 / (k * ts))))
    return 1.0 / n, n


def _mujoco_rollout(m, S0, nstep):
    """A call running mujoco.rollout from the full-physics states S0 (rows) for nstep steps of m."""
    import mujoco
    from mujoco import rollout
    datas = [mujoco.MjData(m)]
    out = np.zeros((len(S0), nstep, S0.shape[1]))
    ctrl = np.zeros((len(S0), nstep, m.nu))

    def call():
        rollout.rollout([m] * len(S0), datas, S0, ctrl, nstep=nstep, state=out, skip_checks=True)
        return out
    return call


def run_model(name, rounds, cache_dir, eomc_ks, mujoco_ks, nstarts, log):
    """Rows (one per contestant) of one model: CPU per simulated second (the starts' mean) and the
    median over the starts of the error at t = 1."""
    import mujoco

    import bench_rollout_contacts as R
    base = mujoco.MjModel.from_xml_path(str(B.gym_xml(name)))
    ts = float(base.opt.timestep)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = B.eomc_model(name, cache_dir)
    X0, S0 = R.starts(model, base, None, {})
    X0[0] = B.eomc_start(model, base)      # row 0: the pose at rest (bench_fixedstep's run)
    X0[0, model.nq:] = 0.0
    d = mujoco.MjData(base)
    mujoco.mj_resetData(base, d)
    mujoco.mj_getState(base, d, S0[0], mujoco.mjtState.mjSTATE_FULLPHYSICS)
    X0, S0 = X0[:nstarts], S0[:nstarts]
    refs = [model.simulate(x, (0, 1.0), method="radau", rtol=1e-9, atol=1e-9, t_eval=[1.0], max_steps=10 ** 7,
                           raise_on_failure=False) for x in X0]
    q_ref = [B.compared_q(model, base, x=r.x[-1]) if r.status == 0 else None for r in refs]
    nfine = int(round(1.0 / ts)) * 16
    fine = B.mujoco_model(name, "RK4", 1.0 / nfine)
    q_fine = [B.compared_q(model, fine, qpos=row[-1, 1:1 + fine.nq]) for row in _mujoco_rollout(fine, S0, nfine)()]
    contestants, finish = {}, {}
    for k in eomc_ks:
        dt, _ = whole(ts, k)
        for checked in (True, False):
            label = f"eomc implicitfast {'checked' if checked else 'unchecked'}, {k:g} x timestep"
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                runs = [B.eomc_call(model, x, dt, split=None if checked else 0.0) for x in X0]

            def call(runs=runs):
                for c, _, _ in runs:
                    c()

            def done(call=call, runs=runs, dt=dt):
                call()
                errs, calls, bad = [], 0, 0
                for (_, x_last, st), q in zip(runs, q_ref):
                    ok = st.status == 0 and np.all(np.isfinite(x_last)) and q is not None
                    errs.append(np.abs(B.compared_q(model, base, x=x_last) - q).max() if ok else np.inf)
                    calls += st.nfev
                    bad += st.status != 0
                return dt, errs, f"{calls / len(runs):.0f} calls a run" + (f", {bad} runs status != 0" if bad else "")
            contestants[label], finish[label] = call, done
    for k in mujoco_ks:
        dt, n = whole(ts, k)
        mm = B.mujoco_model(name, "EULER", dt)
        call = _mujoco_rollout(mm, S0, n)
        label = f"mj_step euler, {k:g} x timestep"

        def done(call=call, mm=mm, dt=dt):
            errs = []
            for row, q in zip(call(), q_fine):
                qpos = row[-1, 1:1 + mm.nq]
                errs.append(np.abs(B.compared_q(model, mm, qpos=qpos) - q).max() if np.all(np.isfinite(qpos))
                            else np.inf)
            return dt, errs, ""
        contestants[label], finish[label] = call, done
    samples = {k: [] for k in contestants}
    order = list(contestants)
    for r in range(rounds):
        s = r % len(order)
        for label in order[s:] + order[:s]:
            samples[label].append(B.cpu_block(contestants[label], 0.05))
    rows = []
    for label in order:
        dt, errs, note = finish[label]()
        cpu = float(np.median(samples[label])) * 1e3 / len(X0)
        rows.append(dict(model=name, contestant=label, dt=dt, cpu_ms=cpu, error=float(np.median(errs)),
                         worst=float(np.max(errs)), note=note))
        log(f"  {name:9s} {label:44s} dt {dt * 1e3:6.3f} ms  {cpu:8.3f} ms  err {np.median(errs):.2e} "
            f"(max {np.max(errs):.2e})  {note}")
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", default=",".join(MODELS))
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--eomc-steps", default="1,1.5,2,2.5,3", help="multiples of the file's timestep")
    parser.add_argument("--mujoco-steps", default="0.5,1,1.5,2", help="multiples of the file's timestep")
    parser.add_argument("--starts", type=int, default=8,
                        help="the pose at rest and the first of bench_rollout_contacts' random starts")
    parser.add_argument("--cache-dir", default=os.environ.get("EOMC_CACHE_DIR"))
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args()
    core = pin_to_one_core()
    rows = []
    for name in [n for n in args.models.split(",") if n]:
        rows += run_model(name, args.rounds, args.cache_dir, _steps(args.eomc_steps), _steps(args.mujoco_steps),
                          args.starts, lambda s: print(s, flush=True))
    import mujoco
    head = environment_header("Fixed steps' work and precision: eomc implicitfast vs MuJoCo mj_step", args,
                              notes=[f"pinned to core {core}; MuJoCo {mujoco.__version__}; {args.rounds} interleaved "
                                     f"rounds, median of per-round block means (thread CPU)"])
    table = format_table(["model", "contestant", "step (ms)", "CPU ms per simulated s",
                          "error at t = 1: median over the starts", "largest", "notes"],
                         [[r["model"], r["contestant"], f"{r['dt'] * 1e3:.3f}", f"{r['cpu_ms']:.3f}",
                           f"{r['error']:.2e}", f"{r['worst']:.2e}", r["note"]] for r in rows])
    panels = []
    for name in dict.fromkeys(r["model"] for r in rows):
        series = {}
        for r in rows:
            if r["model"] == name and np.isfinite(r["error"]):
                side = r["contestant"].rsplit(",", 1)[0]
                series.setdefault(side, []).append((r["cpu_ms"] / 1e3, r["error"]))
        panels.append((name, series))
    text = "\n\n".join([head, __doc__.split("\n\n", 2)[2].strip(), table,
                        "![work and precision](fixedstep_wp.png)  (x axis: thread CPU seconds per simulated second)"])
    print(table)
    if not args.no_write:
        work_precision_figure(panels, RESULTS_DIR / "fixedstep_wp.png", panel_width=4.5,
                              xlabel="thread CPU [s] per simulated second (median)")
        write_results("fixedstep_wp", text, keep_notes=True)


if __name__ == "__main__":
    main()
