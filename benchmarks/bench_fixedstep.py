"""Fixed step at each model's MJCF timestep: eomc's implicitfast against MuJoCo's mj_step.

    python benchmarks/bench_fixedstep.py [--models hopper,walker2d,ant,humanoid] [--rounds 7]
        [--orientation quaternion|euler]

The gymnasium models (hopper, walker2d, ant, humanoid) dropped from their qpos0 with zero
control, 1 simulated second, at the XML's own timestep, each side with the contacts it reads
from the file: MuJoCo its geoms against the floor plane; eomc the same geoms' ground contacts
(compiler/mjcf/collision.py: capsules as their two end spheres, parameters matched to the
geom's solref/solimp/friction; docs/contact.md).  MuJoCo: the XML as shipped, run in C by
``mujoco.rollout`` (no Python loop) with its default integrator (Euler), with implicitfast,
and with the XML's own (RK4).  eomc: its C loop (``simulate``'s prepared C call, no events:
what a control loop runs), method="implicitfast" at dt = timestep.  The contact laws differ
(MuJoCo's soft constraints, eomc's compliant law tuned to rest at the same depth), so each
side's error is against its own reference: eomc against its own Radau at rtol = atol = 1e-9,
MuJoCo against itself with RK4 at timestep / 16.  Error: max abs over
the joint coordinates at t = 1 (free joints: the base position; MuJoCo's qpos holds a
quaternion, eomc the same or body-XYZ angles: the orientation is left out of the error on both sides).
--orientation euler: eomc's free and ball joints as body-XYZ angles (MjcfModel(orientation=
"euler")) instead of MuJoCo's own quaternion (the default since session 30; the same
position-first coordinates, so the same error columns; the gym models only, --robots ""):
the table is printed, not written (benchmarks/results/quaternion_fixedstep.md quotes both
orientations' runs).

Time: thread CPU of one simulated second, pinned to one core, contestants interleaved
(order rotated per round), median over rounds of blocks of runs.
"""
import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import environment_header, pin_to_one_core, write_results  # noqa: E402

MODELS = ("hopper", "walker2d", "ant", "humanoid")


def gym_xml(name):
    import gymnasium
    return Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / f"{name}.xml"


def eomc_model(name, cache_dir, functions=None, orientation="quaternion"):
    """The XML as shipped: its ground contacts come from the file (functions: eomc.compile's;
    orientation: MjcfModel's, the Euler build named NAME_euler)."""
    import eomc
    from eomc.compiler.mjcf.model import MjcfModel
    tag = "" if orientation == "quaternion" else "_euler"
    return eomc.compile(MjcfModel(gym_xml(name), orientation=orientation), name=f"fs_{name}{tag}",
                        cache_dir=cache_dir, functions=functions)


def mujoco_model(name, integrator=None, timestep=None):
    """The XML as shipped; integrator None = the XML's own, else a mjtIntegrator name
    ("EULER", "IMPLICITFAST", "RK4")."""
    import mujoco
    spec = mujoco.MjSpec.from_file(str(gym_xml(name)))
    if integrator is not None:
        spec.option.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator}")
    if timestep is not None:
        spec.option.timestep = timestep
    return spec.compile()


def eomc_start(model, m_mj):
    """eomc's state at MuJoCo's qpos0 (free joints: position, zero angles or the unit
    quaternion), zero speeds."""
    import mujoco
    x = np.zeros(model.nx)
    x[list(getattr(model, "quaternions", ()))] = 1.0       # each quaternion's w: upright
    names = list(model.state_names)
    for j in range(m_mj.njnt):
        a = int(m_mj.jnt_qposadr[j])
        jn = m_mj.joint(j).name
        if int(m_mj.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_FREE):
            coords = [n for n in names[:model.nq] if n.startswith(f"q_{jn}")]
            for k, v in enumerate(m_mj.qpos0[a:a + 3]):
                x[names.index(coords[k])] = v
        elif int(m_mj.jnt_type[j]) in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
            x[names.index(f"q_{jn}")] = m_mj.qpos0[a]
    return x


