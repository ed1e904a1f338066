"""Issue 33: 10 s passive simulations with the default method beside MuJoCo's C loop, and the
swimmer's passive stroke decay against MuJoCo.

Passive runs (gymnasium hopper, walker2d, ant, humanoid; the wheel's files, no flags):

- eomc: ``eomc.compile(path)`` (no flags: the file's contacts, limits, frictionloss as eomc models
  them; self-collision pairs in, eomc's default since session 11: results/passive.md of
  2026-11-29 18:16 was measured before, without them), then ``model.simulate(model.initial_state,
  (0, 10))`` with every option at its default (method "auto": an implicit method from the start
  on a model with contacts; rtol 1e-6; 1001 output points), from the file's initial state;
- MuJoCo: ``mujoco.rollout.rollout`` (its C loop of ``mj_step``, one thread, one MjData) for
  10 s / timestep steps at the file's time step and integrator, from the file's initial state
  (qpos0, zero speeds), zero controls, writing the full physics state at every step.

Wall (perf_counter) and CPU (thread_time: both run in the calling thread) per 10 s run, medians
of --repeat runs after one untimed run of each, the two interleaved, pinned to one core (--core, 1 by default; sched_setaffinity).
Build time is not in the figures.  The root body's height at 10 s on both (eomc's state mapped to
MuJoCo's qpos, ``mj_kinematics``), the deepest contact penetration eomc's depth outputs saw
(below the law's surface) and eomc's verdict on the run (its PhysicsWarnings about contacts:
"none" when there is no penetration warning; other warnings, limits and starts, are listed
in the notes).

Swimmer (gymnasium swimmer.xml: viscosity 0.1, density 4000: fluid forces on every geom, no
contacts): from qpos0 with the two body joints given a stroke (motor1_rot +SPEED, motor2_rot
-SPEED rad/s), 5 s passive; eomc with no flags at rtol = atol = 1e-12 (method "auto": DOP853 on
this non-stiff model); MuJoCo ``mj_step`` with the RK4 integrator at 1e-4 s (the file's own:
RK4, 10 ms).  Compared every 10 ms: the three joint angles and the root's slides (x, y), the
largest difference over the run, beside the largest value each takes (how far the stroke
carries it); again with eomc at its default tolerances.
Usage: python benchmarks/bench_passive.py [--repeat 5] [--write] [--core 1] [--only hopper,swimmer]
"""
import argparse
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import environment_header, format_table, write_results  # noqa: E402

CORE = 1
T = 10.0
PASSIVE = ("hopper", "walker2d", "ant", "humanoid")
SWIM_T, SWIM_H, SWIM_RTOL, SPEED, SWIM_EVERY = 5.0, 1e-4, 1e-12, 2.0, 0.01


def gym_file(stem):
    import gymnasium
    return Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / f"{stem}.xml"


class Mapped:
    """MuJoCo's view of an eomc state of the same file: qpos and the root body's height."""

    def __init__(self, path, model):
        import mujoco
        from eomc.compiler.mjcf.model import load_mjmodel
        from eomc.compiler.mjcf.compare import tree_of
        self.m = load_mjmodel(path)
        self.built, self.model = tree_of(self.m, model), model
        self.d = mujoco.MjData(self.m)

    def qpos(self, x):
        from eomc.compiler.mjcf.compare import to_mujoco
        nq, nu = self.model.nq, self.model.nu
        return to_mujoco(self.m, self.built, x[:nq], x[nq:nq + nu])[0]

    def root_z(self, qpos):
        import mujoco
        self.d.qpos[:] = qpos
        mujoco.mj_kinematics(self.m, self.d)
        return float(self.d.xpos[1][2])

    def state(self, qpos, qvel):
        """eomc's state of MuJoCo's (qpos, qvel), zero for any further states."""
        from eomc.compiler.mjcf.compare import from_mujoco
        q, u = from_mujoco(self.m, self.built, qpos, qvel)
        return np.concatenate([q, u, np.zeros(len(self.model.state_names) - len(q) - len(u))])


def clocked(call):
    t0, c0 = time.perf_counter(), time.thread_time()
    out = call()
    return out, time.perf_counter() - t0, time.thread_time() - c0


def mujoco_loop(m):
    """A call running MuJoCo's C rollout for T from the file's initial state; returns the states."""
    import mujoco
    from mujoco import rollout
    d = mujoco.MjData(m)
    mujoco.mj_resetData(m, d)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state0 = np.zeros(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, d, state0, spec)
    nstep = int(round(T / m.opt.timestep))
    out = np.zeros((1, nstep, state0.size))
    ctrl = np.zeros((1, nstep, m.nu))

    def call():
        rollout.rollout([m], [d], state0[None, :], ctrl, nstep=nstep, state=out, skip_checks=True)
        return out[0, -1, 1:1 + m.nq + m.nv].copy()       # FULLPHYSICS: time, qpos, qvel, ...
    return call, nstep


def passive_row(stem, cache, repeat):
    import eomc
    import mujoco
    path = gym_file(stem)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")          # the build's notes; the warm-up's verdict (recorded below)
        model = eomc.compile(str(path), cache_dir=cache, progress=False)
        view = Mapped(path, model)
        mj_call, nstep = mujoco_loop(view.m)
        model.simulate(model.initial_state, (0.0, T))     # warm-up of both (first-call page faults)
        mj_call()
    eo, mj = [], []
    for _ in range(repeat):                      # interleaved
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            res, wall, cpu = clocked(lambda: model.simulate(model.initial_state, (0.0, T)))
        eo.append((wall, cpu))
        end_mj, wall, cpu = clocked(mj_call)
        mj.append((wall, cpu))
    eo_wall, eo_cpu = np.median(eo, axis=0)
    mj_wall, mj_cpu = np.median(mj, axis=0)
    depths = [k for k in model.output_names if k.startswith("depth_")]
    deepest = max(0.0, float(np.max([res.outputs[k] for k in depths]))) if depths else 0.0
    said = sorted({str(w.message).split("\n")[0] for w in caught})
    contact = [s for s in said if "penetrat" in s or "below the ground" in s or "contact" in s.split(":")[0]]
    z_e, z_m = view.root_z(view.qpos(res.x[-1])), view.root_z(end_mj[:view.m.nq])
    v_m = float(np.abs(end_mj[view.m.nq:]).max())
    integ = mujoco.mjtIntegrator(view.m.opt.integrator).name.replace("mjINT_", "")
    row = [stem, f"{1e3 * view.m.opt.timestep:g} ms {integ}", str(nstep),
           f"{res.method} ({res.stats.get('accepted', '?')} steps)", str(res.status),
           f"{1e3 * eo_wall:.1f}", f"{1e3 * eo_cpu:.1f}", f"{1e3 * mj_wall:.1f}", f"{1e3 * mj_cpu:.1f}", f"{mj_cpu / eo_cpu:.2f}",
           f"{z_e:.4f}", f"{z_m:.4f}", f"{1e3 * (z_e - z_m):+.1f}", f"{v_m:.0e}", f"{1e3 * deepest:.2f}",
           "; ".join(contact) if contact else "none"]
    notes = [f"{stem}: eomc's warnings on the 10 s run: " + (" | ".join(s[:160] for s in said) or "none")]
    return row, notes


def swimmer(cache):
    """(table rows, notes): eomc at a tight tolerance vs MuJoCo RK4 at SWIM_H from a stroke."""
    import eomc
    import mujoco
    path = gym_file("swimmer")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(str(path), cache_dir=cache, progress=False)
    view = Mapped(path, model)
    m = view.m
    m.opt.integrator, m.opt.timestep = mujoco.mjtIntegrator.mjINT_RK4, SWIM_H
    d = mujoco.MjData(m)
    mujoco.mj_resetData(m, d)
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(m.njnt)]
    for name, v in (("motor1_rot", SPEED), ("motor2_rot", -SPEED)):
        d.qvel[m.jnt_dofadr[names.index(name)]] = v
    x0 = view.state(d.qpos.copy(), d.qvel.copy())
    every = int(round(SWIM_EVERY / SWIM_H))
    nsample = int(round(SWIM_T / SWIM_EVERY))
    ref = [d.qpos.copy()]
    (_, mj_wall, mj_cpu) = clocked(lambda: [ref.append(_steps(m, d, every)) for _ in range(nsample)])
    ref = np.array(ref)
    times = SWIM_EVERY * np.arange(nsample + 1)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res, e_wall, e_cpu = clocked(lambda: model.simulate(x0, (0.0, SWIM_T), t_eval=times, rtol=SWIM_RTOL,
                                                            atol=SWIM_RTOL))
    got = np.array([view.qpos(x) for x in res.x])
    with warnings.catch_warnings(record=True) as caught_default:
        warnings.simplefilter("always")
        loose = model.simulate(x0, (0.0, SWIM_T), t_eval=times)
    got_default = np.array([view.qpos(x) for x in loose.x])
    rows = []
    for j, name in enumerate(names):
        a = int(m.jnt_qposadr[j])
        diff = np.abs(got[:, a] - ref[:, a])
        k = int(np.argmax(diff))
        unit = "m" if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_SLIDE else "rad"
        rows.append([name, unit, f"{np.abs(ref[:, a]).max():.4f}", f"{got[-1, a]:+.6f}", f"{ref[-1, a]:+.6f}",
                     f"{diff.max():.2e}", f"{times[k]:.2f}", f"{np.abs(got_default[:, a] - ref[:, a]).max():.2e}"])
    said = sorted({str(w.message).split("\n")[0][:160] for w in [*caught, *caught_default]})
    notes = [f"swimmer: eomc {res.method}, status {res.status}, {res.stats.get('accepted', '?')} steps "
             f"({loose.method} {loose.stats.get('accepted', '?')} at the default rtol), "
             f"wall/CPU {e_wall:.2f}/{e_cpu:.2f} s; MuJoCo RK4 h={SWIM_H:g} s, {nsample * every} steps "
             f"(a Python loop of mj_step), wall/CPU {mj_wall:.2f}/{mj_cpu:.2f} s; eomc's warnings: "
             + (" | ".join(said) or "none")]
    return rows, notes