def compared_q(model, m_mj, x=None, qpos=None):
    """The coordinates the error is taken over, in MuJoCo's joint order: hinge and slide
    values, free joints' positions (angles left out: quaternion vs XYZ angles)."""
    import mujoco
    out = []
    names = list(model.state_names)
    for j in range(m_mj.njnt):
        a = int(m_mj.jnt_qposadr[j])
        jn = m_mj.joint(j).name
        if int(m_mj.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_FREE):
            coords = [n for n in names[:model.nq] if n.startswith(f"q_{jn}")][:3]
            out.extend(qpos[a:a + 3] if qpos is not None else [x[names.index(c)] for c in coords])
        elif int(m_mj.jnt_type[j]) in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
            out.append(qpos[a] if qpos is not None else x[names.index(f"q_{jn}")])
    return np.array(out)


def eomc_call(model, x0, dt, t1=1.0, fast=True, split=None, p=None, t_eval=None):
    """(call, x_last, stats): the C call of one fixed-step run, events and switching off.
    fast=False: the W-method on the whole jac_x (what implicitfast ran before NAME_implicit).
    split: the fast path's residual test (None: simulate's default, 0: off, MuJoCo-like)."""
    from eomc.runtime.simulate import bind_call, prepare
    a = prepare(model, x0, (0.0, t1), method="implicitfast", dt=dt, t_eval=[t1] if t_eval is None else t_eval,
                events=False, max_steps=10 ** 7, p=p)
    a.pop("switches", None)          # the verdict's observers: not part of a control loop
    a.pop("switch_steps", None)
    a["fast"] = fast
    if split is not None:
        a["split"] = split
    call, x_out, x_last, stats = bind_call(model, a)
    if t_eval is not None:
        return call, x_out, x_last, stats
    return call, x_last, stats


def mujoco_call(m, nstep):
    import mujoco
    from mujoco import rollout
    d = mujoco.MjData(m)
    mujoco.mj_resetData(m, d)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state0 = np.zeros(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, d, state0, spec)
    out = np.zeros((1, nstep, state0.size))
    ctrl = np.zeros((1, nstep, m.nu))

    def call():
        rollout.rollout([m], [d], state0[None, :], ctrl, nstep=nstep, state=out, skip_checks=True)
        return out
    return call, m.nq


def cpu_block(call, min_time=0.02):
    """CPU seconds per call, over a block of calls lasting at least min_time."""
    n, t = 0, 0.0
    t0 = time.thread_time()
    while t < min_time or n < 1:
        call()
        n += 1
        t = time.thread_time() - t0
    return t / n


def run_model(name, rounds, cache_dir, log, orientation="quaternion"):
    import mujoco
    base = mujoco.MjModel.from_xml_path(str(gym_xml(name)))
    ts = float(base.opt.timestep)
    shipped = mujoco.mjtIntegrator(base.opt.integrator).name.replace("mjINT_", "")
    t0 = time.time()
    model = eomc_model(name, cache_dir, orientation=orientation)
    npts = sum(1 for o in model.output_names if o.startswith("depth_"))
    log(f"{name}: {npts} eomc contact points, eomc nq={model.nq} built/loaded in {time.time() - t0:.1f} s")
    x0 = eomc_start(model, base)
    nstep = int(round(1.0 / ts))
    # references: eomc's own Radau, MuJoCo's own RK4 at ts / 16
    ref = model.simulate(x0, (0, 1.0), method="radau", rtol=1e-9, atol=1e-9, t_eval=[1.0],
                         max_steps=10 ** 7, raise_on_failure=False)
    q_ref = compared_q(model, base, x=ref.x[-1]) if ref.status == 0 else None
    fine = mujoco_model(name, "RK4", ts / 16)
    fcall, _ = mujoco_call(fine, nstep * 16)
    qpos_fine = fcall()[0, -1, 1:1 + fine.nq]
    q_fine = compared_q(model, fine, qpos=qpos_fine)
    contestants = {}
    call, x_last, stats = eomc_call(model, x0, ts)
    contestants["eomc implicitfast"] = call
    ucall, u_last, u_stats = eomc_call(model, x0, ts, split=0.0)
    contestants["eomc implicitfast unchecked"] = ucall
    wcall, w_last, w_stats = eomc_call(model, x0, ts, fast=False)
    contestants["eomc W-method (jac_x)"] = wcall
    mj = {}
    for integ in ("EULER", "IMPLICITFAST", shipped):
        label = f"mj_step {integ.lower()}" + (" (XML's)" if integ == shipped else "")
        if label in contestants:
            continue
        mm = mujoco_model(name, integ, ts)
        c, _ = mujoco_call(mm, nstep)
        contestants[label] = c
        mj[label] = (mm, c)
    samples = {k: [] for k in contestants}
    order = list(contestants)
    for r in range(rounds):
        k = r % len(order)
        for label in order[k:] + order[:k]:
            samples[label].append(cpu_block(contestants[label]))
    rows = []
    from eomc.runtime.simulate import implicit_terms
    fast = implicit_terms(model) is not None
    t_e = float(np.median(samples["eomc implicitfast"]))
    for label, c, xl, sts in (("eomc implicitfast", call, x_last, stats),
                              ("eomc implicitfast unchecked", ucall, u_last, u_stats),
                              ("eomc W-method (jac_x)", wcall, w_last, w_stats)):
        c()
        st = {f: getattr(sts, f) for f in ("status", "steps", "nfev", "njev", "nlu", "rejected")}
        err_e = (np.abs(compared_q(model, base, x=xl) - q_ref).max() if q_ref is not None else float("nan"))
        t_c = float(np.median(samples[label]))
        what = (f"{st['nfev']} NAME_implicit calls, 0 jac_x" if fast and label.startswith("eomc implicitfast")
                else f"{st['nfev']} rhs, {st['njev']} jac_x, {st['rejected']} unconverged")
        rows.append(dict(model=name, dof=model.nu, contacts=npts, timestep=ts,
                         contestant=label, cpu_ms=t_c * 1e3, ratio=t_c / t_e, error=err_e,
                         ref="eomc Radau 1e-9" + ("" if q_ref is not None else f" FAILED: {ref.message}"),
                         note=f"status {st['status']}, {what}, finite: {bool(np.all(np.isfinite(xl)))}"))
    for label, (mm, c) in mj.items():
        out = c()
        qpos = out[0, -1, 1:1 + mm.nq]
        err = np.abs(compared_q(model, mm, qpos=qpos) - q_fine).max()
        t_m = float(np.median(samples[label]))
        rows.append(dict(model=name, dof=model.nu, contacts=npts, timestep=ts, contestant=label,
                         cpu_ms=t_m * 1e3, ratio=t_m / t_e, error=err, ref="MuJoCo RK4 at timestep/16",
                         note=f"finite: {bool(np.all(np.isfinite(qpos)))}"))
    for row in rows:
        log(f"  {row['contestant']:28s} {row['cpu_ms']:9.3f} ms  x{row['ratio']:.2f}  err {row['error']:.2e}  {row['note']}")
    return rows


ROBOTS = ("go2", "g1")


def urdf_robot(which, cache_dir):
    """(model, x0): Go2 / G1 from example-robot-data, --floating-base, the feet as contacts (as
    benchmarks/contact_defaults.py), a bent-knee pose lifted until the deepest foot is 2 mm up."""
    from importlib.metadata import distribution

    import eomc
    from eomc.compiler.urdf.model import UrdfModel
    root = Path(distribution("example-robot-data").locate_file("cmeel.prefix/share/example-robot-data/robots"))
    if which == "go2":
        contacts = [dict(link=f"{leg}_foot", radius=0.022) for leg in ("FL", "FR", "RL", "RR")]
        path, pose = root / "go2_description/urdf/go2.urdf", {"thigh_joint": 0.8, "calf_joint": -1.5}
    else:
        contacts = ["@collision"]
        path = root / "g1_description/urdf/g1_29dof_rev_1_0.urdf"
        pose = {"hip_pitch_joint": -0.1, "knee_joint": 0.3, "ankle_pitch_joint": -0.2}
    m = eomc.compile(UrdfModel(path, floating_base=True), contacts=contacts, name=f"fs_{which}",
                     cache_dir=cache_dir, functions=("rhs", "jac_x", "outputs", "implicit", "events"), progress=False)
    x0 = np.zeros(m.nx)
    for i, n in enumerate(m.state_names[:m.nq]):
        for k, v in pose.items():
            if n.endswith(k):
                x0[i] = v
    iz = [i for i, n in enumerate(m.state_names) if n.endswith("floating_z")][0]
    d = m.outputs(0, x0)
    x0[iz] = max(v for k, v in d.items() if k.startswith("depth_")) + 0.002
    return m, x0