def _steps(m, d, n):
    import mujoco
    for _ in range(n):
        mujoco.mj_step(m, d)
    return d.qpos.copy()


def main(argv):
    import gymnasium
    import mujoco
    import tempfile
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--write", action="store_true")
    ap.add_argument("--only", default="", help="comma-separated model names (not written)")
    ap.add_argument("--core", type=int, default=CORE, help=f"the core to pin to (default {CORE})")
    args = ap.parse_args(argv)
    only = [s for s in args.only.split(",") if s]
    try:
        os.sched_setaffinity(0, {args.core})
    except (AttributeError, OSError):
        pass
    start = " ".join(f"{v:.2f}" for v in os.getloadavg())
    cache = Path(os.environ.get("EOMC_CACHE_DIR") or tempfile.mkdtemp(prefix="bench_passive_"))
    rows, notes = [], []
    for stem in PASSIVE:
        if only and stem not in only:
            continue
        row, more = passive_row(stem, cache, args.repeat)
        rows.append(row)
        notes += more
        print(" | ".join(row), flush=True)
    swim_rows, swim_notes = ([], []) if only and "swimmer" not in only else swimmer(cache)
    headers = ["model", "MuJoCo step", "MuJoCo steps", "eomc method (steps)", "eomc status",
               "eomc wall ms", "eomc CPU ms", "MuJoCo rollout wall ms", "MuJoCo rollout CPU ms", "CPU MuJoCo / eomc",
               "root z eomc m", "root z MuJoCo m", "diff mm", "MuJoCo max abs qvel at 10 s", "eomc deepest mm", "eomc penetration verdict"]
    swim_headers = ["swimmer joint", "unit", "max abs MuJoCo", "eomc at 5 s", "MuJoCo at 5 s", "max abs diff",
                    "at t s", "max abs diff, eomc at its default rtol 1e-6"]
    text = format_table(headers, rows) if rows else ""
    if swim_rows:
        text += (f"\n\nSwimmer: passive stroke decay, eomc (rtol {SWIM_RTOL:g}) vs MuJoCo RK4 h={SWIM_H:g} s\n\n"
                 + format_table(swim_headers, swim_rows))
    print(text)
    for n in notes + swim_notes:
        print("-", n)
    if args.write and not only:
        end = " ".join(f"{v:.2f}" for v in os.getloadavg())
        head = environment_header(
            "10 s passive runs with the default method beside MuJoCo's C loop; swimmer's stroke decay",
            notes=[f"load average at start: {start}, at the end: {end} (a shared 2-core machine, other "
                   f"engineers' builds and tests beside this); pinned to core {args.core}; medians of "
                   f"{args.repeat} interleaved runs",
                   f"models from gymnasium {gymnasium.__version__}'s wheel; mujoco {mujoco.__version__}",
                   *notes, *swim_notes])
        print(write_results("passive", head + "\n" + text + "\n\n" + (__doc__ or ""), keep_notes=True))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