def run_robot(which, rounds, cache_dir, log, T=1.0):
    """Go2 / G1 collapsing onto their feet (no joint torques), T s at 5, 2 and 1 ms, the residual
    test on (checked, simulate's default) and off (unchecked).  No MuJoCo row: no MJCF of these
    robots with the same foot contacts is in this environment."""
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m, x0 = urdf_robot(which, cache_dir)
    cases = [("default k", None)]
    if which == "g1":      # its 5 mm ankle spheres sink past their radius at the default k
        p = np.array(m.param_defaults, dtype=float)
        for i, n in enumerate(m.param_names):
            if n.startswith("k_"):
                p[i] *= 4.0
        cases.append(("contacts' k x 4", p))
    rows = []
    names = list(m.state_names)
    keep = [i for i, n in enumerate(names[:m.nq]) if not n.endswith(("_rx", "_ry", "_rz"))]
    for label, p in cases:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ref = m.simulate(x0, (0, T), p=p, method="radau", rtol=1e-8, atol=1e-8, t_eval=[T], max_steps=10 ** 7,
                             raise_on_failure=False)
        for dt in (0.005, 0.002, 0.001):
            for mode, split in (("checked", None), ("unchecked", 0.0)):
                grid = np.arange(0.0, T + dt / 2, dt)
                call, x_out, x_last, st = eomc_call(m, x0, dt, t1=T, split=split, p=p, t_eval=grid)
                times = []
                for _ in range(rounds):
                    times.append(cpu_block(call))
                call()
                rows_ok = x_out[:st.n_out]
                deep = max((max(v for k, v in m.outputs(0, x, p=p).items() if k.startswith("depth_"))
                            for x in rows_ok[::max(1, len(rows_ok) // 200)] if np.all(np.isfinite(x))), default=np.nan)
                err = (np.abs(x_last[keep] - ref.x[-1][keep]).max() if st.status == 0 and ref.status == 0
                       else float("nan"))
                rows.append(dict(model=which, dof=m.nu, contacts=len(m.metadata["implicit"]["contacts"]),
                                 timestep=dt, contestant=f"eomc implicitfast {mode} ({label})",
                                 cpu_ms=float(np.median(times)) * 1e3 / T, ratio=float("nan"), error=err,
                                 ref=f"eomc Radau 1e-8 (status {ref.status})",
                                 note=f"status {st.status} at t = {st.t:.3f}, {st.nfev} calls, deepest contact "
                                      f"{deep * 1e3:.1f} mm (of {len(rows_ok)} rows)"))
                log(f"  {which} {rows[-1]['contestant']} dt {dt}: {rows[-1]['cpu_ms']:.2f} ms err {err:.2e} "
                    f"{rows[-1]['note']}")
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", default=",".join(MODELS))
    parser.add_argument("--robots", default=",".join(ROBOTS))
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--cache-dir", default=os.environ.get("EOMC_CACHE_DIR"))
    parser.add_argument("--orientation", choices=("euler", "quaternion"), default="quaternion",
                        help="eomc's free and ball joints: MuJoCo's quaternion (default) or body-XYZ angles")
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args()
    core = pin_to_one_core()
    lines = []
    log = lambda s: (print(s, flush=True), lines.append(s))  # noqa: E731
    rows = []
    for name in [n for n in args.models.split(",") if n]:
        rows.extend(run_model(name, args.rounds, args.cache_dir, log, args.orientation))
    for name in [r for r in args.robots.split(",") if r]:
        rows.extend(run_robot(name, args.rounds, args.cache_dir, log))
    import mujoco
    head = environment_header(
        "Fixed step at the MJCF timestep: eomc implicitfast vs MuJoCo mj_step (rollout, C loop)", args,
        notes=[f"pinned to core {core}; MuJoCo {mujoco.__version__}; 1 simulated second per run; "
               f"{args.rounds} interleaved rounds, median of per-round block means (thread CPU); "
               f"eomc orientation {args.orientation}"])
    table = ["| model | dof | eomc contact points | timestep | contestant | CPU ms per simulated s | "
             "time / eomc | error (max abs q at t = 1) | error against | notes |",
             "|---|--:|--:|--:|---|--:|--:|--:|---|---|"]
    for r in rows:
        table.append(f"| {r['model']} | {r['dof']} | {r['contacts']} | {r['timestep']:g} | {r['contestant']} | "
                     f"{r['cpu_ms']:.3f} | {r['ratio']:.2f} | {r['error']:.2e} | {r['ref']} | {r['note']} |")
    text = head + "\n" + (__doc__.split("\n\n", 2)[2]) + "\n\n" + "\n".join(table) + "\n"
    print("\n".join(table))
    if not args.no_write and args.orientation == "quaternion":
        write_results("fixedstep", text, keep_notes=True)


if __name__ == "__main__":
    main()
